#!/usr/bin/env bash
# Sampled timing against full simulation: `rtusim trace --device timed --sample F` on 1M primary and 1M incoherent
# rays of real meshes, with hits (every ray traced by the datapath, the timing model sampled; the estimator's
# auxiliary is each unit's work from its test counts) and cycles only (no --out: only the sampled rays are traced;
# the auxiliary of the units not measured comes from a 1-in-32 probe). Error of the estimate against the full
# simulation's cycles, the 95% interval the estimate states, and the timed device's trace time (stats
# `trace_seconds`, excluding scene load and BVH build) against the full simulation's, each the best of REPEAT
# runs (the cycles do not change from run to run; the time does, on a shared machine); each repetition runs the
# full and then the sampled simulations, so both times come from the same stretches of the machine's speed.
# Prints a Markdown table (bench/results/sampled-timing.md).
#
#   bench/sample_bench.sh [RTUSIM] [RAYS] [MESH...]     RAYS default 1000000; trace packets are 262,144 rays
#   FRACTIONS="0.05 0.02" MODES="hits cycles-only" REPEAT=3 THREADS=1 SEEDS=1 (environment): the sample fractions
#   and modes measured, the runs each time is the best of, rtusim's --threads for both the full and the sampled
#   simulation (the full one records the next chunk of rays while the model replays this one when it has two
#   threads; the sampled one runs its short segments on one), so that both get the same cores, and the number
#   of samples (--sample-seed 1 .. SEEDS) whose errors are summarized: one sample's error says little about an
#   estimator, the spread over many does (mean error, root mean square error, mean and largest |error|, how
#   many lay beyond 2% and how many inside their 95% interval)
set -euo pipefail
source "$(dirname "$0")/lib.sh"  # the meshes, bench_tmpdir, num and least
rtusim=${1:-build/default/rtusim}
rays=${2:-1000000}
shift $(( $# > 2 ? 2 : $# ))
meshes=("$@")
read -r -a fractions <<< "${FRACTIONS:-0.05 0.02}"
read -r -a modes <<< "${MODES:-hits cycles-only}"
repeat=${REPEAT:-3}
threads=${THREADS:-1}
seeds=${SEEDS:-1}
[ ${#meshes[@]} -gt 0 ] || meshes=("$bench_house" "$bench_engine" "$bench_suzanne")
bench_tmpdir

run() {  # run STATS ARGS...: one rtusim run; prints its trace_seconds
  local stats=$1
  shift
  "$rtusim" "$@" --threads "$threads" --stats "$stats" >/dev/null
  num "['trace_seconds']" "$stats"
}

if [ "$seeds" -gt 1 ]; then
  printf '| mesh | rays | mode | sample | cycles (full) | estimate | error | 95%% interval | rays simulated | trace s (full / sampled) | speed-up | seeds | mean error | rms error | mean / max abs error | beyond 2%% | in interval |\n'
  printf '|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n'
else
  printf '| mesh | rays | mode | sample | cycles (full) | estimate | error | 95%% interval | rays simulated | trace s (full / sampled) | speed-up |\n'
  printf '|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n'
fi
for mesh in "${meshes[@]}"; do
  base=$(basename "$mesh")
  for kind in primary incoherent; do
    "$rtusim" rays --scene "$mesh" --kind "$kind" --count "$rays" --out "$tmp/r.bin" >/dev/null
    # Each repetition runs the full simulation and then every sampled one, so that the full and the sampled
    # times are taken in the same stretch of the machine's speed; each is the best of its REPEAT runs.
    configs=()
    for mode in "${modes[@]}"; do for f in "${fractions[@]}"; do configs+=("$mode:$f"); done; done
    full_s=
    declare -A s_s=()
    for _ in $(seq "$repeat"); do
      t=$(run "$tmp/full.json" trace --scene "$mesh" --rays "$tmp/r.bin" --device timed --out "$tmp/h.bin")
      full_s=$(least "$full_s" "$t")
      for c in "${configs[@]}"; do
        mode=${c%%:*} f=${c#*:}
        out=(--out "$tmp/h2.bin")
        [ "$mode" = cycles-only ] && out=()
        t=$(run "$tmp/s_$c.json" trace --scene "$mesh" --rays "$tmp/r.bin" --device timed --sample "$f" "${out[@]}")
        s_s[$c]=$(least "${s_s[$c]:-}" "$t")
      done
    done
    full=$(num "['timing']['cycles']" "$tmp/full.json")
    for c in "${configs[@]}"; do
      mode=${c%%:*} f=${c#*:}
      est=$(num "['timing']['cycles']" "$tmp/s_$c.json")
      ci=$(num "['timing']['sample']['cycles_ci95']" "$tmp/s_$c.json")
      simf=$(num "['timing']['sample']['simulated_fraction']" "$tmp/s_$c.json")
      # Further samples (seeds 2 .. SEEDS): their estimates and intervals only.
      errs="$est:$ci"
      for seed in $(seq 2 "$seeds"); do
        out=(--out "$tmp/h2.bin")
        [ "$mode" = cycles-only ] && out=()
        "$rtusim" trace --scene "$mesh" --rays "$tmp/r.bin" --device timed --sample "$f" --sample-seed "$seed" \
          "${out[@]}" --threads "$threads" --stats "$tmp/seed.json" >/dev/null
        errs="$errs $(num "['timing']['cycles']" "$tmp/seed.json"):$(num "['timing']['sample']['cycles_ci95']" "$tmp/seed.json")"
      done
      awk -v b="$base" -v k="$kind" -v m="$mode" -v f="$f" -v full="$full" -v est="$est" -v ci="$ci" \
        -v simf="$simf" -v fs="$full_s" -v ss="${s_s[$c]}" -v seeds="$seeds" -v errs="$errs" 'BEGIN{
          printf "| %s | %s | %s | %g | %d | %d | %+.2f%% | +-%.1f%% | %.1f%% | %.2f / %.2f | %.1fx |",
            b, k, m, f, full, est, 100*(est-full)/full, 100*ci/full, 100*simf, fs, ss, fs/ss
          if (seeds > 1) {
            n = split(errs, e, " "); sum = 0; sgn = 0; sq = 0; mx = 0; inside = 0; beyond = 0
            for (i = 1; i <= n; i++) {
              split(e[i], p, ":"); a = p[1] - full; sgn += a; sq += a * a; if (a < 0) a = -a
              sum += a; if (a > mx) mx = a; if (a <= p[2]) inside++; if (a > 0.02 * full) beyond++
            }
            printf " %d | %+.2f%% | %.2f%% | %.2f%% / %.2f%% | %d | %d of %d |", n, 100*sgn/n/full,
              100*sqrt(sq/n)/full, 100*sum/n/full, 100*mx/full, beyond, inside, n
          }
          printf "\n" }'
    done
  done
done
