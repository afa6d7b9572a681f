#!/usr/bin/env bash
# Sampled timing against full simulation: `rtusim trace --device timed --sample F` on 1M primary and 1M incoherent
# rays of real meshes, with hits (every ray traced by the datapath, the timing model sampled; the estimator's
# auxiliary is each unit's test-count bound) and cycles only (no --out: only the sampled rays are traced; the
# auxiliary is the ray count). Error of the estimate against the full simulation's cycles, the 95% interval the
# estimate states, and the timed device's trace time (stats `trace_seconds`, excluding scene load and BVH build)
# against the full simulation's. Prints a Markdown table (README.md).
#
#   bench/sample_bench.sh [RTUSIM] [RAYS] [MESH...]     RAYS default 1000000; trace packets are 262,144 rays
set -euo pipefail
rtusim=${1:-build/default/rtusim}
rays=${2:-1000000}
shift $(( $# > 2 ? 2 : $# ))
meshes=("$@")
if [ ${#meshes[@]} -eq 0 ]; then
  m=/usr/share/assimp/models
  meshes=("$m/IFC/AC14-FZK-Haus.ifc" "$m/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb"
          "$m/BLEND/SuzanneSubdiv_252.blend")
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

num() {  # num PATH FILE: a number from the stats JSON, by a Python-style path
  python3 -c "import json,sys; d=json.load(open(sys.argv[2])); print(eval('d'+sys.argv[1]))" "$1" "$2"
}

printf '| mesh | rays | mode | sample | cycles (full) | estimate | error | 95%% interval | rays simulated | trace s (full / sampled) | speed-up |\n'
printf '|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n'
for mesh in "${meshes[@]}"; do
  base=$(basename "$mesh")
  for kind in primary incoherent; do
    "$rtusim" rays --scene "$mesh" --kind "$kind" --count "$rays" --out "$tmp/r.bin" >/dev/null
    "$rtusim" trace --scene "$mesh" --rays "$tmp/r.bin" --device timed --out "$tmp/h.bin" --stats "$tmp/full.json" >/dev/null
    full=$(num "['timing']['cycles']" "$tmp/full.json")
    full_s=$(num "['trace_seconds']" "$tmp/full.json")
    for mode in hits cycles-only; do
      for f in 0.05 0.02; do
        out=(--out "$tmp/h2.bin")
        [ "$mode" = cycles-only ] && out=()
        "$rtusim" trace --scene "$mesh" --rays "$tmp/r.bin" --device timed --sample "$f" "${out[@]}" \
          --stats "$tmp/s.json" >/dev/null
        est=$(num "['timing']['cycles']" "$tmp/s.json")
        ci=$(num "['timing']['sample']['cycles_ci95']" "$tmp/s.json")
        simf=$(num "['timing']['sample']['simulated_fraction']" "$tmp/s.json")
        s_s=$(num "['trace_seconds']" "$tmp/s.json")
        awk -v b="$base" -v k="$kind" -v m="$mode" -v f="$f" -v full="$full" -v est="$est" -v ci="$ci" \
          -v simf="$simf" -v fs="$full_s" -v ss="$s_s" 'BEGIN{
            printf "| %s | %s | %s | %g | %d | %d | %+.2f%% | +-%.1f%% | %.1f%% | %.2f / %.2f | %.1fx |\n",
              b, k, m, f, full, est, 100*(est-full)/full, 100*ci/full, 100*simf, fs, ss, fs/ss }'
      done
    done
  done
done
