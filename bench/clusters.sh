#!/usr/bin/env bash
# Triangle clusters (format prim_layout 2, hwmodel/format/cluster_layout.h) against triangle blocks (prim_layout 1)
# on real meshes and built-in scenes: bytes per triangle of the image (node section + primitive section, which
# holds the clusters' internal nodes), the datapath's box and triangle tests per ray, and cycles and DRAM bytes
# per ray on a memory preset with the cluster engine off and at a few rates (cluster_tri_rate). Every run traces
# the flattened scene (one BVH) on the same incoherent rays, in the preset's format changed only in prim_layout,
# cluster_tris and the BVH's leaf size. Writes Markdown tables to stdout (bench/results/clusters.md).
#
#   bench/clusters.sh [RTUSIM] [RAYS] [SCENE...]
#     RTUSIM  default build/default/rtusim;  RAYS  incoherent rays per scene, default 20000;  SCENE  default the
#     engine and house meshes of assimp-testmodels, builtin:hairball and builtin:cornell
#     PRESET  (environment) the timing preset, default rdna4-mem (its format rdna4: BVH8 of oriented nodes padded
#             to 128 bytes);  RATES  the cluster engine's triangles per clock of the cycle columns, default "4 16"
set -euo pipefail
source "$(dirname "$0")/lib.sh"  # sets name to clusters.sh
bench_mesh_args 20000 "$bench_engine" "$bench_house" builtin:hairball builtin:cornell -- "$@"
bench_json_reader
bench_tmpdir
preset=${PRESET:-rdna4-mem}
read -r -a rates <<< "${RATES:-4 16}"
for r in "${rates[@]}"; do bench_need_count "RATES entry" "$r"; done
format=$("$rtusim" config --config "$preset" | awk '$1 == "format" { print $3 }')
width=$("$rtusim" config --config "$preset" | awk '$1 == "bvh_width" { print $3 }')
[ -n "$format" ] && [ -n "$width" ] || { echo "$name: cannot read the format of preset $preset" >&2; exit 2; }

# label|leaf size|format changes
variants=(
  "blocks, leaves of 16|16|--prim-layout 1"
  "blocks, leaves of 8|8|--prim-layout 1"
  "clusters <= 256, leaves of 16|16|--prim-layout 2"
  "clusters <= 256, leaves of 8|8|--prim-layout 2"
  "clusters <= 64, leaves of 8|8|--prim-layout 2 --cluster-tris 64"
)

echo "Preset $preset (format $format, BVH$width), $rays incoherent rays per scene, flattened; cycles and DRAM bytes per ray."
for scene in "${meshes[@]}"; do
  [ -e "$scene" ] || [[ "$scene" == builtin:* ]] || { echo "$name: cannot read $scene" >&2; exit 2; }
  "$rtusim" rays --scene "$scene" --kind incoherent --count "$rays" --out "$tmp/r.bin" > /dev/null
  header="| layout | bytes/tri | clusters | box tests/ray | tri tests/ray | cycles/ray, engine off | DRAM B/ray |"
  rule="|---|---:|---:|---:|---:|---:|---:|"
  for r in "${rates[@]}"; do
    header+=" cycles/ray, $r/clock |"
    rule+="---:|"
  done
  first=1
  for v in "${variants[@]}"; do
    IFS='|' read -r label leaf changes <<< "$v"
    read -r -a opts <<< "--format $format --bvh-width $width --leaf-size $leaf $changes"
    "$rtusim" trace --flatten --scene "$scene" --rays "$tmp/r.bin" --device fixed "${opts[@]}" --threads 2 \
      --out "$tmp/h.bin" --stats "$tmp/f.json" > /dev/null
    IFS=$'\t' read -r tris nb rb nrays boxes prims clusters < <(bench_fields "$tmp/f.json" bvh.image.records \
      bvh.image.node_bytes bvh.image.record_bytes valid_rays box_tests prim_tests bvh.image.clusters)
    if [ $first = 1 ]; then
      echo
      echo "### $(basename "$scene"): $tris primitives"
      echo
      echo "$header"
      echo "$rule"
      first=0
    fi
    row="| $label | $(python3 -c "print(f'{($nb + $rb) / $tris:.1f}')") | $clusters"
    row+=" | $(python3 -c "print(f'{$boxes / $nrays:.1f} | {$prims / $nrays:.1f}')")"
    timed() {  # timed RATE: cycles and DRAM bytes per ray
      "$rtusim" trace --flatten --scene "$scene" --rays "$tmp/r.bin" --device timed --config "$preset" "${opts[@]}" \
        --set "cluster_tri_rate=$1" --threads 2 --out "$tmp/t.bin" --stats "$tmp/t.json" > /dev/null
      cmp -s "$tmp/h.bin" "$tmp/t.bin" || { echo "$name: timed hits differ from fixed ($label, $scene)" >&2; exit 1; }
      IFS=$'\t' read -r cycles dram trays < <(bench_fields "$tmp/t.json" timing.cycles timing.dram_bytes timing.rays)
    }
    timed 0
    row+=" | $(python3 -c "print(f'{$cycles / $trays:.1f} | {$dram / $trays:.0f}')")"
    for r in "${rates[@]}"; do
      if [[ $changes == *"--prim-layout 2"* ]]; then
        timed "$r"
        row+=" | $(python3 -c "print(f'{$cycles / $trays:.1f}')")"
      else
        row+=" | -"
      fi
    done
    echo "$row |"
  done
done
