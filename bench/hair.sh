#!/usr/bin/env bash
# Hair as linear swept spheres against hair as triangles: builtin:hair's strands as curve segments, as
# camera-facing ribbons and as two orthogonal triangle strips a strand (the "dots" form), in axis-aligned and
# oriented BVH8, per ray kind: image bytes, box and primitive tests per ray, cycles per ray on timing presets
# (rdna4-mem and xe2-mem test curves in triangle unit slots, rdna4-lss has a curve unit), pJ per ray on
# rdna4-lss; then each form's picture against Embree's round linear curves on primary rays (hair_coverage).
# Writes Markdown to stdout (the hair tables of bench/results/hair-and-clusters.md). Counts and cycles are
# deterministic.
# Usage: bench/hair.sh [RTUSIM] [RAYS]      (RAYS per kind, default 32768)
#   PRESETS="rdna4-mem rdna4-lss xe2-mem"   the timing presets of the cycles columns
#   STRANDS=24000                           strands of builtin:hair
set -euo pipefail
name=hair.sh
. "$(dirname "$0")/lib.sh"
bench_rays_args 32768 "$@"
bench_need_python
bench_tmpdir
presets=(${PRESETS:-rdna4-mem rdna4-lss xe2-mem})
strands=${STRANDS:-24000}
bench_need_count STRANDS "$strands"
coverage="$(dirname "$rtusim")/hair_coverage"
# Every variant in bit-packed nodes and 40-byte records, whatever the preset's format stores, so that the columns
# differ by the primitive and the node kind only.
layout=(--bvh-width 8 --node-layout 1 --node-align 1 --prim-layout 0)

header="| form | rays | nodes | prims | image bytes | box tests/ray | prim tests/ray |"
rule="|---|---|---|---:|---:|---:|---:|"
for p in "${presets[@]}"; do
  header+=" cycles/ray $p |"
  rule+="---:|"
done
header+=" pJ/ray rdna4-lss |"
rule+="---:|"
echo "$header"
echo "$rule"
for form in curves ribbons dots; do
  scene="builtin:hair?as=$form&strands=$strands"
  for kind in primary incoherent; do
    for nk in 0 1; do
      nodes=$([ "$nk" = 1 ] && echo "OBB BVH8" || echo "AABB BVH8")
      "$rtusim" trace --scene "$scene" --rays "$kind:$rays" --device fixed --node-kind "$nk" "${layout[@]}" \
        --stats "$tmp/f.json" > /dev/null
      cycles=""
      for p in "${presets[@]}"; do
        "$rtusim" trace --scene "$scene" --rays "$kind:$rays" --device timed --config "$p" --set bvh_width=8 \
          --node-kind "$nk" --node-layout 1 --node-align 1 --prim-layout 0 --stats "$tmp/t_$p.json" > /dev/null
        cycles+=" $(/usr/bin/python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); print("%.1f" % (j["timing"]["cycles"] / max(1, j["rays"])))' "$tmp/t_$p.json") |"
      done
      "$rtusim" trace --scene "$scene" --rays "$kind:$rays" --device timed --config rdna4-lss --set bvh_width=8 \
        --node-kind "$nk" --node-layout 1 --node-align 1 --prim-layout 0 --stats "$tmp/e.json" > /dev/null
      row=$(/usr/bin/python3 - "$tmp/f.json" "$tmp/e.json" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
e = json.load(open(sys.argv[2]))
r = max(1, j["rays"])
img = j["bvh"]["image"]["total_bytes"]
print("%d | %d | %.2f | %.2f | %.0f" % (j["bvh"]["prims"], img, j["box_tests"] / r, j["prim_tests"] / r,
      e["timing"]["energy"]["pj_per_ray"]))
PY
)
      IFS='|' read -r prims img box prim pj <<< "$row"
      echo "| $form | $kind | $nodes |$prims|$img|$box|$prim |$cycles$pj |"
    done
  done
done

if [ -x "$coverage" ]; then
  echo
  echo "Primary rays (512 x 512, the scene's camera) against Embree's round linear curves: pixels where Embree"
  echo "sees hair and the form does not (missed) or the form sees hair and Embree does not (added), and"
  echo "|t - t_Embree| / t_Embree where both see hair:"
  echo
  echo "| form | pixels | hair pixels (Embree) | missed | added | mean rel. t difference | 99th percentile |"
  echo "|---|---:|---:|---:|---:|---:|---:|"
  "$coverage" 512 "$strands" | while read -r form px hair missed added mean p99; do
    echo "| $form | $px | $hair | $missed | $added | $mean | $p99 |"
  done
else
  echo "$name: $coverage is missing (build the hair_coverage target): no picture table" >&2
fi
