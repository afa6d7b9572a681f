// Texture images (host/io/image.cpp: PNG and JPEG through stb_image), as scene files and mesh files reference
// them. A decoded texture has the size it claims and four bytes per texel, read from memory or from a file alike.
// It then masks a quad (alpha_mode mask, texture coordinates that wrap) traced on the float, fixed and timed
// devices through the firmware's any-hit stage: the bilinear filter's samples stay inside the texels (ASan), hits
// name the quad or miss, and the timed device's hits equal the fixed device's bit for bit.
#include <cstring>
#include <memory>

#include "host/devices/direct_device.h"
#include "host/io/error.h"
#include "host/io/image.h"
#include "host/scene/generators.h"
#include "host/scene/scene.h"
#include "host/scene/shading.h"
#include "tests/fuzz/fuzz.h"

namespace rtu::fuzz {

int texture(const uint8_t* data, size_t size) {
  init();
  host::Texture t;
  try {
    t = host::read_texture_memory(data, size, "fuzz texture");
  } catch (const host::Error&) {
    return 0;
  }
  RTU_FUZZ_CHECK(t.width >= 1 && t.height >= 1);
  RTU_FUZZ_CHECK(t.rgba.size() == size_t(t.width) * t.height * 4);
  const host::Texture f = host::read_texture(scratch_file("t.img", data, size));
  RTU_FUZZ_CHECK(f.width == t.width && f.height == t.height && f.rgba == t.rgba);

  // A 2 x 2 quad at y = 0 whose texture coordinates run from -1 to 2 (three wraps each way).
  host::Scene s;
  s.name = "fuzz texture";
  host::Material m;
  m.texture = 0;
  m.alpha_mode = host::AlphaMode::kMask;
  m.alpha_cutoff = float(data[size / 2]) / 255.0f;
  s.materials.push_back(m);
  s.textures.push_back(std::move(t));
  const host::IndexedMesh quad = host::make_quad(2.0f, 2.0f);
  host::append_triangles(quad, s.geometry.triangles);
  for (const auto& face : quad.faces) {
    host::TriangleUv uv;
    for (int k = 0; k < 3; ++k) {
      uv.s[k] = 3.0f * quad.uvs[face[size_t(k)]][0] - 1.0f;
      uv.t[k] = 3.0f * quad.uvs[face[size_t(k)]][1] - 1.0f;
    }
    s.triangle_uv.push_back(uv);
  }
  s.prim_material.assign(s.geometry.triangles.size(), 0);
  host::finish_scene(s);
  const host::SceneAnyHit alpha(s);
  RTU_FUZZ_CHECK(alpha.stage() != nullptr);

  std::vector<hw::Ray> rays = rays_around(s.geometry.bounds(), 48, size);
  for (int i = 0; i < 16; ++i)  // straight down onto the quad
    rays.push_back(hw::Ray{hw::Vec3(-0.95f + 0.12f * float(i), 1.0f, 0.9f - 0.11f * float(i)), 0.0f,
                           hw::Vec3(0.0f, -1.0f, 0.0f), 2.0f});
  std::vector<hw::Hit> hits[3];
  hw::TraversalStats stats[3];
  const hw::DeviceKind kinds[3] = {hw::DeviceKind::kFloat, hw::DeviceKind::kFixed, hw::DeviceKind::kTimed};
  for (int d = 0; d < 3; ++d) {
    host::DeviceOptions o;
    o.kind = kinds[d];
    o.any_hit = alpha.stage();
    const auto dev = host::make_device(s.geometry, o);
    hits[d].resize(rays.size());
    dev->trace_batch(rays.data(), hits[d].data(), rays.size(), false, 1, stats[d]);
    for (const hw::Hit& h : hits[d]) RTU_FUZZ_CHECK(h.prim == hw::kMissPrim || h.prim < 2);
    RTU_FUZZ_CHECK(stats[d].any_hit_ignored <= stats[d].any_hit_calls);
  }
  RTU_FUZZ_CHECK(std::memcmp(hits[1].data(), hits[2].data(), hits[1].size() * sizeof(hw::Hit)) == 0);
  RTU_FUZZ_CHECK(stats[1].any_hit_calls == stats[2].any_hit_calls);
  return 0;
}

}  // namespace rtu::fuzz

RTU_FUZZ_ENTRY(texture)
