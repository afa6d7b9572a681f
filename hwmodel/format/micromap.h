// Opacity micromaps (DXR 1.2's opacity micromaps, Vulkan's VK_EXT_opacity_micromap): an alpha-tested triangle
// carries, per micro-triangle of a uniform subdivision of it, whether its alpha test is known: transparent,
// opaque, or unknown. The unit looks up the micro-triangle a candidate hit's barycentrics fall in and resolves the
// known states itself (an opaque one is a hit, a transparent one is no hit); only unknown ones go to the any-hit
// stage (any_hit.h). A map is exact when its known states are what the stage would answer at every point of their
// micro-triangles (host/scene/micromap_bake.h bakes such maps from alpha textures), so a render with maps is the
// render without them, with fewer any-hit requests.
//
// Subdivision level L cuts each edge into N = 2^L segments: 4^L micro-triangles. In barycentric coordinates
// (u, v) (hit point (1-u-v) v0 + u v1 + v v2, ray.h), cell (i, j) of the grid holds the upright micro-triangle
// (i/N, j/N), ((i+1)/N, j/N), (i/N, (j+1)/N) and, when i + j < N - 1, the inverted one (i+1)/N, j/N),
// ((i+1)/N, (j+1)/N), (i/N, (j+1)/N). They are numbered row by row (j), upright before inverted: index
// j (2N - j) + 2i (+1 inverted). This is rtu's order, not the Vulkan specification's bird curve: the maps are the
// unit's own data, and a row order makes the lookup two shifts and a compare.
//
// The lookup from (u, v) (micro_index): floor(u N) and floor(v N) are exact in float for N a power of two (a
// scaling and a truncation), and so is each fraction's difference to its floor (Sterbenz). A point on an edge
// between two micro-triangles (or whose fraction sum rounds to 1) goes to the upright one, the lower row or the
// lower column: it lies in that one's closed region, up to a float ulp of 1 in u + v, which bakers cover by
// dilating each micro-triangle (micromap_bake.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace rtu::hw {

// Vulkan's values (VkOpacityMicromapSpecialIndexEXT aside): 2-state maps hold 0 and 1 only.
enum class MicroState : uint8_t { kTransparent = 0, kOpaque = 1, kUnknownTransparent = 2, kUnknownOpaque = 3 };
inline bool known(MicroState s) {
  return s == MicroState::kTransparent || s == MicroState::kOpaque;
}

inline constexpr int kMaxMicromapLevel = 10;  // 4^10 micro-triangles (Vulkan allows 12 for 2-state maps)

// The micro-triangle (u, v) falls in at `level` (0..kMaxMicromapLevel); values outside the triangle (rounding)
// are taken to its nearest micro-triangle of the grid, NaN to micro-triangle 0.
uint32_t micro_index(int level, float u, float v);

// The micro-triangle's corners, (u, v) pairs, in double (exact: multiples of 2^-level).
void micro_corners(int level, uint32_t index, double uv[3][2]);

struct Micromap {
  uint8_t level = 0;
  uint8_t bits = 2;           // per micro-triangle: 1 (2-state: every state known) or 2 (4-state)
  std::vector<uint8_t> data;  // states packed in index order, the lowest bits first
  uint32_t count() const { return uint32_t(1) << (2 * level); }
  uint64_t bytes() const { return data.size(); }
  MicroState state(uint32_t index) const {
    const uint32_t bit = index * bits;
    return MicroState((data[bit >> 3] >> (bit & 7)) & (bits == 1 ? 1u : 3u));
  }
  MicroState lookup(float u, float v) const { return state(micro_index(level, u, v)); }
  // Packs `states` (count() of them) at 1 bit when every state is known, else 2.
  static Micromap pack(int level, const std::vector<MicroState>& states);
};

// The maps of a scene's triangles: map_of[prim] indexes maps, or is kNoMap (the triangle's alpha test always goes
// to the any-hit stage).
struct MicromapSet {
  static constexpr uint32_t kNoMap = ~uint32_t(0);
  std::vector<uint32_t> map_of;
  std::vector<Micromap> maps;
  // The state at a candidate hit on `prim`: an unknown state where it has no map.
  MicroState lookup(uint32_t prim, float u, float v) const {
    if (prim >= map_of.size() || map_of[prim] == kNoMap) return MicroState::kUnknownOpaque;
    return maps[map_of[prim]].lookup(u, v);
  }
  uint64_t bytes() const;  // the maps' states and a 4-byte index per mapped triangle
  // Where the state of micro-triangle `index` of `prim`'s map lies in the maps' section of device memory: the
  // maps' states packed one after another in map order (the triangles' 4-byte indices are in their records' side
  // table, not in this section). Requires a map for prim.
  uint64_t state_byte(uint32_t prim, uint32_t index) const {
    const uint32_t k = map_of[prim];
    return map_start(k) + (uint64_t(index) * maps[k].bits >> 3);
  }
  uint64_t map_start(uint32_t k) const { return k < m_start.size() ? m_start[k] : 0; }
  // Sets each map's start (after filling maps; bake_micromaps calls it).
  void place();
  // Empty when the maps are well formed (levels, sizes, indices), else the first problem.
  std::string check() const;

 private:
  std::vector<uint64_t> m_start;  // per map: its first byte in the section (place())
};

}  // namespace rtu::hw
