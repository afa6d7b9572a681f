#!/usr/bin/env bash
# The timing model held against the RTL traversal unit (rtl_sim/trav/trav_unit.sv) under Verilator, packet by
# packet: per mesh x {camera, incoherent, shadow} x the verilated width-4 units (4, 16 and 32 ray slots; 16 slots
# with a 2-entry stack; 16 slots with 2 box lanes) x {memory "cache": rdna2's 64 KiB cache and DRAM, "dram":
# rdna2-mem's 16 KiB cache and 600-cycle, 3.2 B/clock DRAM}, the mean absolute and largest error of the model's
# cycles and the correlation over all packets (Accel-Sim's terms); then the design sweep (20 designs: the 5 units x
# 4 memories) ranked by both (Kendall's tau) with each design's speed-up over the first. The model runs with
# fetch_port_rate=1 (the unit's port), and once more with RTU_TRAV_PORT=0 (no port limit) for comparison.
#
#   bench/rtl_correlation.sh [BENCH] [RAYS] [MESH...]
#     BENCH  default build/default/rtl_sim/rtu_rtl_trav_bench (not built by default: cmake --build --preset
#     default --target rtu_rtl_trav_bench);  RAYS  rays per packet, default 256 (3 packets a
#     group);  MESH  default the house and engine assimp-testmodels meshes (the sweep: the first)
# Prints Markdown.
set -euo pipefail
source "$(dirname "$0")/lib.sh"  # sets name to rtl_correlation.sh
bench_split_args 2 "$bench_house" "$bench_engine" -- "$@"
bench=${bench_lead[0]:-build/default/rtl_sim/rtu_rtl_trav_bench}
rays=${bench_lead[1]:-256}
[ -x "$bench" ] || { echo "$name: $bench is not an executable (build it: cmake --build --preset default --target rtu_rtl_trav_bench)" >&2; exit 2; }
bench_need_count RAYS "$rays"
for mesh in "${bench_list[@]}"; do [ -r "$mesh" ] || { echo "$name: cannot read $mesh" >&2; exit 2; }; done
echo "## Per packet (model with fetch_port_rate=1)"
echo
"$bench" correlate "$rays" 3 "${bench_list[@]}"
echo
echo "## The design sweep (incoherent rays, $((rays * 2)) a design, ${bench_list[0]##*/})"
echo
"$bench" rank "$((rays * 2))" "${bench_list[0]}"
echo
echo "## Without the port limit (model fetch_port_rate=0): summaries"
echo
RTU_TRAV_PORT=0 "$bench" correlate "$rays" 3 "${bench_list[@]}" | grep -E "^All|^Simulated"
RTU_TRAV_PORT=0 "$bench" rank "$((rays * 2))" "${bench_list[0]}" | grep -E "designs:"
