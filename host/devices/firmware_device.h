// The whole device as the firmware sees it, in process: device memory, the register file and command processor,
// and the trace engine of a device kind (float, fixed or timed), wired as the unit would be. The firmware sees
// only fw::Hal; host jobs that run firmware (render, soak, the demo's renders) drive it this way. DirectDevice
// (direct_device.h) calls the same datapaths directly, without firmware.
#pragma once

#include <atomic>
#include <memory>

#include "firmware/hal.h"
#include "hwmodel/device/command_processor.h"
#include "hwmodel/device/device_kind.h"
#include "hwmodel/device/engine.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/interface/device_memory.h"
#include "hwmodel/numeric/fixed_format.h"

namespace rtu::host {

class FirmwareDevice final : public fw::Hal {
 public:
  // The engine of `kind` (hw::make_engine; `timing` configures the timed one, and its box_unit and tri_unit keys
  // choose the box and triangle units: make_box_unit, make_tri_unit) over memory_bytes of device memory.
  FirmwareDevice(hw::DeviceKind kind, uint64_t memory_bytes, const hw::EngineOptions& opt = {},
                 const hw::TimingConfig& timing = {});

  uint32_t read32(uint32_t offset) override { return m_cp.read(offset); }
  void write32(uint32_t offset, uint32_t value) override { m_cp.write(offset, value); }
  void barrier() override { std::atomic_thread_fence(std::memory_order_seq_cst); }
  uint8_t* mem() override { return m_mem.data(); }
  uint64_t mem_size() override { return m_mem.size(); }
  void set_any_hit(const hw::AnyHitStage* stage) override { m_engine->set_any_hit(stage); }
  void set_micromaps(const hw::MicromapSet* maps) { m_engine->set_micromaps(maps); }

  hw::DeviceKind kind() const { return m_kind; }
  hw::DeviceMemory& memory() { return m_mem; }
  hw::CommandProcessor& processor() { return m_cp; }
  const hw::TraceEngine& engine() const { return *m_engine; }
  // The timed engine (null for float and fixed).
  const hw::TimedEngine* timed() const { return dynamic_cast<const hw::TimedEngine*>(m_engine.get()); }
  hw::TimedEngine* timed() { return dynamic_cast<hw::TimedEngine*>(m_engine.get()); }

 private:
  hw::DeviceKind m_kind;
  hw::DeviceMemory m_mem;
  std::unique_ptr<hw::TraceEngine> m_engine;
  hw::CommandProcessor m_cp;
};

}  // namespace rtu::host
