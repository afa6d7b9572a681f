// How a part of the timing model declares its configuration keys and its counters (parts/*.h): a key names a field
// of TimingConfig with its range, description and any rule beyond the range; a counter names a field of
// TimingStats with its unit, description and how sampled timing scales it. The parts' fields live in their own
// structs (parts/*.h), of which TimingConfig and TimingStats are aggregates, so a part's tables name the whole
// struct's members; timing_config.cpp and timing_stats.cpp gather the tables with one row a part.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <variant>
#include <vector>

namespace rtu::hw {

struct TimingConfig;
struct TimingStats;

inline constexpr int kMaxLatency = 100000;    // the largest latency key in cycles
inline constexpr double kNoRange = -1e300;    // lo of a key whose rule is not a range (bvh_width: 2, 4, 6 or 8)

// A key's declaration: the field it names, its allowed range (ints and doubles), a one-line description, and a
// rule beyond the range (null, or the problem as text, empty when the value is allowed).
struct TimingKeyInfo {
  const char* key;
  std::variant<int TimingConfig::*, double TimingConfig::*, std::string TimingConfig::*> field;
  double lo, hi;  // inclusive range of ints and doubles; unused for strings
  const char* description;
  std::string (*rule)(const TimingConfig&) = nullptr;
};
using TimingKeyTable = std::vector<TimingKeyInfo>;

// How sampled timing (sampler.h) turns the counters of the rays it simulated into a packet's.
enum class SampleScale : uint8_t {
  kPacket,  // set for the packet as a whole: packets (1), cycles (the estimate), rays (the packet's count)
  kPerRay,  // simulated value x packet rays / simulated rays, rounded to nearest
};

struct TimingCounter {
  const char* name;  // the member's name
  uint64_t TimingStats::*member;
  const char* unit;
  const char* description;
  SampleScale scale;
};

}  // namespace rtu::hw
