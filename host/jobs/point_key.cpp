#include "host/jobs/point_key.h"

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "host/io/error.h"
#include "host/io/files.h"
#include "host/io/json_io.h"
#include "host/io/limits.h"
#include "host/io/stats_json.h"
#include "host/jobs/model_identity.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host {

namespace {

uint64_t mix(uint64_t z) {  // SplitMix64's finalizer
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

void hash_geometry(ContentHash& h, const hw::Geometry& g) {
  auto vec = [&](const Vec3& v) {
    for (int a = 0; a < 3; ++a) h.f32(v[a]);
  };
  h.u64(g.triangles.size());
  for (const hw::Triangle& t : g.triangles) {
    vec(t.v0);
    vec(t.v1);
    vec(t.v2);
  }
  h.u64(g.spheres.size());
  for (const hw::Sphere& s : g.spheres) {
    vec(s.center);
    h.f32(s.radius);
  }
  h.u64(g.planes.size());
  for (const hw::Plane& p : g.planes) {
    vec(p.normal);
    h.f32(p.offset);
  }
  h.u64(g.non_opaque.size());
  h.bytes(g.non_opaque.data(), g.non_opaque.size());
  if (!g.curves.empty()) {  // hashed only when present: keys of scenes without curves stay as they were
    h.u64(g.curves.size());
    for (const hw::CurveSegment& c : g.curves) {
      vec(c.p0);
      h.f32(c.r0);
      vec(c.p1);
      h.f32(c.r1);
      h.u64(c.flags);
    }
  }
}

}  // namespace

void ContentHash::bytes(const void* p, size_t n) {
  const auto* c = static_cast<const unsigned char*>(p);
  for (size_t i = 0; i < n; ++i) {
    m_a = (m_a ^ c[i]) * 0x100000001b3ull;  // FNV-1a
    m_b = mix(m_b + c[i] + 0x9E3779B97F4A7C15ull);
  }
}

void ContentHash::text(const std::string& s) {
  u64(s.size());
  bytes(s.data(), s.size());
}

void ContentHash::u64(uint64_t v) {
  unsigned char b[8];
  for (int i = 0; i < 8; ++i) b[i] = static_cast<unsigned char>(v >> (8 * i));  // the same on any host
  bytes(b, 8);
}

void ContentHash::f32(float v) {
  uint32_t u;
  std::memcpy(&u, &v, sizeof u);
  u64(u);
}

std::string ContentHash::hex() const {
  char buf[33];
  std::snprintf(buf, sizeof buf, "%016llx%016llx", (unsigned long long)mix(m_a), (unsigned long long)m_b);
  return buf;
}

std::string scene_digest(const Scene& s) {
  ContentHash h;
  h.text("rtu scene");
  hash_geometry(h, s.geometry);
  h.u64(s.materials.size());
  for (const Material& m : s.materials) {
    h.text(m.name);
    h.u64(uint64_t(m.type));
    for (int a = 0; a < 3; ++a) h.f32(m.color[a]);
    h.f32(m.ior);
    for (int a = 0; a < 3; ++a) h.f32(m.emission[a]);
    h.u64(uint64_t(int64_t(m.texture)));
    h.u64(uint64_t(m.alpha_mode));
    h.f32(m.alpha);
    h.f32(m.alpha_cutoff);
  }
  h.u64(s.prim_material.size());
  for (uint32_t m : s.prim_material) h.u64(m);
  h.u64(s.textures.size());
  for (const Texture& t : s.textures) {
    h.u64(t.width);
    h.u64(t.height);
    h.u64(t.rgba.size());
    h.bytes(t.rgba.data(), t.rgba.size());
  }
  h.u64(s.triangle_uv.size());
  for (const TriangleUv& uv : s.triangle_uv)
    for (int i = 0; i < 3; ++i) {
      h.f32(uv.s[i]);
      h.f32(uv.t[i]);
    }
  h.u64(s.lights.size());
  for (const Light& l : s.lights) {
    h.u64(uint64_t(l.type));
    for (const Vec3* v : {&l.position, &l.edge_u, &l.edge_v, &l.intensity})
      for (int a = 0; a < 3; ++a) h.f32((*v)[a]);
    h.u64(l.first_prim);
  }
  for (const Vec3* v : {&s.camera.position, &s.camera.look_at, &s.camera.up})
    for (int a = 0; a < 3; ++a) h.f32((*v)[a]);
  h.f32(s.camera.fov_y_deg);
  h.u64(uint64_t(int64_t(s.camera.width)));
  h.u64(uint64_t(int64_t(s.camera.height)));
  h.u64(s.has_camera);
  h.u64(s.instances.meshes.size());
  for (const hw::Geometry& g : s.instances.meshes) hash_geometry(h, g);
  h.u64(s.instances.instances.size());
  for (const hw::Instance& in : s.instances.instances) {
    h.u64(in.mesh);
    for (const auto& row : in.to_world.m)
      for (float x : row) h.f32(x);
  }
  return h.hex();
}

std::string area_digest(const AreaTable& area) {
  ContentHash h;
  h.text("rtu area table");
  h.u64(area.by_params.size());
  for (const auto& [params, e] : area.by_params) {  // a map: in the order of its parameters, however written
    h.text(params);
    h.u64(uint64_t(e.cells));
    h.u64(uint64_t(e.transistors));
  }
  return h.hex();
}

std::string point_key(const std::string& scene, const SweepPoint& p, const SweepOptions& o,
                      const std::string& area) {
  ContentHash h;
  h.text(std::string("rtu sweep point ") + kRtuVersion + " results " + std::to_string(kResultsRevision) +
         " model " + model_identity());
  h.text(area);
  h.text(scene);
  h.text(format_json(hw::format_from_spec(p.format)).dump());
  h.u64(uint64_t(p.bvh_width));
  for (const hw::TimingKey& k : hw::timing_keys(sweep_config(p.config))) h.text(k.key + "=" + k.value);
  h.text(sweep_run_params(o));
  return h.hex();
}

namespace {

constexpr const char* kManifestHeader = "# rtu sweep manifest 2";
// The format before the model identity and the area table: its keys name neither.
constexpr const char* kManifestHeaderBefore = "# rtu sweep manifest 1";

std::vector<std::string> split_tabs(const std::string& line) {
  std::vector<std::string> f;
  size_t start = 0;
  for (;;) {
    const size_t tab = line.find('\t', start);
    f.push_back(line.substr(start, tab == std::string::npos ? std::string::npos : tab - start));
    if (tab == std::string::npos) return f;
    start = tab + 1;
  }
}

bool is_key(const std::string& k) {
  if (k.size() != 32) return false;
  for (char c : k)
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  return true;
}

}  // namespace

std::string manifest_text(const Manifest& m) {
  std::string s = std::string(kManifestHeader) + "\n# params\t" + m.params + "\n# model\t" + m.model +
                  "\n# area\t" + m.area + "\n";
  for (const ManifestPoint& p : m.points) {
    for (const std::string* f : {&p.point.scene, &p.point.format, &p.point.config})
      if (f->find_first_of("\t\n\r") != std::string::npos)
        throw Error("manifest: '" + *f + "' holds a tab or a line break");
    s += p.key + '\t' + p.point.scene + '\t' + p.point.format + '\t' + std::to_string(p.point.bvh_width) + '\t' +
         p.point.config + '\n';
  }
  return s;
}

Manifest parse_manifest(const std::string& text, const std::string& name) {
  Manifest m;
  std::istringstream in(text);
  std::string line;
  size_t n = 0;
  std::map<std::string, std::pair<size_t, size_t>> listed;  // key: the line that lists it, its point
  // A header line "# NAME<TAB>VALUE", NAME the n-th expected.
  auto header = [&](const std::string& where, const char* field, const char* what) {
    const std::vector<std::string> f = split_tabs(line);
    if (f.size() != 2 || f[0] != std::string("# ") + field)
      throw Error(where + ": expected '# " + field + "<TAB>" + what + "'");
    return f[1];
  };
  while (std::getline(in, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string where = name + ":" + std::to_string(n);
    if (n == 1) {
      if (line == kManifestHeaderBefore)
        throw Error(where +
                    ": a manifest of an earlier rtu (its keys name no model identity or area table); "
                    "write the manifest again, into a new results folder");
      if (line != kManifestHeader)
        throw Error(where + ": not a sweep manifest (expected the line '" + kManifestHeader + "')");
      continue;
    }
    if (n == 2) {
      m.params = header(where, "params", "--rays N ...");
      options_from_params(m.params);  // checks it
      continue;
    }
    if (n == 3 || n == 4) {
      std::string& v = n == 3 ? m.model : m.area;
      v = header(where, n == 3 ? "model" : "area", n == 3 ? "the model identity" : "the area table's digest");
      if (v.empty() || v.find_first_not_of("0123456789abcdef") != std::string::npos)
        throw Error(where + ": '" + v + "' is not a digest (lowercase hex digits)");
      continue;
    }
    if (line.empty()) continue;
    const std::vector<std::string> f = split_tabs(line);
    if (f.size() != 5) throw Error(where + ": " + std::to_string(f.size()) + " fields, expected 5");
    if (!is_key(f[0])) throw Error(where + ": '" + f[0] + "' is not a point key (32 hex digits)");
    ManifestPoint p;
    p.key = f[0];
    p.point.scene = f[1];
    p.point.format = f[2];
    try {
      size_t used = 0;
      p.point.bvh_width = std::stoi(f[3], &used);
      if (used != f[3].size()) throw std::invalid_argument("trailing text");
    } catch (const std::exception&) {
      throw Error(where + ": BVH width '" + f[3] + "' is not an integer");
    }
    p.point.config = f[4];
    // One key, one row: a key listed again would collect into one row where the lines promise two.
    const auto [first, fresh] = listed.emplace(p.key, std::make_pair(n, m.points.size()));
    if (!fresh)
      throw Error(where + ": point " + p.key + " (" + p.point.key() + ") is listed already on line " +
                  std::to_string(first->second.first) + " (" + m.points[first->second.second].point.key() +
                  "); a manifest lists each point once (--write-manifest does)");
    m.points.push_back(p);
  }
  if (n < 4) throw Error(name + ": not a sweep manifest (its header is cut short)");
  return m;
}

SweepOptions options_from_params(const std::string& params) {
  SweepOptions o;
  std::istringstream in(params);
  std::string word;
  bool rays = false, seed = false, width = false;
  auto number = [&](const std::string& opt) {
    std::string v;
    if (!(in >> v)) throw Error("run parameters '" + params + "': " + opt + " without a value");
    try {
      size_t used = 0;
      const unsigned long long x = std::stoull(v, &used);
      if (used != v.size()) throw std::invalid_argument("trailing");
      return uint64_t(x);
    } catch (const std::exception&) {
      throw Error("run parameters '" + params + "': " + opt + " " + v + " is not a number");
    }
  };
  while (in >> word) {
    if (word == "--rays") {
      o.rays = number(word);
      rays = true;
    } else if (word == "--seed") {
      o.seed = number(word);
      seed = true;
    } else if (word == "--image-width") {
      const uint64_t w = number(word);
      if (w > 4096) throw Error("run parameters '" + params + "': --image-width above 4096");
      o.image_width = int(w);
      width = true;
    } else if (word == "--flatten") {
      o.flatten = true;
    } else {
      throw Error("run parameters '" + params + "': unknown '" + word + "'");
    }
  }
  if (!rays || !seed || !width)
    throw Error("run parameters '" + params + "': need --rays, --seed and --image-width");
  if (o.rays < 1 || o.rays > (uint64_t(1) << 26))
    throw Error("run parameters '" + params + "': --rays out of range");
  return o;
}

void write_point_file(const std::string& dir, const std::string& key, const SweepRow& row,
                      const PointProvenance& prov) {
  nlohmann::ordered_json j;
  j["key"] = key;
  j["header"] = sweep_csv_header();
  j["row"] = sweep_csv_line(row);
  j["version"] = prov.version;
  j["model"] = prov.model;
  j["area"] = prov.area;
  j["host"] = prov.host;
  j["threads"] = prov.threads;
  j["seconds"] = prov.seconds;
  const std::filesystem::path final_path = std::filesystem::path(dir) / (key + ".json");
  // A name no other writer uses (host, process, a counter shared by its threads), in the same folder so the
  // rename is atomic.
  static std::atomic<unsigned> counter{0};
  const std::filesystem::path tmp =
      std::filesystem::path(dir) /
      (".tmp-" + key + "-" + prov.host + "-" + std::to_string(getpid()) + "-" + std::to_string(counter++));
  {
    std::ofstream out = open_output(tmp.string(), std::ios::binary | std::ios::trunc);
    out << j.dump(1) << '\n';
    finish_output(out, tmp.string());
  }
  std::error_code ec;
  std::filesystem::rename(tmp, final_path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw Error("cannot rename a point file into " + final_path.string());
  }
}

bool read_point_file(const std::string& dir, const std::string& key, SweepRow& row, PointProvenance& prov) {
  const std::filesystem::path path = std::filesystem::path(dir) / (key + ".json");
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return false;
  // The text and the JSON values parsed from it (a few times the text): a point file is a few hundred bytes.
  const std::string text = read_file_limited(path.string(), 8);
  std::string csv;
  try {
    const nlohmann::ordered_json j = parse_json_limited(text, path.string());
    if (j.at("key").get<std::string>() != key) throw Error("its key is " + j.at("key").get<std::string>());
    csv = j.at("header").get<std::string>() + "\n" + j.at("row").get<std::string>() + "\n";
    prov.version = j.at("version").get<std::string>();
    prov.model = j.at("model").get<std::string>();
    prov.area = j.at("area").get<std::string>();
    prov.host = j.at("host").get<std::string>();
    prov.threads = j.at("threads").get<int>();
    prov.seconds = j.at("seconds").get<double>();
  } catch (const Error& e) {
    throw Error(path.string() + ": not a point file of this version: " + e.what());
  } catch (const std::exception& e) {
    throw Error(path.string() + ": not a point file of this version: " + e.what());
  }
  // The row's own errors name the file and the field (a figure out of range, a malformed number).
  const std::vector<SweepRow> rows = parse_sweep_csv(csv, path.string());
  if (rows.size() != 1) throw Error(path.string() + ": no row");
  row = rows[0];
  return true;
}

}  // namespace rtu::host
