#!/usr/bin/env bash
# Speed of two or more rtusim binaries on the same rays, interleaved: run 1 of each, run 2 of each, ... and the
# best trace rate of each. On a VM whose speed moves by 1.5x within minutes, only such a same-time comparison
# says whether a change made the simulator faster (the cycles must not change: check them separately).
#
#   bench/ab_speed.sh SCENE RAYS N BIN [BIN...]     e.g. N=5; DEVICE=timed THREADS=1 (environment)
set -euo pipefail
if [ $# -lt 4 ]; then
  echo "usage: $0 SCENE RAYS N BIN [BIN...]" >&2
  exit 2
fi
scene=$1 rays=$2 n=$3
shift 3
device=${DEVICE:-timed}
threads=${THREADS:-1}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
declare -A best all
for _ in $(seq "$n"); do
  for b in "$@"; do
    "$b" trace --scene "$scene" --rays "$rays" --device "$device" --threads "$threads" --out "$tmp/h.bin" \
      --stats "$tmp/s.json" >/dev/null
    r=$(python3 -c "import json,sys; print('%.3f' % (json.load(open(sys.argv[1]))['rays_per_second'] * 1e-6))" \
      "$tmp/s.json")
    all[$b]="${all[$b]:-}$r "
    best[$b]=$(awk -v a="${best[$b]:-0}" -v v="$r" 'BEGIN{print (v > a) ? v : a}')
  done
done
printf '| binary | M rays/s (each run) | best |\n|---|---|---:|\n'
for b in "$@"; do printf '| %s | %s| %s |\n' "$b" "${all[$b]}" "${best[$b]}"; done
