#!/usr/bin/env bash
# What alpha-tested geometry costs the unit: a render of a scene with masked materials on the timed device, once
# per any-hit latency, with cycles per ray and any-hit requests per ray by ray type (primary, shadow, diffuse),
# and the fraction of requests the stage ignored (the candidates a ray had to go on from). The hits and the
# image do not depend on the latency (the script checks that the image stays the same); only the cycles do.
#
#   bench/alpha_cost.sh [RTUSIM] [SCENE] [WIDTH]
#     RTUSIM  default build/default/rtusim;  SCENE  default builtin:forest;  WIDTH  default 320 (4:3, 1 spp,
#     depth 2);  LATENCIES (environment) default "0 50 100 200 400 800 1600";  CONFIG default rdna2
# Prints a Markdown table. Reads the stats JSON with python3.
set -euo pipefail
rtusim=${1:-build/default/rtusim}
scene=${2:-builtin:forest}
width=${3:-320}
read -r -a latencies <<<"${LATENCIES:-0 50 100 200 400 800 1600}"
config=${CONFIG:-rdna2}
source "$(dirname "$0")/lib.sh"  # sets name to alpha_cost.sh
bench_need_rtusim "$rtusim"
bench_need_count WIDTH "$width"
bench_need_python
bench_tmpdir
height=$((width * 3 / 4))
echo "| any_hit_latency | cycles | cycles/ray primary | shadow | diffuse | requests/ray primary | shadow | diffuse | ignored | cycles vs latency 0 |"
echo "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
first=""
for lat in "${latencies[@]}"; do
  "$rtusim" render --scene "$scene" --device timed --config "$config" --set "any_hit_latency=$lat" \
    --width "$width" --height "$height" --max-depth 2 --threads 1 --out "$tmp/$lat.png" \
    --stats "$tmp/$lat.json" >/dev/null
  if [ -z "$first" ]; then
    first=$lat
  elif ! cmp -s "$tmp/$first.png" "$tmp/$lat.png"; then
    echo "alpha_cost.sh: the image changed with any_hit_latency=$lat" >&2
    exit 1
  fi
  python3 - "$lat" "$tmp/$lat.json" "$tmp/$first.json" <<'PY'
import json, sys
lat, f, f0 = sys.argv[1:4]
t = json.load(open(f))["timing"]
t0 = json.load(open(f0))["timing"]
by = t["by_ray_type"]
def per_ray(kind, key):
    b = by.get(kind)
    return b[key] / b["rays"] if b and b["rays"] else 0.0
req = t["any_hit_requests"]
unit = json.load(open(f))["unit"]["total"]
ig = f"{unit['any_hit_ignored'] / unit['any_hit_calls']:.2f}" if unit["any_hit_calls"] else "-"
print(f"| {lat} | {t['cycles']} | {per_ray('primary', 'cycles'):.1f} | {per_ray('shadow', 'cycles'):.1f} | "
      f"{per_ray('diffuse', 'cycles'):.1f} | {per_ray('primary', 'any_hit_requests'):.2f} | "
      f"{per_ray('shadow', 'any_hit_requests'):.2f} | {per_ray('diffuse', 'any_hit_requests'):.2f} | {ig} | "
      f"{t['cycles'] / t0['cycles']:.2f}x |")
PY
done
