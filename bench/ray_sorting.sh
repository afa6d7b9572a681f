#!/usr/bin/env bash
# Ray sorting in the firmware (the ray_sort key) on path-traced frames: the unit's cycles without sorting and with
# each key, the sort's own cycles on the controllers, and the frame with and without that cost. Writes a Markdown
# table to stdout (the rows of bench/results/ray-sorting.md). Cycles and counts are deterministic; only the run
# time is the machine's.
# Usage: bench/ray_sorting.sh [RTUSIM] [WIDTH] [HEIGHT] [SPP]      (default 128 128 1; 3 bounces)
# Environment: PRESETS (default "rdna2-mem rdna2-chip"), SCENES (names of the list below, default all),
# DEPTH (bounces, default 3), GATHER (sort_gather: copy, the default, or index: the sort's cost without moving rays
# or hits, as Meister et al.'s tracer counts it).
set -euo pipefail
name=ray_sorting.sh
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=bench/lib.sh
source "$here/lib.sh"
rtusim=${1:-build/default/rtusim}
width=${2:-128}
height=${3:-128}
spp=${4:-1}
depth=${DEPTH:-3}
gather=${GATHER:-copy}
bench_need_rtusim "$rtusim"
bench_need_count WIDTH "$width"
bench_need_count HEIGHT "$height"
bench_need_count SPP "$spp"
bench_need_python
bench_tmpdir
# name=scene argument (the house flattened: one image, as the other benches trace it)
all_scenes=(
  "house=$bench_house --flatten"
  "atrium=builtin:atrium"
  "engine=$bench_engine"
)
want=(${SCENES:-house atrium engine})
presets=(${PRESETS:-rdna2-mem rdna2-chip})
keys=(none origin direction origin_direction termination)

echo "| scene | preset | key | rays | device cycles | trace speed-up | node-cache misses | sort cycles | sort limit | saved / sort | frame cycles | frame speed-up |"
echo "|---|---|---|---:|---:|---:|---:|---:|---|---:|---:|---:|"
for w in "${want[@]}"; do
  scene=""
  for s in "${all_scenes[@]}"; do [ "${s%%=*}" = "$w" ] && scene=${s#*=}; done
  [ -n "$scene" ] || { echo "$name: unknown scene '$w' (house, atrium, engine)" >&2; exit 2; }
  for preset in "${presets[@]}"; do
    base=""
    for key in "${keys[@]}"; do
      out=$tmp/out.json
      # shellcheck disable=SC2086
      "$rtusim" render --scene $scene --device timed --config "$preset" --width "$width" --height "$height" \
        --spp "$spp" --max-depth "$depth" --threads 2 --set ray_sort="$key" --set sort_gather="$gather" --out "$tmp/out.png" \
        --stats "$out" > /dev/null 2>&1
      row=$(python3 - "$out" "$base" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
t = j["timing"]
device, frame = t["device_clock"], t["frame_cycles"]
sort = t.get("sort_cycles", 0)
base = [int(x) for x in sys.argv[2].split(",")] if sys.argv[2] else [device, frame]
saved = base[0] - device
ratio = "%.2f" % (saved / sort) if sort else "-"
print("%d,%d|%d | %d | %.3f | %d | %d | %s | %s | %d | %.3f" % (
    device, frame, j["rays_total"], device, base[0] / device, t["cache"]["misses"], sort,
    t["sort"]["limit"] if sort else "-", ratio, frame, base[1] / frame))
PY
)
      [ -z "$base" ] && base=${row%%|*}
      echo "| $w | $preset | $key | ${row#*|} |"
    done
  done
done
