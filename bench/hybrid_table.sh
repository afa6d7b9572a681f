#!/usr/bin/env bash
# Hybrid against ray-traced rendering on the timed device, per timing preset: the table "Hybrid rendering" of
# README.md, in Markdown.
#
#   bench/hybrid_table.sh [RTUSIM] [PRESET...]
#     RTUSIM  default build/default/rtusim;  PRESET  default rdna2 intel embedded
#     THREADS (environment) rtusim --threads, default 2 (cycles do not depend on it)
#
# Each row is one `rtusim render --device timed --config PRESET --mode hybrid --compare-modes`: the scene in
# both modes on the same unit. Columns: rays traced by each mode (hybrid saves the primary rays), the raytrace
# frame's cycles (every packet: the device clock), the hybrid frame's raster cycles (the cost model of
# hwmodel/timing/raster_timing.h, with the stage that limits it) and trace cycles, hybrid's speedup (raytrace cycles /
# hybrid cycles), and the PSNR of the hybrid image against the raytrace image (inf: identical).
# Needs python3 to read the stats JSON.
set -euo pipefail
rtusim=${1:-build/default/rtusim}
shift $(($# > 0 ? 1 : 0))
presets=("$@")
[ ${#presets[@]} -gt 0 ] || presets=(rdna2 intel embedded)
threads=${THREADS:-2}
suzanne=/usr/share/assimp/models/BLEND/SuzanneSubdiv_252.blend

source "$(dirname "$0")/lib.sh"  # sets name to hybrid_table.sh
bench_need_rtusim "$rtusim"
bench_need_python
bench_tmpdir

# scene | width | height | spp | depth | extra render options
cases=(
  "builtin:seed|640|480|1|0|"
  "builtin:seed|640|480|1|4|"
  "builtin:seed|640|480|4|4|"
  "builtin:cornell|512|512|1|0|"
  "builtin:cornell|512|512|1|4|"
  "builtin:icosphere|640|480|1|0|"
  "builtin:icosphere?subdiv=8|640|480|1|0|"
)
[ -r "$suzanne" ] && cases+=("$suzanne|160|120|1|0|" "$suzanne|320|240|1|0|" "$suzanne|1280|960|1|0|")

printf '| preset | scene | size, spp, depth | raytrace rays | hybrid rays | raytrace cycles | hybrid raster cycles (limit) | hybrid trace cycles | hybrid speedup | PSNR dB |\n'
printf '|---|---|---|---:|---:|---:|---:|---:|---:|---:|\n'
for preset in "${presets[@]}"; do
  for c in "${cases[@]}"; do
    IFS='|' read -r scene w h spp depth extra <<<"$c"
    # shellcheck disable=SC2086
    "$rtusim" render --scene "$scene" --device timed --config "$preset" --mode hybrid --compare-modes \
      --width "$w" --height "$h" --spp "$spp" --max-depth "$depth" --threads "$threads" $extra \
      --out "$tmp/h.png" --stats "$tmp/h.json" >/dev/null
    python3 - "$tmp/h.json" "$preset" "$scene" "$w" "$h" "$spp" "$depth" <<'PY'
import json, os, sys
j = json.load(open(sys.argv[1]))
preset, scene, w, h, spp, depth = sys.argv[2:]
m = j["modes"]
rt, hy = m["raytrace"], m["hybrid"]
psnr = "inf" if m["psnr_db"] is None else "%.1f" % m["psnr_db"]
name = os.path.basename(scene) if scene.startswith("/") else scene
print("| %s | %s | %sx%s, %s, %s | %d | %d | %d | %d (%s) | %d | %.2fx | %s |" % (
    preset, name, w, h, spp, depth, rt["rays_total"], hy["rays_total"], rt["frame_cycles"],
    hy["raster_cycles"], j["timing"]["raster"]["limit"], hy["trace_cycles"],
    rt["frame_cycles"] / hy["frame_cycles"], psnr))
PY
  done
done
