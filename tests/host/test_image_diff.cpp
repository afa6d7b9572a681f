// Image comparison: metrics against hand-computed values, identical and mismatched images, the PNG reader, the
// heatmap.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include "host/io/error.h"
#include "host/io/image.h"
#include "host/jobs/image_diff.h"
#include "tests/common/test_util.h"

using namespace rtu::host;
namespace fs = std::filesystem;

using rtu::test::temp_dir;

namespace {

Image solid(int w, int h, uint8_t r, uint8_t g, uint8_t b) {
  Image img{w, h, {}};
  for (int i = 0; i < w * h; ++i) img.rgb.insert(img.rgb.end(), {r, g, b});
  return img;
}

bool is_black(const Image& img, size_t pixel) {
  return img.rgb[3 * pixel] == 0 && img.rgb[3 * pixel + 1] == 0 && img.rgb[3 * pixel + 2] == 0;
}

}  // namespace

TEST_CASE("diff: one channel of one pixel off by 10 in a 4x4 image", "[image]") {
  const Image a = solid(4, 4, 100, 150, 200);
  Image b = a;
  b.rgb[3 * 5 + 1] += 10;  // pixel 5, green
  const ImageDiff d = diff_images(a, b);
  CHECK(d.width == 4);
  CHECK(d.height == 4);
  // 48 channel values, one off by 10: MSE = 100 / 48, PSNR = 10 log10(255^2 * 48 / 100) = 44.943 dB.
  CHECK(d.mse == Approx(100.0 / 48.0));
  CHECK(d.psnr_db == Approx(10.0 * std::log10(255.0 * 255.0 * 48.0 / 100.0)));
  CHECK(d.psnr_db == Approx(44.9432).epsilon(1e-5));
  CHECK(d.max_abs == 10);
  CHECK(d.mean_abs == Approx(10.0 / 48.0));
  CHECK(d.pixels_differing == 1);
  CHECK(d.frac_pixels_differing == Approx(1.0 / 16.0));
  CHECK_FALSE(d.identical());
  // Symmetric.
  const ImageDiff e = diff_images(b, a);
  CHECK(e.mse == d.mse);
  CHECK(e.max_abs == d.max_abs);
}

TEST_CASE("diff: several pixels and channels, hand-computed", "[image]") {
  // 2x1: pixel 0 differs by (3, -4, 0), pixel 1 by (0, 0, 255).
  const Image a{2, 1, {10, 20, 30, 0, 0, 0}};
  const Image b{2, 1, {13, 16, 30, 0, 0, 255}};
  const ImageDiff d = diff_images(a, b);
  CHECK(d.mse == Approx((9.0 + 16.0 + 255.0 * 255.0) / 6.0));
  CHECK(d.psnr_db == Approx(10.0 * std::log10(255.0 * 255.0 * 6.0 / (25.0 + 255.0 * 255.0))));
  CHECK(d.max_abs == 255);
  CHECK(d.mean_abs == Approx((3.0 + 4.0 + 255.0) / 6.0));
  CHECK(d.pixels_differing == 2);
  CHECK(d.frac_pixels_differing == 1.0);
  // Every channel at the largest difference: MSE = 255^2, PSNR 0 dB.
  const ImageDiff w = diff_images(solid(3, 2, 0, 0, 0), solid(3, 2, 255, 255, 255));
  CHECK(w.psnr_db == Approx(0.0).margin(1e-12));
  CHECK(w.mean_abs == 255.0);
}

TEST_CASE("diff: identical images give infinite PSNR and zero errors", "[image]") {
  const Image a = solid(7, 3, 1, 2, 3);
  const ImageDiff d = diff_images(a, a);
  CHECK(d.identical());
  CHECK(d.mse == 0.0);
  CHECK(std::isinf(d.psnr_db));
  CHECK(d.psnr_db > 0.0);
  CHECK(d.max_abs == 0);
  CHECK(d.mean_abs == 0.0);
  CHECK(d.pixels_differing == 0);
  CHECK(d.frac_pixels_differing == 0.0);
}

TEST_CASE("diff: mismatched sizes and broken images throw", "[image]") {
  const Image a = solid(4, 4, 0, 0, 0), b = solid(4, 3, 0, 0, 0), c = solid(3, 4, 0, 0, 0);
  CHECK_THROWS_AS(diff_images(a, b), Error);
  CHECK_THROWS_WITH(diff_images(a, b), Catch::Contains("4x4") && Catch::Contains("4x3"));
  CHECK_THROWS_WITH(diff_images(a, c), Catch::Contains("4x4") && Catch::Contains("3x4"));
  CHECK_THROWS_AS(diff_heatmap(a, b, 10.0), Error);
  CHECK_THROWS_AS(diff_images(Image{}, Image{}), Error);
  Image short_buf = a;
  short_buf.rgb.pop_back();
  CHECK_THROWS_AS(diff_images(a, short_buf), Error);
  CHECK_THROWS_AS(diff_heatmap(a, a, 0.0), Error);
  CHECK_THROWS_AS(diff_heatmap(a, a, -1.0), Error);
  CHECK_THROWS_AS(diff_heatmap(a, a, std::nan("")), Error);
}

TEST_CASE("PNG round trip: write_png -> read_png is lossless", "[image][io]") {
  const fs::path dir = temp_dir("image_diff");
  std::mt19937 rng(12345);
  for (const auto& [w, h] : {std::pair{1, 1}, std::pair{17, 5}, std::pair{64, 33}}) {
    Image img{w, h, std::vector<uint8_t>(size_t(w) * size_t(h) * 3)};
    for (uint8_t& v : img.rgb) v = uint8_t(rng() & 0xff);
    const std::string path = (dir / ("rt_" + std::to_string(w) + "x" + std::to_string(h) + ".png")).string();
    write_png(path, img);
    const Image back = read_png(path);
    CHECK(back.width == w);
    CHECK(back.height == h);
    CHECK(back.rgb == img.rgb);
    CHECK(diff_images(img, back).identical());
  }
}

TEST_CASE("read_png: missing and corrupt files throw an Error naming the file", "[image][io]") {
  const fs::path dir = temp_dir("image_diff");
  const std::string missing = (dir / "missing.png").string();
  CHECK_THROWS_AS(read_png(missing), Error);
  CHECK_THROWS_WITH(read_png(missing), Catch::Contains("missing.png"));
  const std::string junk = (dir / "junk.png").string();
  std::ofstream(junk, std::ios::binary) << "this is not a PNG file at all";
  CHECK_THROWS_WITH(read_png(junk), Catch::Contains("junk.png") && Catch::Contains("PNG"));
  // A real PNG cut short.
  const std::string good = (dir / "good.png").string(), cut = (dir / "cut.png").string();
  write_png(good, solid(32, 32, 9, 99, 199));
  const auto size = fs::file_size(good);
  fs::copy_file(good, cut, fs::copy_options::overwrite_existing);
  fs::resize_file(cut, size / 2);
  CHECK_THROWS_WITH(read_png(cut), Catch::Contains("cut.png"));
}

TEST_CASE("heatmap: black where equal, non-black where not, the documented ramp", "[image]") {
  const Image a = solid(3, 2, 50, 50, 50);
  Image b = a;
  b.rgb[3 * 1 + 0] = 51;   // pixel 1: the smallest difference
  b.rgb[3 * 4 + 2] = 150;  // pixel 4: 100, above the full scale
  const Image h = diff_heatmap(a, b, 40.0);
  REQUIRE(h.width == 3);
  REQUIRE(h.height == 2);
  REQUIRE(h.rgb.size() == 18);
  for (size_t p : {0, 2, 3, 5}) CHECK(is_black(h, p));
  CHECK_FALSE(is_black(h, 1));
  CHECK(h.rgb[3 * 1 + 2] >= 64);  // at least dim blue: visible against black
  CHECK(h.rgb[3 * 4] == 255);     // saturates to white
  CHECK(h.rgb[3 * 4 + 1] == 255);
  CHECK(h.rgb[3 * 4 + 2] == 255);
  CHECK(is_black(diff_heatmap(a, a, 1.0), 0));

  using C = std::array<uint8_t, 3>;
  CHECK(heatmap_color(0, 100.0) == C{0, 0, 0});
  CHECK(heatmap_color(25, 100.0) == C{0, 0, 255});
  CHECK(heatmap_color(50, 100.0) == C{255, 0, 0});
  CHECK(heatmap_color(75, 100.0) == C{255, 255, 0});
  CHECK(heatmap_color(100, 100.0) == C{255, 255, 255});
  CHECK(heatmap_color(255, 100.0) == C{255, 255, 255});
  // Every difference is non-black and brighter differences never get darker (sum of channels is monotone).
  int prev = 0;
  for (int d = 1; d <= 255; ++d) {
    const C c = heatmap_color(d, 255.0);
    const int sum = c[0] + c[1] + c[2];
    INFO("d = " << d);
    CHECK(sum > 0);
    CHECK(sum >= prev);
    prev = sum;
  }
}

TEST_CASE("log heatmap: the perceptual ramp, its log scale, no black, exact colours per pixel", "[image]") {
  using C = std::array<uint8_t, 3>;
  // The ramp's ends and stops are its documented colours.
  CHECK(diff_ramp_color(0.0) == C{252, 253, 191});
  CHECK(diff_ramp_color(1.0) == C{28, 16, 68});
  CHECK(diff_ramp_color(-1.0) == diff_ramp_color(0.0));
  CHECK(diff_ramp_color(2.0) == diff_ramp_color(1.0));
  for (const RampStop& s : kDiffRamp) CHECK(diff_ramp_color(s.t) == C{s.r, s.g, s.b});
  // Lightness (Rec. 709 luma of the sRGB values) never rises along the ramp and falls from stop to stop; no
  // colour is near black, so an image that differs nowhere is light, not dark.
  const auto luma = [](const C& c) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; };
  double prev = 1e9;
  for (int i = 0; i <= 1000; ++i) {
    const C c = diff_ramp_color(i / 1000.0);
    INFO("t = " << i / 1000.0);
    CHECK(luma(c) <= prev + 0.5);  // rounding to 8 bits may lift a sample by half a level
    CHECK(luma(c) > 20.0);
    prev = luma(c);
  }
  for (size_t k = 1; k < std::size(kDiffRamp); ++k) {
    const RampStop &a = kDiffRamp[k - 1], &b = kDiffRamp[k];
    CHECK(luma({b.r, b.g, b.b}) < luma({a.r, a.g, a.b}) - 10.0);
  }
  // Full scales: 2^k - 1 at least the largest difference.
  CHECK(diff_ramp_full_scale(0) == 1);
  CHECK(diff_ramp_full_scale(1) == 1);
  CHECK(diff_ramp_full_scale(2) == 3);
  CHECK(diff_ramp_full_scale(16) == 31);
  CHECK(diff_ramp_full_scale(255) == 255);
  // The log scale: 2^j - 1 levels at j / k, saturating at the full scale.
  CHECK(diff_ramp_t(0, 15) == 0.0);
  CHECK(diff_ramp_t(1, 15) == Approx(0.25));
  CHECK(diff_ramp_t(3, 15) == Approx(0.5));
  CHECK(diff_ramp_t(15, 15) == Approx(1.0));
  CHECK(diff_ramp_t(200, 15) == Approx(1.0));
  // Per pixel: the colour of its largest channel difference.
  const Image a = solid(4, 1, 50, 50, 50);
  Image b = a;
  b.rgb[3 * 1 + 0] = 51;   // d = 1
  b.rgb[3 * 2 + 1] = 57;   // d = 7
  b.rgb[3 * 3 + 2] = 250;  // d = 200, above the full scale
  const Image h = diff_heatmap_log(a, b, 15);
  REQUIRE(h.rgb.size() == 12);
  const int d[4] = {0, 1, 7, 200};
  for (size_t p = 0; p < 4; ++p) {
    INFO("pixel " << p);
    CHECK(C{h.rgb[3 * p], h.rgb[3 * p + 1], h.rgb[3 * p + 2]} == diff_ramp_color(diff_ramp_t(d[p], 15)));
  }
  CHECK(C{h.rgb[0], h.rgb[1], h.rgb[2]} == diff_ramp_color(0.0));
  CHECK(C{h.rgb[9], h.rgb[10], h.rgb[11]} == diff_ramp_color(1.0));
  // One level of difference is clearly apart from none.
  CHECK(luma({h.rgb[3], h.rgb[4], h.rgb[5]}) < luma({h.rgb[0], h.rgb[1], h.rgb[2]}) - 20.0);
  CHECK_THROWS_AS(diff_heatmap_log(a, b, 16), Error);
  CHECK_THROWS_AS(diff_heatmap_log(a, b, 0), Error);
  CHECK_THROWS_AS(diff_heatmap_log(a, solid(3, 1, 0, 0, 0), 15), Error);
}
