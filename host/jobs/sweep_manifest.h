// A sweep as a manifest of content-keyed points (host/jobs/point_key.h) run into a folder of point files and
// collected back into a sweep CSV: the steps `rtusim sweep --write-manifest / --manifest / --collect` and the
// Python module's rtu.sweep_on(results=...) share, so that a sweep run by any engine (one process, shards in any
// order, a Slurm array, a Dask cluster) collects to the same table (docs/guide/cluster.md).
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "host/cost/area_tables.h"
#include "host/jobs/point_key.h"
#include "host/jobs/sweep.h"

namespace rtu::host {

// The grid's points in its order (scene x width x format x configuration; check_sweep_grid first).
std::vector<SweepPoint> sweep_grid_points(const SweepGrid& g);

// The manifest of `points` made with `o` and priced with `area`, by this build: each point's key from its scene's
// content (each scene loaded once); a point whose key an earlier one has (the same computation spelled otherwise)
// is listed once and counted in `repeated`.
Manifest make_manifest(const std::vector<SweepPoint>& points, const SweepOptions& o, const AreaTable& area,
                       size_t* repeated = nullptr);

// Reads a manifest file and checks its formats, configurations, widths and ray count as a grid's.
Manifest read_manifest(const std::string& path);

struct ManifestRun {
  size_t mine = 0, ran = 0, done = 0;  // this shard's points; of them run now and found complete in the folder
};
// Runs shard `shard` of `shards` (1-based: points shard-1, shard-1+shards, ...) of the manifest into `results`
// (created), one point file per point; a point whose file is there is skipped. Error, before any point runs, when
// the manifest was written by another build (its model identity, naming both) or for another area table than
// `area`. Each point's key is made again from the scene as this machine loads it: Error when it differs from the
// manifest's (the scene or a mesh changed). `ran(point, row)` sees each point run.
ManifestRun run_manifest(const Manifest& m, const std::string& results, size_t shard, size_t shards, int threads,
                         const AreaTable& area,
                         const std::function<void(const ManifestPoint&, const SweepRow&)>& ran = {});

struct CollectedSweep {
  std::vector<SweepRow> rows;  // in the manifest's order
  std::string provenance_csv;  // key,version,host,threads,seconds: one line per point
  double seconds = 0.0;        // the points' wall time summed
};
// The manifest's points from the folder's point files; Error naming the missing points (and how to resume), or a
// file holding another point or run parameters, made by another build than the manifest's (naming both model
// identities) or with another area table, or with a figure out of its range (read_sweep_csv).
CollectedSweep collect_manifest(const Manifest& m, const std::string& results);

}  // namespace rtu::host
