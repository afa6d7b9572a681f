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
# shellcheck source=bench/lib.sh
. "$here/bench/lib.sh"
bench_tmpdir
bench_synth_row "$name: " "-GOB=$ob -GDB=$db -GMB=$mb" rotate_stage "$here/rtl_sim/rtl/rotate_stage.sv" OB "$ob" DB "$db" \
  MB "$mb"
