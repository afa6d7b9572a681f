#!/usr/bin/env bash
# Latency-hiding techniques side by side on the timed device: cycles, node-cache misses, prefetch accuracy, DRAM
# bytes and energy per ray, and area, per scene, ray kind, preset and format. Ray kinds: primary and incoherent
# (`rtusim trace`, RAYS each) and path (a path-traced frame through the firmware renderer, `rtusim render`,
# PATH_SIZE pixels square, 1 sample, 3 bounces: every packet of every bounce). Writes a Markdown table to stdout
# (the rows of bench/results/latency-hiding.md). Cycles and counts are deterministic; only the run time is the
# machine's.
# Usage: bench/latency_hiding.sh [RTUSIM] [RAYS]      (RAYS per kind, default 32768)
# Environment: KINDS, PATH_SIZE, PRESETS, FORMATS (lists), TECHNIQUES (a regex of technique labels to run).
set -euo pipefail
source "$(dirname "$0")/lib.sh"
bench_tmpdir
rtusim=${1:-build/default/rtusim}
rays=${2:-32768}
scenes=("house=$bench_house" "engine=$bench_engine" "city=builtin:city")
kinds=(${KINDS:-primary incoherent path})
path_size=${PATH_SIZE:-128}
presets=(${PRESETS:-rdna2-mem rdna2-chip})
formats=(${FORMATS:-default compact})  # compact: B = 16, k = 6, reduced precision
# name | --set arguments
techniques=(
  "none|"
  "next_line|--set prefetcher=next_line"
  "treelet layout|--set treelet_bytes=512"
  "treelet 512|--set treelet_bytes=512 --set prefetcher=treelet"
  "treelet 512, queue 64|--set treelet_bytes=512 --set prefetcher=treelet --set prefetch_queue=64"
  "treelet 2048, queue 64|--set treelet_bytes=2048 --set prefetcher=treelet --set prefetch_queue=64"
  "treelet-first 512|--set treelet_bytes=512 --set traversal=treelet_first"
  "treelet 512 + treelet-first|--set treelet_bytes=512 --set prefetcher=treelet --set traversal=treelet_first"
  "treelet 512, queue 4096 + treelet-first|--set treelet_bytes=512 --set prefetcher=treelet --set prefetch_queue=4096 --set traversal=treelet_first"
  "slot order|--set child_order=slot"
  "slot order, treelet 512|--set child_order=slot --set treelet_bytes=512 --set prefetcher=treelet"
  "slot order, treelet-first 512|--set child_order=slot --set treelet_bytes=512 --set traversal=treelet_first"
  "slot order, treelet 512 + treelet-first|--set child_order=slot --set treelet_bytes=512 --set prefetcher=treelet --set traversal=treelet_first"
  "stack, degree 1|--set prefetcher=stack"
  "stack, degree 2, queue 64|--set prefetcher=stack --set prefetch_degree=2 --set prefetch_queue=64"
  "stack_pop, degree 2, queue 64|--set prefetcher=stack_pop --set prefetch_degree=2 --set prefetch_queue=64"
  "ttp|--set prefetcher=ttp"
  "ttp, queue 64|--set prefetcher=ttp --set prefetch_queue=64"
  "next_line, buffer 16|--set prefetcher=next_line --set prefetch_buffer=16"
  "treelet 512, queue 64, buffer 32|--set treelet_bytes=512 --set prefetcher=treelet --set prefetch_queue=64 --set prefetch_buffer=32"
  "restart trail|--set stack_mode=restart"
  "gather octant|--set gather=octant"
  "gather two_point|--set gather=two_point"
  "treelet 512, queue 64 + gather octant + restart|--set treelet_bytes=512 --set prefetcher=treelet --set prefetch_queue=64 --set gather=octant --set stack_mode=restart"
)
echo "| scene | rays | preset | format | technique | cycles | speed-up | misses | miss change | accuracy | coverage | DRAM B/ray | pJ/ray | area mm^2 |"
echo "|---|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for s in "${scenes[@]}"; do
  scene=${s%%=*}
  path=${s#*=}
  for kind in "${kinds[@]}"; do
    for preset in "${presets[@]}"; do
      for fmt in "${formats[@]}"; do
        base=""
        for t in "${techniques[@]}"; do
          label=${t%%|*}
          args=${t#*|}
          # TECHNIQUES=REGEX: only the techniques whose label matches (and the baseline, "none").
          [ "$label" != none ] && [ -n "${TECHNIQUES:-}" ] && ! [[ $label =~ $TECHNIQUES ]] && continue
          out=$tmp/out.json
          if [ "$kind" = path ]; then
            # shellcheck disable=SC2086
            "$rtusim" render --flatten --scene "$path" --width "$path_size" --height "$path_size" --max-depth 3 \
              --device timed --config "$preset" --format "$fmt" $args --out "$tmp/frame.png" --stats "$out" > /dev/null
          else
            # shellcheck disable=SC2086
            "$rtusim" trace --flatten --scene "$path" --rays "$kind:$rays" --device timed --config "$preset" \
              --format "$fmt" $args --stats "$out" > /dev/null
          fi
          row=$(/usr/bin/python3 - "$out" "$base" <<'PY'
import json, sys
t = json.load(open(sys.argv[1]))["timing"]
rays = max(1, t["rays"])
misses = t["cache"]["misses"]
base = sys.argv[2].split(",") if sys.argv[2] else [str(t["cycles"]), str(misses)]
speed = float(base[0]) / t["cycles"]
change = (misses - float(base[1])) / max(1.0, float(base[1]))
print("%d,%d|%d | %.3f | %d | %+.1f%% | %.2f | %.2f | %.0f | %.0f | %.2f" % (t["cycles"], misses, t["cycles"], speed,
      misses, 100 * change, t["prefetch"]["accuracy"], t["prefetch"]["coverage"], t["dram_bytes"] / rays,
      t["energy"]["pj_per_ray"],
      t["energy"]["area"]["total_mm2"]))
PY
)
          [ -z "$base" ] && base=${row%%|*}
          echo "| $scene | $kind | $preset | $fmt | $label | ${row#*|} |"
        done
      done
    done
  done
done
