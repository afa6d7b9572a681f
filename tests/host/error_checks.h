// Shared by the host tests of refusals (test_alpha.cpp, test_instancing.cpp, test_limits.cpp, test_nesting.cpp):
// the message of the host::Error an action throws, to compare with what the user is told.
#pragma once

#include <string>

#include "host/io/error.h"

// The message of the host::Error f() throws, or `none` when it throws nothing.
template <class F>
std::string error_of(F&& f, const std::string& none = "(no error)") {
  try {
    f();
  } catch (const rtu::host::Error& e) {
    return e.what();
  }
  return none;
}
