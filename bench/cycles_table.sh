#!/usr/bin/env bash
# Cycles per scene on the timed device, per timing preset: the table "cycles per scene" of README.md, in Markdown.
#
#   bench/cycles_table.sh [RTUSIM] [RAYS] [MESH...]
#     RTUSIM  default build/default/rtusim;  RAYS  rays per kind on each mesh, default 100000
#     MESH    default the three assimp-testmodels meshes of README.md;  THREADS (environment) rtusim --threads,
#             default 1 (so the simulator's speed is one thread's)
#
# For each preset of `rtusim config --list` (rdna2, intel, embedded):
# - the built-in scenes seed and cornell rendered by the firmware: `rtusim render --device timed --width 160
#   --height 120 --spp 1 --max-depth 2`; rays = every ray the renderer traced (rays_total), cycles = the TRACE
#   packets' cycles, device clock = the unit's clock at the end (packet decode and fences included);
# - each mesh traced with `rtusim trace --device timed` on RAYS primary and RAYS incoherent rays (`rtusim rays`,
#   the same ray files for every preset), one TRACE packet per run.
# Columns: cycles/ray and rays/clock from the TRACE cycles; limited by = the largest of rays (one a clock), box
# tests / box rate, triangle tests / triangle rate, DRAM bytes / bandwidth; cycles / bound = cycles over that
# lower bound; cache hit rate over line accesses; wall s = the simulator's time tracing (trace: trace_seconds;
# render: seconds, firmware and shading included), sim. MRays/s = rays / wall s (simulated rays per second of the
# host).
# Reads the stats JSON with jq, or python3 when jq is missing.
set -euo pipefail
threads=${THREADS:-1}
presets=(rdna2 intel embedded)
builtins=(builtin:seed builtin:cornell)

source "$(dirname "$0")/lib.sh"  # sets name to cycles_table.sh
bench_mesh_args 100000 "$bench_engine" "$bench_suzanne" "$bench_house" -- "$@"
for mesh in "${meshes[@]}"; do
  [ -r "$mesh" ] || { echo "cycles_table.sh: cannot read $mesh" >&2; exit 2; }
done
bench_json_reader
bench_tmpdir


# row PRESET SCENE RAYS_LABEL FILE RAYS_KEY WALL_KEY: one table row from a trace or render stats file.
row() {
  local preset=$1 scene=$2 label=$3 file=$4 rays_key=$5 wall_key=$6
  local n cycles clock cpr rpc lim cob hit wall
  IFS=$'\t' read -r n cycles clock cpr rpc lim cob hit wall < <(bench_fields "$file" "$rays_key" timing.cycles \
    timing.device_clock timing.cycles_per_ray timing.rays_per_clock timing.lower_bound.limited_by \
    timing.lower_bound.cycles_over_bound timing.cache.hit_rate "$wall_key")
  printf '| %s | %s | %s %s | %s | %s | %.2f | %.3f | %s | %.2f | %.3f | %.3f | %.2f |\n' "$preset" "$scene" "$label" \
    "$n" "$cycles" "$clock" "$cpr" "$rpc" "$lim" "$cob" "$hit" "$wall" \
    "$(awk -v n="$n" -v w="$wall" 'BEGIN { print (w > 0 ? n / w * 1e-6 : 0) }')"
}

# The same ray files for every preset.
for i in "${!meshes[@]}"; do
  for kind in primary incoherent; do
    "$rtusim" rays --scene "${meshes[$i]}" --kind "$kind" --count "$rays" --out "$tmp/$i.$kind.rays" >/dev/null
  done
done

printf '%s rays per kind on each mesh; built-in scenes rendered 160x120, 1 spp, depth 2; --threads %s\n\n' \
  "$rays" "$threads"
printf '| preset | scene | rays | cycles | device clock | cycles/ray | rays/clock | limited by | cycles / bound | cache hit rate | wall s | sim. MRays/s |\n'
printf '|---|---|---|---:|---:|---:|---:|---|---:|---:|---:|---:|\n'
for preset in "${presets[@]}"; do
  for scene in "${builtins[@]}"; do
    "$rtusim" render --scene "$scene" --device timed --config "$preset" --width 160 --height 120 --spp 1 \
      --max-depth 2 --threads "$threads" --out "$tmp/render.png" --stats "$tmp/render.json" >/dev/null
    row "$preset" "$scene" render "$tmp/render.json" rays_total seconds
  done
  for i in "${!meshes[@]}"; do
    for kind in primary incoherent; do
      "$rtusim" trace --scene "${meshes[$i]}" --rays "$tmp/$i.$kind.rays" --out "$tmp/hits" --device timed \
        --config "$preset" --threads "$threads" --stats "$tmp/trace.json" >/dev/null
      row "$preset" "$(basename "${meshes[$i]}")" "$kind" "$tmp/trace.json" rays trace_seconds
    done
  done
done
