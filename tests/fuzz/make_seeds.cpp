// Writes the binary seed corpora of the fuzz targets into DIR (default tests/fuzz/corpus): ray and hit files,
// scene images in every format preset (fixed) and the float image, command programs for each engine, and
// textures (PNG with and without alpha, JPEG). The
// text seeds (scene files, meshes, configuration) are written by hand. Usage: fuzz_make_seeds [DIR]
#include <filesystem>
#include <fstream>

#include "host/io/ray_io.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/datapath/instanced_fixed.h"
#include "hwmodel/device/engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/interface/commands.h"
#include "hwmodel/numeric/fixed_format.h"
#include "tests/fuzz/fuzz.h"

#include <stb/stb_image_write.h>

using namespace rtu;
namespace fs = std::filesystem;

namespace {

void put(const fs::path& p, const void* data, size_t n, int prefix = -1) {
  fs::create_directories(p.parent_path());
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  if (prefix >= 0) out.put(char(prefix));
  out.write(static_cast<const char*>(data), std::streamsize(n));
}

// The image of g in format f over a BVH as wide as the format, of leaves of at most `leaf` primitives.
void put_image(const fs::path& p, const hw::Geometry& g, const hw::FixedFormat& f, int leaf) {
  hw::BvhBuildParams bp;
  bp.width = f.width;
  bp.max_leaf_size = leaf;
  const hw::Bvh bvh = hw::Bvh::build(g, bp);
  const hw::DeviceImage img = hw::encode_scene(g, f, &bvh);
  put(p, img.data(), img.size(), 0);
}

// The command program of fuzz_command_processor.cpp: ops of one byte plus their operands.
struct Program {
  std::vector<uint8_t> b;
  template <class T>
  void add(T v) {
    const auto* p = reinterpret_cast<const uint8_t*>(&v);
    b.insert(b.end(), p, p + sizeof v);
  }
  void packet(uint8_t kind, uint16_t count, uint8_t flags) {
    add<uint8_t>(3);
    add(kind);
    add(count);
    add(flags);
  }
};

}  // namespace

int main(int argc, char** argv) {
  const fs::path dir = argc > 1 ? fs::path(argv[1]) : fs::path(RTU_SOURCE_DIR_SEEDS);
  const hw::Geometry& g = fuzz::tiny_geometry();

  const std::vector<hw::Ray> rays = fuzz::rays_around(g.bounds(), 8, 1);
  put(dir / "ray_file" / "rays8.rays", rays.data(), rays.size() * sizeof(hw::Ray));
  put(dir / "ray_file" / "ray1.rays", rays.data(), sizeof(hw::Ray));
  host::write_rays((dir / "ray_file" / "rays3.csv").string(), {rays[0], rays[1], rays[2]});
  const std::vector<hw::Hit> hits = {{1.5f, 3, 0.25f, 0.5f}, {INFINITY, hw::kMissPrim, 0, 0}};
  host::write_hits((dir / "ray_file" / "hits2.csv").string(), hits);

  for (const hw::FixedFormat& f : hw::format_presets()) {
    hw::TracerOptions opt;
    opt.accel = hw::AccelMode::kBvh;
    opt.bvh.width = f.width;
    opt.bvh.max_leaf_size = 2;
    const std::optional<hw::Bvh> bvh = hw::choose_accel(g, opt);
    const hw::DeviceImage img = hw::encode_scene(g, f, &*bvh);
    put(dir / "device_image" / ("fixed_" + f.name + ".img"), img.data(), img.size(), 0);
  }
  // Triangle pairs (kTrianglePair records): the tiny geometry's triangles as a strip of quads.
  {
    hw::Geometry quads;
    for (int i = 0; i < 4; ++i) {
      const float x = float(i);
      quads.triangles.push_back({hw::Vec3(x, 0, 0), hw::Vec3(x + 1, 0, 0), hw::Vec3(x, 1, 0)});
      quads.triangles.push_back({hw::Vec3(x + 1, 0, 0), hw::Vec3(x + 1, 1, 0), hw::Vec3(x, 1, 0)});
    }
    hw::FixedFormat f = hw::format_preset("default");
    f.tri_pairs = 1;
    put_image(dir / "device_image" / "fixed_tri_pairs.img", quads, f, 4);
  }
  // Triangle clusters (prim_layout 2): a 6 x 4 grid of quads in a binary tree of leaves of 2, clusters of up to 16
  // triangles (so they hold internal nodes); and without a BVH (clusters of one leaf).
  {
    hw::Geometry grid;
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 6; ++x) {
        const hw::Vec3 a(float(x), float(y), 0.1f * float(x % 3)), b(float(x + 1), float(y), 0.1f * float(y % 2)),
            c(float(x), float(y + 1), 0.0f), d(float(x + 1), float(y + 1), 0.2f);
        grid.triangles.push_back({a, b, c});
        grid.triangles.push_back({b, d, c});
      }
    const hw::FixedFormat f = hw::format_from_spec("clusters:width=2:cluster_tris=16");
    put_image(dir / "device_image" / "fixed_clusters_tree.img", grid, f, 2);  // f is 2 wide
    const hw::DeviceImage brute_clusters = hw::encode_scene(grid, f, nullptr);
    put(dir / "device_image" / "fixed_brute_clusters.img", brute_clusters.data(), brute_clusters.size(), 0);
  }
  // Oriented nodes (node_kind 1): 4- and 8-wide, the table's size and bits in the header's flags.
  for (const char* spec : {"default:node_kind=1", "wide8:node_kind=1:child_bits=12:rotations=13:rot_bits=8"}) {
    const hw::FixedFormat f = hw::format_from_spec(spec);
    put_image(dir / "device_image" / ("fixed_oriented_w" + std::to_string(f.width) + ".img"), g, f, 2);
  }
  // Curve segments (round records of kind sphere, word 1): two strands of three tapered segments and a lone
  // capped one, in a BVH of 40-byte records and in triangle blocks' raw leaves, and in the float image.
  hw::Geometry curves;
  for (int s = 0; s < 2; ++s) {
    for (int i = 0; i < 3; ++i) {
      const hw::Vec3 p0(float(s), float(i), 0.2f * float(i)), p1(float(s), float(i + 1), 0.2f * float(i + 1));
      curves.curves.push_back(
          {p0, 0.3f - 0.05f * float(i), p1, 0.25f - 0.05f * float(i), i == 0 ? hw::kCurveCapStart : 0u});
    }
  }
  curves.curves.push_back({hw::Vec3(3, 0, 0), 0.0f, hw::Vec3(3, 0, 2), 0.4f, hw::kCurveCapStart});
  curves.triangles = {g.triangles.begin(), g.triangles.begin() + 2};
  for (const char* spec : {"default", "packed"}) {
    put_image(dir / "device_image" / ("fixed_curves_" + std::string(spec) + ".img"), curves,
              hw::format_preset(spec), 2);
  }
  const std::vector<uint64_t> fcurves = hw::encode_float_scene(curves);
  put(dir / "device_image" / "float_curves.img", fcurves.data(), fcurves.size() * 8, 1);
  const hw::DeviceImage brute = hw::encode_scene(g, hw::FixedFormat{}, nullptr);
  put(dir / "device_image" / "fixed_brute.img", brute.data(), brute.size(), 0);
  // No BVH, primitives in triangle blocks (the packed layouts' other path through the checker).
  const hw::DeviceImage brute_blocks = hw::encode_scene(g, hw::format_preset("packed"), nullptr);
  put(dir / "device_image" / "fixed_brute_blocks.img", brute_blocks.data(), brute_blocks.size(), 0);
  // A two-level scene's top level: instance records over the tiny geometry's triangles' boxes.
  std::vector<hw::Aabb> boxes;
  std::vector<uint32_t> ids;
  for (uint32_t i = 0; i < g.triangles.size() && i < 6; ++i) {
    hw::Aabb b;
    b.extend(g.triangles[i].v0);
    b.extend(g.triangles[i].v1);
    b.extend(g.triangles[i].v2);
    boxes.push_back(b);
    ids.push_back(i);
  }
  hw::BvhBuildParams top;
  top.max_leaf_size = 1;
  const hw::DeviceImage top_img =
      hw::encode_top_level(boxes, ids, g, hw::FixedFormat{}, hw::Bvh::build(boxes, top));
  put(dir / "device_image" / "fixed_top_level.img", top_img.data(), top_img.size(), 0);
  // Two levels as one block: the tiny geometry's triangles placed three times.
  hw::InstanceSet set;
  set.meshes.emplace_back();
  set.meshes[0].triangles = g.triangles;
  for (int i = 0; i < 3; ++i) {
    hw::Instance in;
    in.to_world.m[0][3] = 3.0f * float(i);
    in.to_world.m[1][1] = 1.0f + 0.5f * float(i);
    set.instances.push_back(in);
  }
  set.finish();
  const hw::Geometry flat = set.flatten({});
  hw::TracerOptions two_opt;
  const std::vector<uint64_t> block = hw::InstancedFixedTracer(set, flat, hw::FixedFormat{}, two_opt).encode();
  put(dir / "device_image" / "fixed_two_level.img", block.data(), block.size() * 8, 0);
  const std::vector<uint64_t> fimg = hw::encode_float_scene(g);
  put(dir / "device_image" / "float.img", fimg.data(), fimg.size() * 8, 1);

  for (uint8_t engine = 0; engine < 4; ++engine) {
    Program p;
    p.add(engine);
    p.packet(1, 0, 1);   // BIND_SCENE of the whole image
    p.packet(2, 99, 0);  // TRACE 100 closest-hit rays
    p.packet(2, 9, 9);   // TRACE 10 any-hit shadow rays, bounce 1
    p.packet(3, 7, 1);   // FENCE with IRQ
    p.packet(4, 1, 0);   // TIMESTAMP
    put(dir / "command_processor" / ("engine" + std::to_string(engine) + ".prog"), p.b.data(), p.b.size());
  }
  Program q;  // register traffic, a ring resize, a raw NOP, then work
  q.add<uint8_t>(1);
  q.add<uint8_t>(0);  // write IRQ_ENABLE = 3
  q.add<uint8_t>(0x20);
  q.add<uint32_t>(3);
  q.add<uint8_t>(4);  // 4 slots
  q.add<uint8_t>(1);
  q.add<uint8_t>(2);  // raw NOP
  const hw::cmd::Packet nop = hw::cmd::nop();
  q.add(nop);
  q.packet(1, 0, 1);
  q.packet(2, 3, 0);
  q.add<uint8_t>(1);  // read STATUS
  q.add<uint8_t>(0x10);
  put(dir / "command_processor" / "registers.prog", q.b.data(), q.b.size());
  // Textures: a 4 x 4 RGBA checker of alpha 0 and 255, a 3 x 2 grey + alpha PNG, an 8 x 8 RGB JPEG, a 1 x 1 PNG.
  const fs::path tex = dir / "texture";
  fs::create_directories(tex);
  std::vector<uint8_t> rgba(4 * 4 * 4);
  for (int i = 0; i < 16; ++i) {
    rgba[4 * i] = uint8_t(40 * i), rgba[4 * i + 1] = 160, rgba[4 * i + 2] = uint8_t(255 - 9 * i);
    rgba[4 * i + 3] = ((i / 4 + i % 4) % 2) ? 0 : 255;
  }
  stbi_write_png((tex / "checker4.png").string().c_str(), 4, 4, 4, rgba.data(), 16);
  const uint8_t ga[12] = {0, 255, 64, 128, 128, 0, 192, 255, 255, 64, 32, 200};
  stbi_write_png((tex / "grey_alpha3x2.png").string().c_str(), 3, 2, 2, ga, 6);
  std::vector<uint8_t> rgb(8 * 8 * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = uint8_t(i * 37);
  stbi_write_jpg((tex / "noise8.jpg").string().c_str(), 8, 8, 3, rgb.data(), 90);
  const uint8_t one[4] = {10, 20, 30, 255};
  stbi_write_png((tex / "one.png").string().c_str(), 1, 1, 4, one, 4);
  return 0;
}
