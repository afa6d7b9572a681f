// Running a command from a test: the shell runs it, its output (stdout and stderr, interleaved, unless the command
// redirects them itself) and its exit status come back. Used by the end-to-end tests of rtusim (test_cli.cpp,
// test_limits.cpp).
#pragma once

#include <cstdint>
#include <string>

namespace rtu::test {

struct Run {
  bool exited = false;    // ended by exit(), not by a signal
  int status = 0;         // the exit status, or 128 + the signal's number when a signal ended it
  std::string output;     // stdout and stderr
  uint64_t peak_kib = 0;  // run_measured: the largest resident size of the command's processes, in KiB
};

// Runs `command` with /bin/sh. A failure to start the shell fails the test.
Run run_process(const std::string& command);

// As run_process, and the peak resident size of the command's processes in peak_kib (by /usr/bin/time, GNU
// time: required).
Run run_measured(const std::string& command);

// Runs rtusim (RTUSIM_EXE) with `args`; `env` holds VAR=value assignments for its environment, or nothing.
Run run_rtusim(const std::string& args);
Run run_rtusim(const std::string& env, const std::string& args);

}  // namespace rtu::test
