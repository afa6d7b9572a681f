#!/usr/bin/env bash
# Synthesizes the rotation stage of oriented nodes (rtl_sim/rtl/rotate_stage.sv) with yosys as bench/rtl_area.sh
# synthesizes the box unit (synth -flatten, check -assert, stat -tech cmos) at a format's widths, and puts its row
# into bench/data/rtl_area.csv, keyed by its parameters ("-GOB=.. -GDB=.. -GMB=.."), where host/cost/cost_model.cpp
# finds the stage's size for an oriented format. Not part of the test suite (a minute or two).
# Usage: bench/rtl_rotate_area.sh [OB DB MB]
#   the widths: origin B+G+F+1, direction D+2, entries rot_bits+2 (default 39 26 14: the default format with
#   rot_bits 12, the widths rtl_sim verilates and tests)
set -euo pipefail
name=rtl_rotate_area.sh
here=$(cd "$(dirname "$0")/.." && pwd)
ob=${1:-39} db=${2:-26} mb=${3:-14}
command -v yosys >/dev/null || { echo "$name: yosys is not installed (scripts/setup.sh installs it)" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cat >"$tmp/s.ys" <<YS
read_verilog -sv $here/rtl_sim/rtl/rotate_stage.sv
chparam -set OB $ob -set DB $db -set MB $mb rotate_stage
synth -flatten -top rotate_stage
check -assert
tee -o $tmp/stat.txt stat -tech cmos
YS
yosys -q "$tmp/s.ys" >"$tmp/yosys.log" 2>&1 || { cat "$tmp/yosys.log" >&2; exit 1; }
cells=$(sed -n 's/^ *Number of cells: *\([0-9]*\)/\1/p' "$tmp/stat.txt" | tail -1)
ffs=$(grep -E '^\s+\$_(S?DFF|DFF)[A-Z_0-9]*\s' "$tmp/stat.txt" | awk '{s+=$2} END{print s+0}')
trans=$(sed -n 's/^ *Estimated number of transistors: *\([0-9+]*\)/\1/p' "$tmp/stat.txt" | tail -1)
key="-GOB=$ob -GDB=$db -GMB=$mb"
area="$here/bench/data/rtl_area.csv"
grep -v "^$key," "$area" >"$tmp/area.csv" || true
echo "$key,$cells,$ffs,${trans%+}" >>"$tmp/area.csv"
cp "$tmp/area.csv" "$area"
echo "$name: $key: $cells cells, $ffs flip-flops, ${trans%+} transistors (est.) -> $area"
