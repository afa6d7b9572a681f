#!/usr/bin/env bash
# The include direction of docs/architecture.md, checked on the sources: fails, listing each offending line, when
#  - firmware/ includes anything of hwmodel/ outside hwmodel/interface/ (the registers, command packets, ray
#    record and any-hit seam), or anything of host/, rtl_sim/, tests/, bench/, python/;
#  - hwmodel/ includes anything of host/, firmware/, rtl_sim/, tests/, bench/, python/;
#  - a room of hwmodel/ includes a room below it in the order interface, numeric, scene, format, datapath, timing
#    (with timing/memory), device, cost (hwmodel/README.md): interface/ includes only itself;
#  - host/ outside host/cli/ includes host/cli/, tests/, bench/ or python/.
# Usage: check_includes.sh SOURCE_DIR     exit: 0 clean, 1 a wrong-way include, 2 usage
set -uo pipefail
if [[ $# -ne 1 || ! -d $1 ]]; then
  echo "usage: $0 SOURCE_DIR" >&2
  exit 2
fi
cd "$1" || exit 2

bad=""
# rule DIR PATTERN WHY [ALLOWED]: every `#include "..."` line under DIR whose path matches PATTERN (and not
# ALLOWED) is an offence. Files under host/cli/ are the command line and may include anything of host/.
rule() {
  local dir=$1 pattern=$2 why=$3 allowed=${4:-^$} hits
  [[ -d $dir ]] || return 0
  hits=$(grep -rnE "^[[:space:]]*#[[:space:]]*include[[:space:]]*\"($pattern)" --include='*.h' --include='*.cpp' \
           --include='*.hpp' --include='*.in' "$dir" | grep -vE "^host/cli/" |
           grep -vE "include[[:space:]]*\"($allowed)" || true)
  if [[ -n $hits ]]; then
    bad+="$why:"$'\n'"$hits"$'\n'
  fi
}
rule firmware 'hwmodel/|host/|rtl_sim/|tests/|bench/|python/' \
  "firmware/ may include only hwmodel/interface/ of the project" 'hwmodel/interface/'
rule hwmodel 'host/|firmware/|rtl_sim/|tests/|bench/|python/' "hwmodel/ includes nothing of the project outside it"
rooms=(interface numeric scene format datapath timing device cost)
for ((i = 0; i < ${#rooms[@]} - 1; i++)); do
  below=$(IFS='|'; echo "${rooms[*]:i+1}")
  rule "hwmodel/${rooms[i]}" "hwmodel/($below)/" "hwmodel/${rooms[i]}/ includes a room below it ($below)"
done
rule host 'host/cli/|tests/|bench/|python/' "host/ outside cli/ includes no command line, test or benchmark"

if [[ -n $bad ]]; then
  echo "includes that run the wrong way (docs/architecture.md, 'Which way the includes run'):" >&2
  printf '%s' "$bad" >&2
  exit 1
fi
echo "every include runs the documented way"
