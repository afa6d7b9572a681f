#!/usr/bin/env bash
# The vendors' test rates reproduced (issue 44), and the Xe-HPG -> Xe2 and RDNA2 -> RDNA4 steps on the scene suite
# (bench/results/unit-rates.md).
#
#   bench/unit_rates.sh [RTUSIM] [RAYS] [PRESET...]
#     RTUSIM  default build/default/rtusim;  RAYS  rays of each rate run, default 3000
#     PRESET  default rdna2 intel rdna4 xe2 (those with a vendor figure below)
#     SUITE_RAYS (environment) rays per kind and scene of the sensitivity table, default 20000; 0 leaves it out
#     SUITE (environment) default scenes/suite.json;  OUT (environment) default bench/results/unit-rates.md
#     CHECK=1 (environment): measure the rates only, print them, write no file, and exit 1 unless every measured
#       rate equals the vendor's figure exactly (the ctest test unit_rates runs this).
#
# Rates: box tests and triangle tests per clock of ONE unit while its test units are the bottleneck. Each preset
# traces two generated scenes (Wavefront OBJ, written here) with RAYS copies of one ray, with a pipeline trace of
# the whole run (--pipeline-trace: a span per test from its request to its result, so its first issue clock is the
# result's cycle - (latency + issue clocks - 1)). The rate is the tests whose issue clock falls in the run's third
# quarter [T/2, 3T/4) over the quarter's clocks, T the last span's end: after the first rays' cold misses (the
# scene's lines come from DRAM once; every later ray, the same ray, finds them in the node cache) and before the
# last rays drain. The whole run's tests per cycle are printed beside it (lower: the fill and the drain).
# - Box rate, scene `rings`: W rings of W tiny triangles (W the preset's BVH width) spaced along the x axis, the
#   ray down the axis through the middle of every ring. The BVH is a full W-wide root over the rings, each ring
#   a full W-wide node over its triangles; every node's box holds the ray and no triangle's box does, so a ray
#   visits the W + 1 nodes (W (W + 1) box tests) and tests no triangle. Box-bound: W + 1 nodes per ray against
#   one ray per clock through ray fetch and setup, and about 12 clocks of latency per node hidden by the slots.
#   The script checks what makes the count the vendor's: no triangle test, and every node visited full (box tests
#   = W x nodes): a node of c < W children would use c of the unit's W lanes, and a vendor counts lanes.
# - Triangle rate, scene `stack`: 8 leaves of 8 triangles spaced along the x axis, each triangle the same right
#   triangle whose box holds the axis and which the axis misses; the ray down the axis tests all 64 (none hit)
#   against a handful of nodes, and its stack never spills. Triangle-bound on every preset.
# Vendor figures: RDNA2 4 box or 1 triangle test per clock (AMD's RDNA2 ISA guide; Chips and Cheese), Xe-HPG 12
# and 1 (Intel's Arc ray-tracing disclosure, 2022), RDNA4 8 or 2 (Chips and Cheese, "RDNA 4's raytracing
# improvements", 2025), Xe2 18 and 2 (Chips and Cheese, "Raytracing on Intel's Arc B580", 2025).
#
# Sensitivity (SUITE_RAYS > 0): cycles per ray of SUITE_RAYS primary and SUITE_RAYS incoherent rays on every
# available scene of the suite, `rtusim trace --device timed --threads 1`, for intel-mem, intel-mem with one Xe2
# change at a time (BVH cache 16 KiB; three traversal pipelines: box_units 3 and 96 ray slots; 2 triangle tests
# per clock), the 18/2 rates without the third pipeline's slots, the B580's VRAM share per clock (bytes per clock
# and 300 ns at 2.67 GHz), and xe2-mem; likewise rdna2-mem, one RDNA4 change at a time (the 32 KiB L0; 8/2 rates on
# BVH4 nodes; the BVH8 format at rdna2's rates; BVH8 with 8/2; 64 ray slots; the RX 9070 XT's VRAM share per clock)
# and rdna4-mem. The table gives cycles per ray and the ratio to the older preset (> 1: faster), and the
# geometric mean of the ratios over the scenes; the last column is also at each preset's own clock (ns per ray).
set -euo pipefail
source "$(dirname "$0")/lib.sh"  # sets name to unit_rates.sh
bench_split_args 2 rdna2 intel rdna4 xe2 -- "$@"
bench_rays_args 3000 "${bench_lead[@]}"
presets=("${bench_list[@]}")
suite_rays=${SUITE_RAYS:-20000}
suite=${SUITE:-scenes/suite.json}
out=${OUT:-bench/results/unit-rates.md}
check=${CHECK:-0}
bench_need_python
[[ $suite_rays =~ ^[0-9]+$ ]] || { echo "$name: SUITE_RAYS must be a whole number, not '$suite_rays'" >&2; exit 2; }
root=$(cd "$(dirname "$0")/.." && pwd)
bench_tmpdir
start=$(date +%s)

# The vendors' box and triangle tests per clock of one unit.
declare -A vendor_box=([rdna2]=4 [intel]=12 [rdna4]=8 [xe2]=18)
declare -A vendor_tri=([rdna2]=1 [intel]=1 [rdna4]=2 [xe2]=2)
declare -A vendor_name=([rdna2]="AMD RDNA2 Ray Accelerator" [intel]="Intel Xe-HPG RTU" [rdna4]="AMD RDNA4 Ray Accelerator"
                        [xe2]="Intel Xe2 RTU")
for p in "${presets[@]}"; do
  [ -n "${vendor_box[$p]:-}" ] || { echo "$name: no vendor figure for preset '$p' (rdna2, intel, rdna4, xe2)" >&2; exit 2; }
done

# key PRESET KEY: the preset's value of a timing key.
key() {
  "$rtusim" config --config "$1" | awk -v k="$2" '$1 == k && $2 == "=" && !found { print $3; found = 1 }'
}

# The scenes. rings_W.obj: W rings of W triangles; stack.obj: 8 leaves of 8 triangles the axis misses.
python3 - "$tmp" <<'PY'
import math, sys
d = sys.argv[1]
for w in (2, 4, 6, 8):
    with open(f"{d}/rings_{w}.obj", "w") as f:
        n = 0
        for r in range(w):
            x = 4.0 * r
            for k in range(w):
                a = (k + 0.5) * 2 * math.pi / w
                y, z = math.cos(a), math.sin(a)
                # a triangle 0.05 across, lying outward from (y, z) so that its box never holds the axis
                for v in ((x, y, z), (x + 0.05, y, z), (x, y + 0.05 * y, z + 0.05 * z)):
                    f.write("v %.6f %.6f %.6f\n" % v)
                f.write("f %d %d %d\n" % (n + 1, n + 2, n + 3))
                n += 3
with open(f"{d}/stack.obj", "w") as f:
    n = 0
    for g in range(8):
        for j in range(8):
            # a leaf's 8 triangles 0.01 apart (no split shrinks their boxes), leaves 4 apart; in (y, z) each is
            # (-1, 1), (1, 1), (1, -0.5): its box holds (0, 0), its hypotenuse passes 0.25 above it
            x = 4.0 * g + 0.01 * j
            for v in ((x, -1.0, 1.0), (x, 1.0, 1.0), (x, 1.0, -0.5)):
                f.write("v %.6f %.6f %.6f\n" % v)
            f.write("f %d %d %d\n" % (n + 1, n + 2, n + 3))
            n += 3
PY
{
  echo "ox,oy,oz,tmin,dx,dy,dz,tmax"
  for ((i = 0; i < rays; ++i)); do echo "-10,0.001,0.0007,0,1,0,0,1000"; done
} >"$tmp/axis.csv"

# rate PRESET SCENE WHAT (box or triangle): traces RAYS copies of the axis ray with a pipeline trace of the whole
# run; prints the rate over the window (an exact fraction, reduced), the whole run's tests per clock, problems
# ('-' for none), and the window's tests and clocks.
rate() {
  local lat issue
  if [ "$3" = box ]; then
    lat=$(key "$1" box_latency)
    issue=$(((width + $(key "$1" box_rate) - 1) / $(key "$1" box_rate)))
  else
    lat=$(key "$1" tri_latency)
    issue=1
  fi
  "$rtusim" trace --scene "$tmp/$2.obj" --rays "$tmp/axis.csv" --device timed --config "$1" --threads 1 \
    --stats "$tmp/s.json" --pipeline-trace "$tmp/pt.json" --trace-window 0:1000000000 >/dev/null
  python3 - "$3" "$width" "$lat" "$issue" "$tmp/s.json" "$tmp/pt.json" <<'PY'
import json, sys
from fractions import Fraction
what, w, lat, issue = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
t = json.load(open(sys.argv[5]))["timing"]
spans = [e for e in json.load(open(sys.argv[6]))["traceEvents"] if e.get("ph") == "X"]
problems = []
if what == "box":
    if t["triangle_tests"] != 0:
        problems.append(f"{t['triangle_tests']} triangle tests (expected none)")
    if t["box_tests"] != w * t["node_fetches"]:
        problems.append(f"{t['box_tests']} box tests over {t['node_fetches']} nodes: not every node is {w}-wide")
    per_span, name, total = w, "box", t["box_tests"]
else:
    per_span, name, total = 1, "triangle", t["triangle_tests"]
# A span runs from the request to the result, which leaves lat + issue - 1 clocks after the test's first issue
# clock (timing-model.md, "Box units" and "Triangle units"): each span's issue cycle.
starts = [e["ts"] + e["dur"] - lat - issue + 1 for e in spans if e["name"] == name]
end = max(e["ts"] + e["dur"] for e in spans)
a, b = end // 2, 3 * end // 4
tests = per_span * sum(1 for s in starts if a <= s < b)
if len(starts) * per_span != total:
    problems.append(f"the pipeline trace holds {len(starts)} {name} spans for {total} tests")
r = Fraction(tests, b - a)
text = str(r.numerator) if r.denominator == 1 else f"{r.numerator}/{r.denominator}"
print(text, "%.2f" % (total / t["cycles"]), "; ".join(problems) or "-", tests, b - a, sep="\t")
PY
}

results="$tmp/rates.tsv"
: >"$results"
fail=0
for p in "${presets[@]}"; do
  width=$(key "$p" bvh_width)
  IFS=$'\t' read -r box_frac box_whole box_problem box_dt box_dc < <(rate "$p" "rings_$width" box)
  IFS=$'\t' read -r tri_frac tri_whole tri_problem tri_dt tri_dc < <(rate "$p" stack triangle)
  units="$(key "$p" box_units) x $(key "$p" box_rate), $(key "$p" tri_units) x $(key "$p" tri_rate)"
  verdict=equal
  if [ "$box_frac" != "${vendor_box[$p]}" ] || [ "$tri_frac" != "${vendor_tri[$p]}" ] || [ "$box_problem" != - ] ||
    [ "$tri_problem" != - ]; then
    verdict=DIFFERENT
    fail=1
  fi
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$p" "${vendor_name[$p]}" "$width" "$units" \
    "${vendor_box[$p]}" "$box_frac" "$box_dt / $box_dc; $box_whole" "${vendor_tri[$p]}" "$tri_frac" \
    "$tri_dt / $tri_dc; $tri_whole" \
    "$verdict" "$box_problem" "$tri_problem" >>"$results"
  echo "$name: $p: box tests per clock $box_frac (vendor ${vendor_box[$p]}), triangle tests per clock $tri_frac" \
    "(vendor ${vendor_tri[$p]}): $verdict" >&2
  [ "$box_problem" = - ] || echo "$name: $p box run: $box_problem" >&2
  [ "$tri_problem" = - ] || echo "$name: $p triangle run: $tri_problem" >&2
done

if [ "$check" = 1 ]; then
  cat "$results"
  exit $fail
fi

rates_table="$tmp/rates.md"
{
  printf '| preset | resembles | BVH width | box units x rate, triangle units x rate | box tests/clk: vendor | measured | tests / clocks | triangle tests/clk: vendor | measured | tests / clocks | |\n'
  printf '|---|---|---:|---|---:|---:|---:|---:|---:|---:|---|\n'
  while IFS=$'\t' read -r p vn w u vb mb bd vt mt td verdict _ _; do
    printf '| `%s` | %s | %s | %s | %s | **%s** | %s | %s | **%s** | %s | %s |\n' "$p" "$vn" "$w" "$u" "$vb" "$mb" "$bd" \
      "$vt" "$mt" "$td" "$verdict"
  done <"$results"
} >"$rates_table"

# The sensitivity table over the suite.
sens_table="$tmp/sens.md"
: >"$sens_table"
if [ "$suite_rays" -gt 0 ]; then
  [ -r "$suite" ] || { echo "$name: cannot read the suite manifest $suite" >&2; exit 2; }
  if [ -r /usr/share/doc/libcgal-dev/data.tar.gz ]; then "$root/scripts/cgal_meshes.sh" >/dev/null; fi
  "$rtusim" info --suite "$suite" --json "$tmp/suite.json" >/dev/null
  mapfile -t entries < <(python3 -c "import json, sys; d = json.load(open(sys.argv[1]))
for e in d['entries']:
    if e['available']: print(e['name'] + '\x1f' + e['scene'])" "$tmp/suite.json")
  # label|preset|--set arguments
  steps_intel=(
    "intel-mem|intel-mem|"
    "BVH cache 16 KiB|intel-mem|--set cache_kib=16"
    "3 pipelines (box_units 3, 96 slots)|intel-mem|--set box_units=3 --set ray_slots=96"
    "2 triangle tests/clk|intel-mem|--set tri_units=2"
    "18/2 rates, 64 slots|intel-mem|--set box_units=3 --set tri_units=2"
    "B580 VRAM share (8.53 B/clk, 801 cycles)|intel-mem|--set dram_bytes_per_cycle=8.53 --set dram_latency=801"
    "xe2-mem|xe2-mem|"
  )
  steps_amd=(
    "rdna2-mem|rdna2-mem|"
    "L0 32 KiB|rdna2-mem|--set cache_kib=32"
    "8/2 rates, BVH4|rdna2-mem|--set box_rate=8 --set tri_units=2"
    "BVH8 (format rdna4), 4/1 rates|rdna2-mem|--set format=rdna4 --set bvh_width=8"
    "BVH8 and 8/2 rates|rdna2-mem|--set format=rdna4 --set bvh_width=8 --set box_rate=8 --set tri_units=2"
    "64 ray slots|rdna2-mem|--set ray_slots=64"
    "RX 9070 XT VRAM share (4.19 B/clk, 720 cycles)|rdna2-mem|--set dram_bytes_per_cycle=4.19 --set dram_latency=720"
    "rdna4-mem|rdna4-mem|"
  )
  cpr="$tmp/cpr.tsv"  # scene kind family step cycles/ray ns/ray
  : >"$cpr"
  for entry in "${entries[@]}"; do
    IFS=$'\x1f' read -r sname spec <<<"$entry"
    echo "$name: suite: $sname" >&2
    for kind in primary incoherent; do
      "$rtusim" rays --scene "$spec" --kind "$kind" --count "$suite_rays" --out "$tmp/$kind.rays" >/dev/null
      for family in intel amd; do
        declare -n steps="steps_$family"
        for s in "${steps[@]}"; do
          IFS='|' read -r label preset sets <<<"$s"
          # shellcheck disable=SC2086
          "$rtusim" trace --scene "$spec" --rays "$tmp/$kind.rays" --device timed --config "$preset" $sets \
            --threads 1 --stats "$tmp/t.json" >/dev/null 2>&1
          python3 -c "import json, sys; t = json.load(open(sys.argv[1]))['timing']
print('\t'.join([sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5], '%.4f' % t['cycles_per_ray'],
                 '%.4f' % (t['cycles_per_ray'] / t['config']['clock_ghz'] if 'config' in t else 0)]))" \
            "$tmp/t.json" "$sname" "$kind" "$family" "$label" >>"$cpr"
        done
        unset -n steps
      done
    done
  done
  python3 - "$cpr" >"$sens_table" <<'PY'
import math, sys
rows = [l.rstrip("\n").split("\t") for l in open(sys.argv[1])]
scenes = list(dict.fromkeys(r[0] for r in rows))
for family, title in (("intel", "Xe-HPG -> Xe2 (intel-mem -> xe2-mem)"), ("amd", "RDNA2 -> RDNA4 (rdna2-mem -> rdna4-mem)")):
    for kind in ("primary", "incoherent"):
        sub = [r for r in rows if r[2] == family and r[1] == kind]
        steps = list(dict.fromkeys(r[3] for r in sub))
        cell = {(r[0], r[3]): (float(r[4]), float(r[5])) for r in sub}
        print(f"\n### {title}, {kind} rays: cycles per ray (ratio to {steps[0]})\n")
        print("| scene | " + " | ".join(steps) + " | " + steps[-1] + " ns/ray vs " + steps[0] + " |")
        print("|---|" + "---:|" * (len(steps) + 1))
        logs = {s: [] for s in steps}
        logs_ns = []
        for sc in scenes:
            if (sc, steps[0]) not in cell:
                continue
            base, base_ns = cell[(sc, steps[0])]
            out = []
            for s in steps:
                c, _ = cell[(sc, s)]
                logs[s].append(math.log(base / c))
                out.append("%.1f" % c if s == steps[0] else "%.1f (%.2fx)" % (c, base / c))
            last_ns = cell[(sc, steps[-1])][1]
            logs_ns.append(math.log(base_ns / last_ns))
            print(f"| {sc} | " + " | ".join(out) + " | %.1f vs %.1f (%.2fx) |" % (last_ns, base_ns, base_ns / last_ns))
        gm = lambda v: math.exp(sum(v) / len(v)) if v else float("nan")
        print("| geometric mean of the ratios | " + " | ".join("1" if s == steps[0] else "%.2fx" % gm(logs[s]) for s in steps) +
              " | %.2fx |" % gm(logs_ns))
PY
fi
seconds=$(($(date +%s) - start))

bench_report_context "$out" "$root"
{
  printf '# The units of 2025: the vendors'"'"' test rates, and the steps to RDNA4 and Xe2\n\n'
  printf '**Question.** Do the timing presets test as many boxes and triangles per clock as the vendors say their\n'
  printf 'units do, and what does each of the Xe-HPG -> Xe2 and RDNA2 -> RDNA4 changes buy on the scene suite?\n\n'
  printf '**Command.** `bench/unit_rates.sh %s %s %s` with `SUITE_RAYS=%s` (%d s on this machine); the method is in\n' \
    "$rtusim" "$rays" "${presets[*]}" "$suite_rays" "$seconds"
  printf 'the script'"'"'s header. `ctest -R unit_rates` runs the rate measurement on 1200 rays and fails unless every\n'
  printf 'rate equals the vendor'"'"'s.\n\n'
  printf '**Measured** %s (commit %s) on %s, %s cores (%s), %s; Release build. Cycles and counts do not depend\n' \
    "$(date -u +%Y-%m-%d)" "$commit" "$os" "$(nproc)" "$cpu" "$(uname -sr)"
  printf 'on the machine.\n\n'
  printf '## Box and triangle tests per clock of one unit\n\n'
  cat "$rates_table"
  printf '\nMeasured: tests issued in the third quarter of a run of %s rays over its clocks, an exact fraction;\n' "$rays"
  printf '"tests / clocks" are those counts, then the whole run'"'"'s tests per cycle (fill and drain included). Box\n'
  printf 'runs: no triangle test and every node visited full (checked).\n'
  if [ -s "$sens_table" ]; then
    printf '\n## The steps on the scene suite\n\n'
    printf 'Each column after the first changes one thing of the older preset (`--set`), the last is the new preset\n'
    printf '(its memory and clock too). Cycles per ray of %s primary and %s incoherent rays per scene; the ratio is\n' \
      "$suite_rays" "$suite_rays"
    printf 'the older preset'"'"'s cycles over the column'"'"'s (> 1: fewer cycles). The last column compares time at each\n'
    printf 'preset'"'"'s own clock.\n'
    cat "$sens_table"
  fi
  if [ -n "$notes" ]; then
    printf '\n%s\n' "$notes"
  fi
} >"$out"
echo "$name: wrote $out" >&2
exit $fail
