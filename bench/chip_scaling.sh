#!/usr/bin/env bash
# Cycles and rays per clock against the number of units of a chip (docs/timing-model.md, "A chip of units"):
# per mesh and ray kind, a chip preset with 1 to all of its units, and the knee where first principles put it:
# the units at which one unit's rays per clock x DRAM bytes per ray x units reach the DRAM bandwidth.
#
#   bench/chip_scaling.sh [RTUSIM] [RAYS] [MESH...]
#     RTUSIM  default build/default/rtusim;  RAYS  rays per kind, default 200000;  MESH  default two
#     assimp-testmodels meshes.
#   Environment: CHIP the chip preset (default rdna2-chip); UNITS default "1 2 4 8 16 32 64 80"; and overrides of
#   the preset's keys: POLICY (ray_policy), BANDWIDTH (dram_bytes_per_cycle), ROW_CYCLES (activate and
#   precharge cycles), SLOTS (ray_slots); PLOTS a directory for the plots (gnuplot, PNG): scaling.png (rays per
#   clock against units, the knee marked), timeline.png (DRAM and L2 bytes per clock over the run at the largest
#   unit count) and units.png (each unit's box utilization and cache hit rate there).
# Each run: `rtusim trace --device timed --threads 1`, one TRACE packet; also the simulator's speed (simulated
# rays per second on one host thread) against the single unit's in the same run. Prints Markdown; reads the stats
# JSON with python3.
set -euo pipefail
source "$(dirname "$0")/lib.sh"  # sets name to chip_scaling.sh
bench_mesh_setup 200000 "$bench_house" "$bench_engine" -- "$@"
read -r -a units <<<"${UNITS:-1 2 4 8 16 32 64 80}"
plots=${PLOTS:-}
if [ -n "$plots" ]; then
  command -v gnuplot >/dev/null || { echo "$name: PLOTS needs gnuplot (apt-get install gnuplot-nox)" >&2; exit 2; }
  mkdir -p "$plots"
fi
chip=(--config "${CHIP:-rdna2-chip}")
[ -n "${POLICY:-}" ] && chip+=(--set ray_policy="$POLICY")
[ -n "${BANDWIDTH:-}" ] && chip+=(--set dram_bytes_per_cycle="$BANDWIDTH")
[ -n "${ROW_CYCLES:-}" ] && chip+=(--set dram_activate_cycles="$ROW_CYCLES" --set dram_precharge_cycles="$ROW_CYCLES")
[ -n "${SLOTS:-}" ] && chip+=(--set ray_slots="$SLOTS")
echo "chip: ${chip[*]}"
echo
echo "| mesh | rays | units | cycles | rays/clock | speed-up | DRAM bytes/ray | L2 hit rate | row hit rate | DRAM utilization | limited by | knee (units) | sim rays/s vs 1 unit |"
echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|"
for mesh in "${meshes[@]}"; do
  bench_kind_rays "$mesh"
  for kind in primary incoherent; do
    for u in "${units[@]}"; do
      "$rtusim" trace --scene "$mesh" --rays "$tmp/$kind.bin" --out "$tmp/hits.bin" --device timed --threads 1 \
        "${chip[@]}" --set units="$u" --stats "$tmp/stats_$u.json" >/dev/null
    done
    python3 - "$mesh" "$kind" "$tmp" "$plots" "${units[@]}" <<'PY'
import json, os, sys
mesh, kind, tmp, plots = sys.argv[1:5]
units = sys.argv[5:]
first = None
tag = f"{os.path.splitext(os.path.basename(mesh))[0]}-{kind}"
curve = []
for u in units:
    j = json.load(open(f"{tmp}/stats_{u}.json"))
    t = j["timing"]
    bandwidth = t["config"]["dram_bytes_per_cycle"]
    rpc = t["rays_per_clock"]
    bpr = t["dram_bytes"] / t["rays"]
    speed = t["rays"] / j["trace_seconds"]
    if first is None:
        first = (rpc, bpr, speed)
    # First principles: one unit's rays per clock times units, each ray moving its DRAM bytes, meets the bandwidth.
    knee = bandwidth / (first[0] * first[1]) if first[1] > 0 else float("inf")
    curve.append((int(u), rpc, first[0] * int(u), bandwidth / bpr if bpr > 0 else float("inf")))
    print(f"| {os.path.basename(mesh)} | {kind} | {u} | {t['cycles']} | {rpc:.3f} | {rpc / first[0]:.1f}x | "
          f"{bpr:.0f} | {t['l2']['hit_rate']:.3f} | {t['dram_rows']['hit_rate']:.3f} | "
          f"{t['utilization']['dram']:.2f} | {t['lower_bound']['limited_by']} | {knee:.0f} | "
          f"{speed / first[2]:.2f} |")
if plots:
    # Data for the plots: the curve with its two first-principles lines, the largest run's timeline and units.
    with open(f"{plots}/{tag}.scaling.dat", "w") as f:
        f.write("# units rays_per_clock linear_from_one_unit bandwidth_over_bytes_per_ray\n")
        for row in curve:
            f.write(" ".join(str(x) for x in row) + "\n")
    tl = t.get("timeline", {})
    with open(f"{plots}/{tag}.timeline.dat", "w") as f:
        f.write("# cycle dram_bytes_per_clock l2_bytes_per_clock\n")
        b = tl.get("bin_cycles", 1)
        d, l2 = tl.get("dram_bytes", []), tl.get("l2_bytes", [])
        for i in range(max(len(d), len(l2))):
            f.write(f"{i * b} {(d[i] if i < len(d) else 0) / b} {(l2[i] if i < len(l2) else 0) / b}\n")
    with open(f"{plots}/{tag}.units.dat", "w") as f:
        f.write("# unit box_utilization cache_hit_rate\n")
        for i, un in enumerate(t.get("units", [])):
            f.write(f"{i} {un['utilization']['box_units']} {un['cache']['hit_rate']}\n")
PY
  done
done
if [ -n "$plots" ]; then
  tags=()
  for mesh in "${meshes[@]}"; do
    b=$(basename "$mesh"); b=${b%.*}
    tags+=("$b-primary" "$b-incoherent")
  done
  rows=${#meshes[@]}
  {
    echo "set terminal pngcairo size 1280,$((rows * 420)) font ',10'"
    echo "set termoption noenhanced"
    echo "set output '$plots/scaling.png'"
    echo "set multiplot layout $rows,2 title 'rays per clock against units (${chip[*]})'"
    echo "set logscale xy 2; set grid; set key top left; set xlabel 'units'; set ylabel 'rays per clock'"
    for t in "${tags[@]}"; do
      echo "set title '$t'"
      echo "plot '$plots/$t.scaling.dat' u 1:2 w lp pt 7 t 'simulated', '' u 1:3 w l dt 2 t 'one unit x units', '' u 1:4 w l dt 3 t 'DRAM bandwidth / bytes per ray'"
    done
    echo "unset multiplot"
    echo "unset logscale"
    echo "set output '$plots/timeline.png'"
    echo "set multiplot layout $rows,2 title 'memory bandwidth over the run, ${units[-1]} units'"
    echo "set xlabel 'cycle'; set ylabel 'bytes per clock'"
    for t in "${tags[@]}"; do
      echo "set title '$t'"
      echo "plot '$plots/$t.timeline.dat' u 1:2 w steps t 'DRAM', '' u 1:3 w steps t 'L2'"
    done
    echo "unset multiplot"
    echo "set output '$plots/units.png'"
    echo "set multiplot layout $rows,2 title 'per unit, ${units[-1]} units'"
    echo "set xlabel 'unit'; set ylabel 'fraction'; set yrange [0:1]"
    for t in "${tags[@]}"; do
      echo "set title '$t'"
      echo "plot '$plots/$t.units.dat' u 1:2 w p pt 7 t 'box unit utilization', '' u 1:3 w p pt 5 t 'cache hit rate'"
    done
    echo "unset multiplot"
  } >"$tmp/plot.gp"
  gnuplot "$tmp/plot.gp" 2>"$tmp/gnuplot.log" || { cat "$tmp/gnuplot.log" >&2; exit 1; }
  rm -f "$plots"/*.dat
  echo
  echo "plots: $plots/scaling.png, $plots/timeline.png, $plots/units.png"
fi
