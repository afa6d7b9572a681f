#include "tests/host/run_process.h"

#include <catch2/catch.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "tests/common/test_util.h"

namespace rtu::test {

Run run_process(const std::string& command) {
  // The shell's stderr joins its stdout, the pipe, before the command runs: the command's own redirections, if
  // any, come after and win.
  const std::string cmd = "exec 2>&1; " + command;
  std::FILE* p = popen(cmd.c_str(), "r");
  REQUIRE(p != nullptr);
  Run r;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
  const int st = pclose(p);
  r.exited = WIFEXITED(st);
  r.status = r.exited ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  return r;
}

Run run_measured(const std::string& command) {
  // GNU time reports the peak of the process it runs, a shell small since its exec, and of the processes that
  // shell waited for: not of this test process, whose own peak a child forked from it would inherit.
  REQUIRE(std::filesystem::exists("/usr/bin/time"));
  const std::string out = (temp_dir("run_process") / "peak.txt").string();
  std::string quoted = "'";
  for (const char c : command) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  quoted += "'";
  Run r = run_process("/usr/bin/time -f %M -o " + out + " sh -c " + quoted);
  std::ifstream in(out);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;  // after "Command exited with non-zero status N", if so
  std::filesystem::remove(out);
  REQUIRE(!last.empty());
  r.peak_kib = std::stoull(last);
  return r;
}

Run run_rtusim(const std::string& args) {
  return run_process(std::string(RTUSIM_EXE) + " " + args);
}

Run run_rtusim(const std::string& env, const std::string& args) {
  return run_process(env + " " + std::string(RTUSIM_EXE) + " " + args);
}

}  // namespace rtu::test
