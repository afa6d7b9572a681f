#!/usr/bin/env bash
# Node kinds side by side: axis-aligned nodes at widths 4 and 8 against oriented nodes at width 8 (format
# node_kind=1, docs/numerics.md), without and with triangle pairs (tri_pairs=1), per scene and ray kind: image bytes, traversal steps (node and leaf visits), box
# and primitive tests per ray, the build's wall time (BVH and image), and cycles on each timing preset. Then the
# rotation table's knobs (its size and its entries' bits) on one scene. Writes Markdown to stdout (the tables of
# bench/results/node-kinds.md). Counts and cycles are deterministic; build seconds are this machine's.
# Usage: bench/node_kinds.sh [RTUSIM] [RAYS]      (RAYS per kind, default 32768)
#   PRESETS="rdna4-mem xe2-mem"    the timing presets of the cycles columns
#   KNOB_SCENE=builtin:hairball    the scene of the knob table
set -euo pipefail
name=node_kinds.sh
. "$(dirname "$0")/lib.sh"
bench_rays_args 32768 "$@"
bench_tmpdir
presets=(${PRESETS:-rdna4-mem xe2-mem})
scenes=(
  "hairball=builtin:hairball"
  "instances (rotated, flattened)=scenes/instances.json"
  "engine=$bench_engine"
  "house=$bench_house"
  "cornell=builtin:cornell"
)
variants=("AABB BVH4=4:0:0" "AABB BVH8=8:0:0" "OBB BVH8=8:1:0" "OBB BVH8 + pairs=8:1:1")
# Every variant in struct nodes and 40-byte records (oriented nodes and pairs need them), whatever the preset's
# format stores, so that the columns differ by the node kind and the pairs only.
layout=(--node-layout 0 --node-align 1 --prim-layout 0)

# fixed SCENE RAYS WIDTH KIND OUT [FORMAT CHANGES...]: the fixed device's stats of a run.
fixed() {
  local scene=$1 r=$2 w=$3 k=$4 out=$5
  shift 5
  "$rtusim" compare --flatten --scene "$scene" --rays "$r" --bvh-width "$w" --node-kind "$k" "${layout[@]}" "$@" \
    --json "$out.cmp" > /dev/null
  "$rtusim" trace --flatten --scene "$scene" --rays "$r" --device fixed --bvh-width "$w" --node-kind "$k" \
    "${layout[@]}" "$@" --stats "$out" > /dev/null
}

header="| scene | rays | nodes | image bytes | steps/ray | box tests/ray | prim tests/ray | build s | hit agreement |"
rule="|---|---|---|---:|---:|---:|---:|---:|---:|"
for p in "${presets[@]}"; do
  header+=" cycles/ray $p |"
  rule+="---:|"
done
echo "$header"
echo "$rule"
for s in "${scenes[@]}"; do
  label=${s%%=*}
  path=${s#*=}
  [ -e "$path" ] || [[ "$path" == builtin:* ]] || { echo "$name: skipping $label: $path is missing" >&2; continue; }
  for kind in primary incoherent; do
    for v in "${variants[@]}"; do
      vname=${v%%=*}
      spec=${v#*=}
      IFS=: read -r w k pairs <<< "$spec"
      fixed "$path" "$kind:$rays" "$w" "$k" "$tmp/f.json" --tri-pairs "$pairs"
      cycles=""
      for p in "${presets[@]}"; do
        "$rtusim" trace --flatten --scene "$path" --rays "$kind:$rays" --device timed --config "$p" \
          --set bvh_width="$w" --node-kind "$k" --tri-pairs "$pairs" "${layout[@]}" --stats "$tmp/t.json" > /dev/null
        cycles+=" $(/usr/bin/python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); print("%.1f" % (j["timing"]["cycles"] / max(1, j["rays"])))' "$tmp/t.json") |"
      done
      row=$(/usr/bin/python3 - "$tmp/f.json" "$tmp/f.json.cmp" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
c = json.load(open(sys.argv[2]))
r = max(1, j["rays"])
img = j["bvh"]["image"]["total_bytes"] if "image" in j.get("bvh", {}) else 0
agree = c.get("hit_agreement", c.get("summary", {}).get("hit_agreement", float("nan")))
print("%d | %.2f | %.2f | %.2f | %.2f | %.6f" % (img, (j["nodes_visited"] + j["leaves_visited"]) / r,
      j["box_tests"] / r, j["prim_tests"] / r, j["build_seconds"], agree))
PY
)
      echo "| $label | $kind | $vname | $row |$cycles"
    done
  done
done

# The rotation table's knobs on one scene, incoherent rays: what each size and width of the table buys (steps,
# tests) and costs (build time; the test's bits are in docs/numerics.md). Rotation changes no hit: the agreement
# column is the axis-aligned image's.
knob_scene=${KNOB_SCENE:-builtin:hairball}
echo
echo "Rotation table knobs on $knob_scene (BVH8, incoherent rays; rotations 1 is the identity alone):"
echo
echo "| rotations | rot_bits | steps/ray | box tests/ray | prim tests/ray | build s | hit agreement |"
echo "|---:|---:|---:|---:|---:|---:|---:|"
for rb in 6 8 12 14; do
  for nr in 1 13 26 52 104 208 1024; do
    [ "$rb" = 12 ] || [ "$nr" = 104 ] || continue
    fixed "$knob_scene" "incoherent:$rays" 8 1 "$tmp/k.json" --rotations "$nr" --rot-bits "$rb"
    row=$(/usr/bin/python3 - "$tmp/k.json" "$tmp/k.json.cmp" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
c = json.load(open(sys.argv[2]))
r = max(1, j["rays"])
agree = c.get("hit_agreement", c.get("summary", {}).get("hit_agreement", float("nan")))
print("%.2f | %.2f | %.2f | %.2f | %.6f" % ((j["nodes_visited"] + j["leaves_visited"]) / r, j["box_tests"] / r,
      j["prim_tests"] / r, j["build_seconds"], agree))
PY
)
    echo "| $nr | $rb | $row |"
  done
done
