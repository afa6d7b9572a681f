// query_bench: neighbour queries on the unit against a CPU k-d tree measured in the same run. For each point set
// (uniform, clustered, a real mesh's vertices) and radius: the unit's answers (exact; checked equal to nanoflann's
// candidates decided exactly), its candidates and traversal per query, its cycles per query on one unit of each
// timing preset given and the queries a second that makes at the preset's clock; and nanoflann's radius search
// (one thread, best of --runs) in queries a second.
//
//   query_bench [--points N] [--queries M] [--configs rdna2,rdna4] [--runs R] [--any-hit-latency L]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <nanoflann.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "host/jobs/query.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/exact_compare.h"
#include "hwmodel/timing/timing_config.h"

using namespace rtu;

namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct Cloud {
  const std::vector<hw::Vec3>* pts;
  size_t kdtree_get_point_count() const { return pts->size(); }
  float kdtree_get_pt(size_t i, size_t d) const { return (*pts)[i][int(d)]; }
  template <class B>
  bool kdtree_get_bbox(B&) const {
    return false;
  }
};
using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Cloud>, Cloud, 3, uint32_t>;

std::vector<hw::Vec3> mesh_vertices(const std::string& path, size_t limit) {
  std::set<std::tuple<float, float, float>> seen;
  std::vector<hw::Vec3> v;
  for (const hw::Triangle& t : host::import_mesh(path))
    for (const hw::Vec3& p : {t.v0, t.v1, t.v2})
      if (v.size() < limit && seen.insert({p.x, p.y, p.z}).second) v.push_back(p);
  return v;
}

void run(const char* name, const std::vector<hw::Vec3>& pts, const std::vector<hw::Vec3>& qs, float r,
         const std::vector<std::string>& configs, int runs, int any_hit_latency) {
  // nanoflann: radius search (squared radius, float), one thread, best of runs; its answers decided exactly.
  Cloud cloud{&pts};
  KdTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  double best = 1e30;
  uint64_t found = 0;
  std::vector<std::pair<uint32_t, float>> out;
  nanoflann::SearchParams sp;
  sp.sorted = false;
  for (int k = 0; k < runs; ++k) {
    const double t0 = now();
    found = 0;
    for (const hw::Vec3& q : qs) {
      const float qq[3] = {q.x, q.y, q.z};
      found += tree.radiusSearch(qq, r * r, out, sp);
    }
    best = std::min(best, now() - t0);
  }
  host::QueryJobOptions o;
  o.points = pts;
  o.queries = qs;
  o.radius = r;
  o.what = {hw::PointQuery::kCount, 0};
  o.format = hw::format_preset("default");
  const host::QueryJobResult f = host::run_query_job(o);
  std::printf("| %s | %zu | %g | %.2f | %.2f | %.2f | %llu | %.0f |", name, pts.size(), double(r),
              double(f.stats.results) / double(qs.size()), double(f.stats.candidates) / double(qs.size()),
              double(f.stats.nodes_visited) / double(qs.size()), (unsigned long long)found,
              double(qs.size()) / best);
  for (const std::string& c : configs) {
    o.timed = true;
    o.timing = hw::timing_preset(c);
    if (any_hit_latency >= 0) o.timing.any_hit_latency = any_hit_latency;
    o.format = hw::format_preset(o.timing.format);
    o.format.width = o.timing.bvh_width;
    const host::QueryJobResult t = host::run_query_job(o);
    const double qps = double(qs.size()) / (double(t.cycles) / (o.timing.clock_ghz * 1e9));
    std::printf(" %.1f | %.0f (%.2fx) |", double(t.cycles) / double(qs.size()), qps,
                qps * best / double(qs.size()));
    if (t.stats.results != f.stats.results) {
      std::fprintf(stderr, "query_bench: the timed unit's answers differ from the fixed unit's\n");
      std::exit(1);
    }
  }
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  size_t n = 200000, m = 50000;
  int runs = 3, any_hit_latency = -1;
  std::vector<std::string> configs = {"rdna2", "rdna4"};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "query_bench: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--points")
      n = std::stoull(next());
    else if (a == "--queries")
      m = std::stoull(next());
    else if (a == "--runs")
      runs = std::stoi(next());
    else if (a == "--any-hit-latency")
      any_hit_latency = std::stoi(next());
    else if (a == "--configs") {
      configs.clear();
      std::stringstream ss(next());
      for (std::string c; std::getline(ss, c, ',');) configs.push_back(c);
    } else {
      std::fprintf(stderr,
                   "usage: query_bench [--points N] [--queries M] [--configs A,B] [--runs R] "
                   "[--any-hit-latency L]\n");
      return 2;
    }
  }
  std::printf(
      "| points | count | radius | neighbours/query | candidates/query | nodes/query | nanoflann found | "
      "nanoflann queries/s |");
  for (const std::string& c : configs)
    std::printf(" %s cycles/query | %s queries/s (x nanoflann) |", c.c_str(), c.c_str());
  std::printf("\n|---|---:|---:|---:|---:|---:|---:|---:|");
  for (size_t i = 0; i < configs.size(); ++i) std::printf("---:|---:|");
  std::printf("\n");
  const std::vector<hw::Vec3> u = host::points_from_spec("uniform:" + std::to_string(n), 1),
                              uq = host::points_from_spec("uniform:" + std::to_string(m), 2),
                              c = host::points_from_spec("clustered:" + std::to_string(n), 3);
  std::vector<hw::Vec3> cq(c.begin(), c.begin() + std::ptrdiff_t(std::min(m, c.size())));
  for (float r : {1.0f, 2.0f}) run("uniform", u, uq, r, configs, runs, any_hit_latency);
  for (float r : {0.1f, 0.3f}) run("clustered (queries: data points)", c, cq, r, configs, runs, any_hit_latency);
  const std::string mesh = "/usr/share/assimp/models/BLEND/SuzanneSubdiv_252.blend";
  const std::vector<hw::Vec3> sv = mesh_vertices(mesh, n);
  std::vector<hw::Vec3> sq(sv.begin(), sv.begin() + std::ptrdiff_t(std::min(m, sv.size())));
  for (float r : {0.01f, 0.03f}) run("SuzanneSubdiv_252 vertices", sv, sq, r, configs, runs, any_hit_latency);
  return 0;
}
