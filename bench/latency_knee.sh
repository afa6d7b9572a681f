#!/usr/bin/env bash
# Rays per clock against the number of units on the chip preset, with each latency lever and without: where a
# lever moves the chip from latency-bound toward its bandwidth bound, and where the curve bends (the knee). Each
# row is one `rtusim trace --flatten --scene S --rays KIND:RAYS --device timed --config rdna2-chip --set units=U`.
# Writes a Markdown table to stdout. Cycles are deterministic.
# Usage: bench/latency_knee.sh [RTUSIM] [RAYS]      (default 65536 incoherent rays on the engine)
set -euo pipefail
source "$(dirname "$0")/lib.sh"
bench_tmpdir
rtusim=${1:-build/default/rtusim}
rays=${2:-65536}
scene=${SCENE:-$bench_engine}
kind=${KIND:-incoherent}
units_list=(${UNITS:-1 2 4 8 16 32 64 80})
techniques=(
  "none|"
  "next_line|--set prefetcher=next_line"
  "treelet 512, queue 64|--set treelet_bytes=512 --set prefetcher=treelet --set prefetch_queue=64"
  "gather octant|--set gather=octant"
  "restart trail|--set stack_mode=restart"
)
echo "| technique | units | cycles | rays/clock | per unit | vs none | limited by | DRAM busy | slots busy |"
echo "|---|---:|---:|---:|---:|---:|---|---:|---:|"
declare -A base
for t in "${techniques[@]}"; do
  label=${t%%|*}
  args=${t#*|}
  for u in "${units_list[@]}"; do
    # shellcheck disable=SC2086
    "$rtusim" trace --flatten --scene "$scene" --rays "$kind:$rays" --device timed --config rdna2-chip \
      --set units="$u" $args --stats "$tmp/out.json" > /dev/null
    row=$(/usr/bin/python3 - "$tmp/out.json" "$u" "${base[$u]:-}" <<'PY'
import json, sys
t = json.load(open(sys.argv[1]))["timing"]
u = int(sys.argv[2])
rpc = t["rays"] / t["cycles"]
base = float(sys.argv[3]) if sys.argv[3] else rpc
util = t["utilization"]
print("%.6f|%d | %.4f | %.5f | %.3f | %s | %.2f | %.2f" % (rpc, t["cycles"], rpc, rpc / u, rpc / base,
      t["lower_bound"]["limited_by"], util["dram"], util["ray_slots"]))
PY
)
    [ "$label" = none ] && base[$u]=${row%%|*}
    echo "| $label | $u | ${row#*|} |"
  done
done
