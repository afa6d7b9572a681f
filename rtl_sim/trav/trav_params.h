// The traversal unit's parameters (trav/trav_unit.sv) from a timing configuration: its box unit's (rtl_params.h),
// its triangle unit's (tri_params.h), and the slots, short stack and latencies the timing model reads from the
// same keys. What the unit does not have (a second box or triangle unit, another node kind or layout, a
// prefetcher, a ray scheduler, FR-FCFS memory, another traversal or child order) is refused by name:
// trav_refusal().
#pragma once

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "hwmodel/timing/timing_config.h"
#include "rtl_sim/params/rtl_params.h"
#include "rtl_sim/params/tri_params.h"

namespace rtu::rtl {

struct TravParams {
  BoxUnitParams box;
  TriUnitParams tri;
  int slots = 0, stack = 0, setup_lat = 0, trav_lat = 0;
  int nb() const { return 16 + 10 * box.n; }  // node bytes (struct layout, 8-bit offsets)
};

// Empty when the traversal unit can run configuration c; otherwise what it lacks, by key.
inline std::string trav_refusal(const hw::TimingConfig& c) {
  const hw::FixedFormat f = hw::format_from_spec(c.format);
  std::vector<std::string> why;
  auto need = [&](bool ok, const std::string& what) {
    if (!ok) why.push_back(what);
  };
  need(f.node_layout_id() == hw::NodeLayout::kStructs, "node_layout 0 (struct nodes)");
  need(f.prim_layout_id() == hw::PrimLayout::kRecords, "prim_layout 0 (40-byte records)");
  need(f.node_kind_id() == hw::NodeKindId::kQuantizedAabb, "node_kind 0 (axis-aligned boxes)");
  need(f.child_bits <= 8, "child_bits <= 8");
  need(f.tri_pairs == 0, "tri_pairs 0");
  need(c.box_units == 1 && c.tri_units == 1 && c.tri_rate == 1, "box_units = tri_units = tri_rate = 1");
  need(c.curve_units == 0 && c.cluster_tri_rate == 0, "no curve units or cluster engine");
  need(c.stack_mode == hw::StackMode::kSpill, "stack_mode spill");
  // The unit takes a node's children nearest first from one stack; other orders visit other nodes.
  need(c.traversal == hw::TraversalOrder::kDepthFirst, "traversal depth_first");
  need(c.child_order == hw::ChildOrder::kNearest, "child_order nearest");
  need(c.prefetcher == hw::PrefetcherId::kNone, "prefetcher none");
  need(c.gather == hw::GatherKey::kNone, "gather none");
  need(c.dram_scheduler == hw::DramScheduler::kFcfs, "dram_scheduler fcfs");
  need(c.layout_align == 0, "layout_align 0");
  need(c.units == 1, "units 1");
  need(c.setup_latency >= 1 && c.traversal_latency >= 1, "setup_latency >= 1 and traversal_latency >= 1");
  need(c.ray_slots <= 64 && c.stack_entries >= 1, "ray_slots <= 64, stack_entries >= 1");
  if (why.empty()) return {};
  std::string s = "the RTL traversal unit needs ";
  for (size_t i = 0; i < why.size(); ++i) s += (i ? ", " : "") + why[i];
  return s;
}

inline TravParams trav_params(const hw::TimingConfig& c) {
  if (const std::string why = trav_refusal(c); !why.empty()) throw std::invalid_argument(why);
  TravParams p;
  p.box = box_unit_params(c);
  p.tri = tri_unit_params(c);
  if (p.box.a != p.tri.a || p.box.tb != p.tri.tb)
    throw std::logic_error("trav_unit: the box and triangle units disagree on A or TB");
  p.slots = c.ray_slots;
  p.stack = c.stack_entries;
  p.setup_lat = c.setup_latency;
  p.trav_lat = c.traversal_latency;
  return p;
}

// A slot's registers in trav_unit.sv, as its declarations size them (the area and energy model's slot storage,
// docs/energy-model.md; bench/rtl_trav_area.sh counts the synthesized flip-flops, which yosys may trim by a bit).
struct TravSlotBits {
  int state = 0;   // the set-up ray, the closest hit and its record, the traversal registers
  int buffer = 0;  // the fetched node or record (the widest read)
  int entry = 0;   // one short-stack entry: a 32-bit reference and the entry distance (TB + 2 bits)
  int spill = 0;   // entries waiting to be spilled, per slot (N, a node's children)
};
inline TravSlotBits trav_slot_bits(const BoxUnitParams& b, const TriUnitParams& t) {
  constexpr int kState = 3, kCount = 8, kStamp = 32, kRead = 2, kRayId = 24, kDepth = 10, kSpillCount = 4;
  TravSlotBits r;
  r.state = kState + kCount + kStamp + kRead + kRayId + 1 /*any_hit*/ + 3 * b.a /*origin*/ + 3 * t.dw() +
            2 * 3 * (b.m + 2) /*reciprocals, both roundings*/ + 3 * b.rsw() + 3 + 3 /*zero, neg*/ +
            2 * (b.tb + 1) /*tmin, closest t*/ + 1 /*found*/ + 32 /*primitive*/ + 3 * t.ew() /*e1, e2, det*/ + 1 +
            32 /*next node*/ + 32 + 5 + 1 /*leaf records, done*/ + kDepth + kDepth + kSpillCount;
  r.buffer = 8 * std::max(16 + 10 * b.n, 40);
  r.entry = 32 + b.tb + 2;
  r.spill = b.n;
  return r;
}

// trav_unit.sv's parameters by name.
inline std::vector<std::pair<std::string, int>> param_list(const TravParams& p) {
  std::vector<std::pair<std::string, int>> l = {
      {"SLOTS", p.slots}, {"STACK", p.stack}, {"SETUP_LAT", p.setup_lat}, {"TRAV_LAT", p.trav_lat}};
  for (auto [name, value] : param_list(p.box)) l.push_back({name == "LATENCY" ? "BOX_LAT" : name, value});
  for (auto [name, value] : param_list(p.tri))
    if (name != "A" && name != "TB") l.push_back({name == "LATENCY" ? "TRI_LAT" : name, value});
  return l;
}

inline std::string verilator_args(const TravParams& p) {
  std::string s;
  for (const auto& [name, value] : param_list(p))
    s += (s.empty() ? "-G" : " -G") + name + '=' + std::to_string(value);
  return s;
}

}  // namespace rtu::rtl
