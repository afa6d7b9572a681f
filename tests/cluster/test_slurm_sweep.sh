#!/usr/bin/env bash
# A sweep as a real Slurm job array (scripts/slurm_sweep.sh) on a single-node cluster this test starts
# (scripts/slurm_local.sh: munged, slurmctld, slurmd as root, all under a temporary folder) and stops again, also
# when it fails. Checks:
#   - 4 array tasks, at most 2 at once, each ran its shard of the manifest (points k-1, k+3, ... of it), one point
#     file per point; the collected CSV holds every row of the same grid run in one process, equal apart from the
#     wall time
#   - the same manifest run in one process, as 3 shards in the order 3, 1, 2, and from Python on a Dask cluster of 2
#     worker processes (rtu.sweep_on(results=...), which writes the same manifest) collects to the Slurm array's
#     table: the same lines in the same order, byte for byte apart from the wall time
#   - a task that fails for real (its points folder is a file, so rtusim cannot write it) fails the collect, which
#     names the task, its exit status and its log; rerunning only that task (sbatch --array=2) runs only its
#     missing points and mends the sweep
# Exits 77 (skipped) when the cluster cannot start for want of root or packages.
# Usage: test_slurm_sweep.sh RTUSIM SOURCE_DIR
set -euo pipefail
rtusim=$1
src=$2
tasks=4
grid=(--scene builtin:cornell --formats default,compact --bvh-width 2,4,8 --rays 500 --image-width 0)

tmp=$(mktemp -d /tmp/rtu-slurm-test.XXXXXX)
cluster=$tmp/cluster
results=$tmp/results
cleanup() {
  local rc=$?
  if [ $rc -ne 0 ] && [ $rc -ne 77 ]; then
    # What the daemons and the tasks said, for the failure's diagnosis.
    for f in "$cluster"/log/slurmctld.log "$cluster"/log/slurmd.log "$results"/logs/*.out; do
      [ -f "$f" ] && { echo "--- $f"; tail -n 20 "$f"; }
    done
  fi
  "$src"/scripts/slurm_local.sh stop "$cluster" >/dev/null 2>&1 || true
  rm -rf "$tmp"
  exit $rc
}
trap cleanup EXIT

fail() {
  echo "FAIL: $*" >&2
  exit 1
}

set +e
"$src"/scripts/slurm_local.sh start "$cluster"
rc=$?
set -e
[ $rc -eq 77 ] && exit 77
[ $rc -eq 0 ] || fail "the local Slurm cluster did not start (exit $rc)"
export SLURM_CONF=$cluster/slurm.conf

# Waits (bounded) until the job's tasks have all left the queue; cancels it and fails on the deadline.
wait_job() {
  local id=$1 deadline=$((SECONDS + 90))
  while [ -n "$(squeue -h -j "$id" -o %i 2>/dev/null)" ]; do
    if [ $SECONDS -ge $deadline ]; then
      squeue -j "$id" >&2 || true
      scancel "$id" || true
      fail "job $id still queued or running after 90 s"
    fi
    sleep 1
  done
}

# The same grid in one process: the reference.
"$rtusim" sweep "${grid[@]}" --out "$tmp/local.csv" >/dev/null
points=$(($(wc -l <"$tmp/local.csv") - 1))
[ "$points" -eq 6 ] || fail "the local sweep has $points points, not 6"

# --- the array: submitted, waited for, collected ---
id=$("$src"/scripts/slurm_sweep.sh --results "$results" --tasks $tasks --throttle 2 --rtusim "$rtusim" --submit \
  -- "${grid[@]}" | tail -n 1)
[[ "$id" =~ ^[0-9]+$ ]] || fail "--submit printed '$id', not a job id"
grep -q -- "--array=1-4%2" "$results/sweep.sbatch" || fail "the script has no --array=1-4%2"
wait_job "$id"
for k in $(seq 1 $tasks); do
  [ -f "$results/logs/${id}_$k.out" ] || fail "task $k wrote no log ${id}_$k.out"
  grep -q "task $k/4 of job $id on" "$results/logs/${id}_$k.out" || fail "log of task $k does not name its task"
  [ "$(cat "$results/status/task-$k.exit")" = 0 ] || fail "task $k: exit status $(cat "$results/status/task-$k.exit")"
  want=$(awk -v k=$k -v n=$tasks '!/^#/ && (i++ % n) == k - 1' "$results/manifest.txt" | wc -l)
  grep -q "$want points in this shard ($k/$tasks), $want run, 0 already" "$results/logs/${id}_$k.out" ||
    fail "task $k did not run its $want points"
done
[ "$(ls "$results/points" | grep -c '[.]json$')" -eq 6 ] || fail "not one point file per point"
"$src"/scripts/slurm_sweep.sh --collect --results "$results" --rtusim "$rtusim"
python3 "$src"/tests/cluster/compare_sweeps.py "$tmp/local.csv" "$results/sweep.csv"

# --- the same manifest on every other engine collects to the same table ---
manifest=$results/manifest.txt
"$rtusim" sweep --manifest "$manifest" --results "$tmp/one" --threads 2 >/dev/null
"$rtusim" sweep --collect "$tmp/one" --manifest "$manifest" --out "$tmp/one.csv" >/dev/null
for k in 3 1 2; do
  "$rtusim" sweep --manifest "$manifest" --results "$tmp/three" --shard $k/3 >/dev/null
done
"$rtusim" sweep --collect "$tmp/three" --manifest "$manifest" --out "$tmp/three.csv" >/dev/null
# The Dask engine needs Debian's python3-distributed and the build's Python module (the asan preset builds none).
pymod="$(dirname "$rtusim")/python"
if PYTHONPATH="$pymod" /usr/bin/python3 -c "import distributed, pandas, rtu" 2>/dev/null; then
  PYTHONPATH="$pymod" /usr/bin/python3 "$src"/tests/cluster/dask_sweep.py "$tmp/dask"
  cmp "$manifest" "$tmp/dask/manifest.txt" || fail "rtu.sweep_on wrote another manifest for the same grid"
  dask_csv=$tmp/dask/sweep.csv
else
  echo "note: no python3-distributed or no Python module in this build: the Dask engine is not compared" >&2
  dask_csv=
fi
python3 "$src"/tests/cluster/compare_sweeps.py --same-order "$results/sweep.csv" "$tmp/one.csv" "$tmp/three.csv" \
  ${dask_csv:+"$dask_csv"}

# --- a task that fails: collect refuses, naming it and its log; rerunning that task alone mends the sweep ---
rm "$results/sweep.csv"
for key in $(awk -v n=$tasks '!/^#/ && (i++ % n) == 1 {print $1}' "$results/manifest.txt"); do
  rm "$results/points/$key.json"  # task 2's points
done
mv "$results/points" "$results/points.kept"
touch "$results/points"  # a file where the folder was: task 2 cannot write its points and exits non-zero
id2=$(sbatch --parsable --array=2 "$results/sweep.sbatch")
id2=${id2%%;*}
wait_job "$id2"
set +e
"$src"/scripts/slurm_sweep.sh --collect --results "$results" --rtusim "$rtusim" 2>"$tmp/collect.err"
rc=$?
set -e
cat "$tmp/collect.err"
[ $rc -ne 0 ] || fail "--collect succeeded with task 2 failed"
grep -q "task 2 exited with status [1-9][0-9]*; log: $results/logs/${id2}_2.out" "$tmp/collect.err" ||
  fail "--collect did not name task 2, its exit status and its log"
grep -q "task [134] " "$tmp/collect.err" && fail "--collect blamed a task that succeeded"
[ -f "$results/sweep.csv" ] && fail "--collect wrote sweep.csv although task 2 failed"
rm "$results/points"
mv "$results/points.kept" "$results/points"
id3=$(sbatch --parsable --array=2 "$results/sweep.sbatch")
wait_job "${id3%%;*}"
grep -q "2 points in this shard (2/$tasks), 2 run, 0 already" "$results/logs/${id3%%;*}_2.out" ||
  fail "the rerun of task 2 did not run exactly its 2 missing points"
"$src"/scripts/slurm_sweep.sh --collect --results "$results" --rtusim "$rtusim"
python3 "$src"/tests/cluster/compare_sweeps.py "$tmp/local.csv" "$results/sweep.csv"
echo "PASS: a 4-task Slurm array, one process, 3 shards${dask_csv:+ and Dask} collected to one table; a failed task named and mended"
