#include "hwmodel/device/command_processor.h"

#include <exception>
#include <new>
#include <string>
#include <vector>

namespace rtu::hw {

using reg::ErrorCode;

CommandProcessor::CommandProcessor(DeviceMemory& memory, TraceEngine& engine) : m_mem(memory), m_engine(engine) {}

uint32_t CommandProcessor::read(uint32_t offset) {
  switch (offset) {
    case reg::kId:
      return reg::kIdValue;
    case reg::kVersion:
      return reg::kVersionValue;
    case reg::kCaps:
      return m_engine.caps();
    case reg::kControl:
      return m_control;
    case reg::kStatus: {
      uint32_t s = 0;
      if (m_control & reg::kCtrlEnable) s |= reg::kStatusEnabled;
      if (m_head == m_tail) s |= reg::kStatusIdle;
      if (m_error != ErrorCode::kNone) s |= reg::kStatusError;
      if (m_engine.bound()) s |= reg::kStatusBound;
      return s;
    }
    case reg::kErrorCode:
      return uint32_t(m_error);
    case reg::kErrorInfo:
      return m_error_info;
    case reg::kIrqStatus:
      return m_irq_status;
    case reg::kIrqEnable:
      return m_irq_enable;
    case reg::kRingBaseLo:
      return uint32_t(m_ring_base);
    case reg::kRingBaseHi:
      return uint32_t(m_ring_base >> 32);
    case reg::kRingSize:
      return m_ring_size;
    case reg::kRingHead:
      return m_head;
    case reg::kRingTail:
      return m_tail;
    case reg::kClockLo:
      m_clock_hi_latch = uint32_t(m_clock >> 32);
      return uint32_t(m_clock);
    case reg::kClockHi:
      return m_clock_hi_latch;
    case reg::kFenceLo:
      return uint32_t(m_fence);
    case reg::kFenceHi:
      return uint32_t(m_fence >> 32);
    case reg::kMemSizeLo:
      return uint32_t(m_mem.size());
    case reg::kMemSizeHi:
      return uint32_t(m_mem.size() >> 32);
    default:
      return 0xFFFFFFFFu;
  }
}

void CommandProcessor::write(uint32_t offset, uint32_t value) {
  const bool enabled = (m_control & reg::kCtrlEnable) != 0;
  const bool stopped = m_error != ErrorCode::kNone;
  switch (offset) {
    case reg::kControl:
      if (value & ~(reg::kCtrlEnable | reg::kCtrlReset)) return raise(ErrorCode::kReservedBits, offset);
      if (value & reg::kCtrlReset) return reset();
      if (stopped) return;
      if ((value & reg::kCtrlEnable) && !enabled) {
        const uint32_t n = m_ring_size;
        const bool pow2 = n >= 2 && n <= reg::kMaxRingSlots && (n & (n - 1)) == 0;
        if (!pow2 || m_ring_base % cmd::kPacketBytes != 0 ||
            !m_mem.in_range(m_ring_base, uint64_t(n) * cmd::kPacketBytes))
          return raise(ErrorCode::kBadRing, offset);
        m_head = m_tail = 0;
      }
      m_control = value & reg::kCtrlEnable;
      return;
    case reg::kIrqStatus:
      m_irq_status &= ~value;
      return;
    case reg::kIrqEnable:
      m_irq_enable = value & (reg::kIrqFence | reg::kIrqError);
      return;
    case reg::kRingBaseLo:
    case reg::kRingBaseHi:
    case reg::kRingSize:
      if (stopped) return;
      if (enabled) return raise(ErrorCode::kRingMisuse, offset);
      if (offset == reg::kRingBaseLo) m_ring_base = (m_ring_base & ~uint64_t(0xFFFFFFFFu)) | value;
      if (offset == reg::kRingBaseHi) m_ring_base = (m_ring_base & 0xFFFFFFFFu) | (uint64_t(value) << 32);
      if (offset == reg::kRingSize) m_ring_size = value;
      return;
    case reg::kRingTail:
      if (stopped) return;
      if (!enabled || value >= m_ring_size) return raise(ErrorCode::kRingMisuse, offset);
      m_tail = value;
      consume();
      return;
    default:
      return raise(ErrorCode::kBadRegister, offset);  // read-only, unknown or unaligned
  }
}

void CommandProcessor::raise(ErrorCode e, uint32_t info) {
  if (m_error != ErrorCode::kNone) return;  // the first error is kept
  m_error = e;
  m_error_info = info;
  m_irq_status |= reg::kIrqError;
  ++m_counters.errors;
  ++m_counters.irqs;
}

void CommandProcessor::reset() {
  m_control = 0;
  m_irq_status = 0;
  m_error = ErrorCode::kNone;
  m_error_info = 0;
  m_error_detail.clear();
  m_ring_base = 0;
  m_ring_size = 0;
  m_head = m_tail = 0;
  m_fence = 0;
  m_engine.unbind();
}

void CommandProcessor::consume() {
  // At most ring-size - 1 packets are pending, so this ends.
  while (m_head != m_tail && m_error == ErrorCode::kNone) {
    cmd::Packet p;
    m_mem.read(m_ring_base + uint64_t(m_head) * cmd::kPacketBytes, &p, sizeof p);  // in range (checked at enable)
    m_trace_cycles = 0;
    if (!execute(p)) return;  // head stays on the faulting packet
    ++m_counters.packets;
    ++m_counters.by_opcode[p.opcode];
    m_clock += p.opcode == uint8_t(cmd::Opcode::kTrace) ? m_trace_cycles : m_engine.packet_cycles(p.opcode);
    if (p.opcode == uint8_t(cmd::Opcode::kFence) && (p.flags & cmd::kFenceIrq))
      m_counters.last_irq_cycle = m_clock + m_engine.irq_latency();
    m_head = (m_head + 1) & (m_ring_size - 1);
  }
}

bool CommandProcessor::check_buffer(uint64_t addr, uint64_t bytes, uint64_t align) {
  if (addr % align != 0) {
    raise(ErrorCode::kMisaligned, m_head);
    return false;
  }
  if (!m_mem.in_range(addr, bytes)) {
    raise(ErrorCode::kBadAddress, m_head);
    return false;
  }
  return true;
}

bool CommandProcessor::execute_trace(const cmd::Packet& p) {
  const bool any_hit = (p.flags & cmd::kTraceAnyHit) != 0, all_hits = (p.flags & cmd::kTraceAllHits) != 0;
  if ((p.flags & ~(cmd::kTraceAnyHit | cmd::kTraceAllHits)) || (any_hit && all_hits) ||
      p.ray_type >= cmd::kRayTypeCount || (!all_hits && p.value)) {
    raise(ErrorCode::kReservedBits, m_head);
    return false;
  }
  if (p.count == 0 || p.count > cmd::kMaxTraceCount || (all_hits && p.value > cmd::kMaxAllHits)) {
    raise(ErrorCode::kBadCount, m_head);
    return false;
  }
  const uint64_t per_ray = all_hits ? cmd::all_hits_list_bytes(p.value) : cmd::kHitBytes;
  const uint64_t rb = uint64_t(p.count) * cmd::kRayBytes, hb = uint64_t(p.count) * per_ray;
  if (!check_buffer(p.addr0, rb, 16) || !check_buffer(p.addr1, hb, 16)) return false;
  if (p.addr0 < p.addr1 + hb && p.addr1 < p.addr0 + rb) {
    raise(ErrorCode::kOverlap, m_head);
    return false;
  }
  if (!m_engine.bound()) {
    raise(ErrorCode::kNoScene, m_head);
    return false;
  }
  std::vector<Ray> rays(p.count);
  m_mem.read(p.addr0, rays.data(), rb);
  TraversalStats s;
  std::vector<Hit> hits(all_hits ? size_t(p.count) * p.value : p.count);
  std::vector<uint64_t> counts(all_hits ? p.count : 0);
  try {
    if (all_hits)
      m_trace_cycles = m_engine.trace_all_cycles(rays.data(), p.count,
                                                 AllHitsOut{uint32_t(p.value), hits.data(), counts.data()}, s,
                                                 p.ray_type, p.bounce);
    else
      m_trace_cycles = m_engine.trace_cycles(rays.data(), hits.data(), p.count, any_hit, s, p.ray_type, p.bounce);
  } catch (const WatchdogError& e) {
    raise(ErrorCode::kWatchdog, m_head);
    m_error_detail = e.what();
    m_clock += e.cycles();
    return false;
  }
  if (all_hits)
    write_hit_lists(p.addr1, uint32_t(p.value), hits, counts);
  else
    m_mem.write(p.addr1, hits.data(), hb);
  m_counters.stats_by_type[p.ray_type].add(s);
  m_counters.rays_by_type[p.ray_type] += p.count;
  if (any_hit) m_counters.any_hit_rays += p.count;
  if (all_hits) m_counters.all_hit_rays += p.count;
  if (p.bounce > m_counters.max_bounce) m_counters.max_bounce = p.bounce;
  return true;
}

void CommandProcessor::write_hit_lists(uint64_t at, uint32_t k, const std::vector<Hit>& hits,
                                       const std::vector<uint64_t>& counts) {
  for (size_t i = 0; i < counts.size(); ++i, at += cmd::all_hits_list_bytes(k)) {
    const uint64_t n = counts[i];
    const cmd::HitListHeader h = cmd::hit_list_header(n, k);
    m_mem.write(at, &h, sizeof h);
    if (h.kept) m_mem.write(at + sizeof h, hits.data() + i * k, uint64_t(h.kept) * cmd::kHitBytes);
    m_counters.all_hits_found += n;
    m_counters.all_hit_overflows += n > k;
  }
}

bool CommandProcessor::execute(const cmd::Packet& p) {
  using cmd::Opcode;
  auto reserved = [&](bool bad) {
    if (bad) raise(ErrorCode::kReservedBits, m_head);
    return bad;
  };
  if (p.opcode >= cmd::kOpcodeCount) {
    raise(ErrorCode::kBadOpcode, m_head);
    return false;
  }
  switch (Opcode(p.opcode)) {
    case Opcode::kNop:
      return !reserved(p.flags || p.ray_type || p.bounce || p.count || p.addr0 || p.addr1 || p.value);
    case Opcode::kBindScene: {
      if (reserved(p.flags || p.ray_type || p.bounce || p.count || p.addr1)) return false;
      if (!check_buffer(p.addr0, p.value, 8)) return false;
      try {
        m_engine.bind(m_mem.data() + p.addr0, size_t(p.value));
      } catch (const std::bad_alloc&) {  // no memory for the decoded image: said so, not as "std::bad_alloc"
        raise(ErrorCode::kBadScene, m_head);
        m_error_detail = "out of memory binding the scene image of " + std::to_string(p.value) + " bytes";
        return false;
      } catch (const std::exception& e) {  // a malformed image (std::invalid_argument)
        raise(ErrorCode::kBadScene, m_head);
        m_error_detail = e.what();
        return false;
      }
      return true;
    }
    case Opcode::kTrace:
      return execute_trace(p);
    case Opcode::kFence: {
      if (reserved((p.flags & ~cmd::kFenceIrq) || p.ray_type || p.bounce || p.count || p.addr1)) return false;
      if (!check_buffer(p.addr0, 8, 8)) return false;
      m_mem.store<uint64_t>(p.addr0, p.value);
      m_fence = p.value;
      if (p.flags & cmd::kFenceIrq) {
        m_irq_status |= reg::kIrqFence;
        ++m_counters.irqs;
        ++m_counters.fence_irqs;
      }
      return true;
    }
    case Opcode::kTimestamp: {
      if (reserved(p.flags || p.ray_type || p.bounce || p.count || p.addr1 || p.value)) return false;
      if (!check_buffer(p.addr0, 8, 8)) return false;
      m_mem.store<uint64_t>(p.addr0, m_clock);
      return true;
    }
  }
  raise(ErrorCode::kBadOpcode, m_head);
  return false;
}

}  // namespace rtu::hw
