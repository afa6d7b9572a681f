// The rotation stage of oriented nodes (rtl/rotate_stage.sv) under Verilator against the C++ model's rotation
// (hw::rotate_ray, hwmodel/datapath/oriented_aabb_test.h): bit for bit on every rotation of the default table,
// on rays set up from random world rays and on rays at the widths' limits, streamed one per clock; its widths
// are the default format's.
#include <catch2/catch.hpp>

#include <algorithm>
#include <deque>
#include <vector>

#include "hwmodel/datapath/oriented_aabb_test.h"
#include "hwmodel/numeric/rng.h"
#include "rtl_models.h"
#include "rtl_sim/cosim/sim.h"

using namespace rtu;

namespace {

struct Case {
  int64_t o[3], d[3];
  int rot;
};

uint64_t bits(int64_t v, int w) {
  return w >= 64 ? uint64_t(v) : uint64_t(v) & ((uint64_t(1) << w) - 1);
}

}  // namespace

TEST_CASE("rotation stage: bit for bit the C++ rotation, every rotation, one ray per clock", "[obb]") {
  hw::FixedFormat f = hw::format_from_spec("default:node_kind=1");
  // The verilated widths (rtl_sim/CMakeLists.txt) are the format's.
  const int OB = f.coord_bits + f.guard_bits + f.frac_bits + 1, DB = f.dir_bits + 2, MB = f.rot_bits + 2;
  REQUIRE(OB == 39);
  REQUIRE(DB == 26);
  REQUIRE(MB == 14);
  const std::vector<hw::Rotation>& table = hw::rotation_table(f.rotations, f.rot_bits);
  hw::FixedFormat rotated = f;
  rotated.frac_bits += f.rot_bits;
  rotated.dir_bits += f.rot_bits;

  // Rays: set up from world rays in and around the unit cube, and at the limits of the widths.
  std::vector<Case> cases;
  const hw::QuantFrame frame = [&] {
    hw::QuantFrame q;
    q.bits = f.coord_bits;
    q.step_exp = -f.coord_bits;
    q.origin[0] = q.origin[1] = q.origin[2] = 0;
    return q;
  }();
  const hw::RaySetup setup(frame, f);
  hw::Pcg32 rng(51);
  const int64_t omax = (int64_t(1) << (OB - 1)) - 1, dmax = int64_t(1) << f.dir_bits;
  for (int rot = 0; rot < f.rotations; ++rot)
    for (int k = 0; k < 40; ++k) {
      Case c{};
      c.rot = rot;
      if (k < 32) {
        hw::Ray r;
        for (int a = 0; a < 3; ++a) {
          r.origin[a] = -0.5f + 2.0f * rng.next_float();
          r.dir[a] = -1.0f + 2.0f * rng.next_float();
        }
        r.tmin = 0;
        r.tmax = 1e30f;
        hw::FixedRay fr;
        if (setup(r, fr) != hw::RayStatus::kOk) continue;
        std::copy(fr.o, fr.o + 3, c.o);
        std::copy(fr.d, fr.d + 3, c.d);
      } else {
        for (int a = 0; a < 3; ++a) {
          c.o[a] = ((k >> a) & 1) ? omax : -omax;
          c.d[a] = ((k + a) & 1) ? dmax : -dmax;
        }
      }
      cases.push_back(c);
    }

  rtl::Sim<Vrotate_stage_default> sim;
  auto& dut = sim.dut();
  dut.in_valid = 0;
  sim.reset();
  std::deque<size_t> in_flight;  // cases issued, oldest first
  size_t next = 0, checked = 0;
  for (uint64_t cycle = 0; checked < cases.size(); ++cycle) {
    REQUIRE(cycle < cases.size() + 10);
    // Outputs of the case issued two clocks ago.
    if (dut.out_valid) {
      REQUIRE(!in_flight.empty());
      const Case& c = cases[in_flight.front()];
      in_flight.pop_front();
      hw::FixedRay r{};
      hw::set_format_fields(r, f);
      std::copy(c.o, c.o + 3, r.o);
      hw::set_direction(r, c.d, f);
      const hw::FixedRay want = hw::rotate_ray(r, table[size_t(c.rot)], rotated);
      const int64_t got_o[3] = {rtl::sign_extend(dut.out_o0, OB + MB + 1),
                                rtl::sign_extend(dut.out_o1, OB + MB + 1),
                                rtl::sign_extend(dut.out_o2, OB + MB + 1)};
      const int64_t got_d[3] = {rtl::sign_extend(dut.out_d0, DB + MB + 1),
                                rtl::sign_extend(dut.out_d1, DB + MB + 1),
                                rtl::sign_extend(dut.out_d2, DB + MB + 1)};
      for (int a = 0; a < 3; ++a) {
        INFO("rotation " << c.rot << " axis " << a);
        REQUIRE(got_o[a] == want.o[a]);
        REQUIRE(got_d[a] == want.d[a]);
      }
      ++checked;
    }
    // Issue the next case (every clock).
    if (next < cases.size()) {
      const Case& c = cases[next];
      const int32_t(&m)[3][3] = table[size_t(c.rot)].m;
      dut.in_valid = 1;
      dut.in_o0 = bits(c.o[0], OB);
      dut.in_o1 = bits(c.o[1], OB);
      dut.in_o2 = bits(c.o[2], OB);
      dut.in_d0 = uint32_t(bits(c.d[0], DB));
      dut.in_d1 = uint32_t(bits(c.d[1], DB));
      dut.in_d2 = uint32_t(bits(c.d[2], DB));
      dut.in_m00 = uint16_t(bits(m[0][0], MB));
      dut.in_m01 = uint16_t(bits(m[0][1], MB));
      dut.in_m02 = uint16_t(bits(m[0][2], MB));
      dut.in_m10 = uint16_t(bits(m[1][0], MB));
      dut.in_m11 = uint16_t(bits(m[1][1], MB));
      dut.in_m12 = uint16_t(bits(m[1][2], MB));
      dut.in_m20 = uint16_t(bits(m[2][0], MB));
      dut.in_m21 = uint16_t(bits(m[2][1], MB));
      dut.in_m22 = uint16_t(bits(m[2][2], MB));
      in_flight.push_back(next++);
    } else {
      dut.in_valid = 0;
    }
    sim.tick();
  }
  CHECK(checked == cases.size());
  CHECK(cases.size() > 3000);
}
