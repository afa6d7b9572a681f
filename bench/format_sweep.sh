#!/usr/bin/env bash
# Error and overhead of the fixed device against the float reference, per format: `rtusim compare` on identical
# rays for a sweep of coordinate bits and of child-box bits. Prints a Markdown table (the one in README.md).
#
#   bench/format_sweep.sh [RTUSIM] [RAYS] [MESH...]
#     RTUSIM  default build/default/rtusim;  RAYS  rays per kind (primary and incoherent), default 1000000
set -euo pipefail
source "$(dirname "$0")/lib.sh"  # sets name to format_sweep.sh
bench_mesh_args 1000000 "$bench_engine" "$bench_suzanne" -- "$@"
bench_tmpdir

get() {  # get KEY FILE: a top-level number of the compare JSON (one key per line)
  sed -n "s/^  \"$1\": \([-0-9.e+]*\),*$/\1/p" "$2" | head -1
}

printf '| mesh | rays | format | hit agreement | prim agreement | false miss / hit | t rel err mean / max | node / prim overhead | box false neg. |\n'
printf '|---|---|---|---:|---:|---:|---:|---:|---:|\n'
for mesh in "${meshes[@]}"; do
  base=$(basename "$mesh")
  for kind in primary incoherent; do
    while read -r label opts; do
      # shellcheck disable=SC2086
      "$rtusim" compare --scene "$mesh" --rays "$kind:$rays" $opts --json "$tmp/c.json" >/dev/null
      f="$tmp/c.json"
      printf '| %s | %s | %s | %.4f%% | %.4f%% | %s / %s | %.2g / %.2g | %+.2f%% / %+.2f%% | %s |\n' \
        "$base" "$kind" "$label" \
        "$(awk "BEGIN{print 100*$(get hit_agreement "$f")}")" "$(awk "BEGIN{print 100*$(get prim_agreement "$f")}")" \
        "$(get false_misses "$f")" "$(get false_hits "$f")" \
        "$(get t_rel_error_mean "$f")" "$(get t_rel_error_max "$f")" \
        "$(awk "BEGIN{print 100*$(get node_visit_overhead "$f")}")" "$(awk "BEGIN{print 100*$(get prim_test_overhead "$f")}")" \
        "$(get box_false_negatives "$f")"
    done <<'ROWS'
B=12,k=8 --coord-bits 12
B=16,k=8 --coord-bits 16
B=20,k=8 --coord-bits 20
default(B=24,k=8) --format default
B=28,k=8 --coord-bits 28
B=24,k=4 --child-bits 4
B=24,k=6 --child-bits 6
B=24,k=12 --child-bits 12
compact --format compact
precise --format precise
ROWS
  done
done
