#include "hwmodel/format/micromap.h"

#include <algorithm>
#include <cmath>

namespace rtu::hw {

uint32_t micro_index(int level, float u, float v) {
  const int64_t N = int64_t(1) << level;
  // Clamped to the triangle's range; NaN goes to 0 (the comparisons fail).
  const float U = u > 0.0f ? (u < 1.0f ? u : 1.0f) * float(N) : 0.0f;
  const float V = v > 0.0f ? (v < 1.0f ? v : 1.0f) * float(N) : 0.0f;
  int64_t i = int64_t(U), j = int64_t(V);  // floor: both are >= 0
  if (j > N - 1) j = N - 1;
  if (i > N - 1 - j) i = N - 1 - j;  // beyond the hypotenuse (rounding): the row's last, upright
  const float fu = U - float(i), fv = V - float(j);
  const bool inverted = i + j < N - 1 && fu + fv > 1.0f;
  return uint32_t(j * (2 * N - j) + 2 * i + (inverted ? 1 : 0));
}

void micro_corners(int level, uint32_t index, double uv[3][2]) {
  const int64_t N = int64_t(1) << level;
  // Row j starts at j (2N - j) = N^2 - (N - j)^2: the largest such j <= index is N - ceil(sqrt(N^2 - index)),
  // taken in double and corrected by a step either way.
  auto start = [&](int64_t r) { return r * (2 * N - r); };
  int64_t j = N - int64_t(std::ceil(std::sqrt(double(N * N - int64_t(index)))));
  j = std::clamp<int64_t>(j, 0, N - 1);
  while (j > 0 && start(j) > int64_t(index)) --j;
  while (j + 1 < N && start(j + 1) <= int64_t(index)) ++j;
  const int64_t k = int64_t(index) - j * (2 * N - j), i = k / 2;
  const double s = std::ldexp(1.0, -level);
  if (k % 2 == 0) {
    const double c[3][2] = {{double(i), double(j)}, {double(i + 1), double(j)}, {double(i), double(j + 1)}};
    for (int a = 0; a < 3; ++a) uv[a][0] = c[a][0] * s, uv[a][1] = c[a][1] * s;
  } else {
    const double c[3][2] = {
        {double(i + 1), double(j)}, {double(i + 1), double(j + 1)}, {double(i), double(j + 1)}};
    for (int a = 0; a < 3; ++a) uv[a][0] = c[a][0] * s, uv[a][1] = c[a][1] * s;
  }
}

Micromap Micromap::pack(int level, const std::vector<MicroState>& states) {
  Micromap m;
  m.level = uint8_t(level);
  bool all_known = true;
  for (const MicroState s : states) all_known = all_known && known(s);
  m.bits = all_known ? 1 : 2;
  m.data.assign((uint64_t(states.size()) * m.bits + 7) / 8, 0);
  for (uint32_t i = 0; i < states.size(); ++i) {
    const uint32_t bit = i * m.bits;
    m.data[bit >> 3] |= uint8_t(uint8_t(states[i]) << (bit & 7));
  }
  return m;
}

uint64_t MicromapSet::bytes() const {
  uint64_t b = 0;
  for (const Micromap& m : maps) b += m.bytes();
  for (const uint32_t i : map_of) b += i == kNoMap ? 0 : 4;
  return b;
}

void MicromapSet::place() {
  m_start.resize(maps.size());
  uint64_t at = 0;
  for (size_t k = 0; k < maps.size(); ++k) {
    m_start[k] = at;
    at += maps[k].bytes();
  }
}

std::string MicromapSet::check() const {
  for (size_t k = 0; k < maps.size(); ++k) {
    const Micromap& m = maps[k];
    if (m.level > kMaxMicromapLevel) return "micromap " + std::to_string(k) + ": level above 10";
    if (m.bits != 1 && m.bits != 2) return "micromap " + std::to_string(k) + ": 1 or 2 bits per state";
    if (m.data.size() != (uint64_t(m.count()) * m.bits + 7) / 8)
      return "micromap " + std::to_string(k) + ": its states do not fill it";
  }
  uint64_t states = 0;
  for (const Micromap& m : maps) states += m.bytes();
  if (states >= (uint64_t(1) << 32)) return "the maps' states pass 4 GiB";
  for (size_t p = 0; p < map_of.size(); ++p)
    if (map_of[p] != kNoMap && map_of[p] >= maps.size())
      return "triangle " + std::to_string(p) + ": micromap index out of range";
  return "";
}

}  // namespace rtu::hw
