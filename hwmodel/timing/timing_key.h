// How a part of the timing model declares its configuration keys and its counters (parts/*.h): a key names a field
// of TimingConfig with its range, description and any rule beyond the range; a counter names a field of
// TimingStats with its unit, description and how sampled timing scales it. The parts' fields live in their own
// structs (parts/*.h), of which TimingConfig and TimingStats are aggregates, so a part's tables name the whole
// struct's members; timing_config.cpp and timing_stats.cpp gather the tables with one row a part.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <variant>
#include <vector>

namespace rtu::hw {

struct TimingConfig;
struct TimingStats;

inline constexpr int kMaxLatency = 100000;  // the largest latency key in cycles
inline constexpr double kNoRange = -1e300;  // lo of a key whose rule is not a range (bvh_width: 2, 4, 6 or 8)

// One value of a key that takes one of a list (stack_mode, box_unit, prefetcher, ...): its text and what it does.
struct TimingChoice {
  const char* name;
  const char* description;
};
// A key whose member is an enum numbering the entries of a list of choices (a part's own list, or a registry such
// as the prefetchers'): the text is parsed once, when the key is set; the refusal of an unknown value and the
// key's description are made from the list. Made by choice_field() (timing_config.h).
struct ChoiceField {
  int (*get)(const TimingConfig&);
  void (*set)(TimingConfig&, int);
  std::span<const TimingChoice> (*choices)();
};

// The text of an enum key's value. Each enum's part declares choices(E), its list in the enum's order, found by
// argument-dependent lookup.
template <class E>
const char* name_of(E e) {
  return choices(e)[size_t(e)].name;
}

// "a, b or c": the choices' names, for descriptions and refusals.
inline std::string choice_names(std::span<const TimingChoice> choices) {
  std::string s;
  for (size_t i = 0; i < choices.size(); ++i) {
    if (i > 0) s += i + 1 == choices.size() ? " or " : ", ";
    s += choices[i].name;
  }
  return s;
}

// A key's declaration: the field it names, its allowed range (ints and doubles), a one-line description (of a
// choice key: what it chooses; the list of choices is appended), and a rule beyond the range (null, or the
// problem as text, empty when the value is allowed).
struct TimingKeyInfo {
  const char* key;
  std::variant<int TimingConfig::*, double TimingConfig::*, std::string TimingConfig::*, ChoiceField> field;
  double lo, hi;  // inclusive range of ints and doubles; unused for strings and choices
  std::string description;
  std::string (*rule)(const TimingConfig&) = nullptr;
};
using TimingKeyTable = std::vector<TimingKeyInfo>;

// How sampled timing (sampler.h) turns the counters of the rays it simulated into a packet's.
enum class SampleScale : uint8_t {
  kPacket,  // set for the packet as a whole: packets (1), cycles (the estimate), rays (the packet's count)
  kPerRay,  // simulated value x packet rays / simulated rays, rounded to nearest
};

inline constexpr SampleScale kPacket = SampleScale::kPacket, kPerRay = SampleScale::kPerRay;

struct TimingCounter {
  const char* name;  // the member's name
  uint64_t TimingStats::*member;
  const char* unit;
  const char* description;
  SampleScale scale;
};

// A part's counter table, held to a row for every member of the part's counter struct.
template <class Counters, size_t N>
std::span<const TimingCounter> counter_table(const std::array<TimingCounter, N>& rows) {
  static_assert(N * sizeof(uint64_t) == sizeof(Counters), "a counter of the part has no row in its table");
  return rows;
}

}  // namespace rtu::hw
