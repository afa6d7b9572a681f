// The host's error type: a message that names the input and the problem. rtusim prints it and exits non-zero.
#pragma once

#include <stdexcept>
#include <string>

namespace rtu::host {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace rtu::host
