#!/usr/bin/env bash
# The simulator's own speed (bench/results/simulator-speed.md):
# 1. Whole frames: a path-traced frame (SIZE, default 1920x1080, 1 sample per pixel, 3 bounces) of each scene on
#    the timed device: rdna2-chip with its waves (every ray simulated), rdna2-chip with ray_policy=dynamic in full
#    and sampled (--sample FRACTION), and one rdna2 unit in full and sampled (--sample UNIT_FRACTION: one unit's
#    sampler is fastest at 0.01, where its warm-ups are few); the fixed device as the floor (the
#    datapath alone). Per row: rays, frame cycles, render wall time, simulated rays per second per host core
#    (rays / seconds / threads) and, for sampled rows, the error against the same device's full frame.
# 2. The timed device against the fixed device on one TRACE stream (`trace`, 1M camera and 1M incoherent rays of
#    a mesh), each on 1 and 2 host threads: trace seconds (stats `trace_seconds`, best of REPEAT) and ratios.
#
#   bench/simulator_speed.sh [RTUSIM] [SCENE...]     default scenes: the IFC house and builtin:atrium
#   SIZE=1920x1080 FRACTION=0.1 UNIT_FRACTION=0.01 THREADS=2 REPEAT=2 RAYS=1000000 MESH=<the house> (environment)
set -euo pipefail
name=simulator_speed.sh
. "$(dirname "$0")/lib.sh"
bench_scene_args "$bench_house" builtin:atrium -- "$@"
size=${SIZE:-1920x1080}
fraction=${FRACTION:-0.1}
unit_fraction=${UNIT_FRACTION:-0.01}
threads=${THREADS:-2}
repeat=${REPEAT:-2}
rays=${RAYS:-1000000}
mesh=${MESH:-$bench_house}
bench_need_count THREADS "$threads"
bench_need_count REPEAT "$repeat"
bench_need_count RAYS "$rays"
bench_need_python
bench_tmpdir
width=${size%x*}
height=${size#*x}

printf '| scene | device | rays | frame cycles | error | render s | simulated rays / s / core |\n'
printf '|---|---|---:|---:|---:|---:|---:|\n'
for scene in "${scenes[@]}"; do
  base=(render --scene "$scene" --width "$width" --height "$height" --spp 1 --max-depth 3 --threads "$threads")
  declare -A full=()
  for row in "fixed" "rdna2-chip" "rdna2-chip dynamic" "rdna2-chip dynamic $fraction" "rdna2" "rdna2 - $unit_fraction"; do
    read -r dev policy f <<< "$row"
    args=("${base[@]}")
    if [ "$dev" = fixed ]; then
      args+=(--device fixed)
    else
      args+=(--device timed --config "$dev")
      [ "${policy:-}" = dynamic ] && args+=(--set ray_policy=dynamic)
      [ -n "${f:-}" ] && args+=(--sample "$f")
    fi
    "$rtusim" "${args[@]}" --out "$tmp/i.png" --stats "$tmp/s.json" >/dev/null
    n=$(num "['rays_total']" "$tmp/s.json")
    s=$(num "['seconds']" "$tmp/s.json")
    cyc=- err=-
    key=$dev
    [ "${policy:-}" = dynamic ] && key="$dev dynamic"
    if [ "$dev" != fixed ]; then
      cyc=$(num "['timing']['cycles']" "$tmp/s.json")
      if [ -n "${f:-}" ]; then
        err=$(awk -v e="$cyc" -v t="${full[$key]}" 'BEGIN{printf "%+.2f%%", (e - t) / t * 100}')
      else
        full[$key]=$cyc
      fi
    fi
    label=$dev
    [ "${policy:-}" = dynamic ] && label="$label, dynamic"
    [ -n "${f:-}" ] && label="$label, --sample $f"
    awk -v sc="$(basename "$scene")" -v l="$label" -v n="$n" -v c="$cyc" -v e="$err" -v s="$s" -v t="$threads" \
      'BEGIN{printf "| %s | %s | %d | %s | %s | %.2f | %.0f |\n", sc, l, n, c, e, s, n / s / t}'
  done
  unset full
done

printf '\n| mesh | rays | fixed s (1 / 2 threads) | timed s (1 / 2 threads) | timed / fixed speed, 1 thread | timed on 2 / fixed on 1 | timed on 2 / fixed on 2 |\n'
printf '|---|---|---:|---:|---:|---:|---:|\n'
for kind in primary incoherent; do
  "$rtusim" rays --scene "$mesh" --kind "$kind" --count "$rays" --out "$tmp/r.bin" >/dev/null
  declare -A best=()
  for _ in $(seq "$repeat"); do
    for dev in fixed timed; do
      for t in 1 2; do
        "$rtusim" trace --scene "$mesh" --rays "$tmp/r.bin" --device "$dev" --threads "$t" --out "$tmp/h.bin" \
          --stats "$tmp/t.json" >/dev/null
        best[$dev$t]=$(least "${best[$dev$t]:-}" "$(num "['trace_seconds']" "$tmp/t.json")")
      done
    done
  done
  awk -v m="$(basename "$mesh")" -v k="$kind" -v f1="${best[fixed1]}" -v f2="${best[fixed2]}" -v t1="${best[timed1]}" \
    -v t2="${best[timed2]}" 'BEGIN{printf "| %s | %s | %.2f / %.2f | %.2f / %.2f | %.2fx | %.2fx | %.2fx |\n",
      m, k, f1, f2, t1, t2, f1 / t1, f1 / t2, f2 / t2}'
  unset best
done
