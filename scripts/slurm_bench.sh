#!/usr/bin/env bash
# gpatlas_bench as a Slurm job array: each array task runs one shard of the sweep, then one job
# merges the shards into the tables and plots of a one-process run.
#
#   source catkin_ws/devel/setup.bash          # sbatch passes the environment on to the tasks
#   sbatch --array=1-8 --cpus-per-task=2 scripts/slurm_bench.sh --object ... --strategy ... --out /scratch/sweep
#   sbatch --dependency=afterany:JOBID scripts/slurm_bench.sh --merge --out /scratch/sweep
#
# Task K of N runs `gpatlas_bench BENCH_ARGS --shard K/N` into OUT/shard_K_of_N (OUT: the --out
# of BENCH_ARGS, bench_out if none) with --jobs set to the task's CPUs unless BENCH_ARGS set it.
# The array must be 1-N (K is $SLURM_ARRAY_TASK_ID, N is $SLURM_ARRAY_TASK_COUNT); a %limit
# (--array=1-40%8) is fine. `--merge --out OUT` merges OUT/shard_*_of_* into OUT (runs.csv,
# history.csv, reachability.csv, summary.md, the plots); a shard that failed is left out, its jobs
# are named and the merge exits non-zero, so use afterany: the finished shards are merged anyway.
# The bench is $GPATLAS_BENCH if set, else `rosrun probe_sim gpatlas_bench`.
#SBATCH --job-name=gpatlas_bench
set -euo pipefail

read -r -a bench <<< "${GPATLAS_BENCH:-rosrun probe_sim gpatlas_bench}"

args=("$@")
out=bench_out
jobs_given=false
merge=false
for ((i = 0; i < ${#args[@]}; ++i)); do
  case "${args[i]}" in
    --out)
      [ $((i + 1)) -lt ${#args[@]} ] || { echo "slurm_bench.sh: --out needs a folder" >&2; exit 2; }
      out="${args[i + 1]}" ;;
    --jobs) jobs_given=true ;;
    --merge) merge=true ;;
  esac
done

if $merge; then
  shopt -s nullglob
  shards=()
  for folder in "$out"/shard_*_of_*; do
    # A shard writes shard.txt last: a folder without it is a task that failed or still runs.
    if [ -f "$folder/shard.txt" ]; then shards+=("$folder")
    else echo "slurm_bench.sh: $folder has no shard.txt (its task did not finish): left out" >&2; fi
  done
  if [ ${#shards[@]} -eq 0 ]; then
    echo "slurm_bench.sh: no finished shard folders $out/shard_*_of_* to merge" >&2
    exit 2
  fi
  rest=()
  for arg in "${args[@]}"; do [ "$arg" = --merge ] || rest+=("$arg"); done
  exec "${bench[@]}" --merge "${shards[@]}" "${rest[@]}"
fi

if [ -z "${SLURM_ARRAY_TASK_ID:-}" ] || [ -z "${SLURM_ARRAY_TASK_COUNT:-}" ]; then
  echo "slurm_bench.sh: not a task of a job array: submit with sbatch --array=1-N (see the head of this script)" >&2
  exit 2
fi
if [ "${SLURM_ARRAY_TASK_MIN:-1}" -ne 1 ] || [ "${SLURM_ARRAY_TASK_MAX:-$SLURM_ARRAY_TASK_COUNT}" -ne "$SLURM_ARRAY_TASK_COUNT" ]; then
  echo "slurm_bench.sh: the array must be 1-N (got ${SLURM_ARRAY_TASK_MIN:-?}-${SLURM_ARRAY_TASK_MAX:-?}" \
       "with $SLURM_ARRAY_TASK_COUNT tasks)" >&2
  exit 2
fi
shard="$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT"
extra=(--out "$out/shard_${SLURM_ARRAY_TASK_ID}_of_${SLURM_ARRAY_TASK_COUNT}" --shard "$shard")
$jobs_given || extra+=(--jobs "${SLURM_CPUS_PER_TASK:-1}")
# The last --out wins, so the shard's folder replaces the sweep's.
exec "${bench[@]}" "${args[@]}" "${extra[@]}"
