// Scene description files (host/scene/scene_file.cpp) and builtin:NAME?params specs, then what a job does with an
// accepted scene: BVH build and the fixed device's image (which DeviceImage::from_bytes must accept: the encoder's
// output is valid by construction), the float scene image round trip, a few rays on the float and fixed devices
// (every hit names a primitive of the scene), and a tiny firmware render. Mesh files ("file" entries) are left to
// fuzz_mesh_import: a fuzzed path could name any file of the machine.
#include <cmath>
#include <memory>
#include <stdexcept>

#include "host/devices/direct_device.h"
#include "host/io/error.h"
#include "host/jobs/render.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/device/engine.h"
#include "tests/fuzz/fuzz.h"

namespace rtu::fuzz {

int scene_file(const uint8_t* data, size_t size) {
  init();
  const std::string text(reinterpret_cast<const char*>(data), size);
  host::Scene scene;
  try {
    if (text.rfind("builtin:", 0) == 0) {
      if (text.find('\0') != std::string::npos) return 0;
      scene = host::load_scene(text);
    } else {
      if (text.find("file") != std::string::npos || text.find("\\u") != std::string::npos) return 0;
      scene = host::load_scene(scratch_file("scene.json", data, size));
    }
  } catch (const host::Error&) {
    return 0;  // refused with a message: what bad input must get
  }
  const hw::Geometry& g = scene.geometry;
  RTU_FUZZ_CHECK(g.num_prims() > 0 && scene.prim_material.size() == g.num_prims());
  if (g.num_prims() > 20000) return 0;  // valid, but too slow to trace on every input

  // The float scene image decodes to the same geometry, bit for bit.
  const std::vector<uint64_t> fimg = hw::encode_float_scene(g);
  const hw::Geometry back = hw::decode_float_scene(reinterpret_cast<const uint8_t*>(fimg.data()), fimg.size() * 8);
  RTU_FUZZ_CHECK(back.triangles.size() == g.triangles.size() && back.spheres.size() == g.spheres.size() &&
                 back.planes.size() == g.planes.size());
  RTU_FUZZ_CHECK(g.triangles.empty() || std::memcmp(back.triangles.data(), g.triangles.data(),
                                                    g.triangles.size() * sizeof(hw::Triangle)) == 0);

  std::vector<hw::Ray> rays = host::primary_rays(scene.camera, 4, 3);
  const std::vector<hw::Ray> more =
      rays_around(g.bounds().empty() ? hw::Aabb{hw::Vec3(-1.0f), hw::Vec3(1.0f)} : g.bounds(), 8, size);
  rays.insert(rays.end(), more.begin(), more.end());
  for (const char* device : {"float", "fixed"}) {
    host::DeviceOptions o;
    o.kind = rtu::hw::parse_device_kind(device);
    std::unique_ptr<host::DirectDevice> d;
    try {
      d = host::make_device(g, o);
    } catch (const std::invalid_argument&) {
      continue;  // e.g. a scene beyond the fixed format's frame
    }
    if (const hw::DeviceImage* img = d->image()) {
      try {
        hw::DeviceImage::from_bytes(img->data(), img->size());
      } catch (const std::invalid_argument& e) {
        std::fprintf(stderr, "rtu fuzz: the encoder wrote an image from_bytes refuses: %s\n", e.what());
        std::abort();
      }
    }
    std::vector<hw::Hit> hits(rays.size());
    hw::TraversalStats s;
    d->trace_batch(rays.data(), hits.data(), rays.size(), false, 1, s);
    for (const hw::Hit& h : hits) RTU_FUZZ_CHECK(h.prim == hw::kMissPrim || h.prim < g.num_prims());
    RTU_FUZZ_CHECK(s.watchdog_rays == 0);
  }

  // The firmware renderer on the fixed device: materials, lights and camera as the file gives them.
  host::RenderOptions ro;
  ro.device.kind = rtu::hw::DeviceKind::kFixed;
  ro.width = 4;
  ro.height = 3;
  ro.max_depth = 2;
  ro.threads = 1;
  try {
    const host::RenderResult r = host::render(scene, ro);
    RTU_FUZZ_CHECK(r.rgb.size() == 4 * 3 * 3);
  } catch (const host::Error&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}

}  // namespace rtu::fuzz

RTU_FUZZ_ENTRY(scene_file)
