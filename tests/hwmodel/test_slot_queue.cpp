// The timing model's event queue (hwmodel/timing/slot_queue.h) against the order it must serve: a std::set of
// (cycle, slot) pairs. Random schedules that mix waits of a few cycles with long ones, ties between slots, slots
// that leave and come back, the served slot re-queued by replace_top or by pop and push, slot counts from 1 to
// 4,096 (powers of two and between), and the contract's errors.
#include <catch2/catch.hpp>
#include <cstdint>
#include <set>
#include <stdexcept>
#include <utility>
#include <vector>

#include "hwmodel/numeric/rng.h"
#include "hwmodel/timing/slot_queue.h"

using rtu::hw::SlotQueue;

namespace {

// Runs `steps` pops of a model-like schedule: every slot starts queued; a popped slot is queued again after a
// random wait (mostly short, sometimes past the ring, sometimes 0) or leaves and comes back later. Checks every
// pop against the reference set's minimum. Returns the pops made.
size_t run_schedule(uint32_t slots, uint64_t seed, size_t steps, uint64_t long_wait) {
  rtu::hw::Pcg32 rng(seed);
  SlotQueue q;
  q.reset(slots);
  std::set<std::pair<uint64_t, uint32_t>> ref;
  std::vector<uint32_t> idle;
  for (uint32_t s = 0; s < slots; ++s) {
    const uint64_t c = rng.next_u32() % 16;
    q.push(c, s);
    ref.insert({c, s});
  }
  size_t pops = 0;
  uint64_t now = 0;
  while (!ref.empty() && pops < steps) {
    const auto want = *ref.begin();
    REQUIRE(!q.empty());
    REQUIRE(q.top_cycle() == want.first);
    REQUIRE(q.top_slot() == want.second);
    ref.erase(ref.begin());
    ++pops;
    now = want.first;
    const uint32_t r = rng.next_u32() % 100;
    uint64_t wait;
    if (r < 70) {
      wait = rng.next_u32() % 24;  // unit latencies, ties with other slots
    } else if (r < 80) {
      wait = 0;
    } else if (r < 90) {
      wait = 1022 + rng.next_u32() % 5;  // a memory latency
    } else if (r < 97) {
      wait = long_wait + rng.next_u32() % long_wait;  // a DRAM miss behind a queue
    } else {
      q.pop();
      idle.push_back(want.second);  // the slot leaves
      continue;
    }
    if (rng.next_u32() % 2) {  // the model's way: the served slot waits again
      q.replace_top(now + wait);
    } else {
      q.pop();
      q.push(now + wait, want.second);
    }
    ref.insert({now + wait, want.second});
    // A slot that left may come back (admission), at or after the current cycle.
    if (!idle.empty() && rng.next_u32() % 4 == 0) {
      const uint32_t s = idle.back();
      idle.pop_back();
      const uint64_t c = now + rng.next_u32() % 40;
      q.push(c, s);
      ref.insert({c, s});
    }
  }
  if (ref.empty()) REQUIRE(q.empty());
  return pops;
}

}  // namespace

TEST_CASE("slot queue: serves the order of a (cycle, slot) min-heap", "[timing]") {
  for (uint32_t slots : {1u, 2u, 31u, 32u, 63u, 64u, 65u, 200u, 4096u}) {
    for (uint64_t long_wait : {uint64_t(3000), uint64_t(100000)}) {
      INFO("slots " << slots << ", long waits from " << long_wait);
      CHECK(run_schedule(slots, 7 + slots + long_wait, 20000, long_wait) > 0);
    }
  }
}

TEST_CASE("slot queue: ties go to the lowest slot, long waits keep their place", "[timing]") {
  SlotQueue q;
  q.reset(8);
  q.push(5000, 3);
  q.push(5000, 1);
  q.push(9000, 0);
  CHECK(q.top_cycle() == 5000);
  CHECK(q.top_slot() == 1);
  q.replace_top(5001);  // slot 1 again, behind slot 3 at 5000
  CHECK(q.top_slot() == 3);
  q.pop();
  CHECK(q.top_cycle() == 5001);
  CHECK(q.top_slot() == 1);
  q.pop();
  CHECK(q.top_cycle() == 9000);
  CHECK(q.top_slot() == 0);
  q.pop();
  CHECK(q.empty());
}

TEST_CASE("slot queue: contract errors", "[timing]") {
  SlotQueue q;
  CHECK_THROWS_AS(q.reset(0), std::invalid_argument);
  CHECK_THROWS_AS(q.reset(4097), std::invalid_argument);
  q.reset(4);
  q.push(100, 2);
  q.pop();
  CHECK_THROWS_AS(q.push(99, 1), std::logic_error);  // before the last cycle served
  CHECK_THROWS_AS(q.push(uint64_t(1) << 52, 1), std::overflow_error);
  CHECK_NOTHROW(q.push(100, 1));  // the cycle just served is allowed
  CHECK(q.top_cycle() == 100);
  CHECK_THROWS_AS(q.push(200, 1), std::logic_error);     // slot 1 is queued already
  CHECK_THROWS_AS(q.replace_top(99), std::logic_error);  // before the cycle served
  CHECK_THROWS_AS(q.replace_top(uint64_t(1) << 52), std::overflow_error);
  SlotQueue one;
  one.reset(1);  // a single slot: the root is its leaf
  one.push(7, 0);
  one.replace_top(9);
  CHECK(one.top_cycle() == 9);
  one.pop();
  CHECK(one.empty());
}
