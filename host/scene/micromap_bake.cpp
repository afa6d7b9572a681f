#include "host/scene/micromap_bake.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <utility>

namespace rtu::host {

namespace {

// The least and largest alpha byte of a texture's texels, by blocks of 2^k x 2^k texels at level k.
class AlphaPyramid {
 public:
  AlphaPyramid(const uint8_t* texels, uint32_t w, uint32_t h) {
    Level l0{w, h, std::vector<uint8_t>(size_t(w) * h), {}};
    for (size_t i = 0; i < l0.lo.size(); ++i) l0.lo[i] = texels[i * 4 + 3];
    l0.hi = l0.lo;
    m_levels.push_back(std::move(l0));
    while (m_levels.back().w > 1 || m_levels.back().h > 1) {
      const Level& a = m_levels.back();
      Level b{(a.w + 1) / 2, (a.h + 1) / 2, {}, {}};
      b.lo.assign(size_t(b.w) * b.h, 255);
      b.hi.assign(size_t(b.w) * b.h, 0);
      for (uint32_t y = 0; y < a.h; ++y)
        for (uint32_t x = 0; x < a.w; ++x) {
          const size_t i = size_t(y / 2) * b.w + x / 2, j = size_t(y) * a.w + x;
          b.lo[i] = std::min(b.lo[i], a.lo[j]);
          b.hi[i] = std::max(b.hi[i], a.hi[j]);
        }
      m_levels.push_back(std::move(b));
    }
  }
  // The least and largest alpha of the texels of columns [c0, c1] and rows [r0, r1], integers taken modulo the
  // texture's size (repeat), or of a superset of them.
  void range(int64_t c0, int64_t c1, int64_t r0, int64_t r1, uint8_t& lo, uint8_t& hi) const {
    const int64_t w = m_levels[0].w, h = m_levels[0].h;
    if (c1 - c0 + 1 >= w) c0 = 0, c1 = w - 1;
    if (r1 - r0 + 1 >= h) r0 = 0, r1 = h - 1;
    // Up to 64 x 64 texels are read one by one (level 0); larger boxes through blocks at least half their size.
    const int64_t span = std::max(c1 - c0 + 1, r1 - r0 + 1);
    size_t k = 0;
    if ((c1 - c0 + 1) * (r1 - r0 + 1) > 4096)
      while (k + 1 < m_levels.size() && (int64_t(2) << k) < span) ++k;
    const Level& l = m_levels[k];
    const std::vector<int64_t> bx = blocks(c0, c1, w, k), by = blocks(r0, r1, h, k);
    lo = 255;
    hi = 0;
    for (const int64_t y : by)
      for (const int64_t x : bx) {
        lo = std::min(lo, l.lo[size_t(y) * l.w + size_t(x)]);
        hi = std::max(hi, l.hi[size_t(y) * l.w + size_t(x)]);
      }
  }

 private:
  struct Level {
    uint32_t w, h;
    std::vector<uint8_t> lo, hi;
  };
  // The level-k blocks holding the texels [a, b] modulo n.
  static std::vector<int64_t> blocks(int64_t a, int64_t b, int64_t n, size_t k) {
    std::vector<int64_t> out;
    const int64_t size = int64_t(1) << k;
    for (int64_t c = a; c <= b;) {
      const int64_t cm = ((c % n) + n) % n, bl = cm >> k;
      if (out.empty() || out.back() != bl) out.push_back(bl);
      c += std::min(size - (cm & (size - 1)), n - cm);  // to the next block, or the texture's edge
    }
    return out;
  }
  std::vector<Level> m_levels;
};

constexpr double kUvLimit = 1048576.0;  // 2^20: larger texture coordinates are not baked

hw::Micromap uniform(hw::MicroState s) {
  return hw::Micromap::pack(0, {s});
}

// One triangle's map at `level` from its texture's alpha (the header's argument): `big` is the largest magnitude
// of its texture coordinates.
hw::Micromap bake_texture(const AlphaPyramid& pyr, const fw::TextureRecord& tex, const fw::UvRecord& uv,
                          double big, double alpha, double cutoff, int level) {
  std::vector<hw::MicroState> states(size_t(1) << (2 * level));
  const uint32_t count = uint32_t(states.size());
  const double w = double(tex.width), h = double(tex.height), pad = std::ldexp(1.0 + big, -18);
  for (uint32_t i = 0; i < count; ++i) {
    double c[3][2];
    hw::micro_corners(level, i, c);
    double s0 = INFINITY, s1 = -INFINITY, t0 = INFINITY, t1 = -INFINITY;
    for (const auto& p : c) {
      const double b0 = 1.0 - p[0] - p[1];
      const double s = b0 * uv.s[0] + p[0] * uv.s[1] + p[1] * uv.s[2];
      const double t = b0 * uv.t[0] + p[0] * uv.t[1] + p[1] * uv.t[2];
      s0 = std::min(s0, s), s1 = std::max(s1, s), t0 = std::min(t0, t), t1 = std::max(t1, t);
    }
    const double texel_pad = 1.0 / 256.0;
    const int64_t c0 = int64_t(std::floor((s0 - pad) * w - 0.5 - texel_pad));
    const int64_t c1 = int64_t(std::floor((s1 + pad) * w - 0.5 + texel_pad)) + 1;
    const int64_t r0 = int64_t(std::floor((t0 - pad) * h - 0.5 - texel_pad));
    const int64_t r1 = int64_t(std::floor((t1 + pad) * h - 0.5 + texel_pad)) + 1;
    uint8_t lo, hi;
    pyr.range(c0, c1, r0, r1, lo, hi);
    const double a = double(lo) / 255.0 * (1.0 - std::ldexp(1.0, -19)) * alpha;
    const double b = double(hi) / 255.0 * (1.0 + std::ldexp(1.0, -19)) * alpha;
    const double least = std::min(a, b) - std::fabs(std::min(a, b)) * std::ldexp(1.0, -22);
    const double most = std::max(a, b) + std::fabs(std::max(a, b)) * std::ldexp(1.0, -22);
    states[i] = least >= cutoff ? hw::MicroState::kOpaque
                : most < cutoff ? hw::MicroState::kTransparent
                                : (2 * (cutoff - least) < most - least ? hw::MicroState::kUnknownOpaque
                                                                       : hw::MicroState::kUnknownTransparent);
  }
  return hw::Micromap::pack(level, states);
}

// What a texture-masked triangle's map depends on, bit for bit: its texture, its coordinates, the material's alpha
// and cutoff.
using BakeKey = std::pair<const fw::TextureRecord*, std::array<uint32_t, 8>>;

}  // namespace

hw::MicromapSet bake_micromaps(const fw::ShadingTables& st, const std::vector<uint8_t>& non_opaque, int level,
                               MicromapStats* stats) {
  level = std::clamp(level, 0, hw::kMaxMicromapLevel);
  hw::MicromapSet set;
  set.map_of.assign(non_opaque.size(), hw::MicromapSet::kNoMap);
  std::map<const fw::TextureRecord*, AlphaPyramid> pyramids;
  MicromapStats local;
  std::map<BakeKey, size_t> baked;  // the first map baked from each key, by its index in set.maps
  for (uint32_t prim = 0; prim < non_opaque.size() && prim < st.num_prims; ++prim) {
    if (!non_opaque[prim] || st.surfaces[prim].kind != uint32_t(fw::SurfaceKind::kTriangle)) continue;
    const fw::MaterialRecord* m = st.material_of(prim);
    hw::Micromap map;
    const fw::TextureRecord* tex = m ? st.texture_of(*m) : nullptr;
    if (!m || m->alpha_mode != uint32_t(fw::AlphaMode::kMask)) {
      map = uniform(hw::MicroState::kOpaque);  // the stage accepts every candidate
    } else if (!tex || !st.uvs || prim >= st.num_uvs) {
      // The stage's alpha is the material's alone: the same float product and comparison.
      float rgba3 = 1.0f;
      rgba3 *= m->alpha;
      map = uniform(rgba3 >= m->alpha_cutoff ? hw::MicroState::kOpaque : hw::MicroState::kTransparent);
    } else {
      const fw::UvRecord& uv = st.uvs[prim];
      double big = 0.0;
      bool finite = true;
      for (int a = 0; a < 3; ++a) {
        finite = finite && std::isfinite(uv.s[a]) && std::isfinite(uv.t[a]);
        big = std::max({big, std::fabs(double(uv.s[a])), std::fabs(double(uv.t[a]))});
      }
      const double cutoff = double(m->alpha_cutoff), alpha = double(m->alpha);
      if (!finite || big > kUvLimit || !std::isfinite(cutoff) || !std::isfinite(alpha)) {
        map = uniform(hw::MicroState::kUnknownOpaque);
      } else {
        // Cards that repeat one texture's coordinates (a forest's leaves) bake once: the map is a function of
        // the texture, the coordinates' bits, the material's alpha and cutoff.
        BakeKey key{tex, {}};
        std::memcpy(key.second.data(), &uv, sizeof uv);
        std::memcpy(&key.second[6], &m->alpha, sizeof(float));
        std::memcpy(&key.second[7], &m->alpha_cutoff, sizeof(float));
        // The index this triangle's map is about to take in set.maps (below), kept when the key is new.
        const auto [it, fresh] = baked.try_emplace(key, set.maps.size());
        if (fresh) {
          const AlphaPyramid& pyr =
              pyramids.try_emplace(tex, st.mem + tex->texels, tex->width, tex->height).first->second;
          map = bake_texture(pyr, *tex, uv, big, alpha, cutoff, level);
        } else {
          map = set.maps[it->second];
        }
      }
    }
    set.map_of[prim] = uint32_t(set.maps.size());
    ++local.triangles;
    local.micro_triangles += map.count();
    for (uint32_t i = 0; i < map.count(); ++i) {
      local.opaque += map.state(i) == hw::MicroState::kOpaque;
      local.transparent += map.state(i) == hw::MicroState::kTransparent;
    }
    ++(map.bits == 1 ? local.two_state : local.four_state);
    set.maps.push_back(std::move(map));
  }
  if (stats) *stats = local;
  set.place();
  return set;
}

}  // namespace rtu::host
