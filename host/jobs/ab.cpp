#include "host/jobs/ab.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "host/io/error.h"

namespace rtu::host {

namespace {

double num(const Json& j, const char* key) {
  const auto it = j.find(key);
  return it != j.end() && it->is_number() ? it->get<double>() : 0.0;
}

Json side_json(const AbSide& s) {
  if (s.stats == nullptr || !s.stats->contains("timing") || !(*s.stats)["timing"].is_object())
    throw Error("A/B: " + s.label + " has no timing (an A/B compares two runs of the timed device)");
  const Json& st = *s.stats;
  const Json& t = st["timing"];
  const Json& e = t["energy"];
  const Json& b = t["lower_bound"];
  Json j;
  j["label"] = s.label;
  j["config"] = t["config"].value("preset", std::string());
  j["format"] = st["format"].value("name", std::string());
  j["rays"] = num(t, "rays");
  j["cycles"] = num(t, "cycles");
  j["rays_per_clock"] = num(t, "rays_per_clock");
  j["limited_by"] = b.value("limited_by", std::string());
  j["cycles_over_bound"] = num(b, "cycles_over_bound");
  j["area_mm2"] = num(e["area"], "total_mm2");
  j["pj_per_ray"] = num(e, "pj_per_ray");
  j["unit_pj_per_ray"] = num(e, "unit_pj_per_ray");
  const double area = j["area_mm2"].get<double>();
  j["rays_per_clock_per_mm2"] = area > 0 ? j["rays_per_clock"].get<double>() / area : 0.0;
  // With a packet sampled the cycles are an estimate (timing.sample.packets_sampled > 0).
  j["estimated"] = t.contains("sample") && num(t["sample"], "packets_sampled") > 0;
  return j;
}

double ratio(double a, double b) {
  return b > 0 ? a / b : 0.0;
}

// "+12%", "-3%", "same" for a ratio B/A.
std::string change(double r) {
  if (r <= 0) return "n/a";
  const double pct = (r - 1.0) * 100.0;
  if (std::fabs(pct) < 0.05) return "same";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%+.1f%%", pct);
  return buf;
}

}  // namespace

Json ab_json(const AbSide& a, const AbSide& b) {
  // The sides are locals: an ordered_json's members live in a vector, which an insertion may move.
  const Json ja = side_json(a), jb = side_json(b);
  Json j;
  j["a"] = ja;
  j["b"] = jb;
  if (ja["rays"].get<double>() != jb["rays"].get<double>())
    throw Error("A/B: the two runs timed different numbers of rays (" + std::to_string(ja["rays"].get<double>()) +
                " and " + std::to_string(jb["rays"].get<double>()) + ")");
  const double speedup = ratio(ja["cycles"].get<double>(), jb["cycles"].get<double>());
  j["speedup"] = speedup;
  j["area_ratio"] = ratio(jb["area_mm2"].get<double>(), ja["area_mm2"].get<double>());
  j["energy_ratio"] = ratio(jb["pj_per_ray"].get<double>(), ja["pj_per_ray"].get<double>());
  j["unit_energy_ratio"] = ratio(jb["unit_pj_per_ray"].get<double>(), ja["unit_pj_per_ray"].get<double>());
  j["perf_per_area_ratio"] =
      ratio(jb["rays_per_clock_per_mm2"].get<double>(), ja["rays_per_clock_per_mm2"].get<double>());
  // Timing never changes a hit, so two configurations of one format agree on every ray; another format (bits,
  // node kind) may move hits, and how many is part of the answer.
  const bool compare_hits = !a.hits.empty() && !b.hits.empty() && a.hits.size() == b.hits.size();
  size_t differ = 0, t_differ = 0;
  if (compare_hits)
    for (size_t i = 0; i < a.hits.size(); ++i) {
      const bool prim = a.hits[i].prim != b.hits[i].prim;
      differ += prim;
      t_differ += !prim && a.hits[i].hit() && std::memcmp(&a.hits[i].t, &b.hits[i].t, sizeof(float)) != 0;
    }
  j["hits_compared"] = compare_hits ? a.hits.size() : 0;
  j["hits_differ"] = differ;  // hit against miss, or another primitive
  j["t_differ"] = t_differ;   // the same primitive at another t
  const bool estimated = ja["estimated"].get<bool>() || jb["estimated"].get<bool>();
  j["estimated"] = estimated;

  char verdict[400];
  std::snprintf(verdict, sizeof verdict,
                "B is %.3fx %s%s, area %s, energy per ray %s (unit %s), performance per mm^2 %s; A limited by %s, "
                "B by %s",
                speedup >= 1 ? speedup : (speedup > 0 ? 1.0 / speedup : 0.0), speedup >= 1 ? "faster" : "slower",
                estimated ? " (estimated from the sample)" : "", change(j["area_ratio"]).c_str(),
                change(j["energy_ratio"]).c_str(), change(j["unit_energy_ratio"]).c_str(),
                change(j["perf_per_area_ratio"]).c_str(), ja["limited_by"].get<std::string>().c_str(),
                jb["limited_by"].get<std::string>().c_str());
  j["verdict"] = verdict;
  return j;
}

std::vector<std::string> ab_lines(const Json& ab) {
  std::vector<std::string> out;
  char line[512];
  const int width =
      int(std::max(ab["a"]["label"].get<std::string>().size(), ab["b"]["label"].get<std::string>().size()));
  const auto row = [&](const char* name, const Json& s) {
    std::snprintf(line, sizeof line,
                  "  %s %-*s %s%12.0f cycles %7.3f rays/clk  %-8s %5.2fx bound  %7.3f mm^2  %7.0f pJ/ray "
                  "(%5.0f unit)  %.4f rays/clk/mm^2",
                  name, width, s["label"].get<std::string>().c_str(), s["estimated"].get<bool>() ? "~" : " ",
                  s["cycles"].get<double>(), s["rays_per_clock"].get<double>(),
                  s["limited_by"].get<std::string>().c_str(), s["cycles_over_bound"].get<double>(),
                  s["area_mm2"].get<double>(), s["pj_per_ray"].get<double>(), s["unit_pj_per_ray"].get<double>(),
                  s["rays_per_clock_per_mm2"].get<double>());
    out.push_back(line);
  };
  out.push_back("A/B (B against A, the same rays):");
  row("A", ab["a"]);
  row("B", ab["b"]);
  out.push_back("  " + ab["verdict"].get<std::string>());
  const size_t compared = ab["hits_compared"].get<size_t>(), differ = ab["hits_differ"].get<size_t>();
  if (compared > 0) {
    std::snprintf(line, sizeof line,
                  "  hits: %zu of %zu rays hit another primitive or miss, %zu more the same "
                  "primitive at another t%s",
                  differ, compared, ab["t_differ"].get<size_t>(),
                  differ + ab["t_differ"].get<size_t>() == 0 ? "" : " (the two formats round differently)");
    out.push_back(line);
  } else {
    out.push_back("  hits: not compared (cycles only: --sample without --out)");
  }
  return out;
}

DeviceSettings against_settings(const DeviceSettings& a, const AgainstSpec& spec) {
  DeviceSettings b = a;
  if (!spec.config.empty()) {
    b.config = spec.config;
    b.sets.clear();  // A's overrides were for A's preset
  }
  if (!spec.format.empty()) {
    b.format = spec.format;
    std::erase_if(b.sets, [](const std::string& s) { return s.rfind("format=", 0) == 0; });
  }
  for (const std::string& s : spec.sets) {
    // B's own key wins over A's spelling of it by option (--format, --bvh-width).
    if (s.rfind("format=", 0) == 0) b.format.clear();
    if (s.rfind("bvh_width=", 0) == 0) b.bvh_width = 0;
    b.sets.push_back(s);
  }
  return b;
}

std::string settings_label(const DeviceSettings& s) {
  std::string label = s.config;
  for (size_t i = 0; i < s.sets.size(); ++i) label += (i == 0 ? " + " : ", ") + s.sets[i];
  if (!s.format.empty()) label += ", format " + s.format;
  if (s.bvh_width > 0) label += ", width " + std::to_string(s.bvh_width);
  for (const auto& [key, value] : s.format_fields) label += ", " + key + "=" + std::to_string(value);
  return label;
}

}  // namespace rtu::host
