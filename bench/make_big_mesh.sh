#!/usr/bin/env bash
# Writes DIR/sample_subdiv7.ac: assimp-testmodels' AC/sample_subdiv.ac with its `subdiv 6` raised to 7, which
# Assimp subdivides to about a million triangles. Usage: bench/make_big_mesh.sh DIR
set -euo pipefail
dir=${1:?usage: make_big_mesh.sh DIR}
src=/usr/share/assimp/models/AC/sample_subdiv.ac
[ -f "$src" ] || { echo "missing $src (Debian package assimp-testmodels)" >&2; exit 1; }
mkdir -p "$dir"
sed 's/^subdiv 6$/subdiv 7/' "$src" > "$dir/sample_subdiv7.ac"
grep -q '^subdiv 7$' "$dir/sample_subdiv7.ac" || { echo "no 'subdiv 6' line in $src" >&2; exit 1; }
echo "$dir/sample_subdiv7.ac"
