// rtusim end to end: render (ray traced and hybrid), demo and diff.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <vector>

#include "host/io/image.h"
#include "tests/host/cli_checks.h"

namespace fs = std::filesystem;
using namespace rtu::test;

TEST_CASE("demo writes an image, hits and a report", "[cli][scale]") {
  const fs::path d = temp_dir("cli") / "demo";
  REQUIRE_RTUSIM_OK(r, "demo --out " + d.string());
  CHECK(fs::file_size(d / "primary_float.png") > 1000);
  const nlohmann::json j = read_json(d / "report.json");
  CHECK(j["devices"]["float"]["hits"].get<uint64_t>() > 0);
  // The fixed device renders the same image up to quantization: the default format keeps hit agreement above
  // 99.99% on the seed scene (edges move by at most half a grid step of 2^-24 of the scene).
  CHECK(fs::file_size(d / "primary_fixed.png") > 1000);
  CHECK(j["devices"]["fixed"]["hits"].get<uint64_t>() > 0);
  CHECK(j["fixed_vs_float"]["hit_agreement"].get<double>() >= 0.9999);
}

TEST_CASE("diff: identical and differing PNGs, JSON keys, heatmap", "[cli][image]") {
  const fs::path d = temp_dir("cli");
  rtu::host::Image a{8, 4, std::vector<uint8_t>(8 * 4 * 3, 120)};
  rtu::host::Image b = a;
  b.rgb[3 * 9 + 2] = 130;  // one channel of one pixel off by 10
  const std::string pa = (d / "a.png").string(), pa2 = (d / "a2.png").string(), pb = (d / "b.png").string();
  rtu::host::write_png(pa, a);
  rtu::host::write_png(pa2, a);
  rtu::host::write_png(pb, b);

  const std::string same_json = (d / "same.json").string();
  REQUIRE_RTUSIM_OK(same, "diff " + pa + " " + pa2 + " --json " + same_json);
  CHECK(same.output.find("8x4") != std::string::npos);
  CHECK(same.output.find("identical") != std::string::npos);
  const nlohmann::json js = read_json(same_json);
  CHECK(js["identical"] == true);
  CHECK(js["psnr_db"].is_null());
  CHECK(js["pixels_differing"] == 0);

  const std::string json = (d / "diff.json").string(), heat = (d / "heat.png").string();
  REQUIRE_RTUSIM_OK(r, "diff " + pa + " " + pb + " --heatmap " + heat + " --scale 20 --json " + json);
  CHECK(r.output.find("1 of 32 pixels differ") != std::string::npos);
  const nlohmann::json j = read_json(json);
  for (const char* key : {"a", "b", "width", "height", "identical", "mse", "psnr_db", "max_abs", "mean_abs",
                          "pixels_differing", "frac_pixels_differing", "heatmap", "heatmap_scale"})
    CHECK(j.contains(key));
  CHECK(j["width"] == 8);
  CHECK(j["height"] == 4);
  CHECK(j["identical"] == false);
  CHECK(j["max_abs"] == 10);
  CHECK(j["pixels_differing"] == 1);
  CHECK(j["mse"].get<double>() == Approx(100.0 / 96.0));
  CHECK(j["psnr_db"].get<double>() == Approx(10.0 * std::log10(255.0 * 255.0 * 96.0 / 100.0)));
  CHECK(j["heatmap_scale"].get<double>() == 20.0);
  const rtu::host::Image h = rtu::host::read_png(heat);
  REQUIRE(h.width == 8);
  REQUIRE(h.height == 4);
  for (size_t p = 0; p < 32; ++p) {
    const bool black = h.rgb[3 * p] == 0 && h.rgb[3 * p + 1] == 0 && h.rgb[3 * p + 2] == 0;
    CHECK(black == (p != 9));
  }
}

TEST_CASE("diff: missing, corrupt and mismatched files give a clear error and a non-zero exit", "[cli][image]") {
  const fs::path d = temp_dir("cli");
  const std::string a = (d / "d4x4.png").string(), b = (d / "d4x3.png").string(), junk = (d / "junk.png").string();
  rtu::host::write_png(a, rtu::host::Image{4, 4, std::vector<uint8_t>(4 * 4 * 3, 7)});
  rtu::host::write_png(b, rtu::host::Image{4, 3, std::vector<uint8_t>(4 * 3 * 3, 7)});
  std::ofstream(junk, std::ios::binary) << "not a png";
  const std::vector<Refusal> cases = {
      {"diff " + a + " " + (d / "nosuch.png").string(), "nosuch.png"},
      {"diff " + (d / "nosuch.png").string() + " " + a, "nosuch.png"},
      {"diff " + a + " " + junk, "junk.png"},
      {"diff " + a + " " + b, "sizes differ"},
      {"diff " + a + " " + b, "4x3"},
      {"diff " + a + " " + a + " --scale 0", "--scale"},
      {"diff " + a, "required"},
  };
  check_failed(cases);
}

TEST_CASE("render --mode hybrid on the timed device: raster and trace cycles, rays saved, both modes",
          "[cli][hybrid]") {
  const fs::path d = temp_dir("cli");
  const std::string stats = (d / "hy.json").string();
  REQUIRE_RTUSIM_OK(
      r,
      "render --scene builtin:seed --width 80 --height 60 --device timed --mode hybrid --max-depth 2 "
      "--compare-modes --threads 2 --out " +
          (d / "hy.png").string() + " --stats " + stats);
  CHECK(r.output.find("rasterizer:") != std::string::npos);
  CHECK(r.output.find("(4800 primary rays saved)") != std::string::npos);
  const nlohmann::json j = read_json(stats);
  CHECK(j["render_mode"] == "hybrid");
  CHECK(j["rays"]["primary"] == 0);
  CHECK(j["rays_saved"]["primary"] == 80 * 60);
  CHECK(j["raster"]["fragments"].get<uint64_t>() > 0);
  CHECK(j["skipped"]["primary"] == "rasterized (hybrid mode)");
  const auto& t = j["timing"];
  CHECK(t["raster_cycles"].get<uint64_t>() > 0);
  CHECK(t["raster"]["limit"].is_string());
  CHECK(t["frame_cycles"].get<uint64_t>() ==
        t["raster_cycles"].get<uint64_t>() + t["trace_cycles"].get<uint64_t>());
  CHECK(t["config"]["raster_setup_cycles"].is_number());
  // Both modes: the raytrace render traced the primary rays hybrid saved, and its frame has no raster cycles.
  const auto& m = j["modes"];
  CHECK(m["raytrace"]["primary_rays"] == 80 * 60);
  CHECK(m["hybrid"]["primary_rays"] == 0);
  CHECK(m["rays_saved"] == 80 * 60);
  CHECK(m["raytrace"]["raster_cycles"] == 0);
  CHECK(m["raytrace"]["frame_cycles"] == m["raytrace"]["trace_cycles"]);
  CHECK(m["hybrid"]["frame_cycles"] == t["frame_cycles"]);
  CHECK((m["psnr_db"].is_null() || m["psnr_db"].get<double>() >= 30.0));
  // raytrace is the default; an unknown mode is refused.
  const Run rt = run_rtusim("render --scene builtin:cornell --width 16 --height 16 --out " +
                            (d / "rt.png").string() + " --stats " + (d / "rt.json").string());
  REQUIRE(rt.status == 0);
  CHECK(read_json(d / "rt.json")["render_mode"] == "raytrace");
  CHECK(run_rtusim("render --scene builtin:cornell --mode raster --out " + (d / "x.png").string()).status != 0);
}

TEST_CASE("render: a progress line on a terminal, none otherwise", "[cli]") {
  if (rtu::test::run_process("command -v script").status != 0) {
    WARN("no `script` (util-linux) to give rtusim a terminal: the terminal half is not checked");
    return;
  }
  const fs::path d = temp_dir("cli");
  const std::string args =
      "render --scene builtin:cornell --width 32 --height 32 --spp 2 --out " + (d / "prog.png").string();
  // script(1) runs the command on a pseudo-terminal: stderr is a terminal there.
  const Run tty = rtu::test::run_process("script -qec '" + std::string(RTUSIM_EXE) + " " + args + "' /dev/null");
  INFO(tty.output);
  REQUIRE(tty.status == 0);
  CHECK(tty.output.find("render: ") != std::string::npos);
  CHECK(tty.output.find("(batch 1/1, bounce 0)") != std::string::npos);
  CHECK(tty.output.find("\033[K") != std::string::npos);  // cleared before the summary
  REQUIRE_RTUSIM_OK(pipe, args);
  CHECK(pipe.output.find("batch 1/") == std::string::npos);
  CHECK(pipe.output.find('\r') == std::string::npos);
}

TEST_CASE("render --set ray_sort: the sort's rays and cycles in the summary and the JSON, bad keys refused",
          "[cli][sort]") {
  const fs::path d = temp_dir("cli");
  const std::string stats = (d / "sorted.json").string();
  REQUIRE_RTUSIM_OK(
      r,
      "render --scene builtin:seed --width 40 --height 30 --device timed --max-depth 2 --threads 2 --set "
      "ray_sort=direction --out " +
          (d / "sorted.png").string() + " --stats " + stats);
  CHECK(r.output.find("ray sorting by direction:") != std::string::npos);
  CHECK(r.output.find("(sort + trace)") != std::string::npos);
  const nlohmann::json j = read_json(stats);
  CHECK(j["sort"]["key"] == "direction");
  CHECK(j["sort"]["rays"] == j["rays_total"]);
  CHECK(j["sort"]["by_ray_type"]["primary"] == 40 * 30);
  CHECK(j["sort"]["passes"] == 4 * j["sort"]["sorts"].get<uint64_t>());
  const auto& t = j["timing"];
  CHECK(t["config"]["ray_sort"] == "direction");
  CHECK(t["sort_cycles"] == t["sort"]["cycles"]);
  CHECK(t["sort"]["dram_bytes"].get<uint64_t>() > 0);
  CHECK(t["frame_cycles"].get<uint64_t>() ==
        t["raster_cycles"].get<uint64_t>() + t["sort_cycles"].get<uint64_t>() + t["trace_cycles"].get<uint64_t>());
  // Without sorting the JSON has no sort figures at all (every figure is as before the key existed).
  const Run plain = run_rtusim("render --scene builtin:seed --width 8 --height 8 --device timed --out " +
                               (d / "plain.png").string() + " --stats " + (d / "plain.json").string());
  REQUIRE(plain.status == 0);
  const nlohmann::json p = read_json(d / "plain.json");
  CHECK_FALSE(p.contains("sort"));
  CHECK_FALSE(p["timing"].contains("sort_cycles"));
  CHECK(p["timing"]["config"]["ray_sort"] == "none");
  // An unknown key, or a digit width out of range, is refused naming the key.
  const Run bad = run_rtusim(
      "render --scene builtin:seed --width 8 --height 8 --device timed --set "
      "ray_sort=zorder --out " +
      (d / "bad.png").string());
  CHECK(bad.status == 2);
  CHECK(bad.output.find("ray_sort = 'zorder' must be none, origin") != std::string::npos);
  const Run radix = run_rtusim(
      "render --scene builtin:seed --width 8 --height 8 --device timed --set "
      "ray_sort=origin --set sort_radix_bits=20 --out " +
      (d / "bad.png").string());
  CHECK(radix.status == 2);
  CHECK(radix.output.find("sort_radix_bits = 20 outside [1, 16]") != std::string::npos);
}
