#include "hwmodel/timing/parts/test_units.h"

#include <array>

#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

const TimingKeyTable& unit_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"box_units", &C::box_units, 1, 64, "box test units"},
      {"box_rate", &C::box_rate, 1, 64, "box tests per clock per unit (a node of width <= rate: one clock)"},
      {"box_latency", &C::box_latency, 1, kMaxLatency, "box unit pipeline depth (issue to result)"},
      {"obb_latency", &C::obb_latency, 0, kMaxLatency,
       "oriented nodes: clocks the ray's rotation into the node's frame adds to a box test"},
      {"box_unit", choice_field<&C::box_unit>(), 0, 0,
       "which box unit answers the box tests: the C++ datapath, or the Verilated RTL unit (co-simulation, its "
       "clocks per node)"},
      {"tri_units", &C::tri_units, 1, 64, "triangle units (spheres and planes use them too)"},
      {"tri_rate", &C::tri_rate, 1, 64, "triangle tests per clock per unit"},
      {"tri_latency", &C::tri_latency, 1, kMaxLatency, "triangle test pipeline depth"},
      {"tri_unit", choice_field<&C::tri_unit>(), 0, 0,
       "which triangle unit answers the triangle tests: the C++ datapath, or the Verilated RTL unit "
       "(co-simulation, its clocks)"},
      {"sphere_latency", &C::sphere_latency, 1, kMaxLatency, "sphere test pipeline depth (triangle unit slot)"},
      {"plane_latency", &C::plane_latency, 1, kMaxLatency, "plane test pipeline depth (triangle unit slot)"},
      {"curve_units", &C::curve_units, 0, 64,
       "curve (swept sphere) units; 0: curve tests use triangle unit slots"},
      {"curve_rate", &C::curve_rate, 1, 64, "curve tests per clock per curve unit"},
      {"curve_latency", &C::curve_latency, 1, kMaxLatency, "curve test pipeline depth (either unit)"},
      {"curve_issue", &C::curve_issue, 1, 64,
       "without curve units: clocks a curve test holds a triangle unit issue slot"},
      {"cluster_tri_rate", &C::cluster_tri_rate, 0, 64,
       "triangle clusters: the cluster engine's triangles per clock, a leaf per request, its nodes beside the box "
       "units (0: off, the box and triangle units test clusters)"},
      {"queue_depth", &C::queue_depth, 1, 4096,
       "rays the prefetch queue holds; clocks a unit request waits before it counts as a stall"},
  };
  return keys;
}

std::span<const TimingCounter> unit_counters() {
  using S = TimingStats;
  static constexpr std::array<TimingCounter, 14> counters = {{
      {"box_tests", &S::box_tests, "tests", "ray-box tests (one per child of a node visited)", kPerRay},
      {"tri_tests", &S::tri_tests, "tests", "ray-triangle tests", kPerRay},
      {"sphere_tests", &S::sphere_tests, "tests", "ray-sphere tests (in the triangle units' issue slots)",
       kPerRay},
      {"plane_tests", &S::plane_tests, "tests", "ray-plane tests (in the triangle units' issue slots)", kPerRay},
      {"curve_tests", &S::curve_tests, "tests",
       "ray-curve segment tests (curve units, or curve_issue triangle unit clocks each without them)", kPerRay},
      {"box_issue_cycles", &S::box_issue_cycles, "unit clocks",
       "box unit issue clocks used, summed over the units (ceil(children / box_rate) per node)", kPerRay},
      {"tri_issue_cycles", &S::tri_issue_cycles, "unit clocks",
       "triangle unit issue slots used (one per triangle, sphere or plane test)", kPerRay},
      {"tri_pairs", &S::tri_pairs, "requests",
       "triangle pairs (format tri_pairs) fetched and tested as one request; their two tests are in tri_tests",
       kPerRay},
      {"obb_rotations", &S::obb_rotations, "nodes",
       "oriented nodes: rays turned into a node's frame, one per oriented node test (each adds obb_latency)",
       kPerRay},
      {"cluster_box_tests", &S::cluster_box_tests, "tests",
       "triangle clusters: box tests of clusters' internal nodes by the cluster engine (not in box_tests)",
       kPerRay},
      {"cluster_tri_tests", &S::cluster_tri_tests, "tests",
       "triangle clusters: triangle tests by the cluster engine (not in tri_tests)", kPerRay},
      {"cluster_requests", &S::cluster_requests, "requests",
       "triangle clusters: requests to the cluster engine (an internal node, or a leaf's triangles)", kPerRay},
      {"unit_wait_cycles", &S::unit_wait_cycles, "cycles",
       "cycles box, triangle, sphere and plane requests waited for a free unit", kPerRay},
      {"queue_stall_cycles", &S::queue_stall_cycles, "cycles",
       "cycles unit requests waited beyond queue_depth for a free unit", kPerRay},
  }};
  return counter_table<UnitCounters>(counters);
}

}  // namespace rtu::hw
