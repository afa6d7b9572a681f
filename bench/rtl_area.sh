#!/usr/bin/env bash
# Area of the RTL ray-box unit (rtl_sim/rtl/box_unit.sv) against the error of its format: yosys (Debian `yosys`)
# synthesizes the unit with the widths the C++ model derives for each row (rtu_rtl_params --chparam) to its
# generic gate library and reports cells, flip-flops and yosys's CMOS transistor estimate (`stat -tech cmos`);
# `rtusim compare` measures the same format's error against the float reference on one real mesh. Rows vary the
# coordinate bits B, the child-offset bits k, the lanes (box tests per clock) and the node width. Lanes change
# area and clocks per node, never a result, so their error columns repeat. Prints a Markdown table (bench/results/rtl-area.md).
#
#   bench/rtl_area.sh [BUILD] [RAYS] [MESH]
#     BUILD  default build/default (needs rtusim and rtl_sim/rtu_rtl_params);  RAYS  incoherent rays, 300000
#     MESH   default the IFC house of assimp-testmodels
#   ONLY=LABEL runs that row alone (e.g. ONLY=intel).
#   RTL_AREA_CSV=FILE also writes FILE with params,cells,flip_flops,transistors per unit (the Verilator -G
#   options as key), the table `rtusim sweep --area` reads (bench/data/rtl_area.csv is this script's output).
# Takes minutes per row (yosys's abc on the multipliers); not part of the test suite.
set -euo pipefail
build=${1:-build/default}
rays=${2:-300000}
mesh=${3:-/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc}
here=$(cd "$(dirname "$0")/.." && pwd)
name=rtl_area.sh
# shellcheck source=bench/lib.sh
. "$here/bench/lib.sh"
rtl="$here/rtl_sim/rtl"
command -v yosys >/dev/null || { echo "rtl_area.sh: yosys is not installed (scripts/setup.sh installs it)" >&2; exit 1; }
bench_tmpdir

get() {  # get KEY FILE: a top-level number of the compare JSON (one key per line)
  sed -n "s/^  \"$1\": \([-0-9.e+]*\),*$/\1/p" "$2" | head -1
}

csv=${RTL_AREA_CSV:-}
[ -n "$csv" ] && echo "params,cells,flip_flops,transistors" >"$csv"
printf '| unit | format | N | lanes | cells | flip-flops | transistors (est.) | hit agreement | t rel err mean | node overhead | yosys s |\n'
printf '|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n'
while read -r label spec fmtkeys cmpopts; do
  [ -z "$label" ] && continue
  [ -n "${ONLY:-}" ] && [ "$label" != "$ONLY" ] && continue
  keys=${fmtkeys//,/ }
  [ "$keys" = "-" ] && keys=""
  # shellcheck disable=SC2086
  params=$("$build/rtl_sim/rtu_rtl_params" --chparam "$spec" $keys)
  cat >"$tmp/s.ys" <<EOF
read_verilog -sv $rtl/pipe_delay.sv $rtl/box_core.sv $rtl/box_unit.sv
chparam $params box_unit
synth -flatten -top box_unit
check -assert
tee -o $tmp/stat.txt stat -tech cmos
EOF
  bench_yosys_stat "$tmp/s.ys"
  [ -n "$csv" ] && echo "$(sed -E 's/-set ([A-Z]+) ([0-9]+)/-G\1=\2/g' <<<"$params"),$cells,$ffs,${trans%+}" >>"$csv"
  n=$(sed -n 's/.*-set N \([0-9]*\).*/\1/p' <<<"$params")
  lanes=$(sed -n 's/.*-set LANES \([0-9]*\).*/\1/p' <<<"$params")
  # shellcheck disable=SC2086
  "$build/rtusim" compare --scene "$mesh" --rays "incoherent:$rays" $cmpopts --json "$tmp/c.json" >/dev/null
  printf '| %s | %s | %s | %s | %s | %s | %s | %.4f%% | %.2g | %+.2f%% | %s |\n' "$label" "${fmtkeys//,/ }" "$n" "$lanes" \
    "$cells" "$ffs" "$trans" "$(awk "BEGIN{print 100*$(get hit_agreement "$tmp/c.json")}")" \
    "$(get t_rel_error_mean "$tmp/c.json")" "$(awk "BEGIN{print 100*$(get node_visit_overhead "$tmp/c.json")}")" \
    "$secs"
done <<'ROWS'
rdna2 rdna2 - --format default --bvh-width 4
rdna2,B=12 rdna2 coord_bits=12 --coord-bits 12 --bvh-width 4
rdna2,B=16 rdna2 coord_bits=16 --coord-bits 16 --bvh-width 4
rdna2,B=20 rdna2 coord_bits=20 --coord-bits 20 --bvh-width 4
rdna2,k=4 rdna2 child_bits=4 --child-bits 4 --bvh-width 4
rdna2,lanes=2 rdna2:box_rate=2 - --format default --bvh-width 4
rdna2,lanes=1 rdna2:box_rate=1 - --format default --bvh-width 4
embedded embedded - --format compact --bvh-width 4
intel intel - --format xe6 --bvh-width 6
intel,N=8 intel:format=wide8:bvh_width=8 - --format wide8 --bvh-width 8
ROWS
