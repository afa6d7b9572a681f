#include "hwmodel/format/rotation_table.h"

#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>

namespace rtu::hw {

namespace {

std::vector<Rotation> build(int count, int bits) {
  // The cube's rotation axes and the period of each (a box maps onto itself after it).
  struct Axis {
    double x, y, z, period;
  };
  const double q = std::numbers::pi / 2, t = 2 * std::numbers::pi / 3, h = std::numbers::pi;
  const Axis axes[13] = {{1, 0, 0, q},  {0, 1, 0, q},  {0, 0, 1, q}, {1, 1, 1, t},  {1, 1, -1, t},
                         {1, -1, 1, t}, {-1, 1, 1, t}, {1, 1, 0, h}, {1, -1, 0, h}, {1, 0, 1, h},
                         {1, 0, -1, h}, {0, 1, 1, h},  {0, 1, -1, h}};
  const int steps = (count - 1 + 12) / 13;  // S
  const double one = std::ldexp(1.0, bits);
  std::vector<Rotation> out(static_cast<size_t>(count));
  for (int i = 0; i < count; ++i) {
    double m[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    if (i > 0) {
      const Axis& a = axes[(i - 1) % 13];
      const double len = std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
      const double u[3] = {a.x / len, a.y / len, a.z / len};
      const double angle = a.period * double((i - 1) / 13 + 1) / double(steps + 1);
      const double c = std::cos(angle), s = std::sin(angle), C = 1 - c;
      // Rodrigues' rotation matrix about the unit axis u.
      m[0][0] = c + u[0] * u[0] * C;
      m[0][1] = u[0] * u[1] * C - u[2] * s;
      m[0][2] = u[0] * u[2] * C + u[1] * s;
      m[1][0] = u[1] * u[0] * C + u[2] * s;
      m[1][1] = c + u[1] * u[1] * C;
      m[1][2] = u[1] * u[2] * C - u[0] * s;
      m[2][0] = u[2] * u[0] * C - u[1] * s;
      m[2][1] = u[2] * u[1] * C + u[0] * s;
      m[2][2] = c + u[2] * u[2] * C;
    }
    for (int r = 0; r < 3; ++r)
      for (int col = 0; col < 3; ++col) out[size_t(i)].m[r][col] = int32_t(std::llround(m[r][col] * one));
  }
  return out;
}

}  // namespace

const std::vector<Rotation>& rotation_table(int count, int bits) {
  if (count < 1 || count > kMaxRotations || bits < kMinRotationBits || bits > kMaxRotationBits)
    throw std::invalid_argument("rotation_table: " + std::to_string(count) + " rotations at " +
                                std::to_string(bits) + " bits is outside the table's range");
  static std::mutex mu;
  static std::map<std::pair<int, int>, std::unique_ptr<const std::vector<Rotation>>> tables;
  const std::lock_guard<std::mutex> lock(mu);
  auto& t = tables[{count, bits}];
  if (!t) t = std::make_unique<const std::vector<Rotation>>(build(count, bits));
  return *t;
}

}  // namespace rtu::hw
