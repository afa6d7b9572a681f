#!/usr/bin/env bash
# What opacity micromaps save the unit: a render of a scene with alpha-masked materials on the timed device,
# without maps and with maps of each subdivision level (render --omm-level), with the maps' share of known
# micro-triangles and bytes, the any-hit requests the unit still makes, the candidates the maps resolved, and the
# cycles, and the lookup's logic (one per triangle unit) and energy over the frame. The image must not change with
# the maps (the script checks it). Each lookup reads its state's line through the node cache and waits omm_latency.
#
#   bench/omm_cost.sh [RTUSIM] [SCENE] [WIDTH]
#     RTUSIM  default build/default/rtusim;  SCENE  default builtin:forest;  WIDTH  default 320 (4:3, 1 spp,
#     depth 2);  LEVELS (environment) default "-1 0 1 2 3 4 5 6" (-1: no maps);  CONFIG default rdna2
# Prints a Markdown table. Reads the stats JSON with python3.
set -euo pipefail
rtusim=${1:-build/default/rtusim}
scene=${2:-builtin:forest}
width=${3:-320}
read -r -a levels <<<"${LEVELS:--1 0 1 2 3 4 5 6}"
config=${CONFIG:-rdna2}
source "$(dirname "$0")/lib.sh"  # sets name to omm_cost.sh
bench_need_rtusim "$rtusim"
bench_need_count WIDTH "$width"
bench_need_python
bench_tmpdir
height=$((width * 3 / 4))
echo "| omm level | known micro-triangles | map bytes | any-hit requests | resolved by the maps (opaque / transparent) | cycles | cycles vs no maps | lookup logic mm^2 | lookup energy nJ |"
echo "|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
first=""
for lvl in "${levels[@]}"; do
  "$rtusim" render --scene "$scene" --device timed --config "$config" --omm-level "$lvl" \
    --width "$width" --height "$height" --max-depth 2 --threads 1 --out "$tmp/$lvl.png" \
    --stats "$tmp/$lvl.json" >/dev/null
  if [ -z "$first" ]; then
    first=$lvl
  elif ! cmp -s "$tmp/$first.png" "$tmp/$lvl.png"; then
    echo "omm_cost.sh: the image changed with --omm-level $lvl" >&2
    exit 1
  fi
  python3 - "$lvl" "$tmp/$lvl.json" "$tmp/$first.json" <<'PY'
import json, sys
lvl, f, f0 = sys.argv[1:4]
j, j0 = json.load(open(f)), json.load(open(f0))
t, t0 = j["timing"], j0["timing"]
unit = j["unit"]["total"]
m = j.get("micromaps")
known = f"{100 * m['known']:.1f}%" if m else "-"
size = f"{m['bytes']:,}" if m else "-"
res = f"{unit.get('omm_opaque', 0):,} / {unit.get('omm_transparent', 0):,}"
look = m["lookup"] if m else None
area = f"{look['area_mm2']:.4f}" if look else "-"
nj = f"{look['pj'] / 1000:.1f}" if look else "-"
print(f"| {lvl if int(lvl) >= 0 else 'none'} | {known} | {size} | {t['any_hit_requests']:,} | {res} | "
      f"{t['cycles']:,} | {t['cycles'] / t0['cycles']:.2f}x | {area} | {nj} |")
PY
done
# A micromap cache of the maps' own (omm_cache_kib; CACHES, default "4 16 64" KiB) at the levels where the maps know
# most, against the same frame without maps.
read -r -a caches <<<"${CACHES:-4 16 64}"
echo
echo "With a micromap cache (omm_cache_kib) beside the node cache:"
echo
echo "| omm level | omm_cache_kib | any-hit requests | micromap cache hit rate | node cache hit rate | cycles | cycles vs no maps |"
echo "|---:|---:|---:|---:|---:|---:|---:|"
for lvl in 4 5 6; do
  for kib in "${caches[@]}"; do
    "$rtusim" render --scene "$scene" --device timed --config "$config" --omm-level "$lvl" \
      --set "omm_cache_kib=$kib" --width "$width" --height "$height" --max-depth 2 --threads 1 \
      --out "$tmp/c$lvl-$kib.png" --stats "$tmp/c$lvl-$kib.json" >/dev/null
    if ! cmp -s "$tmp/$first.png" "$tmp/c$lvl-$kib.png"; then
      echo "omm_cost.sh: the image changed with omm_cache_kib $kib" >&2
      exit 1
    fi
    python3 - "$lvl" "$kib" "$tmp/c$lvl-$kib.json" "$tmp/$first.json" <<'PY'
import json, sys
lvl, kib, f, f0 = sys.argv[1:5]
t, t0 = json.load(open(f))["timing"], json.load(open(f0))["timing"]
print(f"| {lvl} | {kib} | {t['any_hit_requests']:,} | {t['omm_cache']['hit_rate']:.3f} | "
      f"{t['cache']['hit_rate']:.3f} | {t['cycles']:,} | {t['cycles'] / t0['cycles']:.2f}x |")
PY
  done
done
