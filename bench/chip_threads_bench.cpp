// chip_threads_bench: how a chip's timing replay scales with host threads. The rays' events are recorded once
// (the fixed datapath, not timed); then the chip's units replay them (run_units_in_step) on 1, 2, ... host
// threads, each best of --runs, with the cycles and every counter checked equal to one thread's. This isolates the
// units' replay from recording, which the engine runs on threads of its own (timed_engine_chip.cpp).
//
//   chip_threads_bench [--rays N] [--config PRESET] [--threads 1,2] [--runs R] [MESH]
//   (default: 200000 incoherent rays of /usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc, flattened; rdna2-chip)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/timing/ray_scheduler.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_model.h"

using namespace rtu;

namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct Run {
  uint64_t cycles = 0;
  hw::TimingStats stats;
  double seconds = 0;
};

// One replay of the recorded rays on a fresh chip (a copy of the events: the units take the lists they are given).
Run replay(const hw::TimingConfig& c, const hw::TimingModel::Layout& layout,
           const std::vector<std::vector<std::vector<hw::TraceEvent>>>& recorded, int threads) {
  const size_t U = recorded.size();
  std::vector<std::vector<std::vector<hw::TraceEvent>>> events = recorded;
  hw::MemorySystem mem(c);
  std::vector<std::unique_ptr<hw::TimingModel>> units;
  std::vector<hw::TimingStats> stats(U);
  std::vector<size_t> given(U, 0);
  std::vector<hw::TimingModel*> ptrs;
  for (uint32_t u = 0; u < U; ++u) {
    units.push_back(std::make_unique<hw::TimingModel>(c, layout, &mem, u));
    units.back()->begin(events[u].size(), stats[u]);
    ptrs.push_back(units.back().get());
  }
  const size_t chunk = std::max<size_t>(256, 2 * size_t(c.ray_slots));  // as the engine gives them
  Run r;
  const double t0 = now();
  r.cycles = hw::run_units_in_step(
      ptrs, 0,
      [&](size_t u) {
        const size_t m = std::min(chunk, events[u].size() - given[u]);
        units[u]->add_rays(events[u].data() + given[u], m);
        given[u] += m;
      },
      threads);
  r.seconds = now() - t0;
  for (const hw::TimingStats& s : stats) r.stats.add(s);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  uint64_t n = 200000;
  std::string preset = "rdna2-chip", mesh = "/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc";
  std::vector<int> threads{1, 2};
  int runs = 3;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--rays" && i + 1 < argc) {
      n = std::strtoull(argv[++i], nullptr, 10);
    } else if (a == "--config" && i + 1 < argc) {
      preset = argv[++i];
    } else if (a == "--runs" && i + 1 < argc) {
      runs = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--threads" && i + 1 < argc) {
      threads.clear();
      std::stringstream ss(argv[++i]);
      for (std::string t; std::getline(ss, t, ',');) threads.push_back(std::max(1, std::atoi(t.c_str())));
    } else if (!a.empty() && a[0] != '-') {
      mesh = a;
    } else {
      std::fprintf(stderr,
                   "usage: chip_threads_bench [--rays N] [--config PRESET] [--threads 1,2] [--runs R] [MESH]\n");
      return 2;
    }
  }
  try {
    const hw::TimingConfig c = hw::timing_preset(preset);
    hw::Geometry g;
    g.triangles = host::import_mesh(mesh);
    hw::FixedFormat f = hw::format_from_spec(c.format);
    f.width = c.bvh_width;
    hw::BvhBuildParams bp;
    bp.width = f.width;
    const hw::Bvh bvh = hw::Bvh::build(g, bp);
    const hw::DeviceImage img = hw::encode_scene(g, f, &bvh);
    const hw::FixedTracer tracer(img);
    const std::vector<hw::Ray> rays = host::incoherent_rays(g.bounds(), n, 1);
    const size_t U = size_t(c.units);
    std::vector<std::vector<std::vector<hw::TraceEvent>>> recorded(U);
    hw::TraversalStats ts;
    for (size_t i = 0; i < rays.size(); ++i) {
      std::vector<hw::TraceEvent> ev;
      tracer.trace_recorded(rays[i], false, ts, ev);
      recorded[hw::ray_unit(c.ray_policy, i, rays.size(), U, size_t(c.ray_slots))].push_back(std::move(ev));
    }
    const hw::TimingModel::Layout layout = hw::TimingModel::layout_of(img, uint64_t(c.layout_align));
    std::printf("%s: %llu triangles, %llu incoherent rays on %s (%zu units), replay only, best of %d\n\n",
                mesh.c_str(), (unsigned long long)g.triangles.size(), (unsigned long long)n, preset.c_str(), U,
                runs);
    std::printf("| host threads | replay s | speed-up | cycles | same counters |\n|---|---|---|---|---|\n");
    Run base;
    bool same_all = true;
    for (size_t k = 0; k < threads.size(); ++k) {
      Run best;
      for (int r = 0; r < runs; ++r) {
        Run x = replay(c, layout, recorded, threads[k]);
        if (r == 0 || x.seconds < best.seconds) best = x;
      }
      if (k == 0) base = best;
      bool same = best.cycles == base.cycles;
      for (const hw::TimingCounter& tc : hw::timing_counters())
        same = same && best.stats.*tc.member == base.stats.*tc.member;
      same_all = same_all && same;
      std::printf("| %d | %.3f | %.2fx | %llu | %s |\n", threads[k], best.seconds, base.seconds / best.seconds,
                  (unsigned long long)best.cycles, same ? "yes" : "NO");
    }
    return same_all ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "chip_threads_bench: %s\n", e.what());
    return 1;
  }
}
