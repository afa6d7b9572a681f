#include "hwmodel/timing/ray_admission.h"

#include <algorithm>
#include <stdexcept>

#include "hwmodel/timing/ray_gather.h"

namespace rtu::hw {

namespace {

// Rays in order through a prefetch queue of queue_depth rays.
class InOrderAdmission final : public RayAdmission {
 public:
  explicit InOrderAdmission(const TimingConfig& c)
      : m_recent(size_t(c.queue_depth), 0), m_fetch_latency(uint64_t(c.ray_fetch_latency)) {}
  void begin(size_t, uint64_t t0) override {
    m_t0 = t0;
    m_taken = 0;
    std::fill(m_recent.begin(), m_recent.end(), 0);
  }
  bool reach(uint64_t, const RayFeed& feed, TimingStats&) override { return m_taken < feed.end(); }
  bool ready() const override { return true; }
  uint64_t retry_at() const override { return 0; }
  size_t take(std::vector<TraceEvent>& events, const RayFeed& feed, uint64_t free_at, uint64_t setup_free,
              uint64_t& enter) override {
    const size_t i = m_taken++;
    uint64_t fetch = m_t0 + i;
    const size_t D = m_recent.size();
    if (i >= D) fetch = std::max(fetch, m_recent[i % D]);  // the prefetch queue holds D rays
    enter = std::max({fetch + m_fetch_latency, free_at, setup_free});
    m_recent[i % D] = enter;
    events.swap(feed.rays[i - feed.first]);
    return i;
  }
  size_t fed_up_to() const override { return m_taken; }
  bool starved(const RayFeed& feed, uint64_t) const override { return m_taken >= feed.end(); }

 private:
  std::vector<uint64_t> m_recent;  // setup entry cycles of the last queue_depth rays
  uint64_t m_fetch_latency, m_t0 = 0;
  size_t m_taken = 0;
};

// Rays through the gathering unit's bins (ray_gather.h).
class GatherAdmission final : public RayAdmission {
 public:
  explicit GatherAdmission(const TimingConfig& c) : m_gather(c) {}
  void begin(size_t n, uint64_t t0) override { m_gather.begin(n, t0); }
  bool reach(uint64_t t, const RayFeed& feed, TimingStats& s) override {
    for (uint64_t a; (a = m_gather.next_arrival()) <= t;) {
      if (m_gather.arrived() >= feed.end()) return false;
      m_gather.expire(a, s);
      m_gather.arrive(feed.rays[m_gather.arrived() - feed.first], s);
    }
    m_gather.expire(t, s);
    return true;
  }
  bool ready() const override { return m_gather.ready(); }
  // No bin is issued yet: the next arrival or timeout (both after the cycle reached).
  uint64_t retry_at() const override {
    const uint64_t next = std::min(m_gather.next_arrival(), m_gather.next_timeout());
    if (next == RayGather::kNever) throw std::logic_error("gather: rays left but none can arrive or issue");
    return next;
  }
  size_t take(std::vector<TraceEvent>& events, const RayFeed&, uint64_t free_at, uint64_t setup_free,
              uint64_t& enter) override {
    uint64_t issued;
    const size_t i = m_gather.take(events, issued);
    enter = std::max({issued, free_at, setup_free});
    m_gather.leave(enter);
    return i;
  }
  size_t fed_up_to() const override { return m_gather.arrived(); }
  bool starved(const RayFeed& feed, uint64_t free_at) const override {
    return m_gather.arrived() >= feed.end() && m_gather.next_arrival() <= free_at;
  }

 private:
  RayGather m_gather;
};

}  // namespace

std::unique_ptr<RayAdmission> make_ray_admission(const TimingConfig& c) {
  if (c.gather != GatherKey::kNone) return std::make_unique<GatherAdmission>(c);
  return std::make_unique<InOrderAdmission>(c);
}

}  // namespace rtu::hw
