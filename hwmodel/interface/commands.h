// Command packets: fixed 32-byte records the firmware writes into the ring (regs.h) and the command processor
// consumes in order. Freestanding (only <cstdint>/<cstddef>): the firmware includes it. firmware/README.md has
// the command table; every field not listed for an opcode is reserved and must be 0 (else kReservedBits).
#pragma once

#include <cstddef>
#include <cstdint>

#include "hwmodel/interface/enum_names.h"

namespace rtu::hw::cmd {

enum class Opcode : uint8_t {
  kNop = 0,        // nothing; advances the clock
  kBindScene = 1,  // addr0 = scene image, value = its bytes (8-byte aligned)
  kTrace = 2,      // addr0 = rays (count x 32 B), addr1 = hits (count x 16 B, or with kTraceAllHits count hit
                   // lists of all_hits_list_bytes(value) each), 16-byte aligned; flags kTrace*
  kFence = 3,      // writes the 64-bit value at addr0 (8-byte aligned) once every earlier packet is done
  kTimestamp = 4,  // writes the 64-bit device clock at addr0 (8-byte aligned)
};
inline constexpr uint8_t kOpcodeCount = 5;

inline constexpr uint8_t kTraceAnyHit = 1u << 0;  // TRACE: stop at the first hit (shadow rays)
// TRACE: every intersection in [tmin, tmax], up to `value` (0..kMaxAllHits) kept per ray, all counted: each ray's
// hit list is a HitListHeader and `value` hit records (below). Not with kTraceAnyHit (kReservedBits).
inline constexpr uint8_t kTraceAllHits = 1u << 1;
inline constexpr uint8_t kFenceIrq = 1u << 0;  // FENCE: raise kIrqFence when written

// The kind of ray a TRACE carries: the device counts rays by type and bounce (no effect on results).
enum class RayType : uint8_t { kPrimary = 0, kShadow, kReflection, kRefraction, kDiffuse, kOcclusion, kOther };
inline constexpr uint8_t kRayTypeCount = 7;
inline constexpr const char* kRayTypeNames[] = {"primary", "shadow",    "reflection", "refraction",
                                                "diffuse", "occlusion", "other"};
static_assert(count_of(kRayTypeNames) == kRayTypeCount && kRayTypeCount == std::size_t(RayType::kOther) + 1,
              "a name for every ray type");
constexpr const char* ray_type_name(RayType t) {
  return enum_name(kRayTypeNames, t);
}

inline constexpr uint32_t kMaxTraceCount = 1u << 24;  // rays per TRACE
inline constexpr uint64_t kRayBytes = 32;             // hw::Ray
inline constexpr uint64_t kHitBytes = 16;             // hw::Hit

// An all-hit TRACE's hit list per ray, at addr1 + ray * all_hits_list_bytes(k): this header, then the first
// `kept` hits in the order the unit found them (16 B each, hw::Hit); the slots after them are not written.
inline constexpr uint32_t kMaxAllHits = 256;           // hits kept per ray (the hit list's bound)
inline constexpr uint32_t kHitListOverflow = 1u << 0;  // HitListHeader::flags: more hits than kept
struct HitListHeader {
  uint32_t count;     // intersections found (saturates at 2^32 - 1)
  uint32_t kept;      // hit records written after the header: min(count, k)
  uint32_t flags;     // kHitListOverflow
  uint32_t reserved;  // 0
};
static_assert(sizeof(HitListHeader) == 16);
constexpr uint64_t all_hits_list_bytes(uint64_t k) {
  return (k + 1) * 16;
}
// The header of a ray's list that found `count` intersections, k kept at most.
constexpr HitListHeader hit_list_header(uint64_t count, uint32_t k) {
  return HitListHeader{uint32_t(count < 0xFFFFFFFFu ? count : 0xFFFFFFFFu), uint32_t(count < k ? count : k),
                       count > k ? kHitListOverflow : 0u, 0u};
}

struct Packet {
  uint8_t opcode;    // Opcode
  uint8_t flags;     // per opcode: kTrace*, kFence*
  uint8_t ray_type;  // TRACE: RayType; else 0
  uint8_t bounce;    // TRACE: path depth of the rays (0 = camera rays); else 0
  uint32_t count;    // TRACE: rays; else 0
  uint64_t addr0;    // see Opcode
  uint64_t addr1;    // TRACE: hit buffer; else 0
  uint64_t value;    // BIND_SCENE: image bytes; FENCE: value written; TRACE with kTraceAllHits: hits kept; else 0
};
static_assert(sizeof(Packet) == 32);
static_assert(offsetof(Packet, count) == 4 && offsetof(Packet, addr0) == 8 && offsetof(Packet, addr1) == 16 &&
              offsetof(Packet, value) == 24);
inline constexpr uint32_t kPacketBytes = sizeof(Packet);

constexpr Packet nop() {
  return Packet{uint8_t(Opcode::kNop), 0, 0, 0, 0, 0, 0, 0};
}
constexpr Packet bind_scene(uint64_t image, uint64_t bytes) {
  return Packet{uint8_t(Opcode::kBindScene), 0, 0, 0, 0, image, 0, bytes};
}
constexpr Packet trace(uint64_t rays, uint64_t hits, uint32_t count, bool any_hit, RayType type, uint8_t bounce) {
  return Packet{
      uint8_t(Opcode::kTrace), uint8_t(any_hit ? kTraceAnyHit : 0), uint8_t(type), bounce, count, rays, hits, 0};
}
// An all-hit TRACE keeping up to k hits per ray (k <= kMaxAllHits; 0: count only).
constexpr Packet trace_all_hits(uint64_t rays, uint64_t lists, uint32_t count, uint32_t k, RayType type,
                                uint8_t bounce) {
  return Packet{uint8_t(Opcode::kTrace), kTraceAllHits, uint8_t(type), bounce, count, rays, lists, k};
}
constexpr Packet fence(uint64_t addr, uint64_t value, bool irq) {
  return Packet{uint8_t(Opcode::kFence), uint8_t(irq ? kFenceIrq : 0), 0, 0, 0, addr, 0, value};
}
constexpr Packet timestamp(uint64_t addr) {
  return Packet{uint8_t(Opcode::kTimestamp), 0, 0, 0, 0, addr, 0, 0};
}

}  // namespace rtu::hw::cmd
