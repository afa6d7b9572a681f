#!/usr/bin/env bash
# The memory-bound presets beside the presets they take their datapath from: per mesh and ray kind, the cycles,
# what the lower bound is limited by, DRAM bytes per ray, DRAM utilization and cache hit rate on the timed device.
# rdna2-mem and intel-mem keep rdna2's and intel's datapath and give the unit one ray-tracing unit's share of a
# real GPU's memory (hwmodel/timing/timing_config.cpp), so a difference between a pair is the memory's alone.
#
#   bench/memory_bound.sh [RTUSIM] [RAYS] [MESH...]
#     RTUSIM  default build/default/rtusim;  RAYS  rays per kind, default 50000;  MESH  default two
#     assimp-testmodels meshes;  PRESETS (environment) default "rdna2 rdna2-mem intel intel-mem embedded"
# Each mesh is traced with `rtusim trace --device timed --threads 1`, one TRACE packet per run, on the same
# primary and incoherent ray files (`rtusim rays`) for every preset. Prints a Markdown table. Reads the stats JSON
# with python3.
set -euo pipefail
read -r -a presets <<<"${PRESETS:-rdna2 rdna2-mem intel intel-mem embedded}"
source "$(dirname "$0")/lib.sh"  # sets name to memory_bound.sh
bench_mesh_setup 50000 "$bench_house" "$bench_engine" -- "$@"
echo "| mesh | rays | preset | cycles | cycles/ray | limited by | cycles / bound | DRAM bytes/ray | DRAM utilization | cache hit rate |"
echo "|---|---|---|---:|---:|---|---:|---:|---:|---:|"
for mesh in "${meshes[@]}"; do
  bench_kind_rays "$mesh"
  for kind in primary incoherent; do
    for preset in "${presets[@]}"; do
      "$rtusim" trace --scene "$mesh" --rays "$tmp/$kind.bin" --out "$tmp/hits.bin" --device timed \
        --config "$preset" --threads 1 --stats "$tmp/stats.json" >/dev/null
      python3 - "$mesh" "$kind" "$preset" "$tmp/stats.json" <<'PY'
import json, os, sys
mesh, kind, preset, f = sys.argv[1:5]
t = json.load(open(f))["timing"]
lb = t["lower_bound"]
print(f"| {os.path.basename(mesh)} | {kind} | {preset} | {t['cycles']} | {t['cycles_per_ray']:.1f} | "
      f"{lb['limited_by']} | {lb['cycles_over_bound']:.2f} | {t['dram_bytes'] / t['rays']:.0f} | "
      f"{t['utilization']['dram']:.3f} | {t['cache']['hit_rate']:.3f} |")
PY
    done
  done
done
