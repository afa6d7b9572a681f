#include "host/devices/grid_check.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "host/io/error.h"
#include "hwmodel/format/quant_frame.h"

namespace rtu::host {

namespace {

// The largest extent of a box, in double (the float difference could round).
double largest_extent(const hw::Aabb& b) {
  return std::max({double(b.hi.x) - b.lo.x, double(b.hi.y) - b.lo.y, double(b.hi.z) - b.lo.z});
}

// One frame: the image's bounded primitives in the frame the encoder fits (hwmodel/format/device_image_encode.cpp:
// the geometry's bounds). Adds its primitives to `c` and keeps the frame that loses the most.
void check_frame(const hw::Geometry& g, int bits, GridCheck& c, uint64_t& worst) {
  const hw::Aabb b = g.bounds();
  if (b.empty()) return;  // planes only: nothing quantized has an extent
  hw::QuantFrame frame;
  try {
    frame = hw::QuantFrame::fit(b, bits);
  } catch (const std::invalid_argument& e) {
    throw Error(std::string("quantization frame: ") + e.what());
  }
  // Below 2^-126 a grid step is not a normal float: the datapath's conversions of the scene's coordinates and
  // the float reference's products of them (a radius squared) underflow.
  if (frame.step_exp < FLT_MIN_EXP - 1) {
    char msg[320];
    std::snprintf(msg, sizeof msg,
                  "the scene's extent %.3g is too small for the fixed-point devices: its grid step 2^%d (%d "
                  "coordinate bits) is below the smallest normal float 2^-126; scale the scene up",
                  largest_extent(b), frame.step_exp, bits);
    throw Error(msg);
  }
  const double step = frame.step();
  uint64_t below = 0;
  const uint32_t n = g.num_bounded();
  for (uint32_t p = 0; p < n; ++p)
    if (largest_extent(g.prim_bounds(p)) < step) ++below;
  c.prims += n;
  c.below_step += below;
  if (below > worst || (worst == 0 && step > c.step)) {
    worst = std::max(worst, below);
    c.step = step;
    c.extent = largest_extent(b);
  }
}

}  // namespace

GridCheck check_grid(const hw::Geometry& g, const hw::InstanceSet* instances, bool flatten,
                     const hw::FixedFormat& f) {
  GridCheck c;
  c.coord_bits = f.coord_bits;
  uint64_t worst = 0;
  if (instances && !instances->instances.empty() && !flatten) {
    c.two_level = true;
    for (const hw::Geometry& m : instances->meshes) check_frame(m, f.coord_bits, c, worst);
  } else {
    check_frame(g, f.coord_bits, c, worst);
  }
  return c;
}

std::string grid_warning(const GridCheck& c) {
  if (c.below_step == 0) return "";
  char msg[640];
  std::snprintf(
      msg, sizeof msg,
      "%llu of %llu primitives are smaller than the grid step %.3g (an extent of %.3g over %d "
      "coordinate bits%s): the fixed and timed devices may lose or invent their hits (`compare` counts "
      "them). Cure: give each small mesh its own frame by instancing it (scene files: \"instances\"), or "
      "raise --coord-bits",
      (unsigned long long)c.below_step, (unsigned long long)c.prims, c.step, c.extent, c.coord_bits,
      c.two_level ? ", in a mesh's own frame" : "");
  return msg;
}

}  // namespace rtu::host
