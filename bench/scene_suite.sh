#!/usr/bin/env bash
# The benchmark scene suite's figures (bench/results/scene-suite.md): for every scene of the manifest, its
# triangles, instances and BVH bytes, the timed device's cycles per ray, and the float device's hit agreement with
# Embree.
#
#   bench/scene_suite.sh [RTUSIM] [RAYS] [SUITE]
#     RTUSIM  default build/default/rtusim;  RAYS  rays per kind on each scene, default 100000
#     SUITE   default scenes/suite.json;  OUT (environment) the file written, default bench/results/scene-suite.md
#     THREADS (environment) rtusim --threads, default 1
#
# Per scene:
# - triangles (the flattened scene's: what the fixed and timed devices trace), instances (two levels: what the
#   float device and Embree trace), BVH bytes = the fixed device's image in the default format (nodes + primitive
#   records + planes; `rtusim info`, bvh.image.total_bytes; for an instanced scene both levels and the stored
#   transforms, instancing.fixed.total_bytes) and per flattened triangle;
# - RAYS primary and RAYS incoherent rays (`rtusim rays`), each kind traced as one TRACE packet on the timed
#   device with the rdna2 preset (`rtusim trace --device timed --config rdna2`): cycles per ray, any-hit requests
#   per ray (alpha-tested triangles only);
# - the same rays on the float device and on Embree (bench/suite_agree, built beside rtusim with the benchmarks;
#   '-' without it): rays on which both hit or both miss, and rays on which both name the same primitive (ties =
#   different primitives at the same t, within 1e-4 relative).
# Scenes whose files are missing are listed as skipped with the reason. The CGAL meshes are extracted first
# (scripts/cgal_meshes.sh) when Debian's libcgal-demo is installed. If OUT exists, everything from its line
# "## Notes" on is kept.
set -euo pipefail
source "$(dirname "$0")/lib.sh"  # sets name to scene_suite.sh
bench_rays_args 100000 "$@"
suite=${3:-scenes/suite.json}
out=${OUT:-bench/results/scene-suite.md}
threads=${THREADS:-1}
bench_need_python
[ -r "$suite" ] || { echo "$name: cannot read the suite manifest $suite" >&2; exit 2; }
agree="$(dirname "$rtusim")/suite_agree"
[ -x "$agree" ] || agree=""
root=$(cd "$(dirname "$0")/.." && pwd)
if [ -r /usr/share/doc/libcgal-dev/data.tar.gz ]; then
  "$root/scripts/cgal_meshes.sh" >/dev/null
fi

bench_tmpdir
start=$(date +%s)

# json FILE EXPR: a Python expression over the document d, printed.
json() {
  python3 -c "import json, sys; d = json.load(open(sys.argv[1])); print($2)" "$1"
}

"$rtusim" info --suite "$suite" --json "$tmp/suite.json" >/dev/null
mapfile -t entries < <(json "$tmp/suite.json" \
  "'\n'.join('\x1f'.join([e['name'], e['scene'], 'ok' if e['available'] else 'skipped', e['skipped_because'], e['hard_because']]) for e in d['entries'])")

table="$tmp/table.md"
{
  printf '| scene | triangles | instances | BVH bytes | bytes / triangle | cycles/ray primary | cycles/ray incoherent | any-hit req./ray p / i | Embree: same hit or miss p / i | same primitive p / i | other primitive at the same t p / i |\n'
  printf '|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n'
} >"$table"
skipped=()
for entry in "${entries[@]}"; do
  IFS=$'\x1f' read -r sname spec status reason hard <<<"$entry"
  if [ "$status" != ok ]; then
    skipped+=("- \`$sname\`: $reason")
    echo "$name: skipping $sname: $reason" >&2
    continue
  fi
  echo "$name: $sname ($spec)" >&2
  "$rtusim" info --scene "$spec" --json "$tmp/info.json" >/dev/null
  tris=$(json "$tmp/info.json" "d['triangles']")
  inst=$(json "$tmp/info.json" "d['instancing']['instances'] if 'instancing' in d else '-'")
  bytes=$(json "$tmp/info.json" "d['instancing']['fixed']['total_bytes'] if 'instancing' in d else d['bvh']['image']['total_bytes']")
  for kind in primary incoherent; do
    "$rtusim" rays --scene "$spec" --kind "$kind" --count "$rays" --out "$tmp/$kind.rays" >/dev/null
    "$rtusim" trace --scene "$spec" --rays "$tmp/$kind.rays" --out "$tmp/hits" --device timed --config rdna2 \
      --threads "$threads" --stats "$tmp/$kind.json" >/dev/null
  done
  cp=$(json "$tmp/primary.json" "'%.2f' % d['timing']['cycles_per_ray']")
  ci=$(json "$tmp/incoherent.json" "'%.2f' % d['timing']['cycles_per_ray']")
  ahp=$(json "$tmp/primary.json" "'%.2f' % (d['timing']['any_hit_requests'] / d['rays'])")
  ahi=$(json "$tmp/incoherent.json" "'%.2f' % (d['timing']['any_hit_requests'] / d['rays'])")
  hit="-" prim="-" ties="-"
  if [ -n "$agree" ]; then
    # FILE RAYS HIT_DISAGREE PRIM_DISAGREE TIES HIT% PRIM%, one line per ray file
    mapfile -t a < <("$agree" "$spec" "$tmp/primary.rays" "$tmp/incoherent.rays")
    read -r _ _ _ pdp tp hp pp <<<"${a[0]}"
    read -r _ _ _ pdi ti hi pi <<<"${a[1]}"
    hit="$hp% / $hi%"
    prim="$pp% / $pi%"
    ties="$tp of $pdp / $ti of $pdi"
  fi
  printf '| %s | %s | %s | %s | %.1f | %s | %s | %s / %s | %s | %s | %s |\n' "$sname" "$tris" "$inst" "$bytes" \
    "$(awk -v b="$bytes" -v t="$tris" 'BEGIN { print (t > 0 ? b / t : 0) }')" "$cp" "$ci" "$ahp" "$ahi" "$hit" \
    "$prim" "$ties" >>"$table"
done
seconds=$(($(date +%s) - start))

bench_report_context "$out" "$root"
{
  printf '# The benchmark scene suite\n\n'
  printf '**Question.** What does each scene of the suite (`%s`) cost the unit, what does it hold, and does the\n' "$suite"
  printf 'float reference agree with Embree on it?\n\n'
  printf '**Command.** `bench/scene_suite.sh %s %s %s` (%d s on this machine, one thread per trace): per scene\n' \
    "$rtusim" "$rays" "$suite" "$seconds"
  printf '%s primary and %s incoherent rays; the columns are described in the script'"'"'s header.\n\n' "$rays" "$rays"
  printf '**Measured** %s (commit %s) on %s, %s cores (%s), %s; Release build. Cycles, bytes and agreement\n' \
    "$(date -u +%Y-%m-%d)" "$commit" "$os" "$(nproc)" "$cpu" "$(uname -sr)"
  printf 'do not depend on the machine.\n\n'
  cat "$table"
  printf '\n- BVH bytes: the fixed device'"'"'s image in the default format (BVH4 nodes of 56 bytes, 40-byte triangle\n'
  printf '  records); for instanced scenes both levels and the stored transforms, as the fixed and timed devices trace\n'
  printf '  them (`two-level.md` compares them with the flattened image).\n'
  printf -- '- Cycles per ray: the timed device, `rdna2` preset, each kind of ray as one TRACE packet.\n'
  printf -- '- any-hit req./ray: candidate hits on alpha-tested triangles sent to the any-hit stage, per ray.\n'
  printf -- '- Embree: the float device (two levels for instanced scenes, the scene'"'"'s any-hit stage) against Embree 3\n'
  printf '  (Embree instances, the same any-hit stage through a context filter), on the same rays: rays both call a hit\n'
  printf '  or both a miss; rays on which both name the same primitive; of the others, how many are ties (t within\n'
  printf '  1e-4 relative: coplanar or touching faces, where either answer is right).\n'
  if [ ${#skipped[@]} -gt 0 ]; then
    printf '\nSkipped (their files are missing here):\n\n'
    printf '%s\n' "${skipped[@]}"
  fi
  printf '\nWhat makes each scene hard (from the manifest):\n\n'
  for entry in "${entries[@]}"; do
    IFS=$'\x1f' read -r sname spec status reason hard <<<"$entry"
    printf -- '- `%s` (`%s`): %s\n' "$sname" "$spec" "$hard"
  done
  if [ -n "$notes" ]; then
    printf '\n%s\n' "$notes"
  fi
} >"$out"
echo "$name: wrote $out in $seconds s" >&2
