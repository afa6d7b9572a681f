#!/usr/bin/env bash
# The field's compression results beside the model's (bench/results/compression.md):
#   1. bytes: encoded nodes and primitives against the float BVH2 with float triangles (Ylitie et al., HPG 2017:
#      compressed 8-wide BVHs take 35-60% of the memory);
#   2. DRAM bytes and cycles of narrow against wide boxes and triangles on incoherent rays, on the memory-bound
#      presets (AQB8, ISCA 2025: 8-bit quantization cuts DRAM accesses by 70% and runs 1.82x faster);
#   3. a 5-entry short stack against a full one (Vaidyanathan et al., HPG 2019: close to full-stack step counts).
#
#   bench/compression.sh [RTUSIM] [RAYS] [MESH...]
#     RTUSIM  default build/default/rtusim;  RAYS  incoherent rays per mesh, default 50000;  MESH  default two
#     assimp-testmodels meshes
#     FLATTEN (environment) 1: trace instanced meshes flattened, in one image (`--flatten`), for the one-level
#     cycles; default 0: over two levels, as rtusim does by default
# Every run is `rtusim trace --threads 1` on the same ray file per mesh; bytes come from the fixed device's stats
# JSON (image section), cycles and DRAM bytes from the timed device's. The byte columns are always those of the
# flattened image (one BVH over the mesh's triangles, the quantity the papers compare); for an instanced mesh
# the two-level memory's bytes (top and bottom images and transforms) are a column of their own. Prints Markdown
# tables; needs python3.
set -euo pipefail
source "$(dirname "$0")/lib.sh"  # sets name to compression.sh
bench_mesh_setup 50000 "$bench_house" "$bench_engine" -- "$@"
flat=()
[ "${FLATTEN:-0}" = 1 ] && flat=(--flatten)

# name|options: the formats of tables 1 and 2. The width is given on every row: on the timed device the timing
# preset's bvh_width applies otherwise (intel-mem's 8, rdna2-mem's 4).
formats=(
  "structs, 16-bit offsets, BVH4|--format default --child-bits 16 --bvh-width 4"
  "structs, 8-bit offsets, BVH4|--format default --bvh-width 4"
  "structs, 8-bit offsets, BVH8|--format wide8 --bvh-width 8"
  "compressed-wide BVH8 + blocks|--format cwbvh --bvh-width 8"
  "xe6: bit-packed BVH6 in 64 bytes, records|--format xe6 --bvh-width 6"
  "bit-packed BVH4 + blocks|--format packed --bvh-width 4"
  "bit-packed BVH8 + blocks|--format packed --bvh-width 8"
  "bit-packed BVH4 + blocks, 16-bit grid, 6-bit offsets|--format packed --coord-bits 16 --child-bits 6 --bvh-width 4"
)

stat() {  # stat FILE EXPR: a python expression over the stats JSON j
  python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print($2)" "$1"
}

for mesh in "${meshes[@]}"; do
  [ -r "$mesh" ] || { echo "compression.sh: cannot read $mesh" >&2; exit 2; }
  "$rtusim" rays --scene "$mesh" --kind incoherent --count "$rays" --out "$tmp/inc.bin" >/dev/null
  name=$(basename "$mesh")
  # The baseline: the float BVH2 (its nodes and leaf index) and the float triangles (9 floats each).
  "$rtusim" trace --scene "$mesh" --rays "$tmp/inc.bin" --out "$tmp/h.bin" --device fixed --bvh-width 2 \
    --flatten --threads 1 --stats "$tmp/b2.json" >/dev/null
  base=$(stat "$tmp/b2.json" "j['bvh']['image']['float_node_bytes'] + j['bvh']['image']['float_index_bytes'] + 36 * j['bvh']['image']['records']")
  prims=$(stat "$tmp/b2.json" "j['bvh']['image']['records']")
  hier=$(stat "$tmp/b2.json" "j['bvh']['image']['float_node_bytes'] + j['bvh']['image']['float_index_bytes']")
  echo
  levels="over two levels where the mesh is instanced"
  [ ${#flat[@]} -gt 0 ] && levels="flattened (--flatten)"
  echo "### $name: $prims primitives, $rays incoherent rays, cycles $levels"
  echo
  echo "Float BVH2: $hier bytes of nodes and leaf index; with its triangles $base bytes ($(python3 -c "print(f'{$base / $prims:.1f}')") bytes per primitive)."
  echo
  echo "| format | node bytes | bytes/node | nodes of float BVH2 nodes | primitive bytes | bytes/prim | all of float BVH2 + triangles | two-level bytes | rdna2-mem cycles | DRAM B/ray | intel-mem cycles | DRAM B/ray |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
  for entry in "${formats[@]}"; do
    label=${entry%%|*}
    read -r -a opts <<<"${entry#*|}"
    "$rtusim" trace --scene "$mesh" --rays "$tmp/inc.bin" --out "$tmp/h.bin" --device fixed "${opts[@]}" \
      --flatten --threads 1 --stats "$tmp/f.json" >/dev/null
    "$rtusim" trace --scene "$mesh" --rays "$tmp/inc.bin" --out "$tmp/h.bin" --device fixed "${opts[@]}" \
      --threads 1 --stats "$tmp/f2.json" >/dev/null
    row="| $label | $(stat "$tmp/f.json" "j['bvh']['image']['node_bytes']") | $(stat "$tmp/f.json" "j['bvh']['image']['bytes_per_node']")"
    row+=" | $(stat "$tmp/f.json" "f\"{100 * j['bvh']['image']['node_bytes'] / $hier:.0f}%\"")"
    row+=" | $(stat "$tmp/f.json" "j['bvh']['image']['record_bytes']")"
    row+=" | $(stat "$tmp/f.json" "f\"{(j['bvh']['image']['node_bytes'] + j['bvh']['image']['record_bytes']) / j['bvh']['image']['records']:.1f}\"")"
    row+=" | $(stat "$tmp/f.json" "f\"{100 * (j['bvh']['image']['node_bytes'] + j['bvh']['image']['record_bytes']) / $base:.0f}%\"")"
    row+=" | $(stat "$tmp/f2.json" "j['bvh']['image'].get('two_level', {}).get('total_bytes', '-')")"
    for preset in rdna2-mem intel-mem; do
      "$rtusim" trace --scene "$mesh" --rays "$tmp/inc.bin" --out "$tmp/h.bin" --device timed --config "$preset" \
        "${opts[@]}" "${flat[@]}" --threads 1 --stats "$tmp/t.json" >/dev/null
      row+=" | $(stat "$tmp/t.json" "j['timing']['cycles']") | $(stat "$tmp/t.json" "f\"{j['timing']['dram_bytes'] / j['timing']['rays']:.0f}\"")"
    done
    echo "$row |"
  done
  echo
  echo "Short stack against a full one (rdna2-mem, format packed):"
  echo
  echo "| stack entries | cycles | stack spills | stack refills | DRAM B/ray | nodes visited |"
  echo "|---:|---:|---:|---:|---:|---:|"
  for entries in 64 8 5 2; do
    "$rtusim" trace --scene "$mesh" --rays "$tmp/inc.bin" --out "$tmp/h.bin" --device timed --config rdna2-mem \
      --format packed --set "stack_entries=$entries" "${flat[@]}" --threads 1 --stats "$tmp/s.json" >/dev/null
    echo "| $entries | $(stat "$tmp/s.json" "j['timing']['cycles']") | $(stat "$tmp/s.json" "j['timing']['stack_spills']") | $(stat "$tmp/s.json" "j['timing']['stack_refills']") | $(stat "$tmp/s.json" "f\"{j['timing']['dram_bytes'] / j['timing']['rays']:.0f}\"") | $(stat "$tmp/s.json" "j['nodes_visited']") |"
  done
done
