#include "host/jobs/query.h"

#include <algorithm>
#include <string>
#include <utility>

#include "host/cost/timing_json.h"
#include "host/io/error.h"
#include "host/io/files.h"
#include "host/io/point_io.h"
#include "hwmodel/numeric/rng.h"

namespace rtu::host {

std::vector<hw::Vec3> points_from_spec(const std::string& spec, uint64_t seed) {
  const size_t colon = spec.find(':');
  const std::string kind = colon == std::string::npos ? "" : spec.substr(0, colon);
  if (kind != "uniform" && kind != "clustered") return read_points(spec);
  const std::string n_text = spec.substr(colon + 1);
  uint64_t n = 0;
  try {
    size_t used = 0;
    n = std::stoull(n_text, &used);
    if (used != n_text.size()) throw std::invalid_argument("trailing");
  } catch (const std::exception&) {
    throw Error("points '" + spec + "': expected " + kind + ":N with N a count");
  }
  if (n == 0 || n > (uint64_t(1) << 27)) throw Error("points '" + spec + "': N must be in 1..2^27");
  hw::Pcg32 rng(seed);
  const auto unit = [&] { return hw::Vec3(rng.next_float(), rng.next_float(), rng.next_float()); };
  std::vector<hw::Vec3> pts(n);
  if (kind == "uniform") {
    for (hw::Vec3& p : pts) p = 100.0f * unit();
    return pts;
  }
  hw::Pcg32 crng(seed ^ 0x5eed);
  std::vector<hw::Vec3> centers(16);
  std::vector<float> sizes(16);
  for (size_t c = 0; c < centers.size(); ++c) {
    centers[c] = 100.0f * hw::Vec3(crng.next_float(), crng.next_float(), crng.next_float());
    sizes[c] = 0.5f + 8.0f * crng.next_float() * crng.next_float();
  }
  for (hw::Vec3& p : pts) {
    const uint32_t c = rng.next_u32() % 16;
    p = centers[c] + sizes[c] * (unit() - hw::Vec3(0.5f));
  }
  return pts;
}

std::vector<uint32_t> morton_query_order(const std::vector<hw::Vec3>& qs) {
  hw::Aabb b;
  for (const hw::Vec3& q : qs) b.extend(q);
  const auto spread = [](uint64_t x) {  // 10 bits to every third of 30
    x &= 0x3FF;
    x = (x | (x << 16)) & 0x30000FF;
    x = (x | (x << 8)) & 0x300F00F;
    x = (x | (x << 4)) & 0x30C30C3;
    return (x | (x << 2)) & 0x9249249;
  };
  std::vector<std::pair<uint64_t, uint32_t>> keyed(qs.size());
  for (size_t i = 0; i < qs.size(); ++i) {
    uint64_t code = 0;
    for (int a = 0; a < 3; ++a) {
      const double extent = double(b.hi[a]) - double(b.lo[a]);
      const double u = extent > 0.0 ? (double(qs[i][a]) - double(b.lo[a])) / extent : 0.0;
      code |= spread(uint64_t(std::min(1023.0, std::max(0.0, u * 1024.0)))) << a;
    }
    keyed[i] = {code, uint32_t(i)};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<uint32_t> order(qs.size());
  for (size_t i = 0; i < qs.size(); ++i) order[i] = keyed[i].second;
  return order;
}

QueryJobResult run_query_job(const QueryJobOptions& o) {
  const hw::PointIndex index(o.points, o.radius, o.format);
  const std::vector<hw::Vec3>& input = o.queries.empty() ? o.points : o.queries;
  std::vector<uint32_t> order;
  std::vector<hw::Vec3> sorted;
  if (o.morton_order) {
    order = morton_query_order(input);
    sorted.reserve(input.size());
    for (const uint32_t i : order) sorted.push_back(input[i]);
  }
  const std::vector<hw::Vec3>& qs = o.morton_order ? sorted : input;
  QueryJobResult r;
  r.index_bytes = hw::query_layout(index, o.format).total_bytes;
  if (o.timed) {
    hw::QueryTiming t = hw::time_point_queries(index, o.format, qs, o.what, o.timing);
    r.answers = std::move(t.answers);
    r.stats = t.queries;
    r.cycles = t.cycles;
    r.timing = t.timing;
  } else {
    r.answers = index.query_batch(qs, o.what, o.threads, r.stats);
  }
  if (o.morton_order) {  // back to the input's order
    std::vector<hw::PointAnswer> back(r.answers.size());
    for (size_t k = 0; k < order.size(); ++k) back[order[k]] = std::move(r.answers[k]);
    r.answers = std::move(back);
  }
  return r;
}

Json query_json(const QueryJobOptions& o, const QueryJobResult& r) {
  static const char* kKinds[] = {"radius", "count", "nearest"};
  Json j;
  j["kind"] = kKinds[o.what.kind];
  j["radius"] = o.radius;
  j["bound"] = o.what.max_results;
  j["points"] = o.points.size();
  j["queries"] = r.stats.queries;
  j["format"] = o.format.describe();
  j["results"] = r.stats.results;
  j["candidates"] = r.stats.candidates;
  j["overflows"] = r.stats.overflows;
  j["nodes_visited"] = r.stats.nodes_visited;
  j["box_tests"] = r.stats.box_tests;
  j["index_bytes"] = r.index_bytes;
  j["order"] = o.morton_order ? "morton" : "input";
  if (o.timed)
    probe_timing_json(j, "cycles_per_query", "queries_per_clock", r.stats.queries, r.cycles, r.timing, o.timing,
                      o.format);
  return j;
}

void probe_timing_json(Json& j, const char* per_key, const char* rate_key, uint64_t probes, uint64_t cycles,
                       const hw::TimingStats& t, const hw::TimingConfig& c, const hw::FixedFormat& f) {
  const double q = double(std::max<uint64_t>(1, probes));
  j["cycles"] = cycles;
  j[per_key] = double(cycles) / q;
  j[rate_key] = q / double(std::max<uint64_t>(1, cycles));
  j["shader_calls"] = t.any_hit_requests;
  j["dram_bytes"] = t.dram_bytes;
  hw::TimingStats whole = t;
  whole.cycles = cycles;
  j["timing"] = timing_stats_json(whole, c, f);
}

void write_answers_csv(const std::string& path, const QueryJobOptions& o, const QueryJobResult& r) {
  std::ofstream out = open_output(path);
  if (o.what.kind == hw::PointQuery::kCount) {
    out << "query,count\n";
    for (size_t i = 0; i < r.answers.size(); ++i) out << i << ',' << r.answers[i].count << '\n';
  } else {
    out << "query,id\n";
    for (size_t i = 0; i < r.answers.size(); ++i)
      for (uint32_t id : r.answers[i].ids) out << i << ',' << id << '\n';
  }
  finish_output(out, path);
}

}  // namespace rtu::host
