#!/usr/bin/env bash
# Sets up (Debian packages), builds the `default` preset and runs every test; then the sanitizer stage, one build
# of the `asan` preset (clang: AddressSanitizer + UndefinedBehaviorSanitizer + LeakSanitizer, with libFuzzer's
# coverage instrumentation so that the same build holds the fuzz targets). It builds only what it runs (rtusim,
# test_hwmodel, test_host, test_firmware, test_fuzz_corpus, the fuzz targets) and runs:
#  1. the test suite but the tests labelled `*-scale` (tagged [scale]: the same code paths again at large scale,
#     10^5-10^6 rays or random cases, big sweeps, long timing comparisons, and the scripts bench_plots,
#     unit_rates, report_browser, slurm_sweep), the Embree oracle, the RTL (Verilator models) and the Python
#     module: the preset builds none of the last three. So every parser and check of untrusted input (scene and
#     mesh files, textures, ray files, scene images, command packets, configurations, limits), every error path
#     of the command line and the unit tests of the datapath and timing model run under the sanitizers; the
#     default stage runs all of it again and the rest. tests/README.md, "Under the sanitizers", lists what is
#     left out and the test under ASan that runs the same code;
#  2. `rtusim soak` for RTU_SOAK_ITERATIONS (default 300) iterations from seed 1: random scenes and formats
#     traced and rendered twice, identical bits and cycles, no leak;
#  3. each libFuzzer target of tests/fuzz, as many at once as there are cores, for a fixed number of inputs from a
#     fixed seed (RTU_FUZZ_SEED) over its committed corpus, so that the same commit gets the same verdict on
#     every run: a crash, leak, timeout (30 s) or an input needing over 2 GiB fails the run and leaves the
#     reproducer in build/asan/fuzz-artifacts/.
#     Executions per target: build/asan/fuzz-summary.txt. Each target's input count and -max_len are in
#     scripts/fuzz_targets.sh. Open-ended runs: scripts/fuzz_long.sh, outside CI; what it finds becomes a seed.
# RTU_SKIP_ASAN=1 skips the sanitizer stage. Usage: scripts/test.sh [ctest args]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
# ccache (CMakeLists.txt uses it when installed): paths relative to the clone, so that any clone of the same
# sources hits the same cache entries.
export CCACHE_BASEDIR=$PWD CCACHE_NOHASHDIR=true
cmake --preset default >/dev/null
cmake --build --preset default -j "$(nproc)"
ctest --preset default "$@"

if [[ "${RTU_SKIP_ASAN:-0}" == 1 ]]; then
  exit 0
fi
# The sanitizers' options are compiled into the build's executables (tests/fuzz/sanitizer_options.cpp).
cmake --preset asan >/dev/null
cmake --build --preset asan -j "$(nproc)"
ctest --preset asan
# A fixed set of iterations (seeds 1..N), not a time budget: the same scenes on every run, however fast the machine.
# One process on one core: it runs beside the first fuzz target (below), its status to a file.
soak_status=build/asan/soak.status
rm -f "$soak_status"
(
  status=0
  build/asan/rtusim soak --seconds 1e6 --iterations "${RTU_SOAK_ITERATIONS:-300}" --seed 1 \
    --json build/asan/soak.json >build/asan/soak.log 2>&1 || status=$?
  echo "$status" >"$soak_status"
) &

mkdir -p build/asan/fuzz-artifacts
: >build/asan/fuzz-summary.txt
rm -f build/asan/fuzz-*.status
source scripts/fuzz_targets.sh
# One target's run: a fixed number of inputs from a fixed seed over the committed corpus, into an emptied work
# folder, with the corpus reloaded never, address-space randomisation off (setarch -R) and the same environment
# and relative arguments on every run (env -i): where the heap and the stack land then does not change, nor with
# it the branches pointer-keyed containers take, so libFuzzer keeps the same inputs and makes the same ones next,
# on every run of a commit from the same place: the verdict is the commit's. Its exit status goes to a file.
fuzz_one() {
  local target=$1 work=build/asan/fuzz-work/$1 log=build/asan/fuzz-$1.log status=0
  rm -rf "$work"
  mkdir -p "$work"
  env -i PATH=/usr/bin:/bin setarch "$(uname -m)" -R "build/asan/fuzz_$target" -runs="$(rtu_fuzz_runs "$target")" \
    -seed="$RTU_FUZZ_SEED" -reload=0 -rss_limit_mb=2048 -malloc_limit_mb=2048 \
    -timeout=30 -max_len="$(rtu_fuzz_max_len "$target")" -print_final_stats=1 \
    -artifact_prefix="build/asan/fuzz-artifacts/$target-" "$work" "tests/fuzz/corpus/$target" >"$log" 2>&1 ||
    status=$?
  echo "$status" >"build/asan/fuzz-$target.status"
}
# As many targets at once as the machine has cores (each libFuzzer run is one process on one core; run one after
# another they left the second core idle for 2.4 min). Each run is the same as alone: its own inputs, seed and
# work folder. The results are reported in the order of RTU_FUZZ_TARGETS once all have finished.
for target in "${RTU_FUZZ_TARGETS[@]}"; do
  while (($(jobs -rp | wc -l) >= $(nproc))); do
    wait -n || true
  done
  fuzz_one "$target" &
done
wait
failed=0
cat build/asan/soak.log
if [[ "$(cat "$soak_status" 2>/dev/null)" != 0 ]]; then
  echo "rtusim soak: FAILED (log build/asan/soak.log)" >&2
  failed=1
fi
for target in "${RTU_FUZZ_TARGETS[@]}"; do
  log=build/asan/fuzz-$target.log
  if [[ "$(cat "build/asan/fuzz-$target.status" 2>/dev/null)" != 0 ]]; then
    tail -n 60 "$log"
    echo "fuzz_$target: FAILED (reproducer in build/asan/fuzz-artifacts/, log $log)" >&2
    failed=1
    continue
  fi
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -n 1)
  echo "fuzz_$target: $execs executions (seed $RTU_FUZZ_SEED), $cov, no crash" | tee -a build/asan/fuzz-summary.txt
done
exit "$failed"
