#include "hwmodel/timing/memory/memory_system.h"

#include <algorithm>
#include <memory>
#include <utility>

#include "hwmodel/timing/memory/banked_dram.h"
#include "hwmodel/timing/memory/dram_channel.h"
#include "hwmodel/timing/memory/dram_scheduler.h"
#include "hwmodel/timing/memory/l2_cache.h"

namespace rtu::hw {

namespace {

// A DRAM model as the last level: lines, stack words and write-backs are transfers, each on the timeline by the
// cycle it ends.
template <class Dram>
class DramLevel final : public MemoryBackend {
 public:
  DramLevel(const TimingConfig& c, MemoryTimeline& timeline)
      : m_dram(c),
        m_line_bytes(uint64_t(c.line_bytes)),
        m_latency(uint64_t(c.dram_latency)),
        m_timeline(timeline) {}
  uint64_t read_line(uint64_t line, uint64_t t, TimingStats& s) override {
    return transfer(line * m_line_bytes, m_line_bytes, t, s);
  }
  uint64_t read_word(uint64_t addr, uint64_t t, TimingStats& s) override { return transfer(addr, 8, t, s); }
  void write_word(uint64_t addr, uint64_t t, TimingStats& s) override { write(addr, 8, t, s); }
  void write_line(uint64_t line, uint64_t t, TimingStats& s) override {
    write(line * m_line_bytes, m_line_bytes, t, s);
  }
  uint64_t min_line_cycles() const override { return m_dram.min_line_cycles(); }
  // A transfer starts no earlier than its request and its data comes dram_latency after it ends.
  uint64_t min_answer_cycles() const override { return m_latency; }
  uint64_t free_at() const override { return m_dram.free_at(); }

 private:
  uint64_t transfer(uint64_t addr, uint64_t bytes, uint64_t t, TimingStats& s) {
    const uint64_t ready = m_dram.transfer(addr, bytes, t, s);
    m_timeline.add(m_timeline.dram_bytes, ready - m_latency, bytes);
    return ready;
  }
  // A write takes the channel as a read does; its wait is nobody's (mem_wait_cycles counts reads).
  void write(uint64_t addr, uint64_t bytes, uint64_t t, TimingStats& s) {
    const uint64_t waited = s.mem_wait_cycles;
    transfer(addr, bytes, t, s);
    s.mem_wait_cycles = waited;
  }
  Dram m_dram;
  uint64_t m_line_bytes, m_latency;  // dram_latency: a transfer ends this long before its data is there
  MemoryTimeline& m_timeline;
};

// The L2 in front of the next level: line reads and stack words through its slices (each on the timeline when
// asked for); its dirty lines written back to the next level.
class L2Level final : public MemoryBackend {
 public:
  L2Level(const TimingConfig& c, std::unique_ptr<MemoryBackend> next, MemoryTimeline& timeline)
      : m_l2(c), m_next(std::move(next)), m_line_bytes(uint64_t(c.line_bytes)), m_timeline(timeline) {
    m_l2.set_pending(m_next->pending());
  }
  uint64_t read_line(uint64_t line, uint64_t t, TimingStats& s) override {
    m_timeline.add(m_timeline.l2_bytes, t, m_line_bytes);
    return m_l2.access(
        line, t, [&](uint64_t l, uint64_t at) { return m_next->read_line(l, at, s); },
        [&](uint64_t l, uint64_t at) { m_next->write_line(l, at, s); }, s);
  }
  uint64_t read_word(uint64_t addr, uint64_t t, TimingStats& s) override { return word(addr, false, t, s); }
  void write_word(uint64_t addr, uint64_t t, TimingStats& s) override { word(addr, true, t, s); }
  void write_line(uint64_t line, uint64_t t, TimingStats& s) override { m_next->write_line(line, t, s); }
  uint64_t min_line_cycles() const override { return m_l2.min_cycles(m_next->min_line_cycles()); }
  // Every access, hit or miss, line or word, starts at its request or later and answers l2_latency after that at
  // the earliest (a miss asks the next level then).
  uint64_t min_answer_cycles() const override { return m_l2.latency(); }
  uint64_t free_at() const override { return m_next->free_at(); }
  void warm_line(uint64_t line) override { m_l2.warm(line); }
  PendingTable* pending() override { return m_next->pending(); }
  uint64_t next_decision() const override { return m_next->next_decision(); }
  void decide() override { m_next->decide(); }

 private:
  uint64_t word(uint64_t addr, bool write, uint64_t t, TimingStats& s) {
    m_timeline.add(m_timeline.l2_bytes, t, 8);
    return m_l2.word(
        addr / m_line_bytes, write, t, [&](uint64_t l, uint64_t at) { return m_next->read_line(l, at, s); },
        [&](uint64_t l, uint64_t at) { m_next->write_line(l, at, s); }, s);
  }
  L2Cache m_l2;
  std::unique_ptr<MemoryBackend> m_next;
  uint64_t m_line_bytes;
  MemoryTimeline& m_timeline;
};

// The levels the configuration names, from the DRAM up; the first level a fill reaches is returned.
std::unique_ptr<MemoryBackend> compose_memory(const TimingConfig& c, MemoryTimeline& timeline) {
  std::unique_ptr<MemoryBackend> m;
  if (memory_is_queued(c))
    m = std::make_unique<FrFcfsDram>(c, timeline);
  else if (c.dram_banks > 0 || c.dram_channels > 1)
    m = std::make_unique<DramLevel<BankedDram>>(c, timeline);
  else
    m = std::make_unique<DramLevel<DramChannel>>(c, timeline);
  if (c.l2_kib > 0) m = std::make_unique<L2Level>(c, std::move(m), timeline);
  return m;
}

}  // namespace

void MemoryTimeline::add(std::vector<uint64_t>& series, uint64_t cycle, uint64_t bytes) {
  uint64_t bin = cycle / bin_cycles;
  while (bin >= kTimelineBins) {
    // Coarsen both series together, so that their bins stay the same.
    for (std::vector<uint64_t>* v : {&dram_bytes, &l2_bytes}) {
      for (size_t i = 0; i < v->size(); ++i) (*v)[i / 2] = (i % 2 ? (*v)[i / 2] : 0) + (*v)[i];
      v->resize((v->size() + 1) / 2);
    }
    bin_cycles *= 2;
    bin = cycle / bin_cycles;
  }
  if (series.size() <= bin) series.resize(size_t(bin) + 1, 0);
  series[size_t(bin)] += bytes;
}

MemorySystem::MemorySystem(const TimingConfig& c)
    : m_top(compose_memory(c, m_timeline)), m_pending(m_top->pending()) {}

MemorySystem::MemorySystem(std::unique_ptr<MemoryBackend> top)
    : m_top(std::move(top)), m_pending(m_top->pending()) {}

uint64_t MemorySystem::state_bytes(const TimingConfig& c) {
  const uint64_t banks = uint64_t(c.dram_channels) * uint64_t(std::max(1, c.dram_banks));
  return L2Cache::state_bytes(c) + banks * 2 * sizeof(uint64_t) +
         2 * MemoryTimeline::kTimelineBins * sizeof(uint64_t);
}

}  // namespace rtu::hw
