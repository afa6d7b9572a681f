// A sweep point named by what it computes, and the files that carry points between machines
// (docs/guide/cluster.md):
//
// - point_key(): 32 hex digits of a 128-bit hash over the scene's content (scene_digest: every primitive,
//   material, texture, light, the camera and the instances, as loaded: a file's bytes and the meshes it
//   references as they come out of the loader; a built-in's generated scene), the canonical format (every field
//   of the format the spec names), the BVH width, the whole timing configuration (every key, not the preset's
//   name), the run parameters (rays, seed, image width, flatten), the RTL area table's content (area_digest) and
//   the model that computes the row: this build's model identity (model_identity.h, a digest of the model's
//   sources and toolchain) and the results revision (kResultsRevision). The same point made by the same build on
//   any machine has the same key; a changed mesh, format field, timing key, area table or model gives a new one.
// - A manifest: a text file, one point per line (key, scene, format, width, configuration, tab-separated) after
//   header lines naming the run parameters, the model identity and the area table it was written for. A key
//   listed twice is refused.
// - A point file: RESULTS/KEY.json, the point's sweep row and its provenance (rtu version, model identity, area
//   table, host, threads, wall time). Written to a temporary name in the same folder and renamed when complete,
//   so a reader never sees a partial one and concurrent writers of one point leave one whole file.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "host/cost/area_tables.h"
#include "host/jobs/sweep.h"
#include "host/scene/scene.h"

namespace rtu::host {

// Raised with any change of the model that changes a sweep row's results (the digest, scripts/digest.sh, changes):
// points made before it get other keys and run again. The model identity (model_identity.h) already tells any two
// builds of other sources apart; the revision says so in words, and survives a build that hashes the same.
inline constexpr int kResultsRevision = 2;
inline constexpr const char* kRtuVersion = "0.1.0";

// A 128-bit content hash (two 64-bit lanes of different mixing), as 32 hex digits.
class ContentHash {
 public:
  void bytes(const void* p, size_t n);
  void text(const std::string& s);  // its length, then its bytes
  void u64(uint64_t v);
  void f32(float v);  // its bits
  std::string hex() const;

 private:
  uint64_t m_a = 0xcbf29ce484222325ull, m_b = 0x9E3779B97F4A7C15ull;
};

// The scene's content as loaded (not its name or path).
std::string scene_digest(const Scene& scene);

// The RTL area table's content (every entry it holds), as 32 hex digits: it sets a row's rtl_cells, area_mm2 and
// pj_per_ray.
std::string area_digest(const AreaTable& area);

// The key of point p of a sweep with options o, for a scene of digest `scene` and an area table of digest `area`,
// made by this build (model_identity()).
std::string point_key(const std::string& scene, const SweepPoint& p, const SweepOptions& o,
                      const std::string& area);

struct ManifestPoint {
  std::string key;
  SweepPoint point;
};
struct Manifest {
  std::string params;  // sweep_run_params of the options it was written for
  std::string model;   // the model identity of the build that wrote it (its keys hold it)
  std::string area;    // area_digest of the area table its points are priced with
  std::vector<ManifestPoint> points;
};
// The manifest's text; parse_manifest reads it back (Error naming the line for anything malformed, a key listed
// twice, or a manifest of the format before the model identity).
std::string manifest_text(const Manifest& m);
Manifest parse_manifest(const std::string& text, const std::string& name);
// The run parameters' options back from their text (sweep_run_params).
SweepOptions options_from_params(const std::string& params);

struct PointProvenance {
  std::string version, model, area, host;  // rtu's version, model_identity(), area_digest of the table
  int threads = 0;
  double seconds = 0.0;
};
// Writes DIR/KEY.json atomically (a temporary file, then a rename); Error when it cannot.
void write_point_file(const std::string& dir, const std::string& key, const SweepRow& row,
                      const PointProvenance& prov);
// Reads DIR/KEY.json: false when absent; Error for a malformed one.
bool read_point_file(const std::string& dir, const std::string& key, SweepRow& row, PointProvenance& prov);

}  // namespace rtu::host
