// The unit's register map: 32-bit registers at byte offsets of its MMIO window. Freestanding (no library
// beyond <cstdint>): the firmware includes it. firmware/README.md has the table with the access rules; the
// command processor (command_processor.h) implements them.
#pragma once

#include <cstdint>

#include "hwmodel/interface/enum_names.h"

namespace rtu::hw::reg {

// Offsets (bytes) in the MMIO window. RO: writes are errors; RW: read/write; W1C: write 1 to clear a bit.
inline constexpr uint32_t kId = 0x00;           // RO  kIdValue: tells the unit apart from other devices
inline constexpr uint32_t kVersion = 0x04;      // RO  interface version: major << 16 | minor
inline constexpr uint32_t kCaps = 0x08;         // RO  capability bits (kCap*)
inline constexpr uint32_t kControl = 0x0C;      // RW  kCtrlEnable; kCtrlReset (self-clearing)
inline constexpr uint32_t kStatus = 0x10;       // RO  kStatus* bits
inline constexpr uint32_t kErrorCode = 0x14;    // RO  ErrorCode of the first error since reset
inline constexpr uint32_t kErrorInfo = 0x18;    // RO  ring slot of the faulting packet, or the faulting register
inline constexpr uint32_t kIrqStatus = 0x1C;    // W1C kIrq* bits raised since they were last cleared
inline constexpr uint32_t kIrqEnable = 0x20;    // RW  kIrq* bits that drive the interrupt line
inline constexpr uint32_t kRingBaseLo = 0x24;   // RW  ring base device address, bits 0..31 (32-byte aligned)
inline constexpr uint32_t kRingBaseHi = 0x28;   // RW  bits 32..63
inline constexpr uint32_t kRingSize = 0x2C;     // RW  ring slots: a power of two in [2, kMaxRingSlots]
inline constexpr uint32_t kRingHead = 0x30;     // RO  next slot the device reads (device-owned)
inline constexpr uint32_t kRingTail = 0x34;     // RW  the doorbell: one past the last slot written
inline constexpr uint32_t kClockLo = 0x38;      // RO  device clock, bits 0..31 (see firmware/README.md)
inline constexpr uint32_t kClockHi = 0x3C;      // RO  bits 32..63 (latched when kClockLo is read)
inline constexpr uint32_t kFenceLo = 0x40;      // RO  value of the last completed FENCE, bits 0..31
inline constexpr uint32_t kFenceHi = 0x44;      // RO  bits 32..63
inline constexpr uint32_t kMemSizeLo = 0x48;    // RO  bytes of device memory, bits 0..31
inline constexpr uint32_t kMemSizeHi = 0x4C;    // RO  bits 32..63
inline constexpr uint32_t kWindowBytes = 0x50;  // size of the MMIO window

// The map is dense, ordered and word-aligned: each register 4 bytes after the one before it.
namespace detail {
inline constexpr uint32_t kOrder[] = {kId,         kVersion,   kCaps,      kControl,   kStatus,
                                      kErrorCode,  kErrorInfo, kIrqStatus, kIrqEnable, kRingBaseLo,
                                      kRingBaseHi, kRingSize,  kRingHead,  kRingTail,  kClockLo,
                                      kClockHi,    kFenceLo,   kFenceHi,   kMemSizeLo, kMemSizeHi};
constexpr bool dense() {
  for (uint32_t i = 0; i < sizeof(kOrder) / sizeof(kOrder[0]); ++i)
    if (kOrder[i] != 4 * i) return false;
  return sizeof(kOrder) == kWindowBytes;
}
}  // namespace detail
static_assert(detail::dense(), "register offsets must be 0, 4, 8, ... in the order above, filling the window");

inline constexpr uint32_t kIdValue = 0x31555452u;           // "RTU1" little-endian
inline constexpr uint32_t kVersionValue = (1u << 16) | 1u;  // 1.1: all-hit TRACE

inline constexpr uint32_t kCapTriangles = 1u << 0;  // triangle unit
inline constexpr uint32_t kCapSpheres = 1u << 1;    // sphere unit
inline constexpr uint32_t kCapPlanes = 1u << 2;     // plane unit
inline constexpr uint32_t kCapAnyHit = 1u << 3;     // any-hit TRACE
inline constexpr uint32_t kCapFixed = 1u << 4;      // fixed-point datapath (else float)
inline constexpr uint32_t kCapTimed = 1u << 5;      // the clock counts cycles (else packets)
inline constexpr uint32_t kCapAllHits = 1u << 6;    // all-hit TRACE (commands.h kTraceAllHits)

inline constexpr uint32_t kCtrlEnable = 1u << 0;  // consume the ring; setting it checks the ring registers
inline constexpr uint32_t kCtrlReset = 1u << 1;   // clear error, IRQ status, ring, fence, bound scene

inline constexpr uint32_t kStatusEnabled = 1u << 0;  // the ring is enabled and valid
inline constexpr uint32_t kStatusIdle = 1u << 1;     // head == tail: nothing pending
inline constexpr uint32_t kStatusError = 1u << 2;    // stopped on an error until reset
inline constexpr uint32_t kStatusBound = 1u << 3;    // a scene is bound

inline constexpr uint32_t kIrqFence = 1u << 0;  // a FENCE with kFenceIrq completed
inline constexpr uint32_t kIrqError = 1u << 1;  // an error stopped the unit

inline constexpr uint32_t kMaxRingSlots = 1u << 16;

// Error codes (kErrorCode). The unit keeps the first error and consumes nothing until kCtrlReset.
enum class ErrorCode : uint32_t {
  kNone = 0,
  kBadOpcode = 1,     // unknown opcode
  kBadAddress = 2,    // a buffer outside device memory (or its end overflows 64 bits)
  kMisaligned = 3,    // a buffer or the ring base not aligned as its packet requires
  kBadCount = 4,      // TRACE count 0 or above kMaxTraceCount
  kReservedBits = 5,  // a reserved field or flag bit is not zero
  kBadRing = 6,       // enabling a ring whose size or base is invalid
  kRingMisuse = 7,    // doorbell past the ring, or while disabled; ring registers written while enabled
  kNoScene = 8,       // TRACE before a successful BIND_SCENE
  kBadScene = 9,      // BIND_SCENE on bytes that are not a valid scene image for this device
  kOverlap = 10,      // a TRACE's hit buffer overlaps its ray buffer
  kBadRegister = 11,  // write to an unknown or read-only register, or an unaligned offset
  kWatchdog = 12,     // the watchdog fired: a ray exceeded the cycle limit (timed) or the step bound (traversal)
};

inline constexpr const char* kErrorNames[] = {
    "none",        "bad_opcode", "bad_address", "misaligned", "bad_count",    "reserved_bits", "bad_ring",
    "ring_misuse", "no_scene",   "bad_scene",   "overlap",    "bad_register", "watchdog"};
static_assert(count_of(kErrorNames) == std::size_t(ErrorCode::kWatchdog) + 1, "a name for every error code");
constexpr const char* error_name(ErrorCode e) {
  return enum_name(kErrorNames, e);
}

}  // namespace rtu::hw::reg
