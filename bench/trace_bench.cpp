// trace_bench: MRays/s, build time, accel bytes and peak memory of the float reference, the fixed device (default
// format), the timed device (rdna2 timing preset: the fixed datapath in the same format plus the timing model) and
// Embree 3 (rtcIntersect1, one thread) on the same meshes and the same rays, measured in one run. Each tracer runs
// in a child process of its own, so its peak resident memory (getrusage of the child) is its own. The timed
// device's MRays/s are simulated rays per second of wall time; it traces each kind of ray as one TRACE packet
// (one thread) and also reports the simulated cycles per ray.
//
//   trace_bench [--rays N] [--json F] [MESH...]      (default: the three assimp-testmodels meshes of README.md)
#include <embree3/rtcore.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "host/devices/direct_device.h"
#include "host/oracle/embree_oracle.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/timing/timing_config.h"

using namespace rtu;

namespace {

constexpr const char* kTimedPreset = "rdna2";  // the timed tracer's timing preset

struct Result {
  uint64_t triangles = 0;
  double load_s = 0, build_s = 0, primary_s = 0, incoherent_s = 0;
  uint64_t primary_hits = 0, incoherent_hits = 0;
  uint64_t accel_bytes = 0;  // float: nodes + index + leaf-ordered primitives; fixed: the device image;
                             // Embree: its memory monitor's peak
  uint64_t primary_cycles = 0, incoherent_cycles = 0;  // timed: simulated cycles of each packet
  bool ok = false;
  char error[256] = {};
};

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::atomic<int64_t> g_embree_bytes{0}, g_embree_peak{0};
bool embree_monitor(void*, ssize_t bytes, bool) {
  const int64_t v = g_embree_bytes += bytes;
  int64_t p = g_embree_peak.load();
  while (v > p && !g_embree_peak.compare_exchange_weak(p, v)) {
  }
  return true;
}

Result run_tracer(const std::string& mesh, const std::string& tracer, uint64_t n) {
  Result r;
  double t0 = now();
  hw::Geometry g;
  g.triangles = host::import_mesh(mesh);
  r.triangles = g.triangles.size();
  r.load_s = now() - t0;
  const host::Camera cam = host::frame_camera(g.bounds());
  const std::vector<hw::Ray> primary = host::primary_rays(cam, n);
  const std::vector<hw::Ray> incoherent = host::incoherent_rays(g.bounds(), n, 1);
  auto time_rays = [&](auto&& trace_one, const std::vector<hw::Ray>& rays, uint64_t& hits) {
    const double s = now();
    for (const hw::Ray& ray : rays) hits += trace_one(ray).hit();
    return now() - s;
  };
  if (tracer == "rtu-float") {
    t0 = now();
    hw::TracerOptions opt;
    opt.accel = hw::AccelMode::kBvh;
    const hw::FloatTracer t(g, opt);
    r.build_s = now() - t0;
    const hw::BvhFigures f = t.bvh()->figures();
    r.accel_bytes = f.node_bytes + f.index_bytes + t.leaf_prim_bytes();
    hw::TraversalStats s;
    auto one = [&](const hw::Ray& ray) { return t.trace(ray, false, s); };
    r.primary_s = time_rays(one, primary, r.primary_hits);
    r.incoherent_s = time_rays(one, incoherent, r.incoherent_hits);
  } else if (tracer == "rtu-fixed") {
    t0 = now();
    const hw::FixedFormat f = hw::format_preset("default");
    hw::BvhBuildParams bp;
    bp.width = f.width;
    const hw::Bvh bvh = hw::Bvh::build(g, bp);
    const hw::DeviceImage img = hw::encode_scene(g, f, &bvh);
    const hw::FixedTracer t(img);
    r.build_s = now() - t0;
    r.accel_bytes = img.size();
    hw::TraversalStats s;
    auto one = [&](const hw::Ray& ray) { return t.trace(ray, false, s); };
    r.primary_s = time_rays(one, primary, r.primary_hits);
    r.incoherent_s = time_rays(one, incoherent, r.incoherent_hits);
  } else if (tracer == "rtu-timed") {
    // As rtusim trace --device timed --config rdna2 builds it (DeviceSettings::options): the preset's format with
    // the preset's BVH width; a BVH always, as for rtu-fixed.
    t0 = now();
    host::DeviceOptions o;
    o.kind = rtu::hw::DeviceKind::kTimed;
    o.timing = hw::timing_preset(kTimedPreset);
    o.format = hw::format_from_spec(o.timing.format);
    o.format.width = o.timing.bvh_width;
    o.tracer.accel = hw::AccelMode::kBvh;
    o.tracer.bvh.width = o.format.width;
    const std::unique_ptr<host::DirectDevice> d = host::make_device(g, o);
    r.build_s = now() - t0;
    r.accel_bytes = d->image()->size();
    std::vector<hw::Hit> hits(n);
    auto time_packet = [&](const std::vector<hw::Ray>& rays, uint64_t& nhits, uint64_t& cycles) {
      hw::TraversalStats s;
      const uint64_t before = d->timed()->timing().cycles;
      const double s0 = now();
      d->trace_batch(rays.data(), hits.data(), rays.size(), false, 1, s);
      const double dt = now() - s0;
      cycles = d->timed()->timing().cycles - before;
      for (size_t i = 0; i < rays.size(); ++i) nhits += hits[i].hit();
      return dt;
    };
    r.primary_s = time_packet(primary, r.primary_hits, r.primary_cycles);
    r.incoherent_s = time_packet(incoherent, r.incoherent_hits, r.incoherent_cycles);
  } else {
    t0 = now();
    const oracle::EmbreeScene e(g, "threads=1", embree_monitor);
    r.build_s = now() - t0;
    auto one = [&](const hw::Ray& ray) { return e.intersect(ray); };
    r.primary_s = time_rays(one, primary, r.primary_hits);
    r.incoherent_s = time_rays(one, incoherent, r.incoherent_hits);
    r.accel_bytes = uint64_t(g_embree_peak.load());
  }
  r.ok = true;
  return r;
}

// Runs one tracer in a child process; returns its result and peak RSS in bytes.
Result run_child(const std::string& mesh, const std::string& tracer, uint64_t n, uint64_t& peak_rss) {
  int fd[2];
  if (pipe(fd) != 0) throw std::runtime_error("pipe failed");
  std::fflush(stdout);  // or the child inherits the unwritten table lines and prints them again
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
    Result r;
    try {
      r = run_tracer(mesh, tracer, n);
    } catch (const std::exception& e) {
      std::snprintf(r.error, sizeof r.error, "%s", e.what());
    }
    const ssize_t w = write(fd[1], &r, sizeof r);
    _exit(w == ssize_t(sizeof r) ? 0 : 1);
  }
  close(fd[1]);
  Result r;
  const ssize_t got = read(fd[0], &r, sizeof r);
  close(fd[0]);
  int status = 0;
  rusage ru{};
  wait4(pid, &status, 0, &ru);
  peak_rss = uint64_t(ru.ru_maxrss) * 1024;
  if (got != ssize_t(sizeof r)) {
    r = Result{};
    std::snprintf(r.error, sizeof r.error, "child failed (status %d)", status);
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  uint64_t n = 1000000;
  std::string json_path;
  std::vector<std::string> meshes;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--rays") && i + 1 < argc) {
      n = std::stoull(argv[++i]);
    } else if (!std::strcmp(argv[i], "--json") && i + 1 < argc) {
      json_path = argv[++i];
    } else if (argv[i][0] == '-') {
      std::fprintf(stderr, "usage: trace_bench [--rays N] [--json F] [MESH...]\n");
      return 2;
    } else {
      meshes.push_back(argv[i]);
    }
  }
  if (meshes.empty()) {
    const std::string m = "/usr/share/assimp/models/";
    meshes = {m + "glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb", m + "BLEND/SuzanneSubdiv_252.blend",
              m + "IFC/AC14-FZK-Haus.ifc"};
  }
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  std::printf("%llu primary + %llu incoherent rays per mesh, one thread\n\n", (unsigned long long)n,
              (unsigned long long)n);
  std::printf(
      "| mesh | triangles | tracer | build s | primary MRays/s | incoherent MRays/s | accel B/tri | peak MiB |\n");
  std::printf("|---|---:|---|---:|---:|---:|---:|---:|\n");
  std::vector<std::string> cycle_rows;  // the timed device's simulated cycles, printed after the main table
  for (const std::string& mesh : meshes) {
    constexpr int kFixed = 1, kTimed = 2, kEmbree = 3;
    Result res[4];
    uint64_t rss[4] = {};
    const char* names[4] = {"rtu-float", "rtu-fixed", "rtu-timed", "embree"};
    for (int k = 0; k < 4; ++k) {
      res[k] = run_child(mesh, names[k], n, rss[k]);
      const Result& r = res[k];
      const std::string base = mesh.substr(mesh.find_last_of('/') + 1);
      if (!r.ok) {
        std::printf("| %s | | %s | error: %s | | | | |\n", base.c_str(), names[k], r.error);
        continue;
      }
      std::printf("| %s | %llu | %s | %.2f | %.2f | %.2f | %.0f | %.0f |\n", base.c_str(),
                  (unsigned long long)r.triangles, names[k], r.build_s, double(n) / r.primary_s * 1e-6,
                  double(n) / r.incoherent_s * 1e-6, double(r.accel_bytes) / double(r.triangles),
                  double(rss[k]) / (1 << 20));
      out.push_back({{"mesh", mesh},
                     {"tracer", names[k]},
                     {"triangles", r.triangles},
                     {"rays", n},
                     {"load_seconds", r.load_s},
                     {"build_seconds", r.build_s},
                     {"primary_mrays_per_s", double(n) / r.primary_s * 1e-6},
                     {"incoherent_mrays_per_s", double(n) / r.incoherent_s * 1e-6},
                     {"primary_hits", r.primary_hits},
                     {"incoherent_hits", r.incoherent_hits},
                     {"accel_bytes", r.accel_bytes},
                     {"peak_rss_bytes", rss[k]}});
      if (k == kTimed) {
        nlohmann::ordered_json& j = out.back();
        j["timing_preset"] = kTimedPreset;
        j["primary_cycles"] = r.primary_cycles;
        j["incoherent_cycles"] = r.incoherent_cycles;
        j["primary_cycles_per_ray"] = double(r.primary_cycles) / double(n);
        j["incoherent_cycles_per_ray"] = double(r.incoherent_cycles) / double(n);
        char row[256];
        std::snprintf(row, sizeof row, "| %s | %s | %.2f | %.2f | %.3f | %.3f |", base.c_str(), kTimedPreset,
                      double(r.primary_cycles) / double(n), double(r.incoherent_cycles) / double(n),
                      double(n) / double(r.primary_cycles), double(n) / double(r.incoherent_cycles));
        cycle_rows.push_back(row);
      }
    }
    // Ratios of speed (rays per second: higher is faster) and of peak memory.
    auto ratio_row = [&](int k, int peer) {
      if (!res[k].ok || !res[peer].ok) return;
      std::printf("| | | %s/%s | | %.2fx | %.2fx | | %.2fx |\n", names[k], names[peer],
                  res[peer].primary_s / res[k].primary_s, res[peer].incoherent_s / res[k].incoherent_s,
                  double(rss[k]) / double(rss[peer]));
      if (res[k].primary_hits != res[peer].primary_hits || res[k].incoherent_hits != res[peer].incoherent_hits)
        std::printf("|   | | hits differ: primary %llu vs %llu, incoherent %llu vs %llu | | | | | |\n",
                    (unsigned long long)res[k].primary_hits, (unsigned long long)res[peer].primary_hits,
                    (unsigned long long)res[k].incoherent_hits, (unsigned long long)res[peer].incoherent_hits);
    };
    for (int k = 0; k < kEmbree; ++k) ratio_row(k, kEmbree);
    ratio_row(kTimed, kFixed);  // the target: >= 0.20x (at most 5x slower than the fixed device)
    std::fflush(stdout);
  }
  if (!cycle_rows.empty()) {
    std::printf("\nrtu-timed: simulated cycles (each kind of ray as one TRACE packet)\n\n");
    std::printf(
        "| mesh | timing preset | primary cycles/ray | incoherent cycles/ray | primary rays/clock | incoherent "
        "rays/clock |\n");
    std::printf("|---|---|---:|---:|---:|---:|\n");
    for (const std::string& row : cycle_rows) std::printf("%s\n", row.c_str());
  }
  if (!json_path.empty()) std::ofstream(json_path) << out.dump(2) << '\n';
  return 0;
}
