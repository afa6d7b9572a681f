#!/usr/bin/env bash
# The model identity (host/model_identity.cmake) is a digest of contents, not of times or paths: two copies of the
# model's sources at other paths, one with every file's time changed, give the same identity; a changed byte in
# a source of the model (hwmodel/, host/jobs/, firmware/, rtl_sim/, the area table) gives another, each its own;
# a changed byte of the command line (host/cli/) or the toolchain text changes it only where it should (the
# toolchain: always; the command line: never). Usage: check_model_identity.sh SOURCE_DIR CMAKE
set -uo pipefail
src=$1
cmake=${2:-cmake}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() {
  echo "check_model_identity: $*" >&2
  exit 1
}
identity() {  # ROOT [TOOLCHAIN]
  "$cmake" -DROOT="$1" -DPRINT=1 "-DEXTRA=${2:-gcc 12 Release}" -P "$src/host/model_identity.cmake" 2>&1
}
copy() {
  mkdir -p "$1/bench"
  cp -r "$src/hwmodel" "$src/firmware" "$src/rtl_sim" "$src/host" "$1/"
  cp -r "$src/bench/data" "$1/bench/"
}
copy "$tmp/a"
copy "$tmp/b"
base=$(identity "$src")
[[ $base =~ ^[0-9a-f]{16}$ ]] || fail "not 16 hex digits: '$base'"
[ "$(identity "$src")" = "$base" ] || fail "the same sources twice gave two identities"
[ "$(identity "$tmp/a")" = "$base" ] || fail "a copy at another path gave another identity"
find "$tmp/b" -type f -exec touch -d '2001-02-03 04:05:06' {} +
[ "$(identity "$tmp/b")" = "$base" ] || fail "other file times gave another identity"
[ "$(identity "$tmp/a" "clang 16 Release")" != "$base" ] || fail "another toolchain gave the same identity"
# A source outside the model: the same identity.
echo "// a comment" >>"$tmp/a/host/cli/rtusim.cpp"
[ "$(identity "$tmp/a")" = "$base" ] || fail "a change of host/cli/ changed the identity"
# A byte of each part of the model: each gives an identity of its own.
seen=" $base "
for f in hwmodel/timing/timing_config.cpp host/jobs/point_key.h firmware/CMakeLists.txt \
         rtl_sim/params/rtl_params.h bench/data/rtl_area.csv; do
  [ -f "$tmp/b/$f" ] || fail "$f: no such source (the list above is out of date)"
  echo "" >>"$tmp/b/$f"
  id=$(identity "$tmp/b")
  [[ $seen == *" $id "* ]] && fail "a change of $f did not give a new identity ($id)"
  seen+="$id "
done
# A new source file of the model is part of it too.
echo "int x;" >"$tmp/b/hwmodel/new_file.h"
id=$(identity "$tmp/b")
[[ $seen == *" $id "* ]] && fail "a new file of hwmodel/ did not give a new identity"
echo "model identity: a digest of contents ($base)"
