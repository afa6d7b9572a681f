// Images in and out: 8-bit RGB PNG.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "host/scene/scene.h"

namespace rtu::host {

struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;  // row-major, top row first, 3 bytes per pixel
};

void write_png(const std::string& path, const Image& img);

// Reads a PNG as 8-bit RGB: grey is replicated to three channels, alpha is dropped (not composited), 16-bit
// channels are reduced to 8 bits. Throws Error naming the path and the reason on a missing, unreadable or
// corrupt file.
Image read_png(const std::string& path);

// Reads a texture (PNG or JPEG, the image formats of glTF) as RGBA8, row 0 on top; grey and RGB
// get alpha 255. Throws Error naming the path (or `name`) and the reason on a missing, corrupt or oversized
// (beyond fw::kMaxTextureSide a side) file.
Texture read_texture(const std::string& path);
Texture read_texture_memory(const uint8_t* data, size_t bytes, const std::string& name);

// A quick look at hits without a renderer: each pixel is the hit material's color times (0.15 + 0.85 |n.d|),
// black on a miss. `hits` are of primary_rays(cam, width, height).
Image shade_hits(const Scene& scene, const std::vector<hw::Ray>& rays, const std::vector<hw::Hit>& hits, int width,
                 int height);

// Geometric normal (unit length, not flipped) of primitive `hit.prim` at the hit point.
hw::Vec3 hit_normal(const hw::Geometry& g, const hw::Ray& ray, const hw::Hit& hit);

// The bytes of RGBA8 texels the PNG or JPEG header of a texture file (or of its bytes in memory) declares, read
// without decoding (a few header bytes; no stb); 0 when it declares no size. For a scene's running total of
// texture memory, checked before each texture is decoded (decoding one briefly takes twice its texels' bytes).
uint64_t texture_header_bytes(const std::string& path);
uint64_t texture_header_bytes(const uint8_t* data, size_t bytes);

}  // namespace rtu::host
