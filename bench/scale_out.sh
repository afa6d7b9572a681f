#!/usr/bin/env bash
# Sweeps beyond one process: one manifest of about 10,000 content-keyed points (two built-in scenes, small ray
# counts) run (1) in one process, (2) as two shards at once, and (3) as a Slurm job array on the single-node
# cluster scripts/slurm_local.sh starts (root only; skipped otherwise), each collected and compared with the
# first. Then (4) the same array again over a complete results folder: every point is skipped, so its wall time
# is the scheduler's own cost per task. Writes Markdown to stdout.
# Usage: bench/scale_out.sh [RTUSIM] [TASKS]      (default 8 array tasks, at most 2 at once: this machine's cores)
set -euo pipefail
src=$(cd "$(dirname "$0")/.." && pwd)
rtusim=$(realpath "${1:-build/default/rtusim}")
tasks=${2:-8}
work=$(mktemp -d /tmp/rtu-scale-out.XXXXXX)
cluster=$work/cluster
cleanup() {
  "$src"/scripts/slurm_local.sh stop "$cluster" >/dev/null 2>&1 || true
  rm -rf "$work"
}
trap cleanup EXIT
grid=(--scene builtin:cornell --scene builtin:seed
      --formats default:coord_bits=8,default:coord_bits=10,default:coord_bits=12,default:coord_bits=14,default:coord_bits=16,default:coord_bits=18,default:coord_bits=20,default:coord_bits=22,compact
      --bvh-width 2,4,8 --set cache_kib=8,16,32,64 --set box_units=1,2 --set ray_slots=16,32,64 --set tri_units=1,2
      --set dram_latency=200,400 --set queue_depth=8,16 --rays 10 --image-width 0)
now() { date +%s.%N; }
secs() { /usr/bin/python3 -c "print('%.1f' % ($2 - $1))"; }

t0=$(now)
"$rtusim" sweep "${grid[@]}" --write-manifest "$work/m.txt" >/dev/null
t1=$(now)
points=$(($(wc -l <"$work/m.txt") - 2))
echo "| run | points | wall s | points per hour | collected equals the one-process table |"
echo "|---|---:|---:|---:|---|"
echo "| write the manifest (load and digest 2 scenes, key every point) | $points | $(secs "$t0" "$t1") | - | - |"

row() {  # label, start, end, collected CSV
  local wall
  wall=$(secs "$2" "$3")
  local same=reference
  if [ "$4" != "$work/one.csv" ]; then
    same=$(/usr/bin/python3 "$src"/tests/cluster/compare_sweeps.py "$work/one.csv" "$4" >/dev/null 2>&1 && echo yes || echo NO)
  fi
  echo "| $1 | $points | $wall | $(/usr/bin/python3 -c "print('%.0f' % ($points * 3600 / $wall))") | $same |"
}

t0=$(now)
"$rtusim" sweep --manifest "$work/m.txt" --results "$work/one" --threads 1 >/dev/null
t1=$(now)
"$rtusim" sweep --collect "$work/one" --manifest "$work/m.txt" --out "$work/one.csv" >/dev/null
row "one process, 1 thread" "$t0" "$t1" "$work/one.csv"

t0=$(now)
for k in 1 2; do "$rtusim" sweep --manifest "$work/m.txt" --results "$work/two" --threads 1 --shard $k/2 >/dev/null & done
wait
t1=$(now)
"$rtusim" sweep --collect "$work/two" --manifest "$work/m.txt" --out "$work/two.csv" >/dev/null
row "two shards at once (2 cores)" "$t0" "$t1" "$work/two.csv"

if "$src"/scripts/slurm_local.sh start "$cluster" >/dev/null 2>&1; then
  export SLURM_CONF=$cluster/slurm.conf
  run_array() {  # results folder: submit, wait; prints nothing
    local id
    id=$("$src"/scripts/slurm_sweep.sh --results "$1" --tasks "$tasks" --throttle 2 --rtusim "$rtusim" --submit \
      -- "${grid[@]}" | tail -n 1)
    while [ -n "$(squeue -h -j "$id" -o %i 2>/dev/null)" ]; do sleep 0.2; done
  }
  t0=$(now)
  run_array "$work/slurm"
  t1=$(now)
  "$src"/scripts/slurm_sweep.sh --collect --results "$work/slurm" --rtusim "$rtusim" >/dev/null
  row "Slurm array, $tasks tasks, at most 2 at once" "$t0" "$t1" "$work/slurm/sweep.csv"
  slurm_wall=$(secs "$t0" "$t1")
  rm "$work/slurm/job_id"
  t0=$(now)
  run_array "$work/slurm"
  t1=$(now)
  empty=$(secs "$t0" "$t1")
  echo
  echo "Scheduler overhead: the same array over the complete folder (every point skipped) took $empty s for $tasks"
  echo "tasks at most 2 at once: $(/usr/bin/python3 -c "print('%.2f' % ($empty * 2 / $tasks))") s per task per lane,"
  echo "including rtusim's start and its reading of the manifest. The working array took $slurm_wall s."
else
  echo
  echo "Slurm: skipped (scripts/slurm_local.sh could not start a cluster: not root, or slurm-wlm and munge missing)."
fi
