#!/usr/bin/env bash
# Two levels against one: what instancing buys the fixed-point unit. For each instanced scene, the bytes of the
# two-level memory (top image, bottom images, stored transforms) against the flattened image, and the timed
# device's cycles, DRAM bytes and cache hit rate on primary and incoherent rays, traced over two levels and with
# --flatten. Then the transform's width: the fixed device's error against the float reference on one scene for
# each xform_bits.
#
#   bench/two_level.sh [RTUSIM] [RAYS]
#     RTUSIM  default build/default/rtusim;  RAYS  default 100000 incoherent rays (primary: the camera's image);
#     SCENES (environment) default "builtin:city" and the engine and IFC house of assimp-testmodels;
#     CONFIG default rdna2;  XFORM_SCENE default builtin:city;  XFORM_BITS default "24 20 16 12 8"
# Prints Markdown tables. Reads the stats JSON with python3.
set -euo pipefail
source "$(dirname "$0")/lib.sh"  # sets name to two_level.sh
bench_rays_args 100000 "$@"
read -r -a scenes <<<"${SCENES:-builtin:city $bench_engine $bench_house}"
config=${CONFIG:-rdna2}
xscene=${XFORM_SCENE:-builtin:city}
read -r -a xbits <<<"${XFORM_BITS:-24 20 16 12 8}"
bench_need_python
bench_tmpdir

echo "| scene | instances / meshes | flattened image bytes | two-level bytes | ratio |"
echo "|---|---:|---:|---:|---:|"
for s in "${scenes[@]}"; do
  "$rtusim" info --scene "$s" --json "$tmp/info.json" >/dev/null
  python3 - "$s" "$tmp/info.json" <<'PY'
import json, os, sys
s, f = sys.argv[1:3]
j = json.load(open(f))
inst = j.get("instancing")
if not inst:
    sys.exit(f"two_level.sh: {s} is not instanced")
flat = j["bvh"]["image"]["total_bytes"]
two = inst["fixed"]["total_bytes"]
print(f"| {os.path.basename(s)} | {inst['instances']} / {inst['meshes']} | {flat} | {two} | {flat / two:.1f}x |")
PY
done
echo
echo "| scene | rays | levels | cycles | cycles/ray | DRAM bytes/ray | cache hit rate | instance transforms/ray | cycles two / one |"
echo "|---|---|---|---:|---:|---:|---:|---:|---:|"
for s in "${scenes[@]}"; do
  for kind in primary incoherent; do
    count=()
    [ "$kind" = incoherent ] && count=(--count "$rays")
    "$rtusim" rays --scene "$s" --kind "$kind" "${count[@]}" --out "$tmp/r.rays" >/dev/null
    for flat in "" --flatten; do
      "$rtusim" trace --scene "$s" --rays "$tmp/r.rays" --device timed --config "$config" --threads 1 $flat \
        --out "$tmp/h.bin" --stats "$tmp/t$flat.json" >/dev/null
    done
    python3 - "$s" "$kind" "$tmp/t.json" "$tmp/t--flatten.json" <<'PY'
import json, os, sys
s, kind, two_f, one_f = sys.argv[1:5]
two, one = (json.load(open(f))["timing"] for f in (two_f, one_f))
for label, t in (("two", two), ("one (--flatten)", one)):
    n = t["rays"]
    ratio = f"{two['cycles'] / one['cycles']:.2f}" if label == "two" else ""
    print(f"| {os.path.basename(s)} | {kind} {n} | {label} | {t['cycles']} | {t['cycles'] / n:.2f} | "
          f"{t['dram_bytes'] / n:.1f} | {t['cache']['hit_rate']:.3f} | {t['instance_transforms'] / n:.2f} | {ratio} |")
PY
  done
done
echo
echo "| xform_bits | scene | rays | hit agreement | primitive agreement | t error mean (relative) | t error max | two-level bytes |"
echo "|---:|---|---|---:|---:|---:|---:|---:|"
for b in "${xbits[@]}"; do
  for kind in primary incoherent; do
    spec=$kind
    [ "$kind" = incoherent ] && spec=incoherent:$rays
    "$rtusim" compare --scene "$xscene" --rays "$spec" --xform-bits "$b" --threads 1 --json "$tmp/c.json" >/dev/null
    python3 - "$b" "$xscene" "$kind" "$tmp/c.json" <<'PY'
import json, os, sys
b, s, kind, f = sys.argv[1:5]
j = json.load(open(f))
two = j["bvh"]["image"].get("two_level", {}).get("total_bytes", "-")
print(f"| {b} | {os.path.basename(s)} | {kind} {j['rays']} | {100 * j['hit_agreement']:.4f}% | "
      f"{100 * j['prim_agreement']:.4f}% | {j['t_rel_error_mean']:.3g} | {j['t_rel_error_max']:.3g} | {two} |")
PY
  done
done
