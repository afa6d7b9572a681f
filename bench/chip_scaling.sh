#!/usr/bin/env bash
# Cycles and rays per clock against the number of units of a chip (docs/timing-model.md, "A chip of units"):
# per mesh and ray kind, a chip of 1 to 80 rdna2 units with a memory of RDNA2-class size shared by all, and the
# knee where first principles put it: units at which DRAM bytes per ray x rays per clock reach the bandwidth.
#
#   bench/chip_scaling.sh [RTUSIM] [RAYS] [MESH...]
#     RTUSIM  default build/default/rtusim;  RAYS  rays per kind, default 40000;  MESH  default two
#     assimp-testmodels meshes;  UNITS (environment) default "1 2 4 8 16 32 64 80";  POLICY default waves;
#     BANDWIDTH, the chip's DRAM bytes per clock, default 256.
# The chip: rdna2's unit with rdna2-mem's 16 KiB node cache; a 4 MiB L2 in 16 slices of 64 bytes per clock,
# 100 cycles; DRAM of 16 channels sharing 256 bytes per clock (512 GB/s at 2 GHz, the RX 6900 XT's), 16 banks
# of 2 KiB rows each, 28 cycles to activate and 28 to precharge a row, 600 cycles of latency (rdna2-mem's).
# The L2 and row figures are estimates of the right order, not a vendor's. Each run: `rtusim trace --device timed
# --threads 1`, one TRACE packet; also the simulator's speed (simulated rays per second on one host thread)
# against the single unit's in the same run. Prints Markdown; reads the stats JSON with python3.
set -euo pipefail
rtusim=${1:-build/default/rtusim}
rays=${2:-40000}
shift $(( $# > 2 ? 2 : $# ))
meshes=("$@")
if [ ${#meshes[@]} -eq 0 ]; then
  m=/usr/share/assimp/models
  meshes=("$m/IFC/AC14-FZK-Haus.ifc" "$m/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb")
fi
read -r -a units <<<"${UNITS:-1 2 4 8 16 32 64 80}"
policy=${POLICY:-waves}
bw=${BANDWIDTH:-256}  # DRAM bytes per clock of the chip
name=chip_scaling.sh
source "$(dirname "$0")/lib.sh"
bench_need_rtusim "$rtusim"
bench_need_count RAYS "$rays"
bench_need_python
bench_tmpdir
chip=(--config rdna2 --set cache_kib=16 --set l2_kib=4096 --set l2_slices=16 --set l2_ways=16
      --set l2_latency=100 --set l2_bytes_per_cycle=64 --set dram_bytes_per_cycle="$bw" --set dram_banks=16
      --set dram_channels=16 --set dram_row_bytes=2048 --set dram_activate_cycles="${ROW_CYCLES:-28}" --set dram_precharge_cycles="${ROW_CYCLES:-28}"
      --set dram_latency=600 --set ray_policy="$policy")
echo "| mesh | rays | units | cycles | rays/clock | speed-up | DRAM bytes/ray | L2 hit rate | row hit rate | DRAM utilization | limited by | knee (units) | sim rays/s vs 1 unit |"
echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|"
for mesh in "${meshes[@]}"; do
  [ -r "$mesh" ] || { echo "$name: cannot read $mesh" >&2; exit 2; }
  for kind in primary incoherent; do
    "$rtusim" rays --scene "$mesh" --kind "$kind" --count "$rays" --out "$tmp/$kind.bin" >/dev/null
    for u in "${units[@]}"; do
      "$rtusim" trace --scene "$mesh" --rays "$tmp/$kind.bin" --out "$tmp/hits.bin" --device timed --threads 1 \
        "${chip[@]}" --set units="$u" --stats "$tmp/stats_$u.json" >/dev/null
    done
    python3 - "$mesh" "$kind" "$tmp" "$bw" "${units[@]}" <<'PY'
import json, os, sys
mesh, kind, tmp = sys.argv[1:4]
bandwidth = float(sys.argv[4])  # bytes per clock, the chip's DRAM
units = sys.argv[5:]
first = None
for u in units:
    j = json.load(open(f"{tmp}/stats_{u}.json"))
    t = j["timing"]
    rpc = t["rays_per_clock"]
    bpr = t["dram_bytes"] / t["rays"]
    speed = t["rays"] / j["trace_seconds"]
    if first is None:
        first = (rpc, bpr, speed)
    # First principles: one unit's rays per clock times units, each ray moving its DRAM bytes, meets the bandwidth.
    knee = bandwidth / (first[0] * first[1]) if first[1] > 0 else float("inf")
    print(f"| {os.path.basename(mesh)} | {kind} | {u} | {t['cycles']} | {rpc:.3f} | {rpc / first[0]:.1f}x | "
          f"{bpr:.0f} | {t['l2']['hit_rate']:.3f} | {t['dram_rows']['hit_rate']:.3f} | "
          f"{t['utilization']['dram']:.2f} | {t['lower_bound']['limited_by']} | {knee:.0f} | "
          f"{speed / first[2]:.2f} |")
PY
  done
done
