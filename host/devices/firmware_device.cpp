#include "host/devices/firmware_device.h"

#include "host/devices/box_units.h"

namespace rtu::host {

FirmwareDevice::FirmwareDevice(hw::DeviceKind kind, uint64_t memory_bytes, const hw::EngineOptions& opt,
                               const hw::TimingConfig& timing)
    : m_kind(kind),
      m_mem(memory_bytes),
      m_engine(hw::make_engine(kind, opt, timing, kind == hw::DeviceKind::kTimed ? make_box_unit(timing) : nullptr,
                               kind == hw::DeviceKind::kTimed ? make_tri_unit(timing) : nullptr)),
      m_cp(m_mem, *m_engine) {}

}  // namespace rtu::host
