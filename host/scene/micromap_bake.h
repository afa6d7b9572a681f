// Baking opacity micromaps (hwmodel/format/micromap.h) from a scene's alpha textures, for the any-hit stage the
// renderer and the direct devices use (fw::AlphaStage, firmware/surface.h): a micro-triangle is opaque or
// transparent only if the stage answers so at every point of it, else unknown.
//
// Why a known state is the stage's answer. The stage, at barycentrics (u, v), interpolates the triangle's texture
// coordinates in float, wraps them to [0, 1), and filters the four nearest texels bilinearly (alpha = the sum of
// four non-negative weights times the texels' alpha / 255), times the material's alpha, against its cutoff. The
// unit looks up the micro-triangle with the same (u, v) the stage would get, which lies in that micro-triangle's
// closed region up to a float ulp of 1 (micromap.h). So the baker takes each micro-triangle's region in texture
// space, widens its bounding box by 2^-18 (1 + the largest coordinate) in texture units (the barycentric ulp
// times the triangle's extent, and the stage's float interpolation: a few ulps of the largest coordinate) and by
// 1/256 texel (the texel position's rounding), and reads the alpha of every texel a bilinear lookup anywhere in
// that box can touch (the column and row on each side of the box's texel range, wrapped). The micro-triangle is
// opaque when the least of them, times the material's alpha and less 2^-19 relative (the float weights' sum and
// products, a few ulps each), reaches the cutoff; transparent when the largest, plus 2^-19, stays below it;
// otherwise unknown. A box of up to 64 x 64 texels is read texel by texel; a larger one through a min/max pyramid,
// at most 3 x 3 blocks of the level whose blocks are at least half its size: a superset of its texels (still
// conservative, coarser).
// Triangles whose texture coordinates pass 2^20 in magnitude are unknown throughout.
#pragma once

#include <cstdint>
#include <vector>

#include "firmware/surface.h"
#include "hwmodel/format/micromap.h"

namespace rtu::host {

struct MicromapStats {
  uint64_t triangles = 0;                  // non-opaque triangles given a map
  uint64_t micro_triangles = 0;            // in all maps
  uint64_t opaque = 0, transparent = 0;    // known micro-triangles
  uint64_t two_state = 0, four_state = 0;  // maps of 1 bit a state (every state known) and of 2
};

// The maps at `level` of the triangles [0, non_opaque.size()) whose flag is set (alpha-tested: they reach the
// any-hit stage), over the stage's tables. Other triangles get none.
hw::MicromapSet bake_micromaps(const fw::ShadingTables& st, const std::vector<uint8_t>& non_opaque, int level,
                               MicromapStats* stats = nullptr);

}  // namespace rtu::host
