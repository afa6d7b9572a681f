#!/usr/bin/env bash
# Switching activity of the RTL units, for the energy per box and per triangle test: rtu_rtl_activity
# (rtl_sim/activity/) drives toggle-coverage models (verilator --coverage-toggle) of the box unit and the triangle
# unit (rdna2 and embedded) with vectors captured from traversals of the IFC house, at full throughput, and the
# reference operators of rtl_sim/rtl/ref_ops.sv (32-bit adder, 32x32->64 multiplier) with uniform random
# operands, and writes bench/data/rtl_activity.csv: params (the unit's key in bench/data/rtl_area.csv), unit,
# tests, signal_bits (distinct RTL nets that toggle, clock and reset excluded), toggles_per_test (their bit
# transitions per test, 0->1 and 1->0 each once). Then synthesizes the reference operators with yosys as
# bench/rtl_area.sh does (synth -flatten, stat -tech cmos) and puts their rows, keyed ref:add32 and ref:mul32,
# into bench/data/rtl_area.csv (replacing earlier ones). Prints rtu_rtl_activity's report.
#
#   bench/rtl_activity.sh [BUILD]     BUILD default build/default
# The coverage models are slow to compile (minutes each): the script configures BUILD with
# -DRTU_BUILD_ACTIVITY=ON (it stays on in that build's cache) and builds the target rtu_rtl_activity with -j1
# (JOBS=N to change). ACTIVITY_ARGS="--nodes N --tris N ..." passes options to rtu_rtl_activity; NO_AREA=1 skips
# yosys. Not part of the test suite.
set -euo pipefail
name=rtl_activity.sh
build=${1:-build/default}
here=$(cd "$(dirname "$0")/.." && pwd)
# shellcheck source=bench/lib.sh
. "$here/bench/lib.sh"
[ -f "$build/CMakeCache.txt" ] || { echo "$name: $build is not a configured build directory" >&2; exit 2; }
bench_tmpdir

cmake -S "$here" -B "$build" -DRTU_BUILD_ACTIVITY=ON >"$tmp/configure.log" 2>&1 || { cat "$tmp/configure.log" >&2; exit 1; }
t0=$(date +%s)
cmake --build "$build" --target rtu_rtl_activity -j "${JOBS:-1}" >"$tmp/build.log" 2>&1 || { tail -50 "$tmp/build.log" >&2; exit 1; }
echo "# rtu_rtl_activity built in $(( $(date +%s) - t0 )) s"

csv="$here/bench/data/rtl_activity.csv"
# shellcheck disable=SC2086
"$build/rtl_sim/rtu_rtl_activity" --csv "$csv" --tmp "$tmp" ${ACTIVITY_ARGS:-}
echo "# wrote $csv"
[ -n "${NO_AREA:-}" ] && exit 0

command -v yosys >/dev/null || { echo "$name: yosys is not installed (scripts/setup.sh installs it)" >&2; exit 2; }
for row in add32:0 mul32:1; do
  bench_synth_row "# " "ref:${row%%:*}" ref_ops "$here/rtl_sim/rtl/ref_ops.sv" OP "${row##*:}" W 32
done
