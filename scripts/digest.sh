#!/usr/bin/env bash
# A digest of what the model computes, for refactorings that must change no behaviour: hits (t, primitive, u, v)
# and statistics (traversal, timing, cycles) of
#  - the float, fixed and timed devices on three real meshes, primary and incoherent rays, closest hit;
#  - the timed device under each timing preset (rdna2, intel, embedded), and one sampled run per mesh;
#  - firmware renders of the built-in scenes on the float and timed devices (image bytes and render statistics),
#    ray traced and hybrid;
#  - the memory-bound presets (rdna2-mem, intel-mem) and the chips (rdna2-chip, intel-chip, embedded-chip: units
#    sharing an L2 and banked DRAM, each ray policy), on incoherent rays;
#  - the packed layouts (bit-packed nodes with triangle blocks, compressed-wide, xe6) on fixed and timed;
#  - two-level scenes (builtin:city, the IFC house's instances) over two levels and flattened, and alpha-tested
#    geometry (builtin:forest) traced and rendered on the timed device;
#  - the co-simulated RTL box and triangle units on the timed device, when the build has them.
# Wall-clock fields (seconds, rays per second) and file names are dropped from the JSON; everything else is kept.
# Prints one line per run and a final digest over all of them; two builds that print the same final line computed
# the same results on these inputs.
# DIGEST_DROP="key1 key2 ..." drops those JSON keys too: a change that only adds keys (a new timing key or counter,
# zero or at its default) shows it changed nothing else when the digest without them equals the one before.
# Usage: scripts/digest.sh [RTUSIM] [RAYS]     (RAYS per kind and mesh, default 20000; a few minutes)
set -euo pipefail
source "$(dirname "$0")/../bench/lib.sh"  # the meshes and bench_tmpdir
rtusim=${1:-build/default/rtusim}
rays=${2:-20000}
meshes=("$bench_house" "$bench_engine" "$bench_suzanne")
bench_tmpdir

# The JSON without wall-clock figures and paths, keys sorted, as one line.
strip_json() {
  python3 - "$1" <<'EOF'
import json, os, sys
drop = {"trace_seconds", "rays_per_second", "load_seconds", "build_seconds", "seconds", "wall_seconds",
        "render_seconds", "rays_file", "out", "image", "path", "threads"}
drop |= set(os.environ.get("DIGEST_DROP", "").split())
def clean(v):
    if isinstance(v, dict):
        return {k: clean(x) for k, x in v.items() if k not in drop and not k.endswith("_seconds")}
    if isinstance(v, list):
        return [clean(x) for x in v]
    return v
print(json.dumps(clean(json.load(open(sys.argv[1]))), sort_keys=True))
EOF
}

keep=${DIGEST_KEEP:-}  # a folder: the stripped JSON of every run is kept there, to find what differs
[[ -n $keep ]] && mkdir -p "$keep"

line() {  # name, files...: the name and a hash of the files' contents (JSON files stripped first)
  local name=$1; shift
  local h
  if [[ -n $keep ]]; then
    for f in "$@"; do
      if [[ $f == *.json ]]; then strip_json "$f" | python3 -m json.tool >"$keep/${name//\//_}.json"; fi
    done
  fi
  h=$(for f in "$@"; do
        if [[ $f == *.json ]]; then strip_json "$f"; else sha256sum <"$f"; fi
      done | sha256sum | cut -c1-16)
  echo "$name $h" | tee -a "$tmp/all"
}

for mesh in "${meshes[@]}"; do
  m=$(basename "$mesh")
  for kind in primary incoherent; do
    if [[ $kind == primary ]]; then
      "$rtusim" rays --scene "$mesh" --kind primary --width 160 --height $((rays / 160)) --out "$tmp/r.bin" >/dev/null
    else
      "$rtusim" rays --scene "$mesh" --kind incoherent --count "$rays" --seed 7 --out "$tmp/r.bin" >/dev/null
    fi
    for dev in float fixed; do
      "$rtusim" trace --scene "$mesh" --rays "$tmp/r.bin" --device $dev --threads 2 --out "$tmp/h.bin" \
        --stats "$tmp/s.json" >/dev/null 2>&1
      line "$m/$kind/$dev" "$tmp/h.bin" "$tmp/s.json"
    done
    for preset in rdna2 intel embedded; do
      "$rtusim" trace --scene "$mesh" --rays "$tmp/r.bin" --device timed --config $preset --threads 2 \
        --out "$tmp/h.bin" --stats "$tmp/s.json" >/dev/null 2>&1
      line "$m/$kind/timed-$preset" "$tmp/h.bin" "$tmp/s.json"
    done
    "$rtusim" trace --scene "$mesh" --rays "$tmp/r.bin" --device timed --config rdna2 --threads 2 \
      --sample 0.05 --sample-seed 3 --out "$tmp/h.bin" --stats "$tmp/s.json" >/dev/null 2>&1
    line "$m/$kind/timed-sampled" "$tmp/h.bin" "$tmp/s.json"
  done
done

# Sampled timing on a longer packet (strata, probe, walk, adaptive warm-up), with hits and cycles only; any-hit.
mesh=${meshes[0]}
"$rtusim" rays --scene "$mesh" --kind primary --width 400 --height 300 --out "$tmp/r.bin" >/dev/null
"$rtusim" trace --scene "$mesh" --rays "$tmp/r.bin" --device timed --config rdna2 --threads 2 \
  --sample 0.02 --sample-seed 5 --out "$tmp/h.bin" --stats "$tmp/s.json" >/dev/null 2>&1
line "sampled-120k/hits" "$tmp/h.bin" "$tmp/s.json"
"$rtusim" trace --scene "$mesh" --rays "$tmp/r.bin" --device timed --config intel --threads 2 \
  --sample 0.02 --sample-seed 5 --stats "$tmp/s.json" >/dev/null 2>&1
line "sampled-120k/cycles-only" "$tmp/s.json"
for dev in fixed timed; do
  "$rtusim" trace --scene "$mesh" --rays "$tmp/r.bin" --device $dev --any-hit --threads 2 --out "$tmp/h.bin" \
    --stats "$tmp/s.json" >/dev/null 2>&1
  line "any-hit/$dev" "$tmp/h.bin" "$tmp/s.json"
done

for scene in seed cornell; do
  for dev in float timed; do
    for mode in raytrace hybrid; do
      "$rtusim" render --scene builtin:$scene --device $dev --mode $mode --width 96 --height 72 --spp 1 \
        --max-depth 2 --threads 2 --out "$tmp/i.png" --stats "$tmp/s.json" >/dev/null 2>&1
      line "render/$scene/$dev/$mode" "$tmp/i.png" "$tmp/s.json"
    done
  done
done

# Memory-bound presets and chips, incoherent rays on the house (two levels, as the CLI traces it).
mesh=${meshes[0]}
"$rtusim" rays --scene "$mesh" --kind incoherent --count "$rays" --seed 11 --out "$tmp/r.bin" >/dev/null
for cfg in rdna2-mem intel-mem rdna2-chip intel-chip embedded-chip; do
  "$rtusim" trace --scene "$mesh" --rays "$tmp/r.bin" --device timed --config $cfg --threads 2 \
    --out "$tmp/h.bin" --stats "$tmp/s.json" >/dev/null 2>&1
  line "memory/$cfg" "$tmp/h.bin" "$tmp/s.json"
done
for policy in round_robin blocks; do
  "$rtusim" trace --scene "$mesh" --rays "$tmp/r.bin" --device timed --config rdna2-chip --set ray_policy=$policy \
    --threads 2 --out "$tmp/h.bin" --stats "$tmp/s.json" >/dev/null 2>&1
  line "memory/rdna2-chip-$policy" "$tmp/h.bin" "$tmp/s.json"
done

# Packed layouts on fixed and timed (rdna2-mem: the bytes are what the rays wait for), both levels and flattened.
for fmt in packed cwbvh xe6 "packed --coord-bits 16 --child-bits 6"; do
  for dev in fixed timed; do
    for flat in "" --flatten; do
      # shellcheck disable=SC2086
      "$rtusim" trace --scene "$mesh" --rays "$tmp/r.bin" --device $dev --format $fmt $flat \
        $([[ $dev == timed ]] && echo "--config rdna2-mem") --threads 2 --out "$tmp/h.bin" \
        --stats "$tmp/s.json" >/dev/null 2>&1
      line "layout/${fmt// /_}/$dev${flat:+/flat}" "$tmp/h.bin" "$tmp/s.json"
    done
  done
done

# Two levels (the city) and alpha-tested geometry (the forest): traced both ways and rendered on the timed device.
for scene in city forest; do
  "$rtusim" rays --scene builtin:$scene --kind incoherent --count "$rays" --seed 13 --out "$tmp/r.bin" >/dev/null
  for dev in float fixed timed; do
    for flat in "" --flatten; do
      [[ $dev == float && -n $flat ]] && continue
      # shellcheck disable=SC2086
      "$rtusim" trace --scene builtin:$scene --rays "$tmp/r.bin" --device $dev $flat --threads 2 \
        --out "$tmp/h.bin" --stats "$tmp/s.json" >/dev/null 2>&1
      line "$scene/$dev${flat:+/flat}" "$tmp/h.bin" "$tmp/s.json"
    done
  done
  "$rtusim" render --scene builtin:$scene --device timed --width 64 --height 48 --spp 1 --max-depth 2 --threads 2 \
    --out "$tmp/i.png" --stats "$tmp/s.json" >/dev/null 2>&1
  line "render/$scene/timed" "$tmp/i.png" "$tmp/s.json"
done

# Co-simulated RTL units (builds without RTL refuse box_unit=rtl: those lines are left out, and say so).
"$rtusim" rays --scene builtin:cornell --kind primary --width 64 --height 48 --out "$tmp/r.bin" >/dev/null
for unit in "box_unit=rtl" "tri_unit=rtl" "box_unit=rtl --set tri_unit=rtl"; do
  # shellcheck disable=SC2086
  if "$rtusim" trace --scene builtin:cornell --rays "$tmp/r.bin" --device timed --set $unit --threads 2 \
      --out "$tmp/h.bin" --stats "$tmp/s.json" >/dev/null 2>&1; then
    line "rtl/${unit// --set /+}" "$tmp/h.bin" "$tmp/s.json"
  else
    echo "rtl/${unit// --set /+} (not in this build)" | tee -a "$tmp/all"
  fi
done
if "$rtusim" render --scene builtin:cornell --device timed --set box_unit=rtl --set tri_unit=rtl --width 48 \
    --height 36 --spp 1 --max-depth 2 --threads 2 --out "$tmp/i.png" --stats "$tmp/s.json" >/dev/null 2>&1; then
  line "render/cornell/timed-rtl" "$tmp/i.png" "$tmp/s.json"
fi

echo "digest $(sha256sum <"$tmp/all" | cut -c1-16)"
