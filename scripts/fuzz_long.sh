#!/usr/bin/env bash
# A long fuzzing run, outside CI: each libFuzzer target of the asan build (tests/fuzz) in turn, one at a time, for
# RTU_FUZZ_LONG_RUNS executions (default 10^6) or RTU_FUZZ_LONG_SECONDS (default 1200 s), whichever comes first,
# with the -max_len of scripts/fuzz_targets.sh, -rss_limit_mb=2048 and -timeout=30 as in CI. New inputs go to
# build/asan/fuzz-long-work/TARGET (the committed corpus is only read), crash reproducers to
# build/asan/fuzz-long-artifacts/, logs to build/asan/fuzz-long-TARGET.log. A crash ends that target's run and the
# script goes on with the next one. The table (target, executions, seconds, exec/s, coverage, crashes, what ended
# the run) replaces the block between the markers of RTU_FUZZ_LONG_OUT (default bench/results/fuzzing.md), with
# the command, date, commit and machine; the rest of that file (the discussion) is kept.
#
# Usage: scripts/fuzz_long.sh [TARGET...]   (default: every target). Builds nothing: first
#   cmake --preset asan && cmake --build --preset fuzz
# It takes a while (up to 6 x 20 min): run it in the background, e.g. nohup scripts/fuzz_long.sh >fuzz_long.log &
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/fuzz_targets.sh

runs=${RTU_FUZZ_LONG_RUNS:-1000000}
seconds=${RTU_FUZZ_LONG_SECONDS:-1200}
out=${RTU_FUZZ_LONG_OUT:-bench/results/fuzzing.md}
targets=("$@")
[[ ${#targets[@]} -gt 0 ]] || targets=("${RTU_FUZZ_TARGETS[@]}")

for t in "${targets[@]}"; do
  if [[ ! -x build/asan/fuzz_$t ]]; then
    echo "fuzz_long: build/asan/fuzz_$t missing (cmake --preset asan && cmake --build --preset fuzz)" >&2
    exit 2
  fi
done

artifacts=build/asan/fuzz-long-artifacts
mkdir -p "$artifacts"
rows=()
crashed=0
started=$(date -u '+%Y-%m-%d %H:%M UTC')
# The commit the targets were built from, as the run starts (later commits do not change what ran).
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
dirty=$(git status --porcelain --untracked-files=no 2>/dev/null | grep -q . && echo " (with uncommitted changes)" || true)
for t in "${targets[@]}"; do
  work=build/asan/fuzz-long-work/$t
  mkdir -p "$work"
  log=build/asan/fuzz-long-$t.log
  max_len=$(rtu_fuzz_max_len "$t")
  echo "fuzz_long: fuzz_$t, up to $runs executions or $seconds s, -max_len=$max_len (log $log)"
  t0=$(date +%s.%N)
  status=0
  build/asan/fuzz_"$t" -runs="$runs" -max_total_time="$seconds" -max_len="$max_len" -rss_limit_mb=2048 \
    -timeout=30 -print_final_stats=1 -artifact_prefix="$artifacts/$t-" "$work" "tests/fuzz/corpus/$t" \
    >"$log" 2>&1 || status=$?
  t1=$(date +%s.%N)
  elapsed=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", b - a }')
  exact=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.3f", b - a }')
  # libFuzzer's final statistics; a run that crashed prints them too (-print_final_stats=1).
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -n 1 | cut -d' ' -f2)
  execs=${execs:-0}
  rate=$(awk -v n="$execs" -v s="$exact" 'BEGIN { printf "%.0f", (s > 0 ? n / s : 0) }')
  if [[ $status -ne 0 ]]; then
    crashes="1: $(grep -o "Test unit written to [^ ]*" "$log" | tail -n 1 | sed 's/Test unit written to //')"
    ended="crash (exit $status)"
    crashed=1
  elif [[ $execs -ge $runs ]]; then
    crashes=0
    ended="$runs executions"
  else
    crashes=0
    ended="the $seconds s cap"
  fi
  echo "fuzz_long: fuzz_$t: $execs executions in $elapsed s ($rate/s), cov $cov, crashes $crashes, ended by $ended"
  rows+=("| \`fuzz_$t\` | $(printf "%'d" "$execs") | $elapsed | $(printf "%'d" "$rate") | ${cov:-?} | $max_len | $crashes | $ended |")
done

cpu=$(sed -n 's/^model name[[:space:]]*: *//p' /proc/cpuinfo | head -n 1)
block=$(
  echo "<!-- fuzz_long.sh: generated block, replaced by each run -->"
  echo "**Command.** \`scripts/fuzz_long.sh${*:+ $*}\` (RTU_FUZZ_LONG_RUNS=$runs, RTU_FUZZ_LONG_SECONDS=$seconds):"
  echo "each target \`build/asan/fuzz_TARGET -runs=$runs -max_total_time=$seconds -max_len=N -rss_limit_mb=2048"
  echo "-timeout=30 WORK tests/fuzz/corpus/TARGET\`, one after the other."
  echo
  echo "**Measured** $started, commit $commit$dirty, on $(nproc) cores: $cpu; $(uname -sr)."
  echo
  echo "| target | executions | seconds | exec/s | coverage (edges) | -max_len (bytes) | crashes | ended by |"
  echo "|---|---:|---:|---:|---:|---:|---|---|"
  printf '%s\n' "${rows[@]}"
  echo "<!-- end of the fuzz_long.sh block -->"
)
if [[ -f $out ]] && grep -q '^<!-- fuzz_long.sh: generated block' "$out"; then
  # Replace the old block, keep the rest.
  awk -v block="$block" '
    /^<!-- fuzz_long.sh: generated block/ { print block; skip = 1; next }
    /^<!-- end of the fuzz_long.sh block -->/ { skip = 0; next }
    !skip { print }' "$out" >"$out.tmp"
  mv "$out.tmp" "$out"
else
  {
    echo "# Fuzzing: long runs"
    echo
    echo "**Question.** Do the fuzz targets find anything in 10^6 executions each, with inputs up to -max_len?"
    echo
    echo "$block"
  } >"$out"
fi
echo "fuzz_long: table written to $out"
exit $crashed
