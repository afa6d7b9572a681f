#!/usr/bin/env bash
# The plotting scripts of bench/ end to end on small inputs: bench/pareto.sh (PNGs per scene and error measure;
# without gnuplot a message and exit 2) and bench/scaling.sh (rows per preset and level, the fits, nodes per ray
# growing with n, the raster cycles and their fit; bad RAYS: exit 2). Usage: check_bench_plots.sh RTUSIM SOURCE_DIR
set -uo pipefail
rtusim=$1
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
check() {  # check DESCRIPTION COMMAND...: fails the test when the command fails
  local what=$1
  shift
  if ! "$@"; then
    echo "FAILED: $what" >&2
    fail=1
  fi
}

"$rtusim" sweep --scene builtin:seed --scene builtin:cornell --formats default,compact,default:coord_bits=12 \
  --rays 500 --image-width 0 --threads 2 --out "$tmp/sweep.csv" >/dev/null || { echo "sweep failed" >&2; exit 1; }

# Without gnuplot on PATH: a message naming the package, exit 2 (PATH holds nothing).
out=$(PATH=/nonexistent /bin/bash "$src/bench/pareto.sh" "$tmp/sweep.csv" "$tmp/nognuplot" "$rtusim" 2>&1)
st=$?
check "pareto.sh without gnuplot exits 2 (got $st)" test "$st" -eq 2
check "pareto.sh without gnuplot names gnuplot-nox: $out" grep -q gnuplot-nox <<<"$out"
# Bad arguments.
"$src/bench/pareto.sh" "$tmp/sweep.csv" >/dev/null 2>&1
check "pareto.sh with one argument exits 2" test $? -eq 2
"$src/bench/pareto.sh" "$tmp/missing.csv" "$tmp/p" "$rtusim" >/dev/null 2>&1
check "pareto.sh on a missing CSV exits 2" test $? -eq 2

if command -v gnuplot >/dev/null; then
  check "pareto.sh runs" "$src/bench/pareto.sh" "$tmp/sweep.csv" "$tmp/pareto" "$rtusim"
  for f in pareto_seed_hit.png pareto_seed_terr.png pareto_cornell_hit.png pareto_cornell_terr.png; do
    check "$f is a PNG" bash -c "head -c 8 '$tmp/pareto/$f' | od -An -tx1 | grep -q '89 50 4e 47 0d 0a 1a 0a'"
  done
  # Every point of a scene is labelled (3 formats: 3 places on the cycles axis at most, each with a label).
  check "labels written" test -s "$tmp/pareto/pareto_seed_hit_cycles.labels"
  check "a front is written" test -s "$tmp/pareto/pareto_seed_terr_cycles.front"
else
  echo "gnuplot not installed: pareto.sh plots not checked" >&2
fi

# Scaling on small levels.
SUBDIVS="1 2 3" PRESETS="rdna2 embedded" THREADS=2 "$src/bench/scaling.sh" "$rtusim" 400 "$tmp/scaling" >/dev/null \
  2>"$tmp/scaling.err"
check "scaling.sh runs: $(cat "$tmp/scaling.err")" test $? -eq 0
check "scaling.csv: header + 2 presets x 3 levels" test "$(wc -l <"$tmp/scaling/scaling.csv")" -eq 7
check "scaling.md has the fits" grep -q "log2(n)" "$tmp/scaling/scaling.md"
check "scaling.md fits the raster cycles" grep -q "slope of log(raster cycles)" "$tmp/scaling/scaling.md"
# The rasterizer's cycles grow with n (it sets up and fetches every triangle); the ray tracer's per ray much less.
check "raster cycles grow with n" awk -F, 'NR > 1 { if ($1 == p && !($12 > prev)) bad = 1; p = $1; prev = $12 } END { exit bad }' \
  "$tmp/scaling/scaling.csv"
# Triangles 80, 320, 1280; nodes per ray grow with n for each preset; the same rays hit at every level.
check "triangle counts" bash -c "cut -d, -f3 '$tmp/scaling/scaling.csv' | sed 1d | tr '\n' ' ' | grep -q '^80 320 1280 80 320 1280 $'"
check "nodes per ray grow with n" awk -F, 'NR > 1 { if ($1 == p && $8 <= prev) bad = 1; p = $1; prev = $8 } END { exit bad }' \
  "$tmp/scaling/scaling.csv"
check "cycles > 0" awk -F, 'NR > 1 && !($6 > 0) { bad = 1 } END { exit bad }' "$tmp/scaling/scaling.csv"
if command -v gnuplot >/dev/null; then
  check "scaling.png written" test -s "$tmp/scaling/scaling.png"
fi
"$src/bench/scaling.sh" "$rtusim" abc "$tmp/s2" >/dev/null 2>&1
check "scaling.sh with RAYS=abc exits 2" test $? -eq 2
SUBDIVS="9" "$src/bench/scaling.sh" "$rtusim" 10 "$tmp/s3" >/dev/null 2>&1
check "scaling.sh with SUBDIVS=9 exits 2" test $? -eq 2
exit $fail
