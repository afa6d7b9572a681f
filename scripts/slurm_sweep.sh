#!/usr/bin/env bash
# A design sweep (`rtusim sweep`) as a Slurm job array: writes the grid's manifest of content-keyed points and the
# sbatch script, submits it, and collects the tasks' point files into one sweep CSV. Each of N array tasks runs
# every N-th point of the manifest (`rtusim sweep --manifest M --results RESULTS/points --shard k/N`), at most
# THROTTLE of them at once; docs/guide/cluster.md has the whole walk-through.
#
# On a real cluster (RESULTS and rtusim on a file system every node sees; rtusim built as in README.md):
#
#   scripts/slurm_sweep.sh --results /shared/me/sweep1 --tasks 50 --throttle 10 --rtusim /shared/rtu/rtusim \
#       --sbatch-option=--partition=cpu --sbatch-option=--time=02:00:00 --submit \
#       -- --scene builtin:cornell --formats default,compact --bvh-width 2,4,8 --config rdna2,intel
#   squeue --me                                          # wait until the array's tasks are gone
#   scripts/slurm_sweep.sh --collect --results /shared/me/sweep1 --rtusim /shared/rtu/rtusim
#       -> /shared/me/sweep1/sweep.csv (rtusim pareto|plan|report read it)
#
# Write mode (without --collect) writes RESULTS/manifest.txt (the grid's points, each with its content key: rtusim
# sweep --write-manifest) and RESULTS/sweep.sbatch, and with --submit runs sbatch on it, prints the job id and
# keeps it in RESULTS/job_id. Arguments after `--` are rtusim sweep's grid and run options (--scene, --suite,
# --formats, --bvh-width, --config, --set, --rays, --seed, --image-width, --flatten); --shard, --out, --merge and
# --threads are the script's (each task runs --threads = --cpus-per-task). Task k writes one file per point to
# RESULTS/points/KEY.json (whole, by rename), logs to RESULTS/logs/JOBID_k.out and, when it ends, its exit status
# to RESULTS/status/task-k.exit. Rerunning a task (sbatch --array=k RESULTS/sweep.sbatch) or the whole script runs
# only the points that have no file.
#
# --collect checks every task 1..N: a task that exited non-zero, or has no exit status (killed, timed out, never
# ran), fails the collect, naming the task and its log, and how to rerun it; otherwise `rtusim sweep --collect`
# gathers the point files into RESULTS/sweep.csv (or --out) in the manifest's order, with
# RESULTS/sweep.csv.provenance.csv, and fails naming any point without a file. sacct is not used: it needs
# slurmdbd, which many clusters (and the local test cluster) lack; the status files and logs work everywhere.
#
# Options:
#   --results DIR         the sweep's folder (created): script, shards, logs, status, merged CSV
#   --tasks N             array tasks (default 4); each runs about 1/N of the points
#   --throttle T          at most T tasks at once (default: N)
#   --cpus-per-task C     CPUs (and rtusim threads) per task (default 1)
#   --rtusim PATH         the rtusim every task runs (default: rtusim on PATH); made absolute
#   --sbatch-option OPT   a further #SBATCH line, e.g. --sbatch-option=--partition=cpu (repeatable)
#   --submit              submit the script with sbatch (sbatch must see the cluster: SLURM_CONF, etc.)
#   --collect             collect instead of writing; --out FILE: the merged CSV (default RESULTS/sweep.csv)
set -euo pipefail

die() {
  echo "slurm_sweep: $*" >&2
  exit 2
}

results="" tasks=4 throttle="" cpus=1 rtusim="" submit=0 collect=0 out=""
sbatch_opts=()
grid=()
while [ $# -gt 0 ]; do
  case $1 in
    --results) results=${2:?}; shift 2 ;;
    --results=*) results=${1#*=}; shift ;;
    --tasks) tasks=${2:?}; shift 2 ;;
    --tasks=*) tasks=${1#*=}; shift ;;
    --throttle) throttle=${2:?}; shift 2 ;;
    --throttle=*) throttle=${1#*=}; shift ;;
    --cpus-per-task) cpus=${2:?}; shift 2 ;;
    --cpus-per-task=*) cpus=${1#*=}; shift ;;
    --rtusim) rtusim=${2:?}; shift 2 ;;
    --rtusim=*) rtusim=${1#*=}; shift ;;
    --sbatch-option) sbatch_opts+=("${2:?}"); shift 2 ;;
    --sbatch-option=*) sbatch_opts+=("${1#*=}"); shift ;;
    --submit) submit=1; shift ;;
    --collect) collect=1; shift ;;
    --out) out=${2:?}; shift 2 ;;
    --out=*) out=${1#*=}; shift ;;
    --) shift; grid=("$@"); break ;;
    -h | --help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) die "unknown option '$1' (grid options of rtusim sweep go after --; --help)" ;;
  esac
done
[ -n "$results" ] || die "--results DIR is required"
mkdir -p "$results"
results=$(cd "$results" && pwd)
# An #SBATCH --output line ends at white space.
[[ "$results" =~ [[:space:]] ]] && die "--results: the folder's path may not contain white space: '$results'"
script=$results/sweep.sbatch

if [ -z "$rtusim" ]; then
  rtusim=$(command -v rtusim) || die "no rtusim on PATH: give --rtusim PATH"
fi
[ -x "$rtusim" ] || die "--rtusim $rtusim is not an executable"
rtusim=$(cd "$(dirname "$rtusim")" && pwd)/$(basename "$rtusim")

manifest=$results/manifest.txt
points=$results/points

# --- collect ---
if [ $collect -eq 1 ]; then
  [ ${#grid[@]} -eq 0 ] || die "--collect takes no grid options"
  [ -f "$script" ] || die "no $script: not a sweep folder written by slurm_sweep.sh"
  n=$(sed -n 's/^# rtu-sweep-tasks: \([0-9]*\)$/\1/p' "$script")
  [ -n "$n" ] || die "$script names no task count (# rtu-sweep-tasks: N)"
  job=$(cat "$results/job_id" 2>/dev/null || echo JOBID)
  bad=0
  shards=()
  for k in $(seq 1 "$n"); do
    # The newest log of task k (a rerun writes another JOBID_k.out).
    log=$(ls -t "$results"/logs/*_"$k".out 2>/dev/null | head -n 1 || true)
    log=${log:-"$results/logs/${job}_$k.out (none written: the task never started)"}
    status_file=$results/status/task-$k.exit
    if [ ! -f "$status_file" ]; then
      echo "slurm_sweep: task $k did not finish (no exit status: still running, killed, timed out or never" \
        "started); log: $log" >&2
      bad=1
    elif [ "$(cat "$status_file")" != 0 ]; then
      echo "slurm_sweep: task $k exited with status $(cat "$status_file"); log: $log" >&2
      bad=1
    fi
  done
  if [ $bad -ne 0 ]; then
    echo "slurm_sweep: not collected. Rerun the failed tasks (their finished points are kept), e.g." \
      "sbatch --array=K $script, then --collect again" >&2
    exit 1
  fi
  # Every point's file is there unless a task lost one: collect names the missing keys and fails.
  "$rtusim" sweep --collect "$points" --manifest "$manifest" --out "${out:-$results/sweep.csv}"
  exit 0
fi

# --- write (and submit) ---
[[ "$tasks" =~ ^[1-9][0-9]*$ ]] || die "--tasks: expected a positive integer, got '$tasks'"
throttle=${throttle:-$tasks}
[[ "$throttle" =~ ^[1-9][0-9]*$ ]] || die "--throttle: expected a positive integer, got '$throttle'"
[[ "$cpus" =~ ^[1-9][0-9]*$ ]] || die "--cpus-per-task: expected a positive integer, got '$cpus'"
[ ${#grid[@]} -gt 0 ] || die "no grid: give rtusim sweep's options after --, e.g. -- --scene builtin:cornell"
for a in "${grid[@]}"; do
  case $a in
    --shard | --shard=* | --out | --out=* | --merge | --merge=* | --threads | --threads=*)
      die "$a is set by the script (each task: --manifest RESULTS/manifest.txt --shard k/N --threads C)" ;;
    --area | --area=*)
      die "$a: a manifest's points use the shipped area table" ;;
  esac
done
body=$(
  cat <<EOF
#!/usr/bin/env bash
# A design sweep as a Slurm job array, written by scripts/slurm_sweep.sh; submit with sbatch, collect with
# scripts/slurm_sweep.sh --collect --results $(printf '%q' "$results")
# rtu-sweep-tasks: $tasks
#SBATCH --job-name=rtu-sweep
#SBATCH --array=1-$tasks%$throttle
#SBATCH --ntasks=1
#SBATCH --cpus-per-task=$cpus
#SBATCH --output=$results/logs/%A_%a.out
$(for o in ${sbatch_opts[@]+"${sbatch_opts[@]}"}; do echo "#SBATCH $o"; done)
set -uo pipefail
k=\${SLURM_ARRAY_TASK_ID:?not a Slurm array task}
results=$(printf '%q' "$results")

# The task body, the one place that says what a task computes: shard k of $tasks of the manifest's points, each
# into its own file under points/ (written whole; a point whose file is there is skipped, so a rerun resumes).
run_task() {
  $(printf '%q' "$rtusim") sweep --manifest "\$results/manifest.txt" --results "\$results/points" --threads $cpus --shard "\$1/$tasks"
}

# The exit status is written when the task ends, whatever ends it but SIGKILL; a task with no status file did
# not finish. A stale one from an earlier run goes first.
mkdir -p "\$results/status"
rm -f "\$results/status/task-\$k.exit"
trap 'rc=\$?; echo "\$rc" > "\$results/status/task-\$k.exit.tmp" && mv "\$results/status/task-\$k.exit.tmp" "\$results/status/task-\$k.exit"; echo "rtu-sweep: task \$k exit \$rc \$(date -Is)"' EXIT
trap 'exit 143' TERM
echo "rtu-sweep: task \$k/$tasks of job \${SLURM_ARRAY_JOB_ID:-?} on \$(hostname) at \$(date -Is)"
run_task "\$k"
EOF
)
# A folder holds one sweep: another grid's shards would be resumed as if they were this one's.
if [ -f "$script" ] && [ "$(cat "$script")" != "$body" ]; then
  die "$results already holds another sweep ($script differs); use a new --results folder"
fi
mkdir -p "$results/logs" "$results/status" "$points"
printf '%s\n' "$body" >"$script"
# The points, each named by what it computes: a rerun of a task, or of the whole array, runs only the missing ones.
"$rtusim" sweep "${grid[@]}" --write-manifest "$manifest.new" >/dev/null
if [ -f "$manifest" ] && ! cmp -s "$manifest" "$manifest.new"; then
  rm -f "$manifest.new"
  die "$manifest lists other points (a scene or rtu changed since it was written); use a new --results folder"
fi
mv "$manifest.new" "$manifest"
echo "slurm_sweep: wrote $script ($tasks tasks, at most $throttle at once) and $manifest ($(grep -vc '^#' "$manifest") points)"

if [ $submit -eq 1 ]; then
  command -v sbatch >/dev/null || die "--submit: no sbatch on PATH"
  id=$(sbatch --parsable "$script")
  id=${id%%;*}  # "JOBID;CLUSTER" on federated clusters
  echo "$id" >"$results/job_id"
  echo "$id"
fi
