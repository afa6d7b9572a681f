// rtu_rtl_trav_bench: the timing model held against the RTL traversal unit (trav_unit.sv), packet by packet.
//   rtu_rtl_trav_bench correlate RAYS PACKETS MESH...   per mesh x {camera, incoherent, shadow} x each verilated
//       unit of width 4 x {memory "cache": the preset's, "dram": rdna2-mem's cache and DRAM}: PACKETS packets of
//       RAYS rays on the unit and in the model; a Markdown row per group, then every packet's error summed up as
//       Accel-Sim reports a simulator against silicon: mean absolute error, largest error, Pearson correlation.
//   rtu_rtl_trav_bench rank RAYS MESH                   the design sweep: every verilated unit of width 4 x four
//       memories, one packet of incoherent rays each: cycles on both, the order of the designs (Kendall's tau) and
//       each design's speed-up over the first as the unit and as the model give it.
// Both print the simulated rays per second of the unit and of the model (wall clock, this machine).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/scene/bvh.h"
#include "rtl_models.h"
#include "rtl_sim/params/rtl_params.h"
#include "rtl_sim/trav/trav_driver.h"
#include "rtl_trav_bench_models.h"

namespace {

using namespace rtu;
using Clock = std::chrono::steady_clock;
int g_port = 1;  // the model's fetch_port_rate: 1, the unit's port (RTU_TRAV_PORT=0: the model without the limit)

struct Unit {
  const char* name;
  const char* spec;
  const char* args;
  std::function<rtl::TravRun(const hw::TimingConfig&, const hw::DeviceImage&, const std::vector<hw::Ray>&, bool)>
      run;
};

template <class Model>
rtl::TravRun run_unit(const hw::TimingConfig& c, const hw::DeviceImage& img, const std::vector<hw::Ray>& rays,
                      bool any_hit) {
  std::vector<hw::Hit> hits(rays.size());
  return rtl::run_trav_packet<Model>(c, img, rays.data(), rays.size(), any_hit, hits.data());
}

std::vector<Unit> units() {
  std::vector<Unit> u;
#define RTU_TRAV_UNIT(cls, name, spec, args) u.push_back({name, spec, args, run_unit<cls>});
  RTU_RTL_TRAV_MODELS(RTU_TRAV_UNIT)
  RTU_RTL_TRAVB_MODELS(RTU_TRAV_UNIT)
#undef RTU_TRAV_UNIT
  return u;
}

// The model's cycles, fetches and cache misses of one packet.
struct ModelRun {
  uint64_t cycles, fetches, misses;
};
ModelRun run_model(const hw::TimingConfig& c, const hw::DeviceImage& img, const std::vector<hw::Ray>& rays,
                   bool any_hit) {
  hw::TimedEngine engine(hw::EngineOptions{}, c);
  engine.bind(img.data(), img.size());
  std::vector<hw::Hit> hits(rays.size());
  hw::TraversalStats ts;
  const uint64_t cycles = engine.trace_cycles(rays.data(), hits.data(), rays.size(), any_hit, ts, 0, 0);
  const hw::TimingStats& s = engine.timing();
  return {cycles, s.node_fetches + s.prim_fetches, s.cache_misses};
}

// The unit's configuration with a memory: "cache" keeps the preset's, "dram" takes rdna2-mem's.
hw::TimingConfig config(const Unit& u, const std::string& memory) {
  std::string spec = u.spec;
  if (memory == "dram") spec += ":cache_kib=16:dram_latency=600:dram_bytes_per_cycle=3.2";
  if (memory == "dram200") spec += ":cache_kib=16:dram_bytes_per_cycle=3.2";
  if (memory == "cache16") spec += ":cache_kib=16";
  if (memory == "lat600") spec += ":dram_latency=600";
  hw::TimingConfig c = rtl::unit_config(spec);
  if (rtl::verilator_args(rtl::trav_params(c)) != u.args)
    throw std::logic_error(std::string("unit ") + u.name + ": verilated with other parameters than " + spec);
  return c;
}

struct Mesh {
  host::Scene scene;
  std::vector<hw::DeviceImage> images;  // width 4, width 8
  const hw::DeviceImage& image(int width) const { return images[width == 8 ? 1 : 0]; }
};

Mesh load(const std::string& path) {
  Mesh m{host::load_scene(path), {}};
  const hw::Geometry& g = m.scene.geometry;
  // An instanced scene's geometry is its flattened form: the unit traces that, in one level.
  if (!g.spheres.empty() || !g.planes.empty() || !g.curves.empty())
    throw std::invalid_argument(path + ": the RTL traversal unit traces triangle meshes only");
  for (const char* f : {"default", "wide8"}) {
    hw::BvhBuildParams bp;
    bp.width = hw::format_preset(f).width;
    const hw::Bvh bvh = hw::Bvh::build(g, bp);
    m.images.push_back(hw::encode_scene(g, hw::format_preset(f), &bvh));
  }
  return m;
}

// kind 0 camera, 1 incoherent, 2 shadow (from the camera rays' float hits toward a light above the bounds).
std::vector<hw::Ray> rays_of(const Mesh& m, int kind, size_t n, uint64_t seed) {
  const hw::Aabb b = m.scene.geometry.bounds();
  if (kind == 1) return host::incoherent_rays(b, n, seed);
  std::vector<hw::Ray> cam = host::primary_rays(m.scene.camera, uint64_t(n) * 8);
  std::vector<hw::Ray> picked;
  for (size_t i = 0; i < n; ++i) picked.push_back(cam[(i * 8 + seed) % cam.size()]);
  if (kind == 0) return picked;
  hw::FloatTracer ft(m.scene.geometry);
  const hw::Vec3 light((b.lo.x + b.hi.x) * 0.5f, b.hi.y + (b.hi.y - b.lo.y), (b.lo.z + b.hi.z) * 0.5f);
  std::vector<hw::Ray> shadow;
  for (const hw::Ray& r : picked) {
    hw::TraversalStats s;
    const hw::Hit h = ft.trace(r, false, s);
    if (!h.hit()) continue;
    hw::Ray sr;
    sr.origin = r.origin + h.t * r.dir;
    sr.dir = light - sr.origin;
    sr.tmin = 1e-3f;
    sr.tmax = 1.0f;
    shadow.push_back(sr);
  }
  return shadow;
}

struct Point {
  double rtl, model;
};
double pearson(const std::vector<Point>& p) {
  double mx = 0, my = 0;
  for (const Point& q : p) mx += q.rtl, my += q.model;
  mx /= double(p.size());
  my /= double(p.size());
  double sxy = 0, sxx = 0, syy = 0;
  for (const Point& q : p) {
    sxy += (q.rtl - mx) * (q.model - my);
    sxx += (q.rtl - mx) * (q.rtl - mx);
    syy += (q.model - my) * (q.model - my);
  }
  return sxx > 0 && syy > 0 ? sxy / std::sqrt(sxx * syy) : 1.0;
}
double kendall(const std::vector<Point>& p) {
  long conc = 0, disc = 0;
  for (size_t i = 0; i < p.size(); ++i)
    for (size_t j = i + 1; j < p.size(); ++j) {
      const double a = p[i].rtl - p[j].rtl, b = p[i].model - p[j].model;
      if (a * b > 0) ++conc;
      if (a * b < 0) ++disc;
    }
  return conc + disc > 0 ? double(conc - disc) / double(conc + disc) : 1.0;
}
double err(const Point& q) {
  return (q.model - q.rtl) / q.rtl;
}

struct Speed {
  double rtl_s = 0, model_s = 0;
  uint64_t rays = 0;
  void print() const {
    std::printf("\nSimulated rays per second on this machine: RTL unit %.0f, timing model %.0f (%.0fx)\n",
                double(rays) / rtl_s, double(rays) / model_s, rtl_s / model_s);
  }
};

Point one(const Unit& u, const hw::TimingConfig& c, const hw::DeviceImage& img, const std::vector<hw::Ray>& rays,
          bool any_hit, Speed& sp) {
  const auto t0 = Clock::now();
  const rtl::TravRun run = u.run(c, img, rays, any_hit);
  const auto t1 = Clock::now();
  hw::TimingConfig mc = c;
  mc.fetch_port_rate = g_port;
  const ModelRun model = run_model(mc, img, rays, any_hit);
  const auto t2 = Clock::now();
  sp.rtl_s += std::chrono::duration<double>(t1 - t0).count();
  sp.model_s += std::chrono::duration<double>(t2 - t1).count();
  sp.rays += rays.size();
  // A packet off by more than 5%: both sides' work and cache behaviour, to trace it.
  if (std::abs(double(model.cycles) - double(run.cycles)) > 0.05 * double(run.cycles))
    std::fprintf(stderr, "%s: RTL %llu cycles, %llu fetches, %llu cache misses; model %llu, %llu, %llu\n", u.name,
                 (unsigned long long)run.cycles, (unsigned long long)(run.node_reads + run.record_reads),
                 (unsigned long long)run.cache_misses, (unsigned long long)model.cycles,
                 (unsigned long long)model.fetches, (unsigned long long)model.misses);
  return {double(run.cycles), double(model.cycles)};
}

int correlate(size_t n, int packets, const std::vector<std::string>& meshes) {
  static const char* kKinds[] = {"camera", "incoherent", "shadow"};
  std::vector<Point> all;
  Speed sp;
  std::printf(
      "| mesh | rays | unit | memory | packets | RTL cycles | model cycles | mean abs error | largest |\n");
  std::printf("|---|---|---|---|---:|---:|---:|---:|---:|\n");
  for (const std::string& path : meshes) {
    const Mesh m = load(path);
    for (int kind = 0; kind < 3; ++kind)
      for (const Unit& u : units()) {
        const hw::TimingConfig c0 = rtl::unit_config(u.spec);
        if (c0.bvh_width != 4) continue;
        for (const char* memory : {"cache", "dram"}) {
          const hw::TimingConfig c = config(u, memory);
          std::vector<Point> group;
          for (int p = 0; p < packets; ++p) {
            const std::vector<hw::Ray> rays = rays_of(m, kind, n, uint64_t(p) * 7919 + 1);
            if (rays.empty()) continue;
            group.push_back(one(u, c, m.image(4), rays, kind == 2, sp));
          }
          double rtl = 0, model = 0, mae = 0, worst = 0;
          for (const Point& q : group) {
            rtl += q.rtl;
            model += q.model;
            mae += std::abs(err(q)) / double(group.size());
            worst = std::max(worst, std::abs(err(q)));
          }
          all.insert(all.end(), group.begin(), group.end());
          std::printf("| %s | %s | %s | %s | %zu | %.0f | %.0f | %.3f%% | %.3f%% |\n",
                      path.substr(path.find_last_of('/') + 1).c_str(), kKinds[kind], u.name, memory, group.size(),
                      rtl, model, 100 * mae, 100 * worst);
        }
      }
  }
  double mae = 0, worst = 0;
  for (const Point& q : all) {
    mae += std::abs(err(q)) / double(all.size());
    worst = std::max(worst, std::abs(err(q)));
  }
  std::printf("\nAll %zu packets: mean absolute error %.3f%%, largest %.3f%%, correlation %.6f\n", all.size(),
              100 * mae, 100 * worst, pearson(all));
  sp.print();
  return 0;
}

int rank(size_t n, const std::string& path) {
  const Mesh m = load(path);
  const std::vector<hw::Ray> rays = rays_of(m, 1, n, 1);
  std::vector<Point> pts;
  std::vector<std::string> names;
  Speed sp;
  for (const Unit& u : units()) {
    if (rtl::unit_config(u.spec).bvh_width != 4) continue;
    for (const char* memory : {"cache", "cache16", "lat600", "dram"}) {
      pts.push_back(one(u, config(u, memory), m.image(4), rays, false, sp));
      names.push_back(std::string(u.name) + " " + memory);
    }
  }
  std::printf("| design | RTL cycles | model cycles | error | speed-up (RTL) | speed-up (model) | difference |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|\n");
  double worst_pp = 0;
  for (size_t i = 0; i < pts.size(); ++i) {
    const double su_rtl = pts[0].rtl / pts[i].rtl, su_model = pts[0].model / pts[i].model;
    worst_pp = std::max(worst_pp, std::abs(su_rtl - su_model) * 100);
    std::printf("| %s | %.0f | %.0f | %+.3f%% | %.4f | %.4f | %.2f pp |\n", names[i].c_str(), pts[i].rtl,
                pts[i].model, 100 * err(pts[i]), su_rtl, su_model, 100 * (su_model - su_rtl));
  }
  std::printf("\n%zu designs: Kendall's tau %.4f; largest speed-up difference %.3f percentage points\n",
              pts.size(), kendall(pts), worst_pp);
  sp.print();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string cmd = argc > 1 ? argv[1] : "";
    if (const char* e = std::getenv("RTU_TRAV_PORT")) g_port = std::atoi(e);
    if (cmd == "correlate" && argc >= 5) {
      return correlate(std::stoul(argv[2]), std::stoi(argv[3]), std::vector<std::string>(argv + 4, argv + argc));
    }
    if (cmd == "rank" && argc == 4) return rank(std::stoul(argv[2]), argv[3]);
    std::fprintf(stderr, "usage: rtu_rtl_trav_bench correlate RAYS PACKETS MESH... | rank RAYS MESH\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rtu_rtl_trav_bench: %s\n", e.what());
    return 1;
  }
}
