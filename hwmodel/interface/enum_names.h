// Names of an enum whose values run 0..N-1, from a table in value order. A value outside the table (a
// corrupted register, a byte read from a file) names itself "unknown" rather than reading past the table.
// Freestanding (only <cstddef>): the firmware includes it. Each table sits beside a static_assert that it
// holds a name for every value up to the enum's last enumerator; whoever adds an enumerator moves that
// assert to it (the enums keep their last enumerator at the end, as the wire formats do).
#pragma once

#include <cstddef>

namespace rtu::hw {

template <class E, std::size_t N>
constexpr const char* enum_name(const char* const (&names)[N], E e, const char* unknown = "unknown") {
  const auto i = static_cast<std::size_t>(e);
  return i < N ? names[i] : unknown;
}

// How many names a table holds (for its static_assert; std::size is not freestanding).
template <class T, std::size_t N>
constexpr std::size_t count_of(const T (&)[N]) {
  return N;
}

}  // namespace rtu::hw
