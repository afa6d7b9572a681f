// Configuration text: the timed device's `--config P --set KEY=VALUE` (host timing_config_from over
// hw::set_timing_key) and the fixed-point format fields (`--coord-bits` ...; FixedFormat::validate). Lines of the
// input: "preset NAME", "KEY=VALUE" (timing keys), "format.FIELD=N" (format fields), "memory=SIZE"
// (RTU_MEMORY_LIMIT's syntax). Accepted configurations must work: a format that validates encodes the tiny scene
// and traces rays without undefined behaviour (the widths it proves are the ones the datapath uses); a timing
// configuration runs the timed engine, whose hits equal the fixed device's and whose cycles repeat.
#include <sstream>
#include <stdexcept>

#include "host/devices/device_settings.h"
#include "host/io/error.h"
#include "host/io/limits.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/numeric/fixed_format.h"
#include "tests/fuzz/fuzz.h"

namespace rtu::fuzz {

namespace {

hw::DeviceImage encode(const hw::FixedFormat& f) {
  hw::TracerOptions opt;
  opt.accel = hw::AccelMode::kBvh;
  opt.bvh.width = f.width;
  const std::optional<hw::Bvh> bvh = hw::choose_accel(tiny_geometry(), opt);
  return hw::encode_scene(tiny_geometry(), f, bvh ? &*bvh : nullptr);
}

}  // namespace

int config(const uint8_t* data, size_t size) {
  init();
  std::istringstream text(std::string(reinterpret_cast<const char*>(data), size));
  std::string line, preset = "rdna2";
  std::vector<std::string> sets;
  hw::FixedFormat f;
  bool format_ok = true;
  while (std::getline(text, line)) {
    if (line.rfind("preset ", 0) == 0) {
      preset = line.substr(7);
    } else if (line.rfind("format.", 0) == 0) {
      const size_t eq = line.find('=');
      if (eq == std::string::npos) continue;
      const std::string key = line.substr(7, eq - 7), value = line.substr(eq + 1);
      if (key == "preset") {
        try {
          f = hw::format_preset(value);
        } catch (const std::invalid_argument&) {
          format_ok = false;
        }
        continue;
      }
      int v = 0;
      try {
        size_t used = 0;
        v = std::stoi(value, &used);
        if (used != value.size()) throw std::invalid_argument("trailing");
      } catch (const std::exception&) {
        format_ok = false;
        continue;
      }
      int* field = key == "width"         ? &f.width
                   : key == "coord_bits"  ? &f.coord_bits
                   : key == "child_bits"  ? &f.child_bits
                   : key == "guard_bits"  ? &f.guard_bits
                   : key == "frac_bits"   ? &f.frac_bits
                   : key == "dir_bits"    ? &f.dir_bits
                   : key == "rcp_bits"    ? &f.rcp_bits
                   : key == "t_frac_bits" ? &f.t_frac_bits
                   : key == "t_bits"      ? &f.t_bits
                                          : nullptr;
      if (field) *field = v;
    } else if (line.rfind("memory=", 0) == 0) {
      try {
        const std::string v = line.substr(7);
        const uint64_t m = host::parse_size(v, "memory");
        RTU_FUZZ_CHECK(m % 1024 == 0 || v.find_first_of("KkMmGgTt") == std::string::npos);
      } catch (const host::Error&) {
      }
    } else if (!line.empty()) {
      sets.push_back(line);
    }
  }

  const hw::Geometry& g = tiny_geometry();
  const std::vector<hw::Ray> rays = rays_around(g.bounds(), 16, size);
  if (format_ok) {
    bool valid = true;
    try {
      f.validate();
    } catch (const std::invalid_argument&) {
      valid = false;
    }
    if (valid) {
      const hw::DeviceImage img = encode(f);
      hw::DeviceImage::from_bytes(img.data(), img.size());  // the encoder's output is valid (throws otherwise)
      const hw::FixedTracer t(img, hw::FixedTraceOptions{true});
      std::vector<hw::Hit> hits(rays.size());
      hw::TraversalStats s;
      t.trace_batch(rays.data(), hits.data(), rays.size(), false, 1, s);
      RTU_FUZZ_CHECK(s.box_false_negatives == 0);  // conservative box test, whatever the widths
      for (const hw::Hit& h : hits) RTU_FUZZ_CHECK(h.prim == hw::kMissPrim || h.prim < g.num_prims());
    }
  }

  hw::TimingConfig c;
  try {
    c = host::timing_config_from(preset, sets);
  } catch (const host::Error&) {
    return 0;
  }
  c.validate();                                // timing_config_from accepted it: it must validate
  if (uint64_t(c.cache_kib) > 4096) return 0;  // valid, but allocating 64 MiB per input slows the fuzzer down
  hw::FixedFormat tf = hw::format_preset(c.format);
  tf.width = c.bvh_width;
  const hw::DeviceImage img = encode(tf);
  const hw::FixedTracer t(img);
  std::vector<hw::Hit> want(rays.size()), got(rays.size());
  hw::TraversalStats s;
  t.trace_batch(rays.data(), want.data(), rays.size(), false, 1, s);
  uint64_t cycles[2] = {0, 0};
  for (uint64_t& cyc : cycles) {
    hw::TimedEngine e(hw::EngineOptions{}, c);
    e.bind(img.data(), img.size());
    hw::TraversalStats st;
    try {
      cyc = e.trace_cycles(rays.data(), got.data(), rays.size(), false, st, 0, 0);
    } catch (const hw::WatchdogError& w) {
      RTU_FUZZ_CHECK(c.watchdog_cycles > 0 && std::string(w.what()).find("watchdog") != std::string::npos);
      return 0;
    }
    RTU_FUZZ_CHECK(std::memcmp(want.data(), got.data(), want.size() * sizeof(hw::Hit)) == 0);
  }
  RTU_FUZZ_CHECK(cycles[0] == cycles[1] && cycles[0] > 0);
  return 0;
}

}  // namespace rtu::fuzz

RTU_FUZZ_ENTRY(config)
