// What the firmware reads of a surface at a hit besides its geometry: texture coordinates, the base colour
// texture, alpha, and the any-hit stage that alpha-tests candidate hits for the unit
// (hwmodel/interface/any_hit.h). The same code serves the host's direct devices, over the same records in host
// memory (host/scene/shading.h), so every device alpha-tests the same way. Freestanding: no heap, no libm.
#pragma once

#include <cstdint>

#include "firmware/render_scene.h"
#include "hwmodel/interface/any_hit.h"

namespace rtu::fw {

// The shading records a render job names (render_scene.h), resolved to pointers; `mem` is device address 0
// (texel addresses are device addresses), `mem_size` bounds them.
struct ShadingTables {
  const SurfaceRecord* surfaces = nullptr;
  uint32_t num_prims = 0;
  const MaterialRecord* materials = nullptr;
  uint32_t num_materials = 0;
  const UvRecord* uvs = nullptr;
  uint32_t num_uvs = 0;
  const TextureRecord* textures = nullptr;
  uint32_t num_textures = 0;
  const uint8_t* mem = nullptr;
  uint64_t mem_size = 0;

  const MaterialRecord* material_of(uint32_t prim) const {
    if (prim >= num_prims || num_materials == 0) return nullptr;
    const uint32_t m = surfaces[prim].material;
    return &materials[m < num_materials ? m : 0];
  }
  // The texture of material m, or null (none, out of range, or texels outside memory).
  const TextureRecord* texture_of(const MaterialRecord& m) const {
    if (m.texture == 0 || m.texture > num_textures) return nullptr;
    const TextureRecord& t = textures[m.texture - 1];
    if (t.width == 0 || t.height == 0 || t.width > kMaxTextureSide || t.height > kMaxTextureSide) return nullptr;
    const uint64_t bytes = uint64_t(t.width) * t.height * 4;
    if (t.texels > mem_size || bytes > mem_size - t.texels) return nullptr;
    return &t;
  }
};

// sRGB-encoded 8-bit value to linear: a cubic least-squares fit of the sRGB curve (IEC 61966-2-1) on [0, 1],
// within 0.0018 of it everywhere, less than half a step of 8 bits (no libm for the curve's power 2.4).
inline float srgb_to_linear(uint8_t c) {
  const float x = float(c) * (1.0f / 255.0f);
  const float y = ((0.31742021f * x + 0.66832707f) * x + 0.01598359f) * x;
  return y < 1.0f ? y : 1.0f;
}

// floor(x) for |x| < 2^23 without libm.
inline float floor_small(float x) {
  const float i = float(int32_t(x));
  return i > x ? i - 1.0f : i;
}

// Bilinear lookup at texture coordinates (s, t) over the four nearest texel centres, wrapping (repeat):
// rgb linear, alpha as stored / 255. Coordinates that are not finite read as 0.
inline void sample_texture(const TextureRecord& tex, const uint8_t* texels, float s, float t, float rgba[4]) {
  const int64_t w = tex.width, h = tex.height;
  // Wrap to [0, 1) first, so the texel arithmetic stays in small integers whatever the coordinate.
  auto wrap01 = [](float x) {
    if (!(x > -8388608.0f && x < 8388608.0f)) return 0.0f;  // also NaN
    const float f = x - floor_small(x);
    return f < 1.0f ? f : 0.0f;
  };
  const float x = wrap01(s) * float(w) - 0.5f, y = wrap01(t) * float(h) - 0.5f;
  const float x0f = floor_small(x), y0f = floor_small(y);
  const float fx = x - x0f, fy = y - y0f;
  const int64_t x0 = (int64_t(x0f) + w) % w, y0 = (int64_t(y0f) + h) % h;
  const int64_t x1 = (x0 + 1) % w, y1 = (y0 + 1) % h;
  const uint8_t* p[4] = {texels + (y0 * w + x0) * 4, texels + (y0 * w + x1) * 4, texels + (y1 * w + x0) * 4,
                         texels + (y1 * w + x1) * 4};
  const float wgt[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  for (int c = 0; c < 4; ++c) {
    float acc = 0.0f;
    for (int k = 0; k < 4; ++k)
      acc += wgt[k] * (c < 3 ? srgb_to_linear(p[k][c]) : float(p[k][c]) * (1.0f / 255.0f));
    rgba[c] = acc;
  }
}

// Texture coordinates at barycentrics (u, v) of triangle `prim`; false when it has none.
inline bool triangle_uv(const ShadingTables& st, uint32_t prim, float u, float v, float& s, float& t) {
  if (!st.uvs || prim >= st.num_uvs) return false;
  const UvRecord& r = st.uvs[prim];
  const float w = 1.0f - u - v;
  s = w * r.s[0] + u * r.s[1] + v * r.s[2];
  t = w * r.t[0] + u * r.t[1] + v * r.t[2];
  return true;
}

// The base colour's texture factor (rgb) and alpha (factor times texture) of `prim` at barycentrics (u, v):
// rgb 1 and the material's alpha where there is no texture or no texture coordinates.
inline void surface_texel(const ShadingTables& st, uint32_t prim, float u, float v, float rgba[4]) {
  rgba[0] = rgba[1] = rgba[2] = rgba[3] = 1.0f;
  const MaterialRecord* m = st.material_of(prim);
  if (!m) return;
  float s, t;
  const TextureRecord* tex = st.texture_of(*m);
  if (tex && triangle_uv(st, prim, u, v, s, t)) sample_texture(*tex, st.mem + tex->texels, s, t, rgba);
  rgba[3] *= m->alpha;
}

// The any-hit stage: a candidate hit on a masked triangle counts where its alpha reaches the material's cutoff
// (glTF alphaMode MASK). Anything else is accepted.
class AlphaStage final : public hw::AnyHitStage {
 public:
  explicit AlphaStage(const ShadingTables& st) : m_st(st) {}
  bool accept(uint32_t prim, float u, float v) const override {
    const MaterialRecord* m = m_st.material_of(prim);
    if (!m || m->alpha_mode != uint32_t(AlphaMode::kMask) ||
        m_st.surfaces[prim].kind != uint32_t(SurfaceKind::kTriangle))
      return true;
    float rgba[4];
    surface_texel(m_st, prim, u, v, rgba);
    return rgba[3] >= m->alpha_cutoff;
  }

 private:
  ShadingTables m_st;
};

}  // namespace rtu::fw
