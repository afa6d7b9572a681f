// Switching activity of a Verilated model built with toggle coverage (verilator --coverage-toggle): the per-bit
// toggle counters read through Verilator's coverage API, clock and reset excluded, and merged into distinct nets.
//
// What Verilator counts (5.006, checked in the generated code): for every bit of every signal it covers it keeps
// the bit's previous value and, whenever an evaluation finds the bit different, adds 1 and updates the previous
// value. So a 0->1 and a 1->0 transition count once each; a bit that flips and flips back between two
// evaluations is not seen (the settled value is compared, no glitches). Signals up to --coverage-max-width bits
// (CMake passes a width above every signal's) and not starting with '_' are covered, in every instance.
//
// Verilator covers each signal in every scope that names it, so one physical net is counted several times: a
// submodule's port and the parent's signal connected to it, a packed bus and the signals it is unpacked into, a
// pipeline register and the name of its output. The meter merges such aliases: two bits are one net when their
// counts agree at every checkpoint (counts read at irregular cycles) of every run (a run of uniformly random
// inputs, then the measured run). Aliases always agree; distinct nets with different values almost never agree at
// K checkpoints of random inputs (a register and its input differ at a checkpoint whenever the input toggles on
// the cycle before it). Bits that never toggle in any run (constant in the RTL, e.g. sign bits of a product that
// cannot be negative) cannot be told apart and are not counted as nets (synthesis removes constant logic).
#pragma once

#include <verilated.h>
#include <verilated_cov.h>

#include <cstdint>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

namespace rtu::rtl {

// One toggle coverage point: a bit of a signal in a scope ("top.box_unit.g_full.u_core", "b1_q[5]").
struct TogglePoint {
  std::string scope, signal;
  uint64_t count = 0;  // value changes of the bit since the counters were zeroed
};

// The value of key `k` in a coverage file's item ("\001k\002value..."), or "".
inline std::string coverage_field(const std::string& item, const std::string& k) {
  const std::string tag = "\001" + k + "\002";
  const size_t at = item.find(tag);
  if (at == std::string::npos) return std::string();
  const size_t from = at + tag.size(), to = item.find('\001', from);
  return item.substr(from, to == std::string::npos ? std::string::npos : to - from);
}

// The v_toggle points of a coverage file written by VerilatedCovContext::write with forcePerInstance (one line
// "C '<item>' <count>" per point), in the file's order.
inline std::vector<TogglePoint> parse_toggle_points(std::istream& in) {
  std::vector<TogglePoint> pts;
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("C '", 0) != 0) continue;
    const size_t end = line.rfind("' ");
    if (end == std::string::npos || end < 3) throw std::runtime_error("coverage file: malformed line: " + line);
    const std::string item = line.substr(3, end - 3);
    if (coverage_field(item, "page").rfind("v_toggle/", 0) != 0) continue;
    TogglePoint p;
    p.scope = coverage_field(item, "h");
    p.signal = coverage_field(item, "o");
    p.count = std::stoull(line.substr(end + 2));
    pts.push_back(std::move(p));
  }
  return pts;
}

// Clock and reset (the signals clk and rst in any scope: a submodule's clk is the top's clock) are not counted.
inline bool excluded_signal(const std::string& signal) {
  const std::string base = signal.substr(0, signal.find('['));
  return base == "clk" || base == "rst";
}

// Reads the toggle counters of one Verilated context, in a fixed order of points (clock and reset excluded).
class ToggleMeter {
 public:
  // `path`: the file the counters are written to for reading (overwritten at each read).
  ToggleMeter(VerilatedContext& ctx, std::string path) : m_ctx(ctx), m_path(std::move(path)) {
    m_ctx.coveragep()->forcePerInstance(true);
  }
  void zero() { m_ctx.coveragep()->zero(); }
  // The counts now, one per point (names() order).
  std::vector<uint64_t> read() {
    m_ctx.coveragep()->write(m_path.c_str());
    std::ifstream in(m_path);
    if (!in) throw std::runtime_error("cannot read the coverage file " + m_path);
    const std::vector<TogglePoint> pts = parse_toggle_points(in);
    std::vector<uint64_t> counts(m_names.size(), 0);
    for (const TogglePoint& p : pts) {
      if (excluded_signal(p.signal)) continue;
      const std::string name = p.scope + " " + p.signal;
      auto it = m_index.find(name);
      if (it == m_index.end()) {
        if (m_frozen) throw std::runtime_error("coverage point " + name + " appeared after the first read");
        it = m_index.emplace(name, m_names.size()).first;
        m_names.push_back(name);
        counts.push_back(0);
      }
      counts[it->second] = p.count;
    }
    m_frozen = true;
    return counts;
  }
  const std::vector<std::string>& names() const { return m_names; }  // "scope signal[bit]"

 private:
  VerilatedContext& m_ctx;
  std::string m_path;
  std::vector<std::string> m_names;
  std::unordered_map<std::string, size_t> m_index;
  bool m_frozen = false;
};

// Points grouped into nets by their counts at every checkpoint of every run (each checkpoint a full read()).
struct NetClasses {
  std::vector<int64_t> net;  // per point: its net, or -1 when the point never toggled in any run
  uint64_t nets = 0;         // distinct nets that toggled
  uint64_t constant_points = 0;
};

inline NetClasses classify_nets(const std::vector<std::vector<std::vector<uint64_t>>>& runs, size_t points) {
  NetClasses c;
  c.net.assign(points, -1);
  std::map<std::vector<uint64_t>, int64_t> ids;
  for (size_t i = 0; i < points; ++i) {
    std::vector<uint64_t> sig;
    bool toggled = false;
    for (const auto& run : runs)
      for (const auto& at : run) {
        sig.push_back(at.at(i));
        toggled = toggled || at[i] != 0;
      }
    if (!toggled) {
      ++c.constant_points;
      continue;
    }
    const auto [it, fresh] = ids.emplace(std::move(sig), int64_t(ids.size()));
    c.net[i] = it->second;
  }
  c.nets = ids.size();
  return c;
}

// A run's totals: every point (raw: aliases counted once per name), and per net (each net once).
struct ToggleTotals {
  uint64_t points = 0, toggles_raw = 0;  // covered bits (clock and reset excluded) and their transitions
  uint64_t nets = 0, toggles = 0;        // distinct toggling nets and their transitions
  uint64_t constant_points = 0;          // bits that never toggled in any run
};

inline ToggleTotals net_totals(const NetClasses& c, const std::vector<uint64_t>& counts) {
  ToggleTotals t;
  t.points = counts.size();
  t.nets = c.nets;
  t.constant_points = c.constant_points;
  std::vector<bool> seen(c.nets, false);
  for (size_t i = 0; i < counts.size(); ++i) {
    t.toggles_raw += counts[i];
    if (c.net[i] < 0 || seen[size_t(c.net[i])]) continue;
    seen[size_t(c.net[i])] = true;
    t.toggles += counts[i];
  }
  return t;
}

}  // namespace rtu::rtl
