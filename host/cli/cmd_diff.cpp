// rtusim diff: compare two PNG images (PSNR, max and mean absolute error, pixels that differ), optionally write a
// heatmap of where they differ and the metrics as JSON.
#include <cmath>
#include <cstdio>
#include <memory>

#include "host/cli/common.h"
#include "host/io/error.h"
#include "host/io/image.h"
#include "host/jobs/image_diff.h"

namespace rtu::host::cli {

namespace {

struct DiffOptions {
  std::string a, b, heatmap, json;
  double scale = 0.0;  // 0: the largest difference found
};

void run_diff(const DiffOptions& o) {
  const Image a = read_png(o.a), b = read_png(o.b);
  if (a.width != b.width || a.height != b.height)
    throw Error("diff: image sizes differ: " + o.a + " is " + std::to_string(a.width) + "x" +
                std::to_string(a.height) + ", " + o.b + " is " + std::to_string(b.width) + "x" +
                std::to_string(b.height));
  const ImageDiff d = diff_images(a, b);
  const double scale = o.scale > 0.0 ? o.scale : d.max_abs > 0 ? double(d.max_abs) : 1.0;
  if (!o.heatmap.empty()) write_png(o.heatmap, diff_heatmap(a, b, scale));
  if (!o.json.empty()) {
    Json j;
    j["a"] = o.a;
    j["b"] = o.b;
    j["width"] = d.width;
    j["height"] = d.height;
    j["identical"] = d.identical();
    j["mse"] = d.mse;
    j["psnr_db"] = std::isfinite(d.psnr_db) ? Json(d.psnr_db) : Json(nullptr);  // null: identical
    j["max_abs"] = d.max_abs;
    j["mean_abs"] = d.mean_abs;
    j["pixels_differing"] = d.pixels_differing;
    j["frac_pixels_differing"] = d.frac_pixels_differing;
    j["heatmap"] = o.heatmap.empty() ? Json(nullptr) : Json(o.heatmap);
    j["heatmap_scale"] = o.heatmap.empty() ? Json(nullptr) : Json(scale);
    write_json(o.json, j);
  }
  char psnr[32];
  if (std::isfinite(d.psnr_db))
    std::snprintf(psnr, sizeof psnr, "%.2f dB", d.psnr_db);
  else
    std::snprintf(psnr, sizeof psnr, "inf (identical)");
  std::printf("diff: %dx%d, PSNR %s, max abs %d, mean abs %.4g, %llu of %llu pixels differ (%.4g%%)", d.width,
              d.height, psnr, d.max_abs, d.mean_abs, static_cast<unsigned long long>(d.pixels_differing),
              static_cast<unsigned long long>(uint64_t(d.width) * uint64_t(d.height)),
              100.0 * d.frac_pixels_differing);
  if (!o.heatmap.empty()) std::printf(", heatmap (full scale %g) %s", scale, o.heatmap.c_str());
  std::printf("\n");
}

}  // namespace

void add_diff(CLI::App& app) {
  const auto [sub, o] = add_command<DiffOptions>(
      app, "diff",
      "Compare two PNG images of the same size: PSNR, max and mean absolute error (0..255 per channel), pixels "
      "that differ; optionally a heatmap of where they differ",
      [](DiffOptions& o, CLI::App&) { run_diff(o); });
  sub->add_option("a", o->a, "first PNG")->required();
  sub->add_option("b", o->b, "second PNG")->required();
  CLI::Option* heatmap =
      sub->add_option("--heatmap", o->heatmap,
                      "write a PNG of the largest channel difference per pixel: black where equal, then dim blue, "
                      "blue, red, yellow, white at the full scale");
  sub->add_option("--scale", o->scale,
                  "heatmap full scale in channel units (default: the largest difference found)")
      ->check(CLI::PositiveNumber)
      ->needs(heatmap);  // the scale of the heatmap only
  sub->add_option("--json", o->json, "write the metrics as JSON (psnr_db is null when the images are identical)");
}

}  // namespace rtu::host::cli
