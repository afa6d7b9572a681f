#!/usr/bin/env bash
# The include direction inside host/ (docs/architecture.md): io includes neither jobs/ nor devices/ nor cost/, cost
# does not include jobs/, and only cli/ includes cli/. Fails, listing the includes that break a rule (a source check, no
# build needed). Usage: check_host_includes.sh SOURCE_DIR
set -uo pipefail
cd "$1" || exit 2
# room whose files are checked | rooms it must not include
rules=(
  "io|jobs devices cost"
  "cost|jobs"
)
for room in host/*/; do
  room=${room#host/}
  room=${room%/}
  [ "$room" = cli ] || rules+=("$room|cli")
done
bad=""
for rule in "${rules[@]}"; do
  room=${rule%%|*}
  for banned in ${rule#*|}; do
    hits=$(grep -rnE "^[[:space:]]*#[[:space:]]*include[[:space:]]+\"host/$banned/" "host/$room" 2>/dev/null)
    [ -n "$hits" ] && bad+="host/$room must not include host/$banned/:"$'\n'"$hits"$'\n'
  done
done
if [ -n "$bad" ]; then
  printf '%s' "$bad" >&2
  exit 1
fi
echo "host/ includes run one way"
