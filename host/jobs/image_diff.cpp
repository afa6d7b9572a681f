#include "host/jobs/image_diff.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <iterator>
#include <limits>
#include <string>

#include "host/io/error.h"

namespace rtu::host {

namespace {

std::string size_str(const Image& img) {
  return std::to_string(img.width) + "x" + std::to_string(img.height);
}

void check_pair(const Image& a, const Image& b, const char* what) {
  for (const Image* img : {&a, &b}) {
    if (img->width <= 0 || img->height <= 0)
      throw Error(std::string(what) + ": empty image (" + size_str(*img) + ")");
    if (img->rgb.size() != size_t(img->width) * size_t(img->height) * 3)
      throw Error(std::string(what) + ": image buffer of " + std::to_string(img->rgb.size()) +
                  " bytes does not hold " + size_str(*img) + " RGB pixels");
  }
  if (a.width != b.width || a.height != b.height)
    throw Error(std::string(what) + ": image sizes differ: " + size_str(a) + " and " + size_str(b));
}

}  // namespace

ImageDiff diff_images(const Image& a, const Image& b) {
  check_pair(a, b, "image diff");
  ImageDiff r;
  r.width = a.width;
  r.height = a.height;
  const size_t pixels = size_t(a.width) * size_t(a.height);
  // Exact integer sums: at most 3 * 255^2 per pixel, so 64 bits hold them for any image that fits in memory.
  uint64_t sum_sq = 0, sum_abs = 0;
  for (size_t p = 0; p < pixels; ++p) {
    bool differs = false;
    for (size_t k = 0; k < 3; ++k) {
      const int d = std::abs(int(a.rgb[3 * p + k]) - int(b.rgb[3 * p + k]));
      sum_sq += uint64_t(d * d);
      sum_abs += uint64_t(d);
      r.max_abs = std::max(r.max_abs, d);
      differs |= d != 0;
    }
    r.pixels_differing += differs;
  }
  const double values = double(pixels) * 3.0;
  r.mse = double(sum_sq) / values;
  r.mean_abs = double(sum_abs) / values;
  r.psnr_db = sum_sq == 0 ? std::numeric_limits<double>::infinity() : 10.0 * std::log10(255.0 * 255.0 / r.mse);
  r.frac_pixels_differing = double(r.pixels_differing) / double(pixels);
  return r;
}

std::array<uint8_t, 3> heatmap_color(int d, double full_scale) {
  if (d <= 0) return {0, 0, 0};
  struct Stop {
    double t, r, g, b;
  };
  static constexpr Stop kStops[] = {
      {0.0, 0, 0, 64}, {0.25, 0, 0, 255}, {0.5, 255, 0, 0}, {0.75, 255, 255, 0}, {1.0, 255, 255, 255}};
  const double t = full_scale > 0.0 ? std::min(double(d) / full_scale, 1.0) : 1.0;  // NaN scale: white
  size_t i = 0;
  while (i + 2 < std::size(kStops) && t > kStops[i + 1].t) ++i;
  const Stop &lo = kStops[i], &hi = kStops[i + 1];
  const double f = (t - lo.t) / (hi.t - lo.t);
  return {uint8_t(std::lround(lo.r + f * (hi.r - lo.r))), uint8_t(std::lround(lo.g + f * (hi.g - lo.g))),
          uint8_t(std::lround(lo.b + f * (hi.b - lo.b)))};
}

Image diff_heatmap(const Image& a, const Image& b, double full_scale) {
  check_pair(a, b, "image diff heatmap");
  if (!(full_scale > 0.0) || !std::isfinite(full_scale))
    throw Error("image diff heatmap: full scale must be positive and finite, got " + std::to_string(full_scale));
  Image out{a.width, a.height, std::vector<uint8_t>(a.rgb.size())};
  const size_t pixels = size_t(a.width) * size_t(a.height);
  for (size_t p = 0; p < pixels; ++p) {
    int d = 0;
    for (size_t k = 0; k < 3; ++k) d = std::max(d, std::abs(int(a.rgb[3 * p + k]) - int(b.rgb[3 * p + k])));
    const std::array<uint8_t, 3> c = heatmap_color(d, full_scale);
    std::copy(c.begin(), c.end(), out.rgb.begin() + std::ptrdiff_t(3 * p));
  }
  return out;
}

std::array<uint8_t, 3> diff_ramp_color(double t) {
  t = std::isnan(t) ? 1.0 : std::clamp(t, 0.0, 1.0);
  size_t i = 0;
  while (i + 2 < std::size(kDiffRamp) && t > kDiffRamp[i + 1].t) ++i;
  const RampStop &lo = kDiffRamp[i], &hi = kDiffRamp[i + 1];
  const double f = (t - lo.t) / (hi.t - lo.t);
  const auto mix = [f](uint8_t a, uint8_t b) { return uint8_t(std::lround(a + f * (double(b) - double(a)))); };
  return {mix(lo.r, hi.r), mix(lo.g, hi.g), mix(lo.b, hi.b)};
}

int diff_ramp_full_scale(int max_abs) {
  int s = 1;
  while (s < max_abs && s < 255) s = 2 * s + 1;
  return s;
}

double diff_ramp_t(int d, int full_scale) {
  d = std::clamp(d, 0, full_scale);
  return std::log2(1.0 + d) / std::log2(1.0 + full_scale);
}

Image diff_heatmap_log(const Image& a, const Image& b, int full_scale) {
  check_pair(a, b, "image diff heatmap");
  if (full_scale < 1 || full_scale > 255 || ((full_scale + 1) & full_scale) != 0)
    throw Error("image diff heatmap: the log full scale must be 2^k - 1 with k = 1..8, got " +
                std::to_string(full_scale));
  // One colour per possible difference, computed once.
  std::array<std::array<uint8_t, 3>, 256> lut;
  for (int d = 0; d < 256; ++d) lut[size_t(d)] = diff_ramp_color(diff_ramp_t(d, full_scale));
  Image out{a.width, a.height, std::vector<uint8_t>(a.rgb.size())};
  const size_t pixels = size_t(a.width) * size_t(a.height);
  for (size_t p = 0; p < pixels; ++p) {
    int d = 0;
    for (size_t k = 0; k < 3; ++k) d = std::max(d, std::abs(int(a.rgb[3 * p + k]) - int(b.rgb[3 * p + k])));
    const std::array<uint8_t, 3>& c = lut[size_t(d)];
    std::copy(c.begin(), c.end(), out.rgb.begin() + std::ptrdiff_t(3 * p));
  }
  return out;
}

}  // namespace rtu::host
