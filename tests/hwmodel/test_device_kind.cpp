// Device kinds by name, and the one factory of engines (hw::make_engine).
#include <catch2/catch.hpp>

#include <memory>
#include <stdexcept>
#include <string>

#include "hwmodel/device/device_kind.h"
#include "hwmodel/device/engine.h"
#include "hwmodel/timing/timing_config.h"

using rtu::hw::DeviceKind;

namespace {

struct NoBoxUnit final : rtu::hw::BoxUnit {
  const char* name() const override { return "none"; }
  void check_format(const rtu::hw::FixedFormat&, int) const override {}
  void test(const rtu::hw::FixedRay&, const rtu::hw::BoxUnitNode&, int64_t, int64_t,
            rtu::hw::BoxUnitResult&) override {}
};

struct NoTriUnit final : rtu::hw::TriUnit {
  const char* name() const override { return "none"; }
  void check_format(const rtu::hw::FixedFormat&) const override {}
  void test(const rtu::hw::FixedRay&, const int32_t[3][3], int64_t, int64_t, rtu::hw::TriUnitResult&) override {}
};

}  // namespace

TEST_CASE("device kinds: names round-trip, and an unknown name says which are known", "[device]") {
  REQUIRE(rtu::hw::device_kind_names() == std::vector<std::string>{"float", "fixed", "timed"});
  for (const std::string& name : rtu::hw::device_kind_names())
    CHECK(rtu::hw::device_kind_name(rtu::hw::parse_device_kind(name)) == name);
  CHECK(rtu::hw::parse_device_kind("timed") == DeviceKind::kTimed);
  CHECK_THROWS_MATCHES(rtu::hw::parse_device_kind("Float"), std::invalid_argument,
                       Catch::Message("unknown device 'Float' (known: float, fixed, timed)"));
  CHECK_THROWS_AS(rtu::hw::parse_device_kind(""), std::invalid_argument);
}

TEST_CASE("make_engine: the engine of each kind, and box and triangle units for the timed one only", "[device]") {
  const rtu::hw::TimingConfig c = rtu::hw::timing_preset("rdna2");
  for (const DeviceKind k : {DeviceKind::kFloat, DeviceKind::kFixed, DeviceKind::kTimed}) {
    const std::unique_ptr<rtu::hw::TraceEngine> e = rtu::hw::make_engine(k, {}, c);
    REQUIRE(e);
    CHECK(std::string(e->name()) == rtu::hw::device_kind_name(k));
    CHECK_FALSE(e->bound());
  }
  CHECK_THROWS_AS(rtu::hw::make_engine(DeviceKind::kFixed, {}, c, std::make_unique<NoBoxUnit>()),
                  std::invalid_argument);
  CHECK_THROWS_AS(rtu::hw::make_engine(DeviceKind::kFloat, {}, c, std::make_unique<NoBoxUnit>()),
                  std::invalid_argument);
  // A triangle unit likewise: the timed engine only, and only with tri_unit = rtl (which requires one).
  CHECK_THROWS_WITH(rtu::hw::make_engine(DeviceKind::kFixed, {}, c, nullptr, std::make_unique<NoTriUnit>()),
                    Catch::Contains("takes no triangle unit"));
  CHECK_THROWS_WITH(rtu::hw::make_engine(DeviceKind::kTimed, {}, c, nullptr, std::make_unique<NoTriUnit>()),
                    Catch::Contains("tri_unit = cpp"));
  rtu::hw::TimingConfig rtl = c;
  rtl.tri_unit = rtu::hw::UnitModel::kRtl;
  CHECK_THROWS_WITH(rtu::hw::make_engine(DeviceKind::kTimed, {}, rtl),
                    Catch::Contains("no RTL triangle unit is attached"));
  CHECK(rtu::hw::make_engine(DeviceKind::kTimed, {}, rtl, nullptr, std::make_unique<NoTriUnit>()));
}
