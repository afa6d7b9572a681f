#!/usr/bin/env bash
# Packed against line-aligned layout on the timed device: cycles, cache lines per fetch, DRAM bytes and hit rate
# with `--set layout_align=0` (nodes and records back to back, as the image lays them out) and
# `--set layout_align=64` (each padded to the 64-byte line), per mesh, preset rdna2, primary and incoherent rays.
#
#   bench/layout_align.sh [RTUSIM] [RAYS] [MESH...]
#     RTUSIM  default build/default/rtusim;  RAYS  rays per kind, default 50000;  MESH  default two
#     assimp-testmodels meshes
# Prints a Markdown table. Reads the stats JSON with python3.
set -euo pipefail
source "$(dirname "$0")/lib.sh"  # sets name to layout_align.sh
bench_mesh_setup 50000 "$bench_house" "$bench_engine" -- "$@"
echo "| mesh | rays | layout_align | cycles | lines per fetch | DRAM bytes | cache hit rate | cycles vs packed |"
echo "|---|---|---|---|---|---|---|---|"
for mesh in "${meshes[@]}"; do
  bench_kind_rays "$mesh"
  for kind in primary incoherent; do
    for align in 0 64; do
      "$rtusim" trace --scene "$mesh" --rays "$tmp/$kind.bin" --out "$tmp/hits.bin" --device timed \
        --config rdna2 --set layout_align=$align --threads 1 --stats "$tmp/s$align.json" >/dev/null
    done
    python3 - "$mesh" "$kind" "$tmp/s0.json" "$tmp/s64.json" <<'PY'
import json, os, sys
mesh, kind, packed_file, aligned_file = sys.argv[1:5]
packed = json.load(open(packed_file))["timing"]
for align, f in (("0", packed_file), ("64", aligned_file)):
    t = json.load(open(f))["timing"]
    lines = t["cache"]["hits"] + t["cache"]["misses"]
    fetches = t["node_fetches"] + t["prim_fetches"]
    print(f"| {os.path.basename(mesh)} | {kind} | {align} | {t['cycles']} | {lines / fetches:.3f} | "
          f"{t['dram_bytes']} | {t['cache']['hit_rate']:.3f} | {t['cycles'] / packed['cycles']:.3f} |")
PY
  done
done
