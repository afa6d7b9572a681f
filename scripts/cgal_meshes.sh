#!/usr/bin/env bash
# Extracts the CGAL demo meshes of the benchmark suite (scenes/suite.json) from Debian's libcgal-demo, which ships
# them inside /usr/share/doc/libcgal-dev/data.tar.gz, into DIR (default build/meshes/cgal under the repository,
# where scenes/suite.json looks for them). Idempotent: meshes already there are kept.
#
#   scripts/cgal_meshes.sh [DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
dir=${1:-$root/build/meshes/cgal}
archive=/usr/share/doc/libcgal-dev/data.tar.gz
meshes=(bunny00.off armadillo.off refined_elephant.off ChineseDragon-10kv.off)
if [ ! -r "$archive" ]; then
  echo "cgal_meshes.sh: $archive not found: install the Debian package libcgal-demo (scripts/setup.sh)" >&2
  exit 2
fi
mkdir -p "$dir"
missing=()
for m in "${meshes[@]}"; do
  [ -s "$dir/$m" ] || missing+=("data/meshes/$m")
done
if [ ${#missing[@]} -gt 0 ]; then
  tar -xzf "$archive" -C "$dir" --strip-components=2 "${missing[@]}"
fi
for m in "${meshes[@]}"; do echo "$dir/$m"; done
