#!/usr/bin/env bash
# Area of the RTL triangle test unit (rtl_sim/rtl/tri_core.sv): yosys (Debian `yosys`) synthesizes the unit with
# the widths and latency the C++ model derives for each row (rtu_rtl_params --chparam-tri: the preset's format
# and tri_latency) to its generic gate library and reports cells, flip-flops and yosys's CMOS transistor
# estimate (`stat -tech cmos`), as bench/rtl_area.sh does for the box unit. Prints a Markdown table
# (bench/results/rtl-area.md, "The triangle unit").
#
#   bench/rtl_tri_area.sh [BUILD]     BUILD default build/default (needs rtl_sim/rtu_rtl_params)
#   ONLY=LABEL runs that row alone (e.g. ONLY=embedded).
# Takes minutes per row (yosys's abc on the wide multipliers and the divider); not part of the test suite.
set -euo pipefail
name=rtl_tri_area.sh
build=${1:-build/default}
here=$(cd "$(dirname "$0")/.." && pwd)
# shellcheck source=bench/lib.sh
. "$here/bench/lib.sh"
rtl="$here/rtl_sim/rtl"
command -v yosys >/dev/null || { echo "$name: yosys is not installed (scripts/setup.sh installs it)" >&2; exit 2; }
[ -x "$build/rtl_sim/rtu_rtl_params" ] || { echo "$name: $build/rtl_sim/rtu_rtl_params is missing (build the tree)" >&2; exit 2; }
bench_tmpdir

printf '| unit | format | latency | divider | cells | flip-flops | transistors (est.) | yosys s |\n'
printf '|---|---|---:|---|---:|---:|---:|---:|\n'
while read -r label spec fmtkeys; do
  [ -z "$label" ] && continue
  [ -n "${ONLY:-}" ] && [ "$label" != "$ONLY" ] && continue
  keys=${fmtkeys//,/ }
  [ "$keys" = "-" ] && keys=""
  # shellcheck disable=SC2086
  params=$("$build/rtl_sim/rtu_rtl_params" --chparam-tri "$spec" $keys)
  cat >"$tmp/s.ys" <<YS
read_verilog -sv $rtl/tri_core.sv
chparam $params tri_core
synth -flatten -top tri_core
check -assert
select -assert-none t:\$_DLATCH_*
tee -o $tmp/stat.txt stat -tech cmos
YS
  bench_yosys_stat "$tmp/s.ys"
  lat=$(sed -n 's/.*-set LATENCY \([0-9]*\).*/\1/p' <<<"$params")
  tb=$(sed -n 's/.*-set TB \([0-9]*\).*/\1/p' <<<"$params")
  s=$(sed -n 's/.*-set S \([0-9]*\).*/\1/p' <<<"$params")
  qw=$(( tb > s ? tb + 1 : s + 1 )) ds=$(( lat - 5 ))
  printf '| %s | %s | %s | %s stages x %s bits | %s | %s | %s | %s |\n' "$label" "${fmtkeys//,/ }" "$lat" "$ds" \
    "$(( (qw + ds - 1) / ds ))" "$cells" "$ffs" "$trans" "$secs"
done <<'ROWS'
rdna2 rdna2 -
embedded embedded -
ROWS
