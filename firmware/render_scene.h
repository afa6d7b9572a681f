// What the renderer reads from device memory besides the unit's scene image: the camera, the render settings,
// and shading data (materials, per-primitive surface data, lights). The host writes these records; the firmware
// reads them. Little-endian, naturally aligned, sizes checked below. Freestanding.
#pragma once

#include <cstddef>
#include <cstdint>

namespace rtu::fw {

struct F3 {
  float x, y, z;
};
static_assert(sizeof(F3) == 12);

enum class MaterialKind : uint32_t { kDiffuse = 0, kMirror = 1, kGlass = 2, kEmissive = 3 };

// How a material's alpha is used (glTF's alphaMode; blending is not modelled).
enum class AlphaMode : uint32_t { kOpaque = 0, kMask = 1 };

struct MaterialRecord {
  uint32_t kind;        // MaterialKind
  F3 color;             // diffuse albedo, or the tint of a mirror or glass (times the texture's colour)
  float ior;            // glass: index of refraction (> 0)
  F3 emission;          // emissive: radiance
  uint32_t texture;     // base colour texture: index into the texture table + 1; 0: none
  uint32_t alpha_mode;  // AlphaMode
  float alpha;          // alpha factor (times the texture's alpha)
  float alpha_cutoff;   // kMask: the surface is there where alpha >= alpha_cutoff, else rays pass through it
};
static_assert(sizeof(MaterialRecord) == 48);

// A texture: width x height RGBA8 texels, row 0 at the top, colour in sRGB, alpha linear. Texture coordinates
// (s, t) put texel (x, y) over [x, x + 1) / width by [y, y + 1) / height (t grows downward, as in glTF) and
// wrap (repeat).
struct TextureRecord {
  uint32_t width, height;  // in [1, kMaxTextureSide]
  uint64_t texels;         // device address of width * height * 4 bytes
};
static_assert(sizeof(TextureRecord) == 16);
inline constexpr uint32_t kMaxTextureSide = 16384;

// Texture coordinates of one triangle's vertices v0, v1, v2 (one record per triangle, in primitive order).
struct UvRecord {
  float s[3], t[3];
};
static_assert(sizeof(UvRecord) == 24);

enum class SurfaceKind : uint32_t { kTriangle = 0, kSphere = 1, kPlane = 2, kCurve = 3 };

// Per primitive index (the unit's index space: triangles, spheres, curve segments, planes).
struct SurfaceRecord {
  uint32_t kind;      // SurfaceKind
  uint32_t material;  // index into the material table
  F3 a;               // triangle v0; sphere center; curve p0; plane normal (any length)
  F3 b;               // triangle v1; sphere (radius, 0, 0); curve p1; plane (offset, 0, 0)
  F3 c;               // triangle v2; curve (r0, r1, 1 for a strand's first segment, which has its start cap,
                      // else 0); otherwise 0
};
static_assert(sizeof(SurfaceRecord) == 44);

enum class LightKind : uint32_t { kPoint = 0, kArea = 1 };

struct LightRecord {
  uint32_t kind;  // LightKind
  F3 position;    // point: position; area: a corner of the parallelogram
  F3 edge_u;      // area: first edge from the corner
  F3 edge_v;      // area: second edge
  F3 power;       // point: radiant intensity (W/sr); area: emitted radiance
};
static_assert(sizeof(LightRecord) == 52);

// Render flags.
inline constexpr uint32_t kRenderIndirect = 1u << 0;  // diffuse indirect bounces (path tracing)
inline constexpr uint32_t kRenderAo = 1u << 1;      // ambient occlusion at diffuse hits instead of indirect light
inline constexpr uint32_t kRenderHybrid = 1u << 2;  // primary visibility by the rasterizer (firmware/raster.h)
// Ray sorting (firmware/ray_sort.h): a RaySortJob follows the RenderJob in device memory (at job address +
// sizeof(RenderJob)); without the flag there is none, and the job's layout is what it was before sorting existed.
inline constexpr uint32_t kRenderRaySort = 1u << 3;

struct RenderJob {
  // Image and sampling.
  uint32_t width, height;  // pixels
  uint32_t spp;            // samples per pixel (1: pixel centers; more: jittered)
  uint32_t max_depth;      // bounces after the camera ray (0: primary hits only, lit directly)
  uint32_t flags;          // kRender*
  uint32_t seed;           // of the per-sample generator: same seed, same image
  // Camera: ray direction for pixel position (px, py) is forward + sx * right + sy * up with
  // sx = (2 px / width - 1), sy = (1 - 2 py / height); right and up carry tan(fov/2) and the aspect ratio.
  F3 eye, forward, right, up;
  F3 background;      // radiance of rays that leave the scene (and the ambient light of occlusion rays)
  float ao_distance;  // occlusion rays: length in world units
  // Spawned rays start off the surface: each coordinate i moves by offset_abs + offset_rel * max(|p_i|, |o_i|)
  // (p the hit point, o the ray's origin) in the direction of the normal on the side they leave: the float hit
  // point's rounding (offset_rel) and, on the fixed device, the quantization of the surface (offset_abs, a few
  // grid steps).
  float offset_abs, offset_rel;
  uint32_t num_prims, num_materials, num_lights;
  float raster_near;      // hybrid: the rasterizer's near plane, view-space distance along forward (> 0)
  uint64_t scene_bytes;   // bytes of the unit's scene image (BIND_SCENE)
  uint64_t scene_image;   // device address of the unit's scene image
  uint64_t surfaces;      // SurfaceRecord[num_prims] (also the rasterizer's primitive table)
  uint64_t materials;     // MaterialRecord[num_materials]
  uint64_t lights;        // LightRecord[num_lights]
  uint64_t framebuffer;   // float[width * height * 3], linear RGB, written by the renderer (row 0 on top)
  uint64_t primary_hits;  // 0, or hw::Hit[width * height * spp]: each camera sample's primary hit (the G-buffer
                          // texel in hybrid mode, the traced hit otherwise), in path order
  uint64_t uvs;           // 0, or UvRecord[num_uvs]: texture coordinates of triangles 0 .. num_uvs - 1
  uint64_t textures;      // TextureRecord[num_textures]
  uint32_t num_uvs, num_textures;
};
static_assert(sizeof(RenderJob) == 192);

// The key rays are sorted by before each TRACE (firmware/ray_sort.h says what each is).
enum class RaySortKey : uint32_t {
  kNone = 0,
  kOrigin = 1,
  kDirection = 2,
  kOriginDirection = 3,
  kTermination = 4
};
inline constexpr uint32_t kRaySortKeyCount = 5;

struct RaySortJob {
  uint32_t key;         // RaySortKey
  uint32_t radix_bits;  // digit bits of the LSD radix sort, in [1, 16]
  F3 lo, hi;            // the scene's bounds: the box origin and termination keys are quantized in
  float distance;       // termination key: the estimated distance L to a ray's end, in world units (> 0)
  uint32_t reserved;    // 0
};
static_assert(sizeof(RaySortJob) == 40);
static_assert(offsetof(RaySortJob, lo) == 8 && offsetof(RaySortJob, distance) == 32);

}  // namespace rtu::fw
