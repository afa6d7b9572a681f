#!/usr/bin/env bash
# The short stack with a restart trail (stack_mode = restart) against the spilling short stack, per short-stack
# size: traversal steps per ray (node and leaf visits, plus the nodes restarts visit again) relative to the full
# stack's, and cycles of both modes on a memory-bound preset. Writes a Markdown table to stdout (the rows of the
# restart section of bench/results/latency-hiding.md). Cycles and counts are deterministic.
# Usage: bench/restart_trail.sh [RTUSIM] [RAYS]      (RAYS per kind, default 32768)
set -euo pipefail
source "$(dirname "$0")/lib.sh"
bench_tmpdir
rtusim=${1:-build/default/rtusim}
rays=${2:-32768}
scenes=("house=$bench_house" "engine=$bench_engine")
preset=${PRESET:-rdna2-mem}
widths=(${WIDTHS:-2 4 8})
entries=(${ENTRIES:-1 2 3 4 5 8})
echo "| scene | rays | width | stack entries | steps/ray, full stack | restarts/ray | steps vs full stack | cycles, spill | cycles, restart | restart vs spill | DRAM B/ray, spill | DRAM B/ray, restart |"
echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for s in "${scenes[@]}"; do
  scene=${s%%=*}
  path=${s#*=}
  for kind in primary incoherent; do
    for w in "${widths[@]}"; do
      for k in "${entries[@]}"; do
        for mode in spill restart; do
          "$rtusim" trace --flatten --scene "$path" --rays "$kind:$rays" --device timed --config "$preset" \
            --set bvh_width="$w" --set stack_entries="$k" --set stack_mode=$mode --stats "$tmp/$mode.json" > /dev/null
        done
        row=$(/usr/bin/python3 - "$tmp/spill.json" "$tmp/restart.json" <<'PY'
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
rays = max(1, a["rays"])
steps = (a["nodes_visited"] + a["leaves_visited"]) / rays
ta, tb = a["timing"], b["timing"]
print("%.2f | %.3f | %.3f | %d | %d | %.3f | %.1f | %.1f" % (
    steps, tb["restarts"] / rays, (steps + tb["restart_nodes"] / rays) / steps, ta["cycles"], tb["cycles"],
    tb["cycles"] / ta["cycles"], ta["dram_bytes"] / rays, tb["dram_bytes"] / rays))
PY
)
        echo "| $scene | $kind | $w | $k | $row |"
      done
    done
  done
done
