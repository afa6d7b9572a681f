// The test units (timing_model_units.cpp), by cost class: box units (axis-aligned and oriented nodes), triangle
// units (spheres and planes take their issue slots), curve units or their fallback on the triangle units, and the
// cluster engine of triangle clusters; and how long a request may wait for a unit before it counts as a stall.
#pragma once

#include <cstdint>
#include <span>

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

// Which unit answers a class of tests (the box_unit and tri_unit keys).
enum class UnitModel : uint8_t {
  kCpp,  // the C++ datapath, at the configured rate and depth
  kRtl,  // the Verilated RTL of rtl_sim/ (co-simulation: its clocks; hits stay the C++ unit's, bit for bit)
};
inline std::span<const TimingChoice> choices(UnitModel) {
  static constexpr TimingChoice list[] = {
      {"cpp", "the C++ datapath, at the configured rate and pipeline depth"},
      {"rtl", "the Verilated RTL unit (co-simulation): its clocks per test; the hits stay the C++ unit's"},
  };
  return list;
}

// Units: count, tests per clock per unit, pipeline depth (cycles from issue to result).
struct UnitConfig {
  int box_units = 1;
  int box_rate = 4;  // box tests per clock per unit (a node of width <= rate issues in one clock)
  int box_latency = 6;
  // Oriented nodes (node_kind 1): clocks the ray's rotation into the node's frame adds to the box test's latency
  // (a 3x3 integer product of origin and direction and the reciprocals of the rotated direction; an estimate,
  // timing-model.md). No effect on axis-aligned images.
  int obb_latency = 4;
  // Which box unit answers the box tests: cpp (box_rate and box_latency) or rtl (its clocks per node replace
  // them). The host attaches the RTL unit (hwmodel never sees it).
  UnitModel box_unit = UnitModel::kCpp;
  int tri_units = 1;
  int tri_rate = 1;  // triangle tests per clock per unit
  int tri_latency = 12;
  // Which triangle unit answers the triangle tests: cpp (one issue clock and tri_latency) or rtl (its clocks per
  // triangle replace them). Spheres and planes stay C++. The host attaches the RTL unit.
  UnitModel tri_unit = UnitModel::kCpp;
  int sphere_latency = 16;  // spheres and planes share the triangle units' issue slots (one test per clock)
  int plane_latency = 8;
  // Curve segments (linear swept spheres): a unit of their own, as NVIDIA Blackwell's RT core has, or none, and
  // then each curve test takes one triangle unit issue slot for curve_issue clocks. Latency and fallback slots
  // are estimates (timing-model.md); curve_units 0 is every preset but the -lss what-ifs.
  int curve_units = 0;     // curve units per unit; 0: curve tests go to the triangle units
  int curve_rate = 1;      // curve tests per clock per curve unit
  int curve_latency = 20;  // curve test pipeline depth, issue to result
  int curve_issue = 2;     // without curve units: clocks a curve test holds a triangle unit issue slot
  // Triangle clusters (format prim_layout 2, format/cluster_layout.h): the cluster engine, one per unit, tests a
  // cluster's internal nodes (box_rate boxes per clock, box_latency deep, beside the box units) and each leaf of
  // the cluster as one request of cluster_tri_rate triangles per clock (tri_latency deep). 0: off, a cluster's
  // nodes and triangles go to the box and triangle units as any others do. An estimate: no published figure.
  int cluster_tri_rate = 0;
  // Rays the ray prefetch queue holds ahead of the slots, and clocks a unit request may wait for a free unit
  // before the wait counts as a queue stall (waiting requests stay in their slots; there is no request buffer).
  int queue_depth = 16;
};

struct UnitCounters {
  uint64_t box_tests = 0, tri_tests = 0, sphere_tests = 0, plane_tests = 0;
  uint64_t curve_tests = 0;  // curve segment tests, in curve units or triangle unit slots (curve_units)
  uint64_t box_issue_cycles = 0, tri_issue_cycles = 0;  // unit issue slots used, summed over the units
  uint64_t tri_pairs = 0;      // triangle pairs tested as one request (in tri_tests twice)
  uint64_t obb_rotations = 0;  // oriented nodes: rays turned into a node's frame (one per oriented node test)
  // Triangle clusters with the cluster engine on (cluster_tri_rate > 0): box tests of clusters' internal nodes and
  // triangle tests it did (not in box_tests, tri_tests), and its requests (a node, or a leaf's triangles).
  uint64_t cluster_box_tests = 0, cluster_tri_tests = 0, cluster_requests = 0;
  // Requests queued for a busy box or triangle unit (throughput, not latency: the latency bound takes them out of
  // a ray's life), and the part of those waits beyond queue_depth clocks.
  uint64_t unit_wait_cycles = 0, queue_stall_cycles = 0;
};

const TimingKeyTable& unit_keys();
std::span<const TimingCounter> unit_counters();

}  // namespace rtu::hw
