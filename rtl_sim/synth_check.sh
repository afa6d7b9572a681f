#!/usr/bin/env bash
# Synthesizability check of the box unit (a ctest, label rtl): yosys reads the RTL with a unit's parameters
# (rtu_rtl_params --chparam SPEC), synthesizes it to its coarse netlist (no gate mapping: bench/rtl_area.sh maps
# it for the area) and asserts that `check` finds no problem
# (undriven or multiply-driven nets, combinational loops) and that no latch was inferred.
#   rtl_sim/synth_check.sh YOSYS RTU_RTL_PARAMS RTL_DIR SPEC
set -euo pipefail
yosys=$1 params_tool=$2 rtl=$3 spec=$4
params=$("$params_tool" --chparam "$spec")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cat >"$tmp/s.ys" <<YS
read_verilog -sv $rtl/pipe_delay.sv $rtl/box_core.sv $rtl/box_unit.sv
chparam $params box_unit
synth -flatten -top box_unit -run begin:fine
check -assert
select -assert-none t:\$dlatch t:\$adlatch t:\$dlatchsr
stat
YS
"$yosys" -q -l "$tmp/log" "$tmp/s.ys" >/dev/null
echo "box_unit ($spec: $params) synthesizes (coarse netlist): $(sed -n 's/^ *Number of cells: *//p' "$tmp/log" | tail -1) cells"
