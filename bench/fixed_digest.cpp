// fixed_digest: a fixed, repeatable workload for the fixed device, and a digest of everything it computes.
// For each format preset it traces N primary, N incoherent and N "odd" rays (axis-aligned, tiny and huge
// direction components, subnormals, zero components, short intervals) through FixedTracer::trace_recorded and
// hashes the hits (t, primitive, u, v bits), the statistics and the recorded events the timing model replays.
// Two builds that print the same digests compute the same datapath, bit for bit, on these rays. With --plain it
// only traces (FixedTracer::trace, default format, no recorder, no digest of events): the workload to compare
// variants with `valgrind --tool=callgrind` instruction counts.
//
//   fixed_digest [--rays N] [--plain [--reps R]] [--kind 0|1|2] [--formats a,b,...] MESH
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/scene/bvh.h"

using namespace rtu;

namespace {

// Thread CPU time: on a shared machine it counts only the time this thread ran.
double cpu_now() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

struct Fnv {
  uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, size_t n) {
    const auto* b = static_cast<const uint8_t*>(p);
    for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
  }
  template <class T>
  void add(const T& v) {
    bytes(&v, sizeof v);
  }
};

// Rays aimed at the bounds with awkward directions: components that are zero, subnormal, tiny or huge relative
// to the others, exact powers of two; short and empty intervals; some origins outside the guard range.
std::vector<hw::Ray> odd_rays(const hw::Aabb& b, size_t n) {
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<float> u01(0.0f, 1.0f);
  std::vector<hw::Ray> rays(n);
  const float tiny[] = {0.0f, -0.0f, 1e-45f, -1e-45f, 1e-38f, 1e-20f, 1e-7f, 1.0f, 0.5f, 2.0f, 3.0f, 1e20f};
  for (size_t i = 0; i < n; ++i) {
    hw::Ray& r = rays[i];
    for (int a = 0; a < 3; ++a) {
      const float lo = b.lo[a], hi = b.hi[a], ext = hi - lo;
      r.origin[a] = lo - 0.25f * ext + 1.5f * ext * u01(rng);
      const int pick = int(rng() % 16);
      float d = pick < 12 ? tiny[pick] : 2.0f * u01(rng) - 1.0f;
      if (rng() & 1) d = -d;
      r.dir[a] = d;
    }
    if (r.dir.x == 0.0f && r.dir.y == 0.0f && r.dir.z == 0.0f) r.dir.x = 1.0f;
    r.tmin = (rng() % 4 == 0) ? u01(rng) * 10.0f : 0.0f;
    r.tmax = (rng() % 4 == 0) ? u01(rng) * 1000.0f : INFINITY;
  }
  return rays;
}

}  // namespace

int main(int argc, char** argv) {
  size_t n = 20000;
  bool plain = false;
  int reps = 1;   // --reps R (with --plain): trace each kind R times, report the fastest repetition
  int only = -1;  // --kind K: only that kind of ray (0 primary, 1 incoherent, 2 odd)
  std::string formats = "default,wide8,binary,compact,precise", mesh;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--rays") && i + 1 < argc) {
      n = std::stoull(argv[++i]);
    } else if (!std::strcmp(argv[i], "--reps") && i + 1 < argc) {
      reps = std::max(1, std::stoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--kind") && i + 1 < argc) {
      only = std::stoi(argv[++i]);
    } else if (!std::strcmp(argv[i], "--plain")) {
      plain = true;
    } else if (!std::strcmp(argv[i], "--formats") && i + 1 < argc) {
      formats = argv[++i];
    } else if (argv[i][0] == '-') {
      std::fprintf(stderr,
                   "usage: fixed_digest [--rays N] [--plain [--reps R]] [--kind K] [--formats a,b,...] MESH\n");
      return 2;
    } else {
      mesh = argv[i];
    }
  }
  if (mesh.empty()) {
    std::fprintf(stderr, "fixed_digest: no mesh\n");
    return 2;
  }
  hw::Geometry g;
  g.triangles = host::import_mesh(mesh);
  const host::Camera cam = host::frame_camera(g.bounds());
  const std::vector<hw::Ray> kinds[3] = {host::primary_rays(cam, n), host::incoherent_rays(g.bounds(), n, 1),
                                         odd_rays(g.bounds(), n)};
  const char* kind_names[3] = {"primary", "incoherent", "odd"};
  if (plain) formats = "default";
  std::stringstream fs(formats);
  std::string fname;
  while (std::getline(fs, fname, ',')) {
    const hw::FixedFormat f = hw::format_preset(fname);
    hw::BvhBuildParams bp;
    bp.width = f.width;
    const hw::Bvh bvh = hw::Bvh::build(g, bp);
    const hw::DeviceImage img = hw::encode_scene(g, f, &bvh);
    const hw::FixedTracer t(img);
    for (int k = 0; k < 3 && !plain; ++k) {  // ray setup alone: its outputs and its time
      Fnv h;
      const double t0 = cpu_now();
      for (int rep = 0; rep < 10; ++rep) {
        for (const hw::Ray& r : kinds[k]) {
          hw::FixedRay fr{};
          const hw::RayStatus st = hw::setup_ray(r, img.frame(), f, fr);
          if (rep == 0) {
            h.add(st);
            if (st == hw::RayStatus::kOk) {
              h.add(fr.o), h.add(fr.d), h.add(fr.rcp_dn), h.add(fr.rcp_up), h.add(fr.rcpm_dn), h.add(fr.rcpm_up);
              h.add(fr.rcp_sh), h.add(fr.narrow), h.add(fr.zero), h.add(fr.tmin), h.add(fr.tmax), h.add(fr.t_exp);
              h.add(fr.frac), h.add(fr.dir_bits), h.add(fr.box_shift), h.add(fr.t_shift), h.add(fr.t_limit);
            }
          }
        }
      }
      const double secs = cpu_now() - t0;
      std::printf("%-8s %-10s setup digest %016llx %6.1f ns/ray\n", fname.c_str(), kind_names[k],
                  (unsigned long long)h.h, secs / double(10 * kinds[k].size()) * 1e9);
    }
    for (int k = 0; k < 3; ++k) {
      if (only >= 0 && k != only) continue;
      Fnv h;
      hw::TraversalStats s;
      std::vector<hw::TraceEvent> ev;
      uint64_t hits = 0;
      double secs = 1e30;
      for (int rep = 0; rep < (plain ? reps : 1); ++rep) {
        if (rep > 0) {
          h = Fnv{};
          s = hw::TraversalStats{};
          hits = 0;
        }
        const double t0 = cpu_now();
        for (const hw::Ray& r : kinds[k]) {
          hw::Hit hit;
          if (plain) {
            hit = t.trace(r, false, s);
          } else {
            ev.clear();
            hit = t.trace_recorded(r, false, s, ev);
            h.bytes(ev.data(), ev.size() * sizeof(hw::TraceEvent));
          }
          hits += hit.hit();
          h.add(hit.t);
          h.add(hit.prim);
          h.add(hit.u);
          h.add(hit.v);
        }
        secs = std::min(secs, cpu_now() - t0);
      }
      const uint64_t fig[] = {s.rays,      s.hits,       s.nodes_visited, s.leaves_visited,
                              s.box_tests, s.prim_tests, s.invalid_rays,  s.saturations};
      h.add(fig);
      std::printf(
          "%-8s %-10s hits %7llu nodes %9llu boxes %10llu prims %9llu invalid %6llu sat %4llu digest %016llx "
          "%6.2f MRays/s (thread CPU time)\n",
          fname.c_str(), kind_names[k], (unsigned long long)hits, (unsigned long long)s.nodes_visited,
          (unsigned long long)s.box_tests, (unsigned long long)s.prim_tests, (unsigned long long)s.invalid_rays,
          (unsigned long long)s.saturations, (unsigned long long)h.h, double(kinds[k].size()) / secs * 1e-6);
    }
  }
  return 0;
}
