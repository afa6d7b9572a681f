#include "host/model_device.h"

#include "host/box_units.h"
#include "host/error.h"

namespace rtu::host {

namespace {

std::unique_ptr<hw::TraceEngine> make_engine(const std::string& name, const hw::EngineOptions& opt,
                                             const hw::TimingConfig& timing) {
  if (name == "float") return hw::make_float_engine(opt);
  if (name == "fixed") return hw::make_fixed_engine(opt);
  if (name == "timed") return hw::make_timed_engine(opt, timing, make_box_unit(timing));
  throw Error("unknown device '" + name + "' (devices: float, fixed, timed)");
}

}  // namespace

ModelDevice::ModelDevice(const std::string& engine, uint64_t memory_bytes, const hw::EngineOptions& opt,
                         const hw::TimingConfig& timing)
    : m_name(engine), m_mem(memory_bytes), m_engine(make_engine(engine, opt, timing)), m_cp(m_mem, *m_engine) {}

}  // namespace rtu::host
