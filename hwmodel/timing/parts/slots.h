// The ray slots and what moves a slot's ray from one unit result to its next request (timing_model.h): the slots'
// count; the scheduler's turn-around; the waits a ray takes in its slot for the any-hit stage (any_hit.h) and the
// instance transform of two-level scenes (instanced_fixed.h), and what an instance visit fetches.
#pragma once

#include <cstdint>
#include <span>

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

struct SlotConfig {
  int ray_slots = 32;  // rays in flight, each with its own traversal state
};

struct SchedulerConfig {
  int traversal_latency = 2;  // scheduler: cycles from a unit result to the slot's next request
  // Cycles a ray waits in its slot for the any-hit stage's answer on a candidate hit of a non-opaque triangle
  // (any_hit.h): the request to the firmware, its mask lookup (a texture read from memory) and the answer.
  int any_hit_latency = 400;
  // Cycles a ray waits in its slot for the opacity micromap lookup of a non-opaque triangle's candidate hit
  // (micromap.h): the micro-triangle's index from the hit's barycentrics and the read of its state bits, before
  // the hit counts, is dropped, or goes to the any-hit stage. Only rays of scenes traced with micromaps look up.
  int omm_latency = 4;
  // Two-level scenes (instanced_fixed.h): cycles from an instance record's arrival to the ray's object-space
  // origin and direction (the transform unit, pipelined: one ray per clock).
  int xform_latency = 12;
  // Two-level scenes: the bytes an instance visit fetches, at a stride of as many bytes. 0: the image's instance
  // record and its stored transform and bottom-level address (40 + 56 = 96 bytes at 24 transform bits); 64 models
  // a one-line instance leaf such as the 64-byte half of Intel's 128-byte InstanceLeaf that traversal reads.
  int instance_bytes = 0;
};

struct SlotCounters {
  uint64_t slot_busy_cycles = 0;  // sum over rays of the cycles from entering a slot to leaving it
};

struct SchedulerCounters {
  uint64_t any_hit_requests = 0;     // candidate hits on non-opaque triangles sent to the firmware's any-hit stage
  uint64_t omm_lookups = 0;          // candidate hits on non-opaque triangles looked up in their opacity micromap
  uint64_t instance_transforms = 0;  // two-level scenes: rays transformed into an instance's bottom level
};

const TimingKeyTable& slot_keys();
const TimingKeyTable& scheduler_keys();
std::span<const TimingCounter> slot_counters();
std::span<const TimingCounter> scheduler_counters();

}  // namespace rtu::hw
