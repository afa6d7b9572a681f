// The host's error type: a message that names the input and the problem. rtusim prints it and exits non-zero.
#pragma once

#include <stdexcept>
#include <string>

namespace rtu::host {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Thrown by a command that ran to the end but must exit with `code` (e.g. 1: a checked promise broke). The
// command has already printed why.
class ExitStatus : public std::exception {
 public:
  explicit ExitStatus(int code) : m_code(code) {}
  int code() const { return m_code; }
  const char* what() const noexcept override { return "exit status"; }

 private:
  int m_code;
};

}  // namespace rtu::host
