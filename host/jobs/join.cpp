#include "host/jobs/join.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "host/io/error.h"
#include "host/io/files.h"
#include "host/jobs/query.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/timing/query_timing.h"

namespace rtu::host {

namespace {

// The rows of a CSV file of `k` numbers a line (a first line that is not numbers is a header).
std::vector<std::vector<double>> read_rows(const std::string& path, int k, const char* shape) {
  check_input_file(path);
  std::ifstream in(path);
  std::vector<std::vector<double>> rows;
  std::string line;
  for (size_t n = 1; std::getline(in, line); ++n) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    std::vector<double> v;
    std::stringstream ss(line);
    std::string cell;
    bool ok = true;
    while (std::getline(ss, cell, ',')) {
      char* end = nullptr;
      const double x = std::strtod(cell.c_str(), &end);
      if (end == cell.c_str() || *end != '\0') ok = false;
      v.push_back(x);
    }
    if (!ok || int(v.size()) != k) {
      if (n == 1 && rows.empty()) continue;  // a header
      throw Error(path + ":" + std::to_string(n) + ": expected " + shape + ", got '" + line + "'");
    }
    for (double x : v)
      if (!(std::fabs(x) <= 0x1p62))
        throw Error(path + ":" + std::to_string(n) + ": a coordinate is not finite or beyond 2^62");
    rows.push_back(std::move(v));
  }
  if (rows.empty()) throw Error(path + ": no rows");
  return rows;
}

// "KIND:N" -> N when spec starts with kind, else 0.
uint64_t generator_count(const std::string& spec, const std::string& kind) {
  if (spec.rfind(kind + ":", 0) != 0) return 0;
  const std::string t = spec.substr(kind.size() + 1);
  size_t used = 0;
  uint64_t n = 0;
  try {
    n = std::stoull(t, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != t.size() || n == 0 || n > (uint64_t(1) << 24))
    throw Error("'" + spec + "': expected " + kind + ":N with N in 1..2^24");
  return n;
}

}  // namespace

std::vector<hw::Segment2> segments_from_spec(const std::string& spec, uint64_t seed) {
  if (const uint64_t n = generator_count(spec, "random")) {
    hw::Pcg32 rng(seed);
    std::vector<hw::Segment2> v(n);
    for (hw::Segment2& s : v) {
      s.a = hw::Point2{100.0f * rng.next_float(), 100.0f * rng.next_float()};
      s.b = hw::Point2{s.a.x + 2.0f * rng.next_float() - 1.0f, s.a.y + 2.0f * rng.next_float() - 1.0f};
    }
    return v;
  }
  std::vector<hw::Segment2> v;
  for (const auto& r : read_rows(spec, 4, "x0,y0,x1,y1"))
    v.push_back(hw::Segment2{{float(r[0]), float(r[1])}, {float(r[2]), float(r[3])}});
  return v;
}

std::vector<hw::Polygon2> polygons_from_spec(const std::string& spec, uint64_t seed) {
  if (const uint64_t n = generator_count(spec, "stars")) {
    hw::Pcg32 rng(seed);
    std::vector<hw::Polygon2> v(n);
    for (hw::Polygon2& p : v) {
      const float cx = 100.0f * rng.next_float(), cy = 100.0f * rng.next_float();
      const int k = 3 + int(rng.next_u32() % 10);
      for (int i = 0; i < k; ++i) {
        const double ang = 6.283185307179586 * (i + 0.8 * rng.next_float()) / k;
        const float r = 0.5f + 2.5f * rng.next_float();
        p.push_back(hw::Point2{cx + float(r * std::cos(ang)), cy + float(r * std::sin(ang))});
      }
    }
    return v;
  }
  std::vector<hw::Polygon2> v;
  double current = NAN;
  for (const auto& r : read_rows(spec, 3, "polygon,x,y")) {
    if (!(r[0] == current)) {
      v.emplace_back();
      current = r[0];
    }
    v.back().push_back(hw::Point2{float(r[1]), float(r[2])});
  }
  return v;
}

std::vector<hw::Point2> points2_from_spec(const std::string& spec, uint64_t seed) {
  if (const uint64_t n = generator_count(spec, "uniform")) {
    hw::Pcg32 rng(seed);
    std::vector<hw::Point2> v(n);
    for (hw::Point2& p : v) p = hw::Point2{100.0f * rng.next_float(), 100.0f * rng.next_float()};
    return v;
  }
  std::vector<hw::Point2> v;
  for (const auto& r : read_rows(spec, 2, "x,y")) v.push_back(hw::Point2{float(r[0]), float(r[1])});
  return v;
}

namespace {

// A probe's coordinates, named by its index (the probes' own checks cannot know it).
void check_probe(const hw::Point2& p, const char* what, size_t j) {
  if (!(std::fabs(p.x) <= 0x1p62f && std::fabs(p.y) <= 0x1p62f))
    throw Error(std::string(what) + " " + std::to_string(j) +
                " has a coordinate that is not finite or beyond 2^62");
}

// The probes of an index (a PolygonIndex or SegmentIndex) on the fixed unit over threads, or timed; each probe's
// answer into answers[j].
template <class Index, class Probe>
void run_index(const Index& index, const std::vector<Probe>& probes, const JoinJobOptions& o, JoinJobResult& r,
               std::vector<std::vector<uint32_t>>& answers) {
  answers.assign(probes.size(), {});
  r.index_bytes = hw::box_index_layout(index.index(), o.format).total_bytes;
  if (!o.timed) {
    hw::run_probes(probes.size(), o.threads, r.stats,
                   [&](size_t j, hw::QueryStats& s) { answers[j] = index.probe(probes[j], s); });
    return;
  }
  const hw::ProbeTiming t = hw::time_probes(
      index.index(), o.format, probes.size(),
      [&](size_t j, hw::QueryStats& s, std::vector<hw::TraceEvent>* rec) {
        answers[j] = index.probe(probes[j], s, rec);
      },
      o.timing);
  r.cycles = t.cycles;
  r.timing = t.timing;
  r.stats = t.queries;
}

}  // namespace

JoinJobResult run_join_job(const JoinJobOptions& o) {
  JoinJobResult r;
  std::vector<std::vector<uint32_t>> answers;
  hw::Aabb frame;  // the probes' extent, fitted beside the index's boxes
  if (o.polygons) {
    for (size_t j = 0; j < o.points.size(); ++j) {
      check_probe(o.points[j], "point", j);
      frame.extend(hw::Vec3(o.points[j].x, o.points[j].y, 0.0f));
    }
    run_index(hw::PolygonIndex(o.polys, o.format, frame), o.points, o, r, answers);
    for (size_t j = 0; j < answers.size(); ++j)
      for (uint32_t k : answers[j]) r.pairs.emplace_back(uint32_t(j), k);
    return r;
  }
  for (size_t j = 0; j < o.b.size(); ++j)
    for (const hw::Point2& p : {o.b[j].a, o.b[j].b}) {
      check_probe(p, "probe segment", j);
      frame.extend(hw::Vec3(p.x, p.y, 0.0f));
    }
  run_index(hw::SegmentIndex(o.a, o.format, frame), o.b, o, r, answers);
  for (size_t j = 0; j < answers.size(); ++j)
    for (uint32_t i : answers[j]) r.pairs.emplace_back(i, uint32_t(j));
  std::sort(r.pairs.begin(), r.pairs.end());
  return r;
}

Json join_json(const JoinJobOptions& o, const JoinJobResult& r) {
  Json j;
  j["join"] = o.polygons ? "point_in_polygon" : "segment_intersection";
  if (o.polygons) {
    j["polygons"] = o.polys.size();
    j["points"] = o.points.size();
  } else {
    j["segments"] = o.a.size();
    j["probes"] = o.b.size();
  }
  j["format"] = o.format.describe();
  j["pairs"] = r.pairs.size();
  j["candidates"] = r.stats.candidates;
  j["nodes_visited"] = r.stats.nodes_visited;
  j["box_tests"] = r.stats.box_tests;
  j["index_bytes"] = r.index_bytes;
  if (o.timed)
    probe_timing_json(j, "cycles_per_probe", "probes_per_clock", r.stats.queries, r.cycles, r.timing, o.timing,
                      o.format);
  return j;
}

void write_pairs_csv(const std::string& path, const JoinJobOptions& o, const JoinJobResult& r) {
  std::ofstream out = open_output(path);
  out << (o.polygons ? "point,polygon\n" : "a,b\n");
  for (const auto& [x, y] : r.pairs) out << x << ',' << y << '\n';
  finish_output(out, path);
}

}  // namespace rtu::host
