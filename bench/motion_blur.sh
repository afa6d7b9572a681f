#!/usr/bin/env bash
# Motion blur on two unit designs (docs/timing-model.md, "Motion blur"): rtusim motion's frame of the built-in
# moving scene, timed on a static unit (the scene frozen at mid-shutter), a time-aware unit (boxes and vertices
# interpolated in the unit) and a time-oblivious one (boxes over the whole shutter, moving triangles tested in the
# shader at any_hit_latency), as the balls' moves are scaled; then the time-aware unit's cycles by the box unit's
# time bits; then the time-oblivious unit by the shader's round trip; then the built-in moving instances.
#
#   bench/motion_blur.sh [RTUSIM] [WIDTH]
#     RTUSIM  default build/default/rtusim;  WIDTH  default 320 (4:3, 4 shutter times per pixel);  CONFIG default
#     rdna2
# Prints Markdown tables. Reads the JSON with python3.
set -euo pipefail
rtusim=${1:-build/default/rtusim}
width=${2:-320}
config=${CONFIG:-rdna2}
source "$(dirname "$0")/lib.sh"
bench_need_rtusim "$rtusim"
bench_need_count WIDTH "$width"
bench_need_python
bench_tmpdir
height=$((width * 3 / 4))
run() {  # run NAME ARGS...: rtusim motion into $tmp/NAME.json
  local n=$1
  shift
  "$rtusim" motion --config "$config" --width "$width" --height "$height" --json "$tmp/$n.json" "$@" >/dev/null
}
row() {  # row JSON LABEL: one line per unit
  python3 - "$1" "$2" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
for d in j["designs"]:
    rays = j["rays"]
    print(f"| {sys.argv[2]} | {d['unit']} | {d['cycles']:,} | {d['ratio_to_static']:.2f}x | "
          f"{d['nodes_visited'] / rays:.2f} | {d['triangle_tests'] / rays:.2f} | {d['shader_calls']:,} | "
          f"{d['dram_bytes']:,} |")
PY
}
echo "### By the size of the moves"
echo
echo "| motion scale | unit | cycles | vs static | nodes/ray | triangles/ray | shader calls | DRAM bytes |"
echo "|---:|---|---:|---:|---:|---:|---:|---:|"
for s in 1 0.5 0.25 0.1 0; do
  run "scale$s" --motion-scale "$s"
  row "$tmp/scale$s.json" "$s"
done
echo
echo "### The time-aware unit by its box time bits (motion scale 1)"
echo
echo "| box time bits | cycles | vs static | nodes/ray | triangles/ray | interpolators mm^2 | interpolation pJ/ray |"
echo "|---:|---:|---:|---:|---:|---:|---:|"
for b in 0 1 2 4 6 8 12 16; do
  run "bits$b" --box-time-bits "$b"
  python3 - "$tmp/bits$b.json" "$b" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
d = j["designs"][1]
rays = j["rays"]
print(f"| {sys.argv[2]} | {d['cycles']:,} | {d['ratio_to_static']:.2f}x | {d['nodes_visited'] / rays:.2f} | "
      f"{d['triangle_tests'] / rays:.2f} | {d['interpolators_mm2']:.4f} | {d['interpolation_pj'] / rays:.2f} |")
PY
done
echo
echo "### The time-oblivious unit by the shader's round trip (motion scale 0.1)"
echo
echo "| any_hit_latency | cycles | vs static |"
echo "|---:|---:|---:|"
for l in 25 50 100 200 400; do
  run "lat$l" --motion-scale 0.1 --set "any_hit_latency=$l"
  python3 - "$tmp/lat$l.json" "$l" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
d = j["designs"][2]
print(f"| {sys.argv[2]} | {d['cycles']:,} | {d['ratio_to_static']:.2f}x |")
PY
done
echo
echo "### Instances with two transforms (rtusim motion --instances), by the size of the moves"
echo
echo "| motion scale | unit | cycles | vs static | nodes/ray | triangles/ray | shader calls | DRAM bytes |"
echo "|---:|---|---:|---:|---:|---:|---:|---:|"
for s in 1 0.1 0; do
  run "inst$s" --instances --motion-scale "$s"
  row "$tmp/inst$s.json" "$s"
done
