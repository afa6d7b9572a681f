#!/usr/bin/env bash
# Sampled timing of whole renders, as Zatel (ISPASS 2024) states its accuracy: path-traced frames of the benchmark
# suite's scenes at 512x512 and 2 samples per pixel (3 bounces), each rendered on the timed device in full and then
# with --sample F for SEEDS seeds, on one unit (rdna2) and on a chip of 80 (rdna2-chip with ray_policy=dynamic: a
# chip samples only when its waves go to whichever unit asks, sampler.h), each at its own fraction. For each scene
# and device: the full
# frame's cycles (the TRACE packets'), the sampled estimates' mean and mean absolute error, the largest error, how
# many of the seeds' 95% intervals hold the full figure, the share of rays the timing model simulated, the render's
# wall time full and sampled (best of the seeds' runs; this shared machine's speed moves +-20-40%) and their ratio.
# Every sampled image is compared with the full render's, byte for byte (a column says whether all were equal).
#
#   bench/render_sampling.sh [RTUSIM] [SCENE...]     default scenes: atrium seed cornell FZK-Haus 2CylinderEngine
#   SEEDS=3 SIZE=512 SPP=2 DEPTH=3 DEVICES="rdna2:0.01 rdna2-chip:0.1" (environment: each device with its --sample
#   fraction; one unit's sampler is fastest at 0.01, where its warm-ups are few, a chip's needs 0.1 to measure
#   four bursts in a packet)
#
# Prints a Markdown table (bench/results/sampled-timing.md, "Renders").
set -euo pipefail
name=render_sampling.sh
. "$(dirname "$0")/lib.sh"
bench_scene_args builtin:atrium builtin:seed builtin:cornell "$bench_house" "$bench_engine" -- "$@"
seeds=${SEEDS:-3}
size=${SIZE:-512}
spp=${SPP:-2}
depth=${DEPTH:-3}
read -r -a devices <<< "${DEVICES:-rdna2:0.01 rdna2-chip:0.1}"
bench_need_count SEEDS "$seeds"
bench_need_python
bench_tmpdir

printf '| scene | device | sample | rays | cycles (full) | seeds | mean error | mean abs error | max abs error | in 95%% interval | rays simulated | render s (full / sampled) | speed-up | image |\n'
printf '|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n'
for scene in "${scenes[@]}"; do
  for d in "${devices[@]}"; do
    dev=${d%%:*} fraction=${d#*:}
    args=(render --scene "$scene" --device timed --config "$dev" --width "$size" --height "$size" --spp "$spp"
          --max-depth "$depth")
    case $dev in *-chip) args+=(--set ray_policy=dynamic) ;; esac
    "$rtusim" "${args[@]}" --out "$tmp/full.png" --stats "$tmp/full.json" >/dev/null
    full=$(num "['timing']['cycles']" "$tmp/full.json")
    rays=$(num "['rays_total']" "$tmp/full.json")
    full_s=$(num "['seconds']" "$tmp/full.json")
    stats=() best= same=yes
    for s in $(seq "$seeds"); do
      "$rtusim" "${args[@]}" --sample "$fraction" --sample-seed "$s" --out "$tmp/s.png" --stats "$tmp/s.json" >/dev/null
      cmp -s "$tmp/full.png" "$tmp/s.png" || same=no
      est=$(num "['timing']['cycles']" "$tmp/s.json")
      ci=$(num "['timing']['sample']['cycles_ci95']" "$tmp/s.json")
      sim=$(num "['timing']['sample']['simulated_fraction']" "$tmp/s.json")
      best=$(least "$best" "$(num "['seconds']" "$tmp/s.json")")
      stats+=("$est $ci $sim")
    done
    printf '%s\n' "${stats[@]}" | awk -v F="$full" -v scene="$(basename "$scene")" -v dev="$dev" -v f="$fraction" -v rays="$rays" \
      -v fs="$full_s" -v ss="$best" -v same="$same" '
      { e = ($1 - F) / F * 100; s += e; a += (e < 0 ? -e : e); if ((e < 0 ? -e : e) > m) m = (e < 0 ? -e : e)
        d = $1 - F; if (d * d <= $2 * $2) inside++; sim += $3; n++ }
      END { printf "| %s | %s | %s | %d | %d | %d | %+.2f%% | %.2f%% | %.2f%% | %d of %d | %.1f%% | %.2f / %.2f | %.2fx | %s |\n",
                   scene, dev, f, rays, F, n, s / n, a / n, m, inside, n, 100 * sim / n, fs, ss, fs / ss,
                   same == "yes" ? "equal" : "DIFFERS" }'
  done
done
