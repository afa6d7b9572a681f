#!/usr/bin/env bash
# The DRAM scheduler on the chip presets: FCFS (the default: each request served at its own cycle, in the order
# it comes), FR-FCFS with cap 0 (the queued memory serving the oldest first: FCFS decided when the bank is free)
# and FR-FCFS with the default cap of 16 (row hits first), on incoherent rays. Per mesh, preset and scheduler: the
# cycles, against FCFS, what the lower bound is limited by, DRAM utilization, the row hit rate, the memory wait
# per ray, requests reordered and capped, and the L2 hit rate.
#
#   bench/dram_scheduler.sh [RTUSIM] [RAYS] [MESH...]
#     RTUSIM  default build/default/rtusim;  RAYS  incoherent rays per mesh, default 50000;  MESH  default two
#     assimp-testmodels meshes;  PRESETS (environment) default "rdna2-chip embedded-chip", each a preset name
#     optionally with key changes, e.g. rdna2-chip:dram_bytes_per_cycle=16 (the chip starved of bandwidth)
# Each run is `rtusim trace --device timed --threads 1`, one TRACE packet, the same ray file for every scheduler.
# Prints a Markdown table. Reads the stats JSON with python3.
set -euo pipefail
read -r -a presets <<<"${PRESETS:-rdna2-chip embedded-chip}"
source "$(dirname "$0")/lib.sh"  # sets name to dram_scheduler.sh
bench_mesh_setup 50000 "$bench_engine" "$bench_house" -- "$@"
echo "| mesh | preset | scheduler | cycles | vs fcfs | limited by | DRAM utilization | row hit rate | mem wait/ray | reordered | capped | L2 hit rate |"
echo "|---|---|---|---:|---:|---|---:|---:|---:|---:|---:|---:|"
for mesh in "${meshes[@]}"; do
  [ -r "$mesh" ] || { echo "$name: cannot read $mesh" >&2; exit 2; }
  "$rtusim" rays --scene "$mesh" --kind incoherent --count "$rays" --seed 7 --out "$tmp/rays.bin" >/dev/null
  for preset in "${presets[@]}"; do
    IFS=: read -r -a spec <<<"$preset"
    sets=()
    for kv in "${spec[@]:1}"; do sets+=(--set "$kv"); done
    base=""
    for sched in fcfs "frfcfs cap 0" "frfcfs cap 16"; do
      read -r s _ cap <<<"$sched"
      "$rtusim" trace --scene "$mesh" --rays "$tmp/rays.bin" --out "$tmp/hits.bin" --device timed \
        --config "${spec[0]}" "${sets[@]}" --threads 1 --set dram_scheduler="$s" --set dram_frfcfs_cap="${cap:-16}" \
        --stats "$tmp/stats.json" >/dev/null
      cycles=$(num '["timing"]["cycles"]' "$tmp/stats.json")
      base=${base:-$cycles}
      python3 - "$mesh" "$preset" "$sched" "$base" "$tmp/stats.json" <<'PY'
import json, os, sys
mesh, preset, sched, base, f = sys.argv[1:6]
t = json.load(open(f))["timing"]
print(f"| {os.path.basename(mesh)} | {preset} | {sched} | {t['cycles']} | {t['cycles'] / int(base):.3f} | "
      f"{t['lower_bound']['limited_by']} | {t['utilization']['dram']:.3f} | {t['dram_rows']['hit_rate']:.3f} | "
      f"{t['mem_wait_cycles'] / t['rays']:.0f} | {t['dram_sched']['reordered']} | {t['dram_sched']['capped']} | "
      f"{t['l2']['hit_rate']:.3f} |")
PY
    done
  done
done
