#!/usr/bin/env bash
# Pareto plots of a sweep: error against cycles, memory and area, per scene, as PNGs drawn by gnuplot.
#
#   bench/pareto.sh SWEEP.csv OUTDIR [RTUSIM]
#     SWEEP.csv  a CSV of `rtusim sweep` (header scene,format,bvh_width,config,rays,seed,image_width,hit_agreement,...)
#     OUTDIR     created if needed; gets per scene pareto_<scene>_hit.png (error = hit disagreement,
#                1 - hit agreement, a zero drawn at 1 / rays) and pareto_<scene>_terr.png (error = mean relative
#                t error, a zero drawn at 1e-10), up to five panels each: against cycles, bvh_bytes,
#                dram_bytes_per_ray, area_mm2 and pj_per_ray (rows without one, a 0 in the CSV, are left out of
#                that panel, a panel no row has is left out); every point labelled
#                format/width/config, the Pareto front (points not dominated in both error and cost) drawn as a
#                staircase line; beside them the gnuplot scripts (.gp), their data (.dat, .front) and logs.
#     RTUSIM     default build/default/rtusim
#
# The plotting is `rtusim pareto --sweep SWEEP.csv --out OUTDIR` (host/jobs/pareto.cpp writes the gnuplot scripts
# and runs gnuplot with the pngcairo terminal); `rtusim report` uses the same code.
set -euo pipefail
if [ $# -lt 2 ] || [ $# -gt 3 ]; then
  echo "usage: bench/pareto.sh SWEEP.csv OUTDIR [RTUSIM]" >&2
  exit 2
fi
sweep=$1
out=$2
rtusim=${3:-build/default/rtusim}
if ! command -v gnuplot >/dev/null; then
  echo "pareto.sh: gnuplot not found; install the Debian package gnuplot-nox (scripts/setup.sh does)" >&2
  exit 2
fi
if ! [ -x "$rtusim" ]; then
  echo "pareto.sh: $rtusim is not an executable (build the rtusim target, or pass its path)" >&2
  exit 2
fi
[ -r "$sweep" ] || { echo "pareto.sh: cannot read $sweep" >&2; exit 2; }
exec "$rtusim" pareto --sweep "$sweep" --out "$out"
