#include "tests/host/run_process.h"

#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <cstdio>

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

Run run_rtusim(const std::string& args) {
  return run_process(std::string(RTUSIM_EXE) + " " + args);
}

Run run_rtusim(const std::string& env, const std::string& args) {
  return run_process(env + " " + std::string(RTUSIM_EXE) + " " + args);
}

}  // namespace rtu::test
