#include "host/jobs/sweep_manifest.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <set>

#include "host/io/error.h"
#include "host/io/limits.h"
#include "host/jobs/model_identity.h"

namespace rtu::host {

std::vector<SweepPoint> sweep_grid_points(const SweepGrid& g) {
  std::vector<SweepPoint> points;
  for (const std::string& spec : g.scenes)
    for (int w : g.widths)
      for (const std::string& f : g.formats)
        for (const std::string& c : g.configs) points.push_back({spec, f, w, c});
  return points;
}

Manifest make_manifest(const std::vector<SweepPoint>& points, const SweepOptions& o, const AreaTable& area,
                       size_t* repeated) {
  check_sweep_rays("sweep", o.rays);
  Manifest m;
  m.params = sweep_run_params(o);
  m.model = model_identity();
  m.area = area_digest(area);
  std::set<std::string> seen;
  std::map<std::string, std::string> digests;  // scene spec: its content's digest
  size_t again = 0;
  for (const SweepPoint& p : points) {
    auto it = digests.find(p.scene);
    if (it == digests.end()) it = digests.emplace(p.scene, scene_digest(load_scene(p.scene))).first;
    const std::string key = point_key(it->second, p, o, m.area);
    if (!seen.insert(key).second) {
      ++again;
      continue;
    }
    m.points.push_back({key, p});
  }
  if (repeated) *repeated = again;
  return m;
}

Manifest read_manifest(const std::string& path) {
  // The text, its copy split into lines and the points parsed from it: four times the file at most.
  const Manifest m = parse_manifest(read_file_limited(path, 4), path);
  SweepGrid check{{}, {}, {}, {}};  // the manifest's formats, configurations and widths, checked as a grid's
  for (const ManifestPoint& p : m.points) {
    check.formats.push_back(p.point.format);
    check.configs.push_back(p.point.config);
    check.widths.push_back(p.point.bvh_width);
  }
  check_sweep_grid(check);
  check_sweep_rays("sweep", options_from_params(m.params).rays);
  return m;
}

ManifestRun run_manifest(const Manifest& m, const std::string& results, size_t shard, size_t shards, int threads,
                         const AreaTable& area,
                         const std::function<void(const ManifestPoint&, const SweepRow&)>& ran) {
  if (shard < 1 || shard > shards)
    throw Error("shard " + std::to_string(shard) + "/" + std::to_string(shards) + ": expected 1 <= k <= N");
  if (m.model != model_identity())
    throw Error("the manifest was written by the rtu build of model " + m.model + "; this is build " +
                model_identity() +
                ": points of two builds do not mix in one table. Run it with that build, or write the manifest "
                "again with this one (into a new results folder)");
  if (m.area != area_digest(area))
    throw Error("the manifest's points are priced with the area table of digest " + m.area + ", not this run's (" +
                area_digest(area) +
                "): give the run the --area the manifest was written with (none: the shipped table)");
  SweepOptions o = options_from_params(m.params);
  o.threads = threads;
  std::filesystem::create_directories(results);
  char host[256] = "unknown";
  gethostname(host, sizeof host - 1);
  std::string loaded;  // the scene spec held in `scene`
  std::unique_ptr<Scene> scene;
  std::string digest;
  auto cache = make_sweep_cache();
  ManifestRun run;
  for (size_t i = shard - 1; i < m.points.size(); i += shards) {
    ++run.mine;
    const ManifestPoint& mp = m.points[i];
    if (std::filesystem::exists(std::filesystem::path(results) / (mp.key + ".json"))) {
      ++run.done;  // complete: a point file appears only whole
      continue;
    }
    if (!scene || loaded != mp.point.scene) {
      scene = std::make_unique<Scene>(load_scene(mp.point.scene));
      digest = scene_digest(*scene);
      loaded = mp.point.scene;
      cache = make_sweep_cache();
    }
    const std::string key = point_key(digest, mp.point, o, m.area);
    if (key != mp.key)
      throw Error("point " + mp.key + " (" + mp.point.key() + "): this rtu and these files make it point " + key +
                  ": the scene or a mesh it references changed since the manifest was written; write the "
                  "manifest again");
    const SweepRow r = run_sweep_point(*scene, mp.point, o, area, *cache);
    write_point_file(results, mp.key, r,
                     PointProvenance{kRtuVersion, model_identity(), m.area, host, o.threads, r.seconds});
    ++run.ran;
    if (ran) ran(mp, r);
  }
  return run;
}

CollectedSweep collect_manifest(const Manifest& m, const std::string& results) {
  CollectedSweep c;
  c.provenance_csv = "key,version,model,host,threads,seconds\n";  // the manifest names each key's point
  std::vector<std::string> missing;
  for (const ManifestPoint& mp : m.points) {
    SweepRow r;
    PointProvenance prov;
    if (!read_point_file(results, mp.key, r, prov)) {
      missing.push_back(mp.key);
      continue;
    }
    const std::string file = results + "/" + mp.key + ".json";
    // Rows of two builds (or two area tables) differ for one point: never one table.
    if (prov.model != m.model)
      throw Error("sweep --collect: " + file + " was made by the rtu build of model " + prov.model +
                  ", the manifest by build " + m.model +
                  ": points of two builds do not mix in one table; run the manifest with one build into a new "
                  "results folder");
    if (prov.area != m.area)
      throw Error("sweep --collect: " + file + " was priced with the area table of digest " + prov.area +
                  ", the manifest's points with " + m.area + ": run the manifest again into a new results folder");
    if (r.p.key() != mp.point.key() || sweep_run_params(r) != m.params)
      throw Error(file + ": holds point " + r.p.key() + " made with " + sweep_run_params(r) +
                  ", not the manifest's " + mp.point.key() + " with " + m.params);
    c.rows.push_back(r);
    c.seconds += prov.seconds;
    c.provenance_csv += mp.key + "," + prov.version + "," + prov.model + "," + prov.host + "," +
                        std::to_string(prov.threads) + "," + std::to_string(prov.seconds) + "\n";
  }
  if (!missing.empty()) {
    std::string some;
    for (size_t i = 0; i < missing.size() && i < 5; ++i) some += (i ? ", " : "") + missing[i];
    throw Error("sweep --collect: " + std::to_string(missing.size()) + " of " + std::to_string(m.points.size()) +
                " points have no file in " + results + " (" + some + (missing.size() > 5 ? ", ..." : "") +
                "); run the manifest again: only the missing points run");
  }
  return c;
}

}  // namespace rtu::host
