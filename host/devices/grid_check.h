// How well a scene fits the fixed-point devices' quantization frame (hwmodel/format/quant_frame.h). The frame is
// fitted to the bounds of what one image holds: the whole scene, or over two levels each mesh in its own frame.
// One grid step is extent / 2^coord_bits rounded up to a power of two, so a scene whose extent dwarfs its
// primitives (two unit boxes 10^12 apart) quantizes them to a cell or two: the fixed and timed devices then lose
// or invent their hits, exactly and conservatively as documented, but no longer the float reference's. Jobs say so
// before they trace (trace, render, Python); a frame whose step is below the smallest normal float cannot be
// quantized at all and is refused.
#pragma once

#include <cstdint>
#include <string>

#include "hwmodel/datapath/instancing.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::host {

struct GridCheck {
  uint64_t prims = 0;       // bounded primitives checked (planes have no extent to lose)
  uint64_t below_step = 0;  // those whose largest extent is below the grid step of their frame
  double step = 0.0;        // the grid step of the frame with the most such primitives (else the coarsest)
  double extent = 0.0;      // that frame's largest extent, world units
  int coord_bits = 0;
  bool two_level = false;  // frames per mesh (instances traced over two levels)
};

// The frames the fixed and timed devices fit to `g` (or, with `instances` and not `flatten`, to each mesh of
// `instances`), and the primitives below their step. Throws Error when a frame's grid step is below 2^-126, the
// smallest normal float (a scene so small that its coordinates and their products are denormals or underflow).
GridCheck check_grid(const hw::Geometry& g, const hw::InstanceSet* instances, bool flatten,
                     const hw::FixedFormat& f);

// One warning line for a check with primitives below the step, naming the step and the cure; "" otherwise.
std::string grid_warning(const GridCheck& c);

}  // namespace rtu::host
