#!/usr/bin/env bash
# Scaling with the primitive count: the classic claim that ray tracing with a BVH costs ~log n per ray while
# rasterization costs ~n. Meshes of 1k to 1.3M triangles at the same screen coverage (the built-in closed
# icosphere of radius 1, subdivision level N: 20 * 4^N triangles), the same primary rays (a camera at distance 4
# framed on the sphere: it fills pi/4 of the image) traced as one TRACE packet on the timed device per preset.
#
#   bench/scaling.sh [RTUSIM] [RAYS] [OUTDIR]
#     RTUSIM  default build/default/rtusim;  RAYS  primary rays, default 100000 (rounded up to a square image)
#     OUTDIR  default out/scaling
#     SUBDIVS (environment) subdivision levels, default "3 4 5 6 7 8" (1280 .. 1,310,720 triangles)
#     PRESETS (environment) timing presets, default "rdna2 intel embedded";  THREADS  rtusim --threads, default 2
#
# Writes OUTDIR/scaling.csv (preset,subdiv,triangles,rays,hits,cycles,cycles_per_ray,nodes_per_ray,
# prim_tests_per_ray,cache_hit_rate,limited_by), OUTDIR/scaling.md (the table and, per preset, the least-squares
# fit cycles/ray = a + b log2(n) with its R^2, the slope of log(cycles) against log(n): ~0 for log n growth, 1 for
# linear growth, and the same log2 fit of the BVH nodes visited per ray, the traversal's work without memory) and OUTDIR/scaling.png (gnuplot, when installed; the script is OUTDIR/scaling.gp).
# Raster cycles: the same mesh rendered in hybrid mode (`rtusim render --mode hybrid --device timed`, the scene's
# own camera, which also sees the sphere at the same coverage whatever n; a square image of the same side,
# 1 spp, direct light only) gives the rasterizer's cycles from its cost model (hwmodel/timing/raster_timing.h) and what
# limits it; fitted like the ray tracing cycles. Reads the stats JSON with jq, or python3 when jq is missing.
set -euo pipefail
source "$(dirname "$0")/lib.sh"  # sets name to scaling.sh
bench_rays_args 100000 "$@"
out=${3:-out/scaling}
read -r -a subdivs <<< "${SUBDIVS:-3 4 5 6 7 8}"
read -r -a presets <<< "${PRESETS:-rdna2 intel embedded}"
threads=${THREADS:-2}
for s in "${subdivs[@]}"; do
  [[ $s =~ ^[0-8]$ ]] || { echo "scaling.sh: SUBDIVS: '$s' is not a level 0..8" >&2; exit 2; }
done
bench_json_reader
mkdir -p "$out" || { echo "scaling.sh: cannot create $out" >&2; exit 2; }

bench_tmpdir

# The same primary rays for every mesh and preset: a pinhole camera at (0, 0, 4) looking down -z, a square image
# of side ceil(sqrt(RAYS)) framed on the sphere's silhouette (tan of the half angle 0.26 > 1 / sqrt(15), so the
# sphere fills pi/4 of the image whatever its subdivision).
side=$(awk -v n="$rays" 'BEGIN { s = int(sqrt(n)); if (s * s < n) s++; print s }')
awk -v s="$side" 'BEGIN {
  print "ox,oy,oz,tmin,dx,dy,dz,tmax"
  for (j = 0; j < s; j++) for (i = 0; i < s; i++) {
    u = 0.26 * (2 * (i + 0.5) / s - 1); v = 0.26 * (1 - 2 * (j + 0.5) / s); l = sqrt(u * u + v * v + 1)
    printf "0,0,4,0,%.9g,%.9g,%.9g,inf\n", u / l, v / l, -1 / l
  }
}' >"$tmp/primary.csv"
rays=$((side * side))

csv=$out/scaling.csv
echo "preset,subdiv,triangles,rays,hits,cycles,cycles_per_ray,nodes_per_ray,prim_tests_per_ray,cache_hit_rate,limited_by,raster_cycles,raster_limit" >"$csv"
for preset in "${presets[@]}"; do
  for s in "${subdivs[@]}"; do
    n=$((20 * 4 ** s))
    "$rtusim" trace --scene "builtin:icosphere?subdiv=$s" --rays "$tmp/primary.csv" --out "$tmp/hits" \
      --device timed --config "$preset" --threads "$threads" --stats "$tmp/stats.json" >/dev/null
    IFS=$'\t' read -r nr hits cycles cpr nodes prims hit lim < <(bench_fields "$tmp/stats.json" rays hits timing.cycles \
      timing.cycles_per_ray nodes_visited prim_tests timing.cache.hit_rate timing.lower_bound.limited_by)
    "$rtusim" render --scene "builtin:icosphere?subdiv=$s" --mode hybrid --device timed --config "$preset" \
      --width "$side" --height "$side" --spp 1 --max-depth 0 --threads "$threads" --out "$tmp/hybrid.png" \
      --stats "$tmp/render.json" >/dev/null
    IFS=$'\t' read -r rc rlim < <(bench_fields "$tmp/render.json" timing.raster.cycles timing.raster.limit)
    awk -v OFS=, -v p="$preset" -v s="$s" -v n="$n" -v nr="$nr" -v h="$hits" -v c="$cycles" -v cpr="$cpr" \
      -v nodes="$nodes" -v prims="$prims" -v hit="$hit" -v lim="$lim" -v rc="$rc" -v rlim="$rlim" \
      'BEGIN { print p, s, n, nr, h, c, sprintf("%.4f", cpr), sprintf("%.3f", nodes / nr), sprintf("%.3f", prims / nr), sprintf("%.4f", hit), lim, rc, rlim }' >>"$csv"
    echo "scaling.sh: $preset subdiv $s ($n triangles): $cycles cycles, raster $rc" >&2
  done
done

# The table and the fits (least squares: cycles/ray = a + b log2 n; log-log slope of cycles against n).
md=$out/scaling.md
{
  printf '%s primary rays (%sx%s) of a pinhole camera at distance 4 framed on the icosphere of radius 1 (it covers pi/4 of the image at every n), one TRACE packet on the timed device, closest hit, `--threads %s`.\n\n' "$rays" "$side" "$side" "$threads"
  printf '| preset | subdiv | triangles | hits | cycles | cycles/ray | nodes/ray | prim tests/ray | cache hit rate | limited by | raster cycles (limit) |\n'
  printf '|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|\n'
  awk -F, 'NR > 1 { printf "| %s | %s | %s | %s | %s | %.2f | %.2f | %.2f | %.3f | %s | %s (%s) |\n", $1, $2, $3, $5, $6, $7, $8, $9, $10, $11, $12, $13 }' "$csv"
  printf '\nFits over n = triangles (least squares):\n\n'
  printf '| preset | cycles/ray = a + b log2(n): a | b (cycles/ray per doubling) | R^2 | slope of log(cycles) vs log(n) | cycles/ray at largest n / smallest n | n ratio | nodes/ray = a + b log2(n): b | R^2 |\n'
  printf '|---|---:|---:|---:|---:|---:|---:|---:|---:|\n'
  awk -F, 'NR > 1 {
      p = $1; if (!(p in k)) { order[++np] = p }
      k[p]++; x = log($3) / log(2); y = $7; lx = log($3); ly = log($6)
      sx[p] += x; sy[p] += y; sxx[p] += x * x; sxy[p] += x * y; syy[p] += y * y
      slx[p] += lx; sly[p] += ly; slxx[p] += lx * lx; slxy[p] += lx * ly
      if (!(p in first)) { first[p] = y; n0[p] = $3 } last[p] = y; n1[p] = $3
      z = $8; sz[p] += z; szz[p] += z * z; sxz[p] += x * z
    }
    END {
      for (i = 1; i <= np; i++) {
        p = order[i]; m = k[p]
        b = (m * sxy[p] - sx[p] * sy[p]) / (m * sxx[p] - sx[p] * sx[p]); a = (sy[p] - b * sx[p]) / m
        sst = syy[p] - sy[p] * sy[p] / m
        r2num = (m * sxy[p] - sx[p] * sy[p]); r2 = (sst > 0) ? r2num * r2num / ((m * sxx[p] - sx[p] * sx[p]) * (m * syy[p] - sy[p] * sy[p])) : 1
        s = (m * slxy[p] - slx[p] * sly[p]) / (m * slxx[p] - slx[p] * slx[p])
        dx = m * sxx[p] - sx[p] * sx[p]; bz = (m * sxz[p] - sx[p] * sz[p]) / dx; dz = m * szz[p] - sz[p] * sz[p]
        r2z = dz > 0 ? (m * sxz[p] - sx[p] * sz[p]) ^ 2 / (dx * dz) : 1
        printf "| %s | %.2f | %.3f | %.3f | %.3f | %.2fx | %.0fx | %.3f | %.3f |\n", p, a, b, r2, s, last[p] / first[p], n1[p] / n0[p], bz, r2z
        printf "%s %.6g %.6g\n", p, a, b > "/dev/stderr"
      }
    }' "$csv" 2>"$tmp/fits"
  printf '\nRaster cycles against n (the hybrid render of the same sphere): slope of log(raster cycles) against log(n), over all n and over the largest four:\n\n'
  printf '| preset | slope, all n | slope, largest four n | raster cycles at largest n / smallest n | n ratio |\n|---|---:|---:|---:|---:|\n'
  awk -F, 'NR > 1 {
      p = $1; if (!(p in k)) { order[++np] = p }
      k[p]++; i = k[p]; lx[p, i] = log($3); ly[p, i] = log($12); if (i == 1) { r0[p] = $12; n0[p] = $3 } r1[p] = $12; n1[p] = $3
    }
    function slope(p, from, to,   i, m, sx, sy, sxx, sxy) {
      m = 0; sx = sy = sxx = sxy = 0
      for (i = from; i <= to; i++) { m++; sx += lx[p, i]; sy += ly[p, i]; sxx += lx[p, i] ^ 2; sxy += lx[p, i] * ly[p, i] }
      return (m * sxy - sx * sy) / (m * sxx - sx * sx)
    }
    END {
      for (j = 1; j <= np; j++) {
        p = order[j]; m = k[p]
        printf "| %s | %.3f | %.3f | %.1fx | %.0fx |\n", p, slope(p, 1, m), slope(p, m > 4 ? m - 3 : 1, m), r1[p] / r0[p], n1[p] / n0[p]
      }
    }' "$csv"
} >"$md"
cat "$md"

# The plot: cycles per ray against triangles (log x) with the fits, per preset.
if command -v gnuplot >/dev/null; then
  gp=$out/scaling.gp
  {
    echo "set terminal pngcairo noenhanced size 1000,650 font 'sans,11'"
    echo "set output 'scaling.png'"
    echo "set datafile separator ','"
    echo "set logscale x 2"
    echo "set format x '%.0s%c'"
    echo "set grid"
    echo "set key top left"
    echo "set xlabel 'triangles n (icosphere, same screen coverage)'"
    echo "set ylabel 'cycles per primary ray (timed device)'"
    echo "set title 'Ray tracing cost against primitive count; lines: least-squares fits a + b log2(n)'"
    printf "plot "
    i=0
    while read -r p a b; do
      i=$((i + 1))
      [ $i -gt 1 ] && printf ", \\\\\n  "
      printf "'scaling.csv' using (\$1 eq '%s' ? \$3 : 1/0):7 with points pt 7 ps 1.4 lc %d title '%s', \\\\\n" "$p" "$i" "$p"
      printf "  %s + %s * log(x) / log(2) with lines lw 2 dt 2 lc %d title '%s fit: %.2f + %.3f log2 n'" "$a" "$b" "$i" "$p" "$a" "$b"
    done <"$tmp/fits"
    echo
  } >"$gp"
  # String comparison needs the column as text: strcol.
  sed -i "s/(\$1 eq /(strcol(1) eq /" "$gp"
  if (cd "$out" && gnuplot scaling.gp); then
    echo "scaling.sh: wrote $out/scaling.png" >&2
  else
    echo "scaling.sh: gnuplot failed on $gp" >&2
    exit 1
  fi
else
  echo "scaling.sh: gnuplot not found (Debian package gnuplot-nox): no $out/scaling.png" >&2
fi
echo "scaling.sh: wrote $csv and $md" >&2
