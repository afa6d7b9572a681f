// Alpha-tested geometry: a quad whose texture masks known texels, primary and shadow rays through them with exact
// counts on every device, the any-hit stage's cost in the timing model, nothing changed without masks, renders
// (ray traced and hybrid) that see through the masked half, and the bad inputs textures add.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "host/devices/direct_device.h"
#include "host/io/error.h"
#include "host/io/image.h"
#include "host/jobs/render.h"
#include "host/scene/scene.h"
#include "host/scene/shading.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/timing/timing_config.h"
#include "tests/common/test_util.h"
#include "tests/host/error_checks.h"
#include "tests/host/run_process.h"

#include <stb/stb_image_write.h>

using namespace rtu;
using Catch::Matchers::Contains;

namespace {

std::filesystem::path test_dir() {
  return rtu::test::temp_dir("alpha");
}

std::string write_file(const std::string& name, const std::string& text) {
  const std::string path = (test_dir() / name).string();
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

std::string alpha_load_error(const std::string& text) {
  return error_of([&] { host::load_scene(write_file("bad.json", text)); }, "(loaded)");
}

// The mask: 4 x 4 texels, bit (row * 4 + col) of kMask set where the leaf is there (alpha 255), clear where rays
// pass (alpha 0). Its colour is irrelevant to the test.
constexpr int kSide = 4;
constexpr uint32_t kMask = 0xA5C3;  // 8 of 16 texels set, no two rows alike
constexpr float kLeafSize =
    4.0f;  // the leaf quad spans x, z in [-2, 2] at y = 0, s = x / 4 + 0.5, t = z / 4 + 0.5

bool texel_set(int col, int row) {
  return (kMask >> (row * kSide + col)) & 1u;
}

// The leaf (triangles 0, 1) over an opaque floor (triangles 2, 3) at y = -1.
std::string leaf_scene(const std::string& alpha_mode) {
  std::string texels;
  for (int row = 0; row < kSide; ++row)
    for (int col = 0; col < kSide; ++col)
      texels +=
          std::string(texels.empty() ? "" : ", ") + "[40, 160, 40, " + (texel_set(col, row) ? "255" : "0") + "]";
  return R"({
    "textures": {"mask": {"width": 4, "height": 4, "texels": [)" +
         texels + R"(]}},
    "materials": {
      "leaf": {"color": [1, 1, 1], "texture": "mask", "alpha_mode": ")" +
         alpha_mode + R"(", "alpha_cutoff": 0.5},
      "floor": {"color": [0.8, 0.2, 0.2]}
    },
    "meshes": [
      {"generate": "quad", "size": [4, 4], "material": "leaf"},
      {"generate": "quad", "size": [8, 8], "material": "floor", "transform": {"translate": [0, -1, 0]}}
    ],
    "lights": [{"type": "point", "position": [0, 6, 0], "intensity": [30, 30, 30]}],
    "camera": {"position": [0, 6, 0.01], "look_at": [0, 0, 0], "fov_y": 40}
  })";
}

host::Scene load_leaf(const std::string& alpha_mode) {
  return host::load_scene(write_file("leaf_" + alpha_mode + ".json", leaf_scene(alpha_mode)));
}

// Rays crossing y = 0 at four points of every texel, each within 0.15 texel of the centre in s and in t. Bilinear
// filtering then gives the texel's own alpha a weight >= 0.85^2 = 0.72: alpha >= 0.72 on a set texel and <= 0.28
// on a clear one, far from the cutoff 0.5 against float error in u, v (~1e-7). The offsets differ in s and t, so
// no point lies on the quad's diagonal (the edge its two triangles share).
struct TexelRays {
  std::vector<hw::Ray> rays;
  std::vector<bool> solid;  // the ray's texel is set
  uint64_t solid_count = 0;
};

TexelRays texel_rays(bool downward) {
  const float offsets[4][2] = {{0.10f, -0.10f}, {-0.10f, 0.10f}, {0.15f, -0.05f}, {-0.05f, 0.15f}};
  TexelRays out;
  for (int row = 0; row < kSide; ++row)
    for (int col = 0; col < kSide; ++col)
      for (const auto& off : offsets) {
        const float s = (float(col) + 0.5f + off[0]) / kSide, t = (float(row) + 0.5f + off[1]) / kSide;
        const hw::Vec3 at((s - 0.5f) * kLeafSize, 0.0f, (t - 0.5f) * kLeafSize);
        hw::Ray r{};
        r.tmax = std::numeric_limits<float>::infinity();
        if (downward) {
          // Primary rays from above, slightly slanted so that they are not axis-aligned.
          r.origin = at + hw::Vec3(0.03f, 2.0f, -0.02f);
          r.dir = at - r.origin;
        } else {
          // Shadow rays from below up to a light above the leaf: occluded exactly where the leaf is there.
          r.origin = at + hw::Vec3(-0.01f, -0.5f, 0.02f);
          r.dir = at - r.origin;
          r.tmax = 3.0f;
        }
        out.rays.push_back(r);
        out.solid.push_back(texel_set(col, row));
        out.solid_count += texel_set(col, row);
      }
  return out;
}

const hw::DeviceKind kKinds[] = {hw::DeviceKind::kFloat, hw::DeviceKind::kFixed, hw::DeviceKind::kTimed};

struct AlphaTraced {
  std::vector<hw::Hit> hits;
  hw::TraversalStats stats;
  hw::TimingStats timing;
};

AlphaTraced alpha_trace(const host::Scene& scene, hw::DeviceKind kind, const std::vector<hw::Ray>& rays,
                        bool any_hit, const hw::TimingConfig* timing = nullptr) {
  const host::SceneAnyHit alpha(scene);
  host::DeviceOptions o;
  o.kind = kind;
  o.any_hit = alpha.stage();
  if (timing) o.timing = *timing;
  const auto dev = host::make_device(scene.geometry, o);
  AlphaTraced out;
  out.hits.resize(rays.size());
  dev->trace_batch(rays.data(), out.hits.data(), rays.size(), any_hit, 1, out.stats);
  if (const hw::TimedEngine* te = dev->timed()) out.timing = te->timing();
  return out;
}

}  // namespace

TEST_CASE("scene files carry textures, masks and texture coordinates", "[alpha][scene]") {
  const host::Scene s = load_leaf("mask");
  REQUIRE(s.textures.size() == 1);
  CHECK(s.textures[0].width == 4);
  CHECK(s.textures[0].rgba.size() == 4 * 4 * 4);
  REQUIRE(s.triangle_uv.size() == 4);
  REQUIRE(s.geometry.non_opaque.size() == 4);
  CHECK(s.geometry.non_opaque[0] == 1);
  CHECK(s.geometry.non_opaque[1] == 1);
  CHECK(s.geometry.non_opaque[2] == 0);  // the floor
  CHECK(s.materials[s.prim_material[0]].alpha_mode == host::AlphaMode::kMask);
  // The same scene with the leaf opaque has no non-opaque triangle.
  const host::Scene o = load_leaf("opaque");
  CHECK((o.geometry.non_opaque.empty() || std::all_of(o.geometry.non_opaque.begin(), o.geometry.non_opaque.end(),
                                                      [](uint8_t b) { return b == 0; })));
}

TEST_CASE("primary rays pass through exactly the masked texels on every device", "[alpha]") {
  const host::Scene s = load_leaf("mask");
  const TexelRays tr = texel_rays(true);
  const uint64_t n = tr.rays.size();
  for (const hw::DeviceKind kind : kKinds) {
    INFO(hw::device_kind_name(kind));
    const AlphaTraced r = alpha_trace(s, kind, tr.rays, false);
    uint64_t leaf = 0;
    for (size_t i = 0; i < n; ++i) {
      INFO("ray " << i);
      REQUIRE(r.hits[i].hit());
      const bool on_leaf = r.hits[i].prim < 2;
      CHECK(on_leaf == tr.solid[i]);
      leaf += on_leaf;
    }
    CHECK(leaf == tr.solid_count);
    CHECK(tr.solid_count == 4 * 8);
    // Each ray meets the leaf once (one of its two triangles): one question to the stage, and the clear texels'
    // candidates are ignored.
    CHECK(r.stats.any_hit_calls == n);
    CHECK(r.stats.any_hit_ignored == n - tr.solid_count);
    if (kind == hw::DeviceKind::kTimed) CHECK(r.timing.any_hit_requests == n);
  }
}

TEST_CASE("shadow rays are occluded exactly by the texels that are there", "[alpha]") {
  const host::Scene s = load_leaf("mask");
  const TexelRays tr = texel_rays(false);
  for (const hw::DeviceKind kind : kKinds) {
    INFO(hw::device_kind_name(kind));
    const AlphaTraced r = alpha_trace(s, kind, tr.rays, true);
    uint64_t occluded = 0;
    for (size_t i = 0; i < tr.rays.size(); ++i) {
      INFO("ray " << i);
      CHECK(r.hits[i].hit() == tr.solid[i]);
      occluded += r.hits[i].hit();
    }
    CHECK(occluded == tr.solid_count);
    CHECK(r.stats.any_hit_calls == tr.rays.size());
    CHECK(r.stats.any_hit_ignored == tr.rays.size() - tr.solid_count);
  }
}

TEST_CASE("without masks nothing asks the any-hit stage and its latency costs nothing", "[alpha][timed]") {
  const host::Scene s = load_leaf("opaque");
  const TexelRays tr = texel_rays(true);
  hw::TimingConfig fast = hw::timing_preset("rdna2"), slow = fast;
  fast.any_hit_latency = 1;
  slow.any_hit_latency = 5000;
  const AlphaTraced a = alpha_trace(s, hw::DeviceKind::kTimed, tr.rays, false, &fast);
  const AlphaTraced b = alpha_trace(s, hw::DeviceKind::kTimed, tr.rays, false, &slow);
  for (size_t i = 0; i < tr.rays.size(); ++i) CHECK(a.hits[i].prim < 2);  // every ray stops at the opaque leaf
  CHECK(a.stats.any_hit_calls == 0);
  CHECK(a.timing.any_hit_requests == 0);
  CHECK(a.timing.cycles == b.timing.cycles);
  // And the float device without a stage installed treats masked triangles as opaque.
  const host::Scene m = load_leaf("mask");
  host::DeviceOptions o;
  const auto dev = host::make_device(m.geometry, o);
  std::vector<hw::Hit> hits(tr.rays.size());
  hw::TraversalStats st;
  dev->trace_batch(tr.rays.data(), hits.data(), hits.size(), false, 1, st);
  for (const hw::Hit& h : hits) CHECK(h.prim < 2);
  CHECK(st.any_hit_calls == 0);
}

TEST_CASE("each any-hit request holds its ray slot for the stage's latency", "[alpha][timed]") {
  const host::Scene s = load_leaf("mask");
  const TexelRays tr = texel_rays(true);
  // One ray slot: nothing overlaps a request, so each of the n requests adds the latency difference exactly.
  hw::TimingConfig a = hw::timing_preset("rdna2");
  a.ray_slots = 1;
  a.any_hit_latency = 10;
  hw::TimingConfig b = a;
  b.any_hit_latency = 1010;
  const AlphaTraced ta = alpha_trace(s, hw::DeviceKind::kTimed, tr.rays, false, &a);
  const AlphaTraced tb = alpha_trace(s, hw::DeviceKind::kTimed, tr.rays, false, &b);
  REQUIRE(ta.timing.any_hit_requests == tr.rays.size());
  CHECK(tb.timing.cycles - ta.timing.cycles == tr.rays.size() * 1000);
  for (size_t i = 0; i < tr.rays.size(); ++i) CHECK(ta.hits[i].prim == tb.hits[i].prim);
  // With many slots the latency overlaps other rays' work: less than the serial sum, more than one latency.
  a.ray_slots = b.ray_slots = 32;
  const AlphaTraced pa = alpha_trace(s, hw::DeviceKind::kTimed, tr.rays, false, &a);
  const AlphaTraced pb = alpha_trace(s, hw::DeviceKind::kTimed, tr.rays, false, &b);
  CHECK(pb.timing.cycles - pa.timing.cycles >= 1000);
  CHECK(pb.timing.cycles - pa.timing.cycles < tr.rays.size() * 1000);
}

TEST_CASE("renders see the floor through the masked half of a leaf, ray traced and hybrid", "[alpha][render]") {
  // A 4 x 1 mask: texels 0 and 1 set, 2 and 3 clear. Bilinear alpha (wrapping) reaches 0.5 exactly on s in
  // [0, 0.5]: between texel 1 (centre 0.375) and texel 2 (0.625) it falls linearly through 0.5 at s = 0.5, and
  // between texel 3 (0.875) and texel 0 (1.125) it rises through 0.5 at s = 1.
  const std::string scene = R"({
    "textures": {"half": {"width": 4, "height": 1,
                          "texels": [[0, 200, 0, 255], [0, 200, 0, 255], [0, 200, 0, 0], [0, 200, 0, 0]]}},
    "materials": {"leaf": {"texture": "half", "alpha_mode": "%MODE%"}, "floor": {"color": [0.8, 0.2, 0.2]}},
    "meshes": [
      {"generate": "quad", "size": [4, 4], "material": "leaf"},
      {"generate": "quad", "size": [8, 8], "material": "floor", "transform": {"translate": [0, -1, 0]}}
    ],
    "lights": [{"type": "point", "position": [0, 6, 0], "intensity": [30, 30, 30]}],
    "camera": {"position": [0.3, 6, 0.2], "look_at": [0, 0, 0], "fov_y": 40}
  })";
  auto with_mode = [&](const std::string& mode) {
    std::string t = scene;
    t.replace(t.find("%MODE%"), 6, mode);
    return host::load_scene(write_file("half_" + mode + ".json", t));
  };
  const host::Scene masked = with_mode("mask"), opaque = with_mode("opaque");
  for (const char* device : {"float", "fixed"})
    for (const bool hybrid : {false, true}) {
      INFO(device << (hybrid ? " hybrid" : " raytrace"));
      host::RenderOptions o;
      o.device.kind = hw::parse_device_kind(device);
      o.width = o.height = 48;
      o.max_depth = 1;
      o.hybrid = hybrid;
      o.keep_primary = true;
      o.threads = 1;
      auto leaf_s = [&](const host::Scene& s) {
        const host::RenderResult r = host::render(s, o);
        std::vector<float> out;  // s of each primary hit on the leaf
        for (const hw::Hit& h : r.primary) {
          if (!h.hit() || h.prim >= 2) continue;
          const hw::Triangle& t = s.geometry.triangles[h.prim];
          const hw::Vec3 p = (1.0f - h.u - h.v) * t.v0 + h.u * t.v1 + h.v * t.v2;
          out.push_back(p.x / kLeafSize + 0.5f);
        }
        return out;
      };
      const std::vector<float> m = leaf_s(masked), all = leaf_s(opaque);
      REQUIRE(!all.empty());
      // Every visible leaf point lies where alpha >= 0.5: s in [0, 0.5], up to the fixed device's hit position
      // error (a few grid steps of 2^-16 of the 8-unit scene, far below 1e-3 in s).
      for (const float s : m) {
        CHECK(s >= -1e-3f);
        CHECK(s <= 0.5f + 1e-3f);
      }
      // About half the leaf's pixels remain: the boundary line crosses ~48 pixels of the ~900 that see the leaf.
      const double ratio = double(m.size()) / double(all.size());
      CHECK(ratio > 0.44);
      CHECK(ratio < 0.56);
    }
}

TEST_CASE("bad textures and masks get clear errors", "[alpha][scene][errors]") {
  auto scene_with = [](const std::string& textures, const std::string& leaf) {
    return R"({"textures": )" + textures + R"(, "materials": {"leaf": )" + leaf +
           R"(}, "meshes": [{"generate": "quad", "material": "leaf"}]})";
  };
  const std::string tex = R"({"t": {"width": 1, "height": 1, "texels": [[1, 2, 3, 4]]}})";
  CHECK_THAT(alpha_load_error(scene_with(tex, R"({"texture": "nope"})")), Contains("unknown texture 'nope'"));
  CHECK_THAT(alpha_load_error(scene_with(tex, R"({"texture": "t", "alpha_cutoff": 1.5})")),
             Contains("alpha_cutoff"));
  CHECK_THAT(alpha_load_error(scene_with(tex, R"({"texture": "t", "alpha": -0.1})")), Contains("alpha"));
  CHECK_THAT(alpha_load_error(scene_with(tex, R"({"alpha_mode": "blend"})")),
             Contains("unknown alpha mode 'blend'"));
  CHECK_THAT(alpha_load_error(scene_with(R"({"t": {"width": 2, "height": 1, "texels": [[1, 2, 3, 4]]}})", "{}")),
             Contains("texels"));
  CHECK_THAT(alpha_load_error(scene_with(R"({"t": {"width": 1, "height": 1, "texels": [[1, 2, 300, 4]]}})", "{}")),
             Contains("texels"));
  CHECK_THAT(alpha_load_error(scene_with(R"({"t": {"width": 0, "height": 1, "texels": []}})", "{}")),
             Contains("width"));
  CHECK_THAT(
      alpha_load_error(scene_with(R"({"t": {"width": 1, "height": 1, "texels": [[1, 2, 3, 4]], "x": 1}})", "{}")),
      Contains("x"));
  // Texture files: missing, not an image, and an image truncated after its header.
  const std::string missing = (test_dir() / "missing.png").string();
  CHECK_THAT(alpha_load_error(scene_with(R"({"t": {"file": ")" + missing + R"("}})", "{}")),
             Contains("missing.png"));
  const std::string garbage = write_file("garbage.png", "this is not a PNG file at all");
  CHECK_THAT(alpha_load_error(scene_with(R"({"t": {"file": ")" + garbage + R"("}})", "{}")),
             Contains("garbage.png"));
  const std::string truncated =
      write_file("truncated.png", std::string("\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR\0\0\x10\0\0\0\x10\0\x08\x06", 24));
  CHECK_THAT(alpha_load_error(scene_with(R"({"t": {"file": ")" + truncated + R"("}})", "{}")),
             Contains("truncated.png"));
  // A chunk whose declared length runs past the file's end (the fuzzer's 262-byte PNG declared a 2 GiB IDAT, and
  // stb allocated that much before reading): refused before stb sees it, whichever chunk it is.
  const std::string ihdr("\0\0\0\x0dIHDR\0\0\0\x04\0\0\0\x04\x08\x06\0\0\0\0\0\0\0", 25);
  for (const char* type : {"IDAT", "tEXt"}) {
    std::string png = std::string("\x89PNG\r\n\x1a\n", 8) + ihdr + std::string("\x7f\xff\xff\xf0", 4) + type;
    png.resize(262, '\0');
    const std::string e = error_of([&] {
      host::read_texture_memory(reinterpret_cast<const uint8_t*>(png.data()), png.size(), "long_chunk.png");
    });
    CHECK_THAT(
        e, Contains("long_chunk.png") && Contains("2147483632 bytes at offset 33, past the file's end at 262"));
  }
}

namespace {

// A glTF 2.0 file of three unit quads in the z = 0 plane (x, y in [-1, 1]): a leaf at x = 0 with alphaMode MASK
// and a 2 x 2 base-colour texture (a PNG beside it) whose top-left texel alone is there, a smooth metal at x = 5
// and an emitter at x = 10. glTF's texture coordinates start at the image's top left: the quad's top-left corner
// (-1, 1) has (0, 0).
std::string write_gltf(const std::string& folder) {
  const std::filesystem::path dir = test_dir() / folder;  // one per test case: ctest runs them in parallel
  std::filesystem::create_directories(dir);
  const uint8_t mask[16] = {255, 255, 255, 255, 255, 255, 255, 0, 255, 255, 255, 0, 255, 255, 255, 0};
  REQUIRE(stbi_write_png((dir / "mask.png").string().c_str(), 2, 2, 4, mask, 8) != 0);
  const float pos[12] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
  const float uv[8] = {0, 1, 1, 1, 1, 0, 0, 0};
  const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
  std::ofstream bin(dir / "quad.bin", std::ios::binary);
  bin.write(reinterpret_cast<const char*>(pos), sizeof pos);
  bin.write(reinterpret_cast<const char*>(uv), sizeof uv);
  bin.write(reinterpret_cast<const char*>(idx), sizeof idx);
  bin.close();
  const std::string prim = R"("attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2)";
  std::ofstream(dir / "leaf.gltf") << R"({
    "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1, 2]}],
    "nodes": [{"mesh": 0}, {"mesh": 1, "translation": [5, 0, 0]}, {"mesh": 2, "translation": [10, 0, 0]}],
    "meshes": [{"primitives": [{)" + prim +
                                          R"(, "material": 0}]}, {"primitives": [{)" + prim +
                                          R"(, "material": 1}]}, {"primitives": [{)" + prim +
                                          R"(, "material": 2}]}],
    "materials": [
      {"name": "leaf", "alphaMode": "MASK", "alphaCutoff": 0.5,
       "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0, "roughnessFactor": 1}},
      {"name": "chrome", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.8, 0.7, 1], "metallicFactor": 1,
                                                  "roughnessFactor": 0.1}},
      {"name": "lamp", "emissiveFactor": [1, 0.5, 0.25]}
    ],
    "textures": [{"source": 0}], "images": [{"uri": "mask.png"}],
    "buffers": [{"uri": "quad.bin", "byteLength": 92}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 32},
                    {"buffer": 0, "byteOffset": 80, "byteLength": 12}],
    "accessors": [
      {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
      {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
      {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}
    ]
  })";
  return (dir / "leaf.gltf").string();
}

}  // namespace

TEST_CASE("glTF materials: base colour, metal, emission, and alpha masks with their texture", "[alpha][scene]") {
  const std::string file = write_gltf("gltf");
  const host::Scene s = host::load_scene(file);
  REQUIRE(s.geometry.triangles.size() == 6);
  REQUIRE(s.materials.size() == 3);
  const host::Material& leaf = s.materials[s.prim_material[0]];
  const host::Material& chrome = s.materials[s.prim_material[2]];
  const host::Material& lamp = s.materials[s.prim_material[4]];
  CHECK(leaf.name == "leaf");
  CHECK(leaf.alpha_mode == host::AlphaMode::kMask);
  CHECK(leaf.alpha_cutoff == 0.5f);
  REQUIRE(leaf.texture == 0);
  REQUIRE(s.textures.size() == 1);
  CHECK(s.textures[0].width == 2);
  CHECK(chrome.type == host::MaterialType::kMirror);
  CHECK(chrome.color.x == Approx(0.9f));
  CHECK(chrome.color.z == Approx(0.7f));
  CHECK(lamp.type == host::MaterialType::kEmissive);
  CHECK(lamp.emission.y == Approx(0.5f));
  REQUIRE(s.geometry.non_opaque.size() == 6);
  CHECK(s.geometry.non_opaque[0] == 1);
  CHECK(s.geometry.non_opaque[2] == 0);
  REQUIRE(s.triangle_uv.size() == 6);

  // Rays along -z through the middle of each quarter of the leaf (offset off the quad's diagonal): only the
  // top-left quarter is there. The offset of 0.05 (0.05 texel) keeps the texel's own bilinear weight >= 0.9.
  std::vector<hw::Ray> rays;
  std::vector<bool> there;
  for (const float x : {-0.45f, 0.55f})
    for (const float y : {-0.55f, 0.45f}) {
      rays.push_back(hw::Ray{hw::Vec3(x, y, 2.0f), 0.0f, hw::Vec3(0.0f, 0.0f, -1.0f),
                             std::numeric_limits<float>::infinity()});
      there.push_back(x < 0.0f && y > 0.0f);
    }
  for (const hw::DeviceKind kind : kKinds) {
    INFO(hw::device_kind_name(kind));
    const AlphaTraced r = alpha_trace(s, kind, rays, false);
    for (size_t i = 0; i < rays.size(); ++i) {
      INFO("ray " << i);
      CHECK(r.hits[i].hit() == there[i]);
    }
  }

  // In a scene file, a file entry without "material" brings the file's materials (named FILE/NAME); with one,
  // the entry's material replaces them.
  const host::Scene own = host::load_scene(write_file(
      "gltf_own.json", R"({"meshes": [{"file": ")" + file + R"("}, {"file": ")" + file + R"(", "material": "m"}],
                           "materials": {"m": {"color": [0.5, 0.5, 0.5]}}})"));
  REQUIRE(own.geometry.triangles.size() == 12);
  CHECK(own.materials[own.prim_material[0]].name == "leaf.gltf/leaf");
  CHECK(own.materials[own.prim_material[0]].alpha_mode == host::AlphaMode::kMask);
  CHECK(own.materials[own.prim_material[6]].name == "m");
  CHECK(own.geometry.non_opaque[0] == 1);
  CHECK(own.geometry.non_opaque[6] == 0);
}

TEST_CASE("a mesh file's texture that cannot be read leaves its material untextured", "[alpha][scene][errors]") {
  const std::string file = write_gltf("gltf_missing_texture");
  std::filesystem::remove(std::filesystem::path(file).parent_path() / "mask.png");
  const host::Scene s = host::load_scene(file);  // a warning on stderr, no error
  REQUIRE(s.materials.size() == 3);
  CHECK(s.materials[s.prim_material[0]].texture == -1);
  CHECK(s.textures.empty());
}

TEST_CASE("scenes/alpha.json: its fences and leaf let light through their masked texels", "[alpha][scene]") {
  const host::Scene s = host::load_scene(RTU_SOURCE_DIR "/scenes/alpha.json");
  REQUIRE(s.textures.size() == 2);
  // Floor 2, three fences and the leaf 2 each, the ball 20 * 4^3.
  REQUIRE(s.geometry.triangles.size() == 2 + 4 * 2 + 1280);
  size_t non_opaque = 0;
  for (const uint8_t b : s.geometry.non_opaque) non_opaque += b;
  CHECK(non_opaque == 8);
  // Straight down through the middle fence's holes and bars: the fence stands in the plane z = 0, x in [-1, 1],
  // y in [0, 1.6]; rays along -z at heights in a hole (texel row 2 of 8) and on a bar (row 4).
  auto ray_at = [](float x, float y) {
    return hw::Ray{hw::Vec3(x, y, 1.0f), 0.0f, hw::Vec3(0.0f, 0.0f, -1.0f), 1.5f};  // stops before the ball
  };
  const float hole_y = 1.6f - 2.5f / 8.0f * 1.6f, bar_y = 1.6f - 4.5f / 8.0f * 1.6f;
  const float hole_x = -1.0f + 2.5f / 8.0f * 2.0f;
  const std::vector<hw::Ray> rays = {ray_at(hole_x, hole_y), ray_at(hole_x, bar_y)};
  for (const hw::DeviceKind kind : kKinds) {
    INFO(hw::device_kind_name(kind));
    const AlphaTraced r = alpha_trace(s, kind, rays, true);
    CHECK(!r.hits[0].hit());
    CHECK(r.hits[1].hit());
  }
  // rtusim info counts the same textures and alpha-tested triangles.
  const rtu::test::Run info = rtu::test::run_rtusim("info --scene " RTU_SOURCE_DIR "/scenes/alpha.json");
  REQUIRE(info.status == 0);
  CHECK(info.output.find("textures 2") != std::string::npos);
  CHECK(info.output.find("alpha        8 alpha-tested triangles") != std::string::npos);
}
