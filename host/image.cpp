#include "host/image.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

#include "firmware/render_scene.h"
#include "host/error.h"
#include "host/limits.h"

#define STB_IMAGE_WRITE_IMPLEMENTATION
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#endif
#include <stb/stb_image_write.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG  // textures: glTF's two image formats
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#endif
#include <stb/stb_image.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace rtu::host {

void write_png(const std::string& path, const Image& img) {
  if (img.width <= 0 || img.height <= 0 || img.rgb.size() != size_t(img.width) * size_t(img.height) * 3)
    throw Error(path + ": invalid image");
  if (!stbi_write_png(path.c_str(), img.width, img.height, 3, img.rgb.data(), img.width * 3))
    throw Error(path + ": cannot write PNG");
}

Image read_png(const std::string& path) {
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) throw Error(path + ": cannot open (" + std::strerror(errno) + ")");
  int w = 0, h = 0, channels = 0;
  const std::unique_ptr<stbi_uc, void (*)(void*)> data(stbi_load_from_file(f.get(), &w, &h, &channels, 3),
                                                       &stbi_image_free);
  if (!data) {
    const char* why = stbi_failure_reason();
    throw Error(path + ": cannot read PNG (" + (why ? why : "unknown reason") + ")");
  }
  Image img{w, h, {}};
  img.rgb.assign(data.get(), data.get() + size_t(w) * size_t(h) * 3);
  return img;
}

namespace {

Texture texture_from(stbi_uc* data, int w, int h, const std::string& name) {
  const std::unique_ptr<stbi_uc, void (*)(void*)> own(data, &stbi_image_free);
  if (!data) {
    const char* why = stbi_failure_reason();
    throw Error(name + ": cannot read texture (" + (why ? why : "unknown reason") + ")");
  }
  Texture t{name, uint32_t(w), uint32_t(h), {}};
  t.rgba.assign(data, data + size_t(w) * size_t(h) * 4);
  return t;
}

void check_texture_size(int w, int h, const std::string& name) {
  if (w < 1 || h < 1 || w > int(fw::kMaxTextureSide) || h > int(fw::kMaxTextureSide))
    throw Error(name + ": texture of " + std::to_string(w) + " x " + std::to_string(h) +
                " texels (each side must be in [1, " + std::to_string(fw::kMaxTextureSide) + "])");
  // A header is a few bytes and may claim a 1 GiB image: the decoder's buffer and the copy are refused before
  // they are allocated when they do not fit the memory limit.
  check_memory(name + ": decoding a " + std::to_string(w) + " x " + std::to_string(h) + " texture",
               uint64_t(w) * uint64_t(h) * 8);
}

}  // namespace

Texture read_texture(const std::string& path) {
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) throw Error(path + ": cannot open (" + std::strerror(errno) + ")");
  int w = 0, h = 0, channels = 0;
  if (!stbi_info_from_file(f.get(), &w, &h, &channels)) {
    const char* why = stbi_failure_reason();
    throw Error(path + ": cannot read texture (" + (why ? why : "unknown format") + ")");
  }
  check_texture_size(w, h, path);
  return texture_from(stbi_load_from_file(f.get(), &w, &h, &channels, 4), w, h, path);
}

Texture read_texture_memory(const uint8_t* data, size_t bytes, const std::string& name) {
  if (bytes == 0 || bytes > size_t(INT32_MAX)) throw Error(name + ": cannot read texture (empty or over 2 GiB)");
  int w = 0, h = 0, channels = 0;
  if (!stbi_info_from_memory(data, int(bytes), &w, &h, &channels)) {
    const char* why = stbi_failure_reason();
    throw Error(name + ": cannot read texture (" + (why ? why : "unknown format") + ")");
  }
  check_texture_size(w, h, name);
  return texture_from(stbi_load_from_memory(data, int(bytes), &w, &h, &channels, 4), w, h, name);
}

hw::Vec3 hit_normal(const hw::Geometry& g, const hw::Ray& ray, const hw::Hit& hit) {
  hw::Vec3 n(0.0f, 0.0f, 1.0f);
  switch (g.kind(hit.prim)) {
    case hw::PrimKind::kTriangle: {
      const hw::Triangle& t = g.triangles[hit.prim];
      n = glm::cross(t.v1 - t.v0, t.v2 - t.v0);
      break;
    }
    case hw::PrimKind::kSphere: {
      const hw::Sphere& s = g.spheres[hit.prim - g.triangles.size()];
      n = ray.origin + hit.t * ray.dir - s.center;
      break;
    }
    case hw::PrimKind::kPlane:
      n = g.planes[hit.prim - g.num_bounded()].normal;
      break;
  }
  const float len = glm::length(n);
  return len > 0.0f ? n / len : hw::Vec3(0.0f, 0.0f, 1.0f);
}

Image shade_hits(const Scene& scene, const std::vector<hw::Ray>& rays, const std::vector<hw::Hit>& hits, int width,
                 int height) {
  Image img{width, height, std::vector<uint8_t>(size_t(width) * size_t(height) * 3, 0)};
  const size_t n = std::min(hits.size(), size_t(width) * size_t(height));
  for (size_t i = 0; i < n; ++i) {
    const hw::Hit& h = hits[i];
    if (!h.hit()) continue;
    const Material& m = scene.materials[scene.prim_material[h.prim]];
    const hw::Vec3 base = m.type == MaterialType::kEmissive ? glm::min(m.emission, hw::Vec3(1.0f)) : m.color;
    const float facing = std::abs(glm::dot(hit_normal(scene.geometry, rays[i], h), glm::normalize(rays[i].dir)));
    const hw::Vec3 c = base * (0.15f + 0.85f * facing);
    for (int k = 0; k < 3; ++k)
      img.rgb[3 * i + size_t(k)] = uint8_t(std::lround(255.0f * std::pow(std::clamp(c[k], 0.0f, 1.0f), 1 / 2.2f)));
  }
  return img;
}

}  // namespace rtu::host
