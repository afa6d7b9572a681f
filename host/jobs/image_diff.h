// Comparing two 8-bit RGB images: error metrics (MSE, PSNR, max and mean absolute error, pixels that differ) and
// heatmaps that show where they differ. Used by `rtusim diff`, `rtusim demo` and `rtusim report` (the log
// heatmap).
#pragma once

#include <array>
#include <cstdint>

#include "host/io/image.h"

namespace rtu::host {

struct ImageDiff {
  int width = 0, height = 0;
  // Mean of the squared differences over all channels of all pixels (channel values 0..255).
  double mse = 0.0;
  // 10 log10(255^2 / mse) in dB; +infinity when the images are identical (mse == 0). JSON writes it as null.
  double psnr_db = 0.0;
  // Largest absolute difference of one channel (0..255).
  int max_abs = 0;
  // Mean absolute difference per channel value (0..255).
  double mean_abs = 0.0;
  // Pixels where at least one channel differs, and their fraction of all pixels.
  uint64_t pixels_differing = 0;
  double frac_pixels_differing = 0.0;

  bool identical() const { return pixels_differing == 0; }
};

// Throws Error when the sizes differ (naming both), when an image is empty, or when an image's buffer does not
// hold width x height x 3 bytes.
ImageDiff diff_images(const Image& a, const Image& b);

// One pixel per pixel of the inputs: the largest absolute channel difference d of that pixel, mapped to a color.
// d == 0 is black, exactly and only there; d > 0 goes through t = min(d / full_scale, 1) along a piecewise
// linear ramp (in 8-bit sRGB values) of
//   t = 0: dim blue (0, 0, 64), 0.25: blue (0, 0, 255), 0.5: red (255, 0, 0), 0.75: yellow (255, 255, 0),
//   1: white (255, 255, 255),
// so the smallest difference is still visible against black, and differences of full_scale or more are white.
// full_scale is in channel units (0..255 scale) and must be > 0 and finite. Throws Error like diff_images.
Image diff_heatmap(const Image& a, const Image& b, double full_scale);

// The color of the heatmap for a largest channel difference d (0..255) at full_scale.
std::array<uint8_t, 3> heatmap_color(int d, double full_scale);

// A perceptual heatmap (rtusim report): a magma-like ramp of eight colours, light cream at t = 0 through orange,
// red and purple to dark purple at t = 1, linear in 8-bit sRGB between stops at t = i / 7, so that lightness
// falls steadily with t and no colour is black. The difference is on a log scale: the largest channel difference
// d of a pixel gives t = log2(1 + min(d, full_scale)) / log2(1 + full_scale), full_scale = 2^k - 1 (k = 1..8),
// so that differences of 1, 3, 7, ... levels are evenly spaced and a single level is still clearly visible.
struct RampStop {
  double t;
  uint8_t r, g, b;
};
inline constexpr RampStop kDiffRamp[8] = {
    {0.0 / 7, 252, 253, 191}, {1.0 / 7, 254, 194, 135}, {2.0 / 7, 251, 135, 97}, {3.0 / 7, 229, 80, 100},
    {4.0 / 7, 181, 54, 122},  {5.0 / 7, 129, 37, 129},  {6.0 / 7, 79, 18, 123},  {7.0 / 7, 28, 16, 68}};
// The ramp's colour at t (clamped to 0..1).
std::array<uint8_t, 3> diff_ramp_color(double t);
// The smallest 2^k - 1 (k = 1..8) at least max_abs: the full scale of the log heatmap for that largest difference.
int diff_ramp_full_scale(int max_abs);
// Where a difference d sits on the log scale: log2(1 + min(d, full_scale)) / log2(1 + full_scale).
double diff_ramp_t(int d, int full_scale);
// The log heatmap of the difference (d and t as above); full_scale must be 2^k - 1 with k = 1..8 (Error).
Image diff_heatmap_log(const Image& a, const Image& b, int full_scale);

}  // namespace rtu::host
