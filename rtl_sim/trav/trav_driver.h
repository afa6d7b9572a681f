// The testbench around a Verilated traversal unit (trav_unit.sv): what the timing model puts around its slots.
//   - Rays: set up in C++ (hw::setup_ray, as the fixed device does) and offered on the ray port as the model's ray
//     fetch offers them: ray i from cycle i + ray_fetch_latency, at most queue_depth rays ahead of the slots.
//   - Memory: behind the port, the timing model's own node cache and memory system (node_cache.h,
//     memory_system.h) say when each read's data is there; the data is the image's bytes (nodes, records) or the
//     stack entries the unit wrote (spills). At most one response an edge: two due at the same edge go in
//     request order, the later one edge later.
//   - Hits: taken the edge they are offered; the packet ends writeback_latency after the last.
// Cycle 0 is the model's t0 (the packet decoded); the packet's cycles add packet_latency, as the model's do.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <map>
#include <queue>
#include <stdexcept>
#include <string>
#include <vector>

#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/format/hw_format.h"
#include "hwmodel/interface/ray.h"
#include "hwmodel/timing/memory/memory_system.h"
#include "hwmodel/timing/memory/node_cache.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_model.h"
#include "hwmodel/timing/timing_stats.h"
#include "rtl_sim/cosim/sim.h"
#include "rtl_sim/trav/trav_params.h"

namespace rtu::rtl {

// What a packet on the unit did.
struct TravRun {
  uint64_t cycles = 0;  // packet_latency + the last hit's write-back edge + writeback_latency
  uint64_t node_reads = 0, record_reads = 0, spills = 0, refills = 0;
  uint64_t response_delays = 0;  // responses moved an edge later because another was due at the same edge
  uint64_t cache_misses = 0;     // line accesses the node cache missed
};

// Empty when the image is one the unit traverses: a BVH of struct-layout axis-aligned nodes of the unit's width
// with 8-bit offsets, opaque triangle records only, no planes, one level.
inline std::string trav_image_refusal(const hw::DeviceImage& img, const TravParams& p) {
  const hw::ImageHeader& h = img.header();
  if (h.flags & hw::kImageNoBvh) return "an image without a BVH";
  if (h.flags & hw::kImageTopLevel) return "a two-level (instanced) image";
  if (h.width != p.box.n)
    return "nodes of width " + std::to_string(h.width) + " (the unit's: " + std::to_string(p.box.n) + ")";
  if (h.q_bytes != 1 || h.node_layout != 0 || h.prim_layout != 0 ||
      hw::node_kind(h) != hw::NodeKindId::kQuantizedAabb)
    return "nodes other than struct-layout axis-aligned boxes with 8-bit offsets";
  if (h.plane_count != 0) return "planes";
  if (h.root_ref == hw::kEmptyChild) return "an empty BVH";
  for (uint32_t i = 0; i < h.record_count; ++i) {
    const uint8_t* r = img.record(i);
    if (hw::record_kind(r) != hw::RecordKind::kTriangle)
      return "records other than triangles (record " + std::to_string(i) + ")";
    uint32_t word;
    std::memcpy(&word, r + 36, 4);
    if (word & hw::kRecordNonOpaque) return "non-opaque triangles (record " + std::to_string(i) + ")";
  }
  return {};
}

template <class Model>
class TravDriver {
 public:
  TravDriver(const TravParams& p, const hw::TimingConfig& c, const hw::DeviceImage& img)
      : m_p(p), m_c(c), m_img(img), m_frame(img.frame()), m_f(img.format()), m_cache(c), m_mem(c) {
    if (const std::string why = trav_image_refusal(img, p); !why.empty())
      throw std::invalid_argument("the RTL traversal unit cannot run " + why);
    while ((uint64_t(1) << m_line_shift) < uint64_t(c.line_bytes)) ++m_line_shift;
    m_stack_base = hw::TimingModel::stack_base(img.size(), 0, p.slots);  // layout_align 0: the image's bytes
  }

  // Traces rays[0, n) in one packet: their hits (as the fixed device's: t in world units, primitive, u, v).
  TravRun trace(const hw::Ray* rays, hw::Hit* hits, size_t n, bool any_hit, hw::TimingStats& s) {
    TravRun run;
    const uint64_t misses0 = s.cache_misses;
    std::vector<hw::FixedRay> fr(n);
    std::vector<size_t> sent;  // rays the unit traverses (set up, with an interval)
    for (size_t i = 0; i < n; ++i) {
      hits[i] = hw::Hit{};
      if (hw::setup_ray(rays[i], m_frame, m_f, fr[i]) != hw::RayStatus::kOk || fr[i].tmin > fr[i].tmax) continue;
      if (!fr[i].narrow)
        throw std::invalid_argument("the RTL traversal unit has the 64-bit datapath only: ray " +
                                    std::to_string(i) + " needs the wide one");
      sent.push_back(i);
    }
    Sim<Model> sim;
    Model& m = sim.dut();
    const hw::ImageHeader& h = m_img.header();
    m.cfg_node_base = h.node_offset;
    m.cfg_rec_base = h.record_offset;
    m.cfg_stack_base = m_stack_base;
    m.cfg_root = h.root_ref;
    m.ray_valid = 0;
    m.hit_ready = 1;
    m.mem_req_ready = 1;
    m.mem_resp_valid = 0;
    sim.reset();
    const size_t D = size_t(m_c.queue_depth);
    std::vector<uint64_t> enter;  // the cycle each sent ray entered a slot
    size_t next = 0, written = 0;
    uint64_t last_wb = 0;
    struct Due {
      uint64_t at, order;
      uint32_t id;
      std::vector<uint8_t> bytes;
      bool operator>(const Due& o) const { return at != o.at ? at > o.at : order > o.order; }
    };
    std::priority_queue<Due, std::vector<Due>, std::greater<>> due;
    uint64_t order = 0;
    const uint64_t limit = 1000000 + uint64_t(sent.size()) * 200000;
    for (uint64_t c = 0; written < sent.size(); ++c) {
      if (c > limit) throw std::runtime_error("the RTL traversal unit did not finish its packet (hang)");
      // Inputs for this edge: the next ray when the ray fetch has it, a response due now.
      bool offer = false;
      if (next < sent.size()) {
        uint64_t fetch = next;
        if (next >= D) fetch = std::max(fetch, enter[next - D]);
        offer = c >= fetch + uint64_t(m_c.ray_fetch_latency);
      }
      m.ray_valid = offer;
      if (offer) drive_ray(m, fr[sent[next]], uint32_t(sent[next]), any_hit);
      m.mem_resp_valid = 0;
      if (!due.empty() && due.top().at <= c) {
        const Due& d = due.top();
        run.response_delays += d.at < c;
        m.mem_resp_valid = 1;
        m.mem_resp_id = d.id;
        for (size_t b = 0; b < d.bytes.size(); ++b) put_bits(m.mem_resp_data, int(8 * b), 8, d.bytes[b]);
      }
      sim.eval();
      // What is taken at this edge.
      if (offer && m.ray_ready) {
        enter.push_back(c);
        ++next;
      }
      if (m.mem_resp_valid) due.pop();
      if (m.mem_req_valid) {
        const uint64_t addr = m.mem_req_addr;
        const uint32_t bytes = m.mem_req_bytes;
        if (m.mem_req_write) {
          ++run.spills;
          ++s.stack_spills;
          m_mem.write_word(addr, c, s);
          std::vector<uint8_t> e(16);
          for (int b = 0; b < 16; ++b)
            e[size_t(b)] = uint8_t(get_bits(m.mem_req_wdata, 8 * b, std::min(8, entry_bits() - 8 * b)));
          m_entries[addr] = e;
        } else {
          Due d{c, order++, uint32_t(m.mem_req_id), {}};
          if (bytes == 8) {
            ++run.refills;
            ++s.stack_refills;
            d.at = m_mem.read_word(addr, c, s);
            auto it = m_entries.find(addr);
            if (it == m_entries.end())
              throw std::logic_error("trav_unit: a refill of a stack entry never written");
            d.bytes = it->second;
          } else {
            ++(bytes == 40 ? run.record_reads : run.node_reads);
            ++(bytes == 40 ? s.prim_fetches : s.node_fetches);
            if (addr + bytes > m_img.size()) throw std::logic_error("trav_unit: a read outside the image");
            for (uint64_t line = addr >> m_line_shift; line <= (addr + bytes - 1) >> m_line_shift; ++line)
              d.at = std::max(d.at, m_cache.access(line, c, m_mem, s));
            d.bytes.assign(m_img.data() + addr, m_img.data() + addr + bytes);
          }
          if (d.at <= c) throw std::logic_error("trav_unit: a read answered at its own edge");
          due.push(std::move(d));
        }
      }
      if (m.hit_valid) {
        const uint32_t i = uint32_t(m.hit_id);
        if (i >= n) throw std::logic_error("trav_unit: a hit for no ray");
        if (m.hit_found) {
          const int64_t t = sign_extend(get_bits(m.hit_t, 0, m_p.box.tb + 1), m_p.box.tb + 1);
          hw::Hit hit{hw::t_to_world(t, fr[i]), uint32_t(m.hit_prim) & hw::kRecordPrimMask, 0.0f, 0.0f};
          hw::triangle_barycentrics(wide(m.hit_e1), wide(m.hit_e2), wide(m.hit_det), hit.u, hit.v);
          hits[i] = hit;
        }
        ++written;
        last_wb = c;
      }
      sim.tick();
    }
    run.cache_misses = s.cache_misses - misses0;
    run.cycles = uint64_t(m_c.packet_latency) + (sent.empty() ? 0 : last_wb + uint64_t(m_c.writeback_latency));
    s.rays += n;
    ++s.packets;
    s.cycles += run.cycles;
    return run;
  }

 private:
  int entry_bits() const { return 32 + m_p.box.tb + 2; }
  int ew() const { return m_p.tri.ew(); }
  template <class Port>
  hw::Wide wide(const Port& p) const {
    const uint64_t lo = get_bits(p, 0, 64), hi = get_bits(p, 64, ew() - 64);
    const hw::Wide v = (hw::Wide(hi) << 64) | hw::Wide(lo);
    const int sh = 128 - ew();
    return (v << sh) >> sh;
  }
  void drive_ray(Model& m, const hw::FixedRay& r, uint32_t id, bool any_hit) const {
    const int A = m_p.box.a, DW = m_p.tri.dw(), M2 = m_p.box.m + 2, RSW = m_p.box.rsw(), TB = m_p.box.tb;
    m.ray_id = id;
    m.ray_any_hit = any_hit;
    for (int a = 0; a < 3; ++a) {
      put_bits(m.ray_o, a * A, A, uint64_t(r.o[a]));
      put_bits(m.ray_d, a * DW, DW, uint64_t(r.d[a]));
      put_bits(m.ray_rcpm_dn, a * M2, M2, uint64_t(r.rcpm_dn[a]));
      put_bits(m.ray_rcpm_up, a * M2, M2, uint64_t(r.rcpm_up[a]));
      put_bits(m.ray_rcp_sh, a * RSW, RSW, uint64_t(int64_t(r.rcp_sh[a])));
      put_bits(m.ray_zero, a, 1, r.zero[a] ? 1 : 0);
      put_bits(m.ray_neg, a, 1, r.d[a] < 0 ? 1 : 0);
    }
    put_bits(m.ray_tmin, 0, TB + 1, uint64_t(r.tmin));
    put_bits(m.ray_tmax, 0, TB + 1, uint64_t(r.tmax));
  }

  TravParams m_p;
  hw::TimingConfig m_c;
  const hw::DeviceImage& m_img;
  hw::QuantFrame m_frame;
  hw::FixedFormat m_f;
  hw::NodeCache m_cache;
  hw::MemorySystem m_mem;
  int m_line_shift = 0;
  uint64_t m_stack_base = 0;
  std::map<uint64_t, std::vector<uint8_t>> m_entries;  // what spills wrote
};

// One packet on the Verilated unit `Model` (which must have configuration c's parameters): hits into `hits`.
template <class Model>
TravRun run_trav_packet(const hw::TimingConfig& c, const hw::DeviceImage& img, const hw::Ray* rays, size_t n,
                        bool any_hit, hw::Hit* hits) {
  TravDriver<Model> drv(trav_params(c), c, img);
  hw::TimingStats s;
  return drv.trace(rays, hits, n, any_hit, s);
}

}  // namespace rtu::rtl
