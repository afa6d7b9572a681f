// Wall-clock seconds since construction (steady clock), for the seconds a job reports beside its figures.
#pragma once

#include <chrono>

namespace rtu::host {

class Stopwatch {
 public:
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
  }

 private:
  std::chrono::steady_clock::time_point m_start = std::chrono::steady_clock::now();
};

}  // namespace rtu::host
