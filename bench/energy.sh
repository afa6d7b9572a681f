#!/usr/bin/env bash
# Area and energy per ray (docs/energy-model.md) beside published figures: per timing preset on a real mesh, the
# unit's area, rays per second at its clock, energy per ray and where it goes; the model's reference operators
# against Horowitz (ISSCC 2014); narrower coordinates against AQB8's 8-bit quantization; the units against
# RayCore (28 nm); and an iso-area plan. Prints Markdown (bench/results/area-energy.md).
#
#   bench/energy.sh [RTUSIM] [RAYS] [MESH]
#     RTUSIM  default build/default/rtusim;  RAYS  rays per kind, default 50000;  MESH  default
#     /usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc;  PRESETS (environment) default "rdna2 intel embedded
#     rdna2-mem intel-mem";  PLAN=0 leaves out the iso-area plan (the slow part: minutes).
# Reads the stats JSON and the sweep CSV with python3.
set -euo pipefail
source "$(dirname "$0")/lib.sh"  # sets name to energy.sh
bench_rays_args 50000 "$@"
mesh=${3:-$bench_house}
read -r -a presets <<<"${PRESETS:-rdna2 intel embedded rdna2-mem intel-mem}"
bench_need_python
bench_tmpdir
bench_kind_rays "$mesh"

echo "## Per preset: $(basename "$mesh"), $rays rays per kind"
echo
echo "| preset | rays | MRays/s | area mm^2 (units + SRAM) | pJ/ray | units | cache | DRAM + stream | stack | leakage | W | MRays/s/mm^2 | Mrays/J |"
echo "|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for preset in "${presets[@]}"; do
  for kind in primary incoherent; do
    "$rtusim" trace --scene "$mesh" --rays "$tmp/$kind.bin" --out "$tmp/hits.bin" --device timed \
      --config "$preset" --threads 1 --stats "$tmp/stats_${preset}_$kind.json" >/dev/null
    python3 - "$preset" "$kind" "$tmp/stats_${preset}_$kind.json" <<'PY'
import json, sys
preset, kind, f = sys.argv[1:4]
t = json.load(open(f))["timing"]
e = t["energy"]
a = e["area"]
ev = {k: v["pj"] for k, v in e["events"].items()}
tot = e["total_pj"]
share = lambda *ks: f"{100 * sum(ev[k] for k in ks) / tot:.0f}%"
mrays = t["rays"] / t["seconds_at_clock"] / 1e6
units = a["box_units_mm2"] + a["tri_units_mm2"]
sram = a["cache_mm2"] + a["slots_mm2"]
print(f"| {preset} | {kind} | {mrays:.0f} | {a['total_mm2']:.2f} ({units:.2f} + {sram:.2f}) | {e['pj_per_ray']:.0f} | "
      f"{share('box_test', 'tri_test')} | {share('cache_read', 'cache_fill')} | {share('dram', 'stream')} | "
      f"{share('stack')} | {share('leakage')} | {e['watts']:.2f} | {mrays / a['total_mm2']:.0f} | "
      f"{e['rays_per_joule'] / 1e6:.0f} |")
PY
  done
done

echo
echo "## Against RayCore"
echo
echo "RayCore (Nah et al., TOG 2014): its 28 nm evaluation chip as SiliconArts presented it at Hot Chips 2014"
echo "(reported by embedded.com) has 18 mm^2, 6 ray-tracing units and a tree-building unit, and reaches 239 MRays/s"
echo "at about 1 W. On-chip figures only (no DRAM or ray/hit stream energy: RayCore's watt is the chip's), ours scaled ideally"
echo "from 45 to 28 nm (area x (28/45)^2, energy x 28/45): a bound in our favour."
echo
echo "| unit | rays | MRays/s | mm^2 at 45 nm | MRays/s/mm^2 at 28 nm | on-chip nJ/ray at 45 nm | at 28 nm |"
echo "|---|---|---:|---:|---:|---:|---:|"
for preset in "${presets[@]}"; do
  for kind in primary incoherent; do
    python3 - "$preset" "$kind" "$tmp/stats_${preset}_$kind.json" <<'PY'
import json, sys
preset, kind, f = sys.argv[1:4]
t = json.load(open(f))["timing"]
e = t["energy"]
onchip = sum(v["pj"] for k, v in e["events"].items() if k not in ("dram", "stream")) / t["rays"] / 1000
mrays = t["rays"] / t["seconds_at_clock"] / 1e6
s = 28 / 45
mm2 = e["area"]["total_mm2"]
print(f"| {preset} | {kind} | {mrays:.0f} | {mm2:.2f} | {mrays / (mm2 * s * s):.0f} | {onchip:.2f} | {onchip * s:.2f} |")
PY
  done
done
echo "| RayCore (published) | Whitted | 239 | - | 13 | - | 4.2 |"

echo
echo "## The model's reference operators against Horowitz (ISSCC 2014, 45 nm)"
echo
echo '```'
"$rtusim" config --energy | sed -n '/^# calibration/,$p'
echo '```'

echo
echo "## Narrower coordinates (AQB8's question): rdna2 at 24, 16 and 12 coordinate bits"
echo
"$rtusim" sweep --scene "$mesh" --formats default,default:coord_bits=16,default:coord_bits=12 --bvh-width 4 \
  --config rdna2 --rays "$rays" --image-width 0 --threads 1 --out "$tmp/sweep.csv" >/dev/null
"$rtusim" config --config rdna2 --energy | grep -E '^box unit' | sed 's/^/    rdna2 (24 bits): /'
python3 - "$tmp/sweep.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
base = rows[0]
print()
print("| format | hit agreement | cycles/ray | area mm^2 | area vs 24 bits | RTL box cells | box cells vs 24 bits | pJ/ray | pJ/ray vs 24 bits |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
for r in rows:
    pct = lambda k: f"{100 * (float(r[k]) / float(base[k]) - 1):+.1f}%"
    print(f"| {r['format']} | {100 * float(r['hit_agreement']):.4f}% | {float(r['cycles_per_ray']):.2f} | "
          f"{float(r['area_mm2']):.3f} | {pct('area_mm2')} | {r['rtl_cells']} | {pct('rtl_cells')} | "
          f"{float(r['pj_per_ray']):.0f} | {pct('pj_per_ray')} |")
PY

if [ "${PLAN:-1}" != 0 ]; then
  budget=${AREA_BUDGET:-2.0}
  echo
  echo "## Iso-area plan: rdna2, $budget mm^2, hit disagreement <= 1e-3"
  echo
  echo '```'
  "$rtusim" plan --scene "$mesh" --max-error 1e-3 --config rdna2 --bvh-width 4 --coord-bits 10,12,14,16,20,24 \
    --child-bits 8 --rays "$(( rays / 5 > 2000 ? rays / 5 : 2000 ))" --image-width 0 --threads 1 \
    --area-budget "$budget" | grep -v '^width\|^the base'
  echo '```'
fi
