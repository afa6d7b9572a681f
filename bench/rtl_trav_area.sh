#!/usr/bin/env bash
# Area of the whole RTL traversal unit (rtl_sim/trav/trav_unit.sv) per block, beside the energy model's estimate.
# yosys (Debian `yosys`) synthesizes the unit with the parameters rtu_rtl_params derives from each row's timing
# spec (as the Verilator models are built), its box and triangle units read as black boxes; the flattened netlist
# is split by instance and by the registers each flip-flop drives:
#   scheduler      the six oldest-first arbiters (trav_oldest.sv: memory reads, spill writes, box unit, triangle
#                  unit, hit port, free slot)
#   node decode    trav_decode.sv: a node's origin, exponents and offsets into the box unit's inputs
#   slot control   the rest of trav_unit's logic: per-slot next state, the pop search over the short stack, the
#                  child sort, the multiplexers that pick a slot's registers for a unit or a port
#   slot state     flip-flops of each slot's ray, hit and traversal registers
#   buffers        flip-flops of each slot's fetched node or record (the widest read)
#   stack          flip-flops of the short stacks and the pending spills
#   box/tri unit   box_unit.sv and tri_core.sv at the row's parameters, from bench/data/rtl_area.csv (the same
#                  flow; a missing row is synthesized and added)
# It writes one row per design to bench/data/rtl_trav_area.csv (the traversal logic the cost model prices, see
# docs/energy-model.md) and prints the tables of bench/results/rtl-trav-area.md.
#
#   bench/rtl_trav_area.sh [BUILD]     BUILD default build/default (needs rtl_sim/rtu_rtl_params and rtusim)
#   ONLY=LABEL runs that row alone (e.g. ONLY=rdna2_s4).
# Minutes per row (the 32-slot unit's multiplexers); not part of the test suite.
set -euo pipefail
name=rtl_trav_area.sh
build=${1:-build/default}
here=$(cd "$(dirname "$0")/.." && pwd)
# shellcheck source=bench/lib.sh
. "$here/bench/lib.sh"
rtl="$here/rtl_sim/rtl"
trav="$here/rtl_sim/trav"
params_tool="$build/rtl_sim/rtu_rtl_params"
command -v yosys >/dev/null || { echo "$name: yosys is not installed (scripts/setup.sh installs it)" >&2; exit 2; }
[ -x "$params_tool" ] || { echo "$name: $params_tool is missing (build the tree)" >&2; exit 2; }
bench_tmpdir
area_csv="$here/bench/data/rtl_area.csv"
trav_csv="$here/bench/data/rtl_trav_area.csv"
[ -f "$trav_csv" ] || echo "params,control_cells,control_transistors,state_bits,buffer_bits,stack_bits" >"$trav_csv"

# The stat of a selection: cells, flip-flops and transistors (flip-flops carry none in yosys's estimate).
block() {  # block LABEL SELECTION
  printf 'tee -q -o %s/%s.txt stat -tech cmos %s\n' "$tmp" "$1" "$2"
}
stat_of() {  # stat_of LABEL: "cells ffs transistors"
  local f="$tmp/$1.txt"
  printf '%s %s %s\n' "$(sed -n 's/^ *Number of cells: *\([0-9]*\)/\1/p' "$f" | tail -1)" \
    "$(grep -E '^\s+\$_(S?DFF|DFF)[A-Z_0-9]*\s' "$f" | awk '{s+=$2} END{print s+0}')" \
    "$(sed -n 's/^ *Estimated number of transistors: *\([0-9]*\).*/\1/p' "$f" | tail -1)"
}
unit_row() {  # unit_row KEY TOP SV NAME=VALUE...: "cells ffs transistors" of rtl_area.csv's KEY (synthesized if absent)
  local key=$1 top=$2 sv=$3
  shift 3
  if ! grep -q -- "^$key," "$area_csv"; then
    # shellcheck disable=SC2046
    bench_synth_row "  " "$key" "$top" "$sv" $(printf '%s\n' "$@" | tr '=' ' ') >&2
  fi
  grep -- "^$key," "$area_csv" | tail -1 | awk -F, '{print $2, $3, $4}'
}

printf '| design | slots | stack | N | block | cells | flip-flops | transistors (est.) |\n'
printf '|---|---:|---:|---:|---|---:|---:|---:|\n'
summary=""
while read -r label spec; do
  [ -z "$label" ] && continue
  [ -n "${ONLY:-}" ] && [ "$label" != "$ONLY" ] && continue
  gparams=$("$params_tool" rdna2 --trav "$label=$spec" | sed -n "s/^trav:$label: //p")
  [ -n "$gparams" ] || { echo "$name: no parameters for $label=$spec" >&2; exit 1; }
  get() { sed -n "s/.*-G$1=\([0-9]*\).*/\1/p" <<<"$gparams"; }
  slots=$(get SLOTS) stack=$(get STACK) n=$(get N)
  cat >"$tmp/s.ys" <<EOF
read_verilog -sv $trav/trav_oldest.sv $trav/trav_decode.sv $trav/trav_unit.sv
read_verilog -sv -lib $rtl/box_unit.sv $rtl/tri_core.sv
chparam $(sed -E 's/-G([A-Z_]+)=([0-9]+)/-set \1 \2/g' <<<"$gparams") trav_unit
synth -top trav_unit
flatten
check -assert
select -assert-none t:\$_DLATCH_*
$(block scheduler 'c:*_arb.*')
$(block decode 'c:*u_decode.*')
$(block control 't:* t:*DFF* %d c:*_arb.* %d c:*u_decode.* %d t:box_unit %d t:tri_core %d')
$(block stack 'w:sref* w:sdist* w:sp_ent* %u %u %ci1:+[Q] t:*DFF* %i')
$(block buffers 'w:data* %ci1:+[Q] t:*DFF* %i')
$(block state 't:*DFF* w:sref* w:sdist* w:sp_ent* w:data* %u %u %u %ci1:+[Q] t:*DFF* %i %d')
EOF
  t0=$(date +%s)
  yosys -q "$tmp/s.ys" >"$tmp/yosys.log" 2>&1 || { cat "$tmp/yosys.log" >&2; exit 1; }
  secs=$(( $(date +%s) - t0 ))
  box_key="-GN=$n -GLANES=$(get LANES) -GK=$(get K) -GA=$(get A) -GM=$(get M) -GTB=$(get TB) -GSHW=$(get SHW)"
  box_key+=" -GRSH=$(get RSH) -GLSH=$(get LSH) -GLATENCY=$(get BOX_LAT)"
  tri_key="-GB=$(get B) -GA=$(get A) -GF=$(get F) -GD=$(get D) -GTB=$(get TB) -GS=$(get S) -GLATENCY=$(get TRI_LAT)"
  # shellcheck disable=SC2046
  read -r bc bf bt <<<"$(unit_row "$box_key" box_unit "$rtl/pipe_delay.sv $rtl/box_core.sv $rtl/box_unit.sv" \
    $(sed 's/-G//g' <<<"$box_key"))"
  # shellcheck disable=SC2046
  read -r tc tf tt <<<"$(unit_row "$tri_key" tri_core "$rtl/tri_core.sv" $(sed 's/-G//g' <<<"$tri_key"))"
  tot_c=0 tot_f=0 tot_t=0
  for b in scheduler decode control state buffers stack box tri; do
    case $b in
      box) c=$bc f=$bf t=$bt what="box unit (box_unit.sv)" ;;
      tri) c=$tc f=$tf t=$tt what="triangle unit (tri_core.sv)" ;;
      *) read -r c f t <<<"$(stat_of $b)"
         case $b in
           scheduler) what="scheduler (6 arbiters)" ;; decode) what="node decode" ;;
           control) what="slot control" ;; state) what="slot state" ;;
           buffers) what="node/record buffers" ;; stack) what="short stack + spill buffer" ;;
         esac ;;
    esac
    printf '| %s | %s | %s | %s | %s | %s | %s | %s |\n' "$label" "$slots" "$stack" "$n" "$what" "$c" "$f" "$t"
    tot_c=$((tot_c + c)) tot_f=$((tot_f + f)) tot_t=$((tot_t + t))
    eval "${b}_c=$c ${b}_f=$f ${b}_t=$t"
  done
  printf '| %s | %s | %s | %s | **whole unit** | %s | %s | %s |\n' "$label" "$slots" "$stack" "$n" "$tot_c" "$tot_f" "$tot_t"
  # shellcheck disable=SC2154
  ctl_c=$((scheduler_c + decode_c + control_c)) ctl_t=$((scheduler_t + decode_t + control_t))
  grep -v -- "^$gparams," "$trav_csv" >"$tmp/trav.csv" || true
  # shellcheck disable=SC2154
  echo "$gparams,$ctl_c,$ctl_t,$state_f,$buffers_f,$stack_f" >>"$tmp/trav.csv"
  cp "$tmp/trav.csv" "$trav_csv"
  # The energy model's view of the same design (its area report: slot SRAM, units; no traversal logic).
  # shellcheck disable=SC2046
  model=$("$build/rtusim" config --config "$(cut -d: -f1 <<<"$spec")" $(tr ':' '\n' <<<"$spec" | tail -n +2 |
    sed 's/^/--set /') --energy | awk '
      /^box unit/ {for (i = 1; i <= NF; i++) if ($i == "mm^2") box = $(i - 1)}
      /^tri unit/ {for (i = 1; i <= NF; i++) if ($i == "mm^2") tri = $(i - 1)}
      /^SRAM:/ {for (i = 1; i <= NF; i++) if ($i == "mm^2;") slots = $(i - 1)}
      END {printf "%s | %s | %s", slots, box, tri}')
  summary+="| $label | $slots | $stack | $((state_f + buffers_f + stack_f)) | $(awk "BEGIN{printf \"%.0f\", $ctl_t/4}") | $model | $secs |"$'\n'
done <<'ROWS'
rdna2_s4 rdna2:ray_slots=4
rdna2_s16 rdna2:ray_slots=16
rdna2_s32 rdna2:ray_slots=32
rdna2_s16_st2 rdna2:ray_slots=16:stack_entries=2
wide8_s4 rdna2:format=wide8:bvh_width=8:ray_slots=4
ROWS
printf '\n| design | slots | stack | RTL state bits | RTL traversal logic (NAND2 eq.) | model slot SRAM mm^2 | model box mm^2 | model tri mm^2 | yosys s |\n'
printf '|---|---:|---:|---:|---:|---:|---:|---:|---:|\n'
printf '%s' "$summary"
