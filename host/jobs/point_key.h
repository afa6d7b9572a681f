// A sweep point named by what it computes, and the files that carry points between machines
// (docs/guide/cluster.md):
//
// - point_key(): 32 hex digits of a 128-bit hash over the scene's content (scene_digest: every primitive,
// material,
//   texture, light, the camera and the instances, as loaded: a file's bytes and the meshes it references as they
//   come out of the loader; a built-in's generated scene), the canonical format (every field of the format the
//   spec names), the BVH width, the whole timing configuration (every key, not the preset's name), the run
//   parameters (rays, seed, image width, flatten) and the results revision of this rtu (kResultsRevision). The
//   same point made on any machine has the same key; a changed mesh, format field or timing key gives a new one.
// - A manifest: a text file, one point per line (key, scene, format, width, configuration, tab-separated) after a
//   header line naming the run parameters. The same key listed twice is one point.
// - A point file: RESULTS/KEY.json, the point's sweep row and its provenance (rtu version, host, threads, wall
//   time). Written to a temporary name in the same folder and renamed when complete, so a reader never sees a
//   partial one and concurrent writers of one point leave one whole file.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "host/jobs/sweep.h"
#include "host/scene/scene.h"

namespace rtu::host {

// Bump with any change of the model that changes a sweep row's results (the digest, scripts/digest.sh, changes):
// points made before it get other keys and run again.
inline constexpr int kResultsRevision = 1;
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

// The key of point p of a sweep with options o, for a scene of digest `scene`.
std::string point_key(const std::string& scene, const SweepPoint& p, const SweepOptions& o);

struct ManifestPoint {
  std::string key;
  SweepPoint point;
};
struct Manifest {
  std::string params;  // sweep_run_params of the options it was written for
  std::vector<ManifestPoint> points;
};
// The manifest's text; parse_manifest reads it back (Error naming the line for anything malformed).
std::string manifest_text(const Manifest& m);
Manifest parse_manifest(const std::string& text, const std::string& name);
// The run parameters' options back from their text (sweep_run_params).
SweepOptions options_from_params(const std::string& params);

struct PointProvenance {
  std::string version, host;
  int threads = 0;
  double seconds = 0.0;
};
// Writes DIR/KEY.json atomically (a temporary file, then a rename); Error when it cannot.
void write_point_file(const std::string& dir, const std::string& key, const SweepRow& row,
                      const PointProvenance& prov);
// Reads DIR/KEY.json: false when absent; Error for a malformed one.
bool read_point_file(const std::string& dir, const std::string& key, SweepRow& row, PointProvenance& prov);

}  // namespace rtu::host
