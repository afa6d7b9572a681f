// Cycles not decided yet: what a queued memory (dram_scheduler.h) answers for a read whose service it decides
// later, when simulated time reaches the cycle its bank is free.
//
// A ready cycle is a uint64_t; a pending one is kPending | id, where id names an entry of this table. An entry is
// either a request's own completion (make(), resolved by the memory that serves it) or a cycle derived from
// another entry, max(floor, parent + add) (after(): a cache hit on a line still on its way, a fetch's cache
// latency on top). Cache lines that hold a pending cycle are watched (watch()): when the entry resolves, the
// line's field is rewritten with the cycle, unless the line holds something else by then. A waiter (a timing
// model's ray slot) is notified with the cycle (notify()). Resolution runs when the memory decides, never inside a
// request, so no caller sees its own request resolve. Entries are recycled once resolved: the table holds what
// is in flight, not the history.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <vector>

namespace rtu::hw {

inline constexpr uint64_t kPending = uint64_t(1) << 63;  // cycles stay below 2^52 (slot_queue.h)
inline bool is_pending(uint64_t ready) {
  return (ready & kPending) != 0;
}

// Who waits for a pending cycle: told `tag` (a ray slot) and the cycle when it resolves, and `wait`: the cycles of
// it the request spent queued in the memory, as the resolver said (0 for a derived entry's waiters).
class PendingWaiter {
 public:
  virtual void woken(uint32_t tag, uint64_t cycle, uint64_t wait) = 0;

 protected:
  ~PendingWaiter() = default;
};

class PendingTable {
 public:
  // A new pending completion (a request's own): resolve(it, cycle) decides it.
  uint64_t make() { return kPending | alloc(0, 0); }
  // max(floor, ready + add): a cycle when ready is one, else a pending entry that follows ready's.
  uint64_t after(uint64_t ready, uint64_t floor, uint64_t add) {
    if (!is_pending(ready)) return ready + add > floor ? ready + add : floor;
    const uint32_t child = alloc(floor, add);
    subscribe(ready, Sub{Sub::kChild, child, nullptr, nullptr});
    return kPending | child;
  }
  // The field (a cache line's ready cycle) holds a pending cycle: it is rewritten with the cycle when that
  // resolves, if it still holds it. Fields must not move (the caches' lines are allocated once).
  void watch(uint64_t* field) {
    if (is_pending(*field)) subscribe(*field, Sub{Sub::kField, 0, field, nullptr});
  }
  // w->woken(tag, cycle, wait) when the pending cycle resolves.
  void notify(uint64_t ready, PendingWaiter* w, uint32_t tag) {
    subscribe(ready, Sub{Sub::kWaiter, tag, nullptr, w});
  }
  // Decides a make() entry: its subscribers (derived entries, fields, waiters) learn their cycles, in the order
  // they subscribed; derived entries pass theirs on in turn. `wait`: what the entry's own waiters are told of the
  // request's queueing (derived entries' waiters did not queue: 0).
  void resolve(uint64_t ready, uint64_t cycle, uint64_t wait = 0) {
    std::vector<std::pair<uint32_t, uint64_t>>& work = m_work;  // empty between calls (no allocation per call)
    const uint32_t root = uint32_t(ready & ~kPending);
    work.push_back({root, cycle});
    while (!work.empty()) {
      const auto [id, c] = work.back();
      work.pop_back();
      Entry& e = m_entries[id];
      for (uint32_t s = e.first; s != kNone;) {
        const Sub sub = m_subs[s];
        switch (sub.kind) {
          case Sub::kChild: {
            const Entry& ch = m_entries[sub.id];
            work.push_back({sub.id, c + ch.add > ch.floor ? c + ch.add : ch.floor});
            break;
          }
          case Sub::kField:
            if (*sub.field == (kPending | id)) *sub.field = c;
            break;
          case Sub::kWaiter:
            sub.waiter->woken(sub.id, c, id == root ? wait : 0);
            break;
        }
        const uint32_t next = sub.next;
        m_subs[s].next = m_free_sub;
        m_free_sub = s;
        s = next;
      }
      m_entries[id] = Entry{};
      m_entries[id].next_free = m_free_entry;
      m_free_entry = id;
    }
  }

 private:
  static constexpr uint32_t kNone = ~uint32_t(0);
  struct Entry {
    uint64_t floor = 0, add = 0;
    uint32_t first = kNone, last = kNone;  // subscribers, in order
    uint32_t next_free = kNone;
  };
  struct Sub {
    enum Kind : uint8_t { kChild, kField, kWaiter } kind;
    uint32_t id;  // kChild: the derived entry; kWaiter: the tag
    uint64_t* field;
    PendingWaiter* waiter;
    uint32_t next = kNone;
  };
  uint32_t alloc(uint64_t floor, uint64_t add) {
    uint32_t id = m_free_entry;
    if (id == kNone) {
      if (m_entries.size() >= (uint64_t(1) << 32) - 1)
        throw std::overflow_error("pending table: too many in flight");
      id = uint32_t(m_entries.size());
      m_entries.emplace_back();
    } else {
      m_free_entry = m_entries[id].next_free;
    }
    m_entries[id] = Entry{floor, add, kNone, kNone, kNone};
    return id;
  }
  void subscribe(uint64_t ready, Sub sub) {
    Entry& e = m_entries[uint32_t(ready & ~kPending)];
    uint32_t s = m_free_sub;
    if (s == kNone) {
      s = uint32_t(m_subs.size());
      m_subs.push_back(sub);
    } else {
      m_free_sub = m_subs[s].next;
      m_subs[s] = sub;
    }
    m_subs[s].next = kNone;
    if (e.last == kNone)
      e.first = s;
    else
      m_subs[e.last].next = s;
    e.last = s;
  }
  std::vector<Entry> m_entries;
  std::vector<Sub> m_subs;
  std::vector<std::pair<uint32_t, uint64_t>> m_work;  // resolve()'s entries still to pass their cycles on
  uint32_t m_free_entry = kNone, m_free_sub = kNone;
};

}  // namespace rtu::hw
