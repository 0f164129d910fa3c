#!/bin/bash
# Submits a `hapticlab plan power` run to Slurm: an array of SHARDS tasks
# (plan_power.sbatch) and the merge that waits for all of them
# (plan_merge.sbatch, --dependency=afterok). Prints the two job ids.
#
#   scripts/slurm/submit_plan_power.sh SHARDS OUT_DIR [plan power options...]
#   e.g. scripts/slurm/submit_plan_power.sh 50 /scratch/$USER/power \
#          --protocol examples/protocols/thesis_as_run.json --participants 3,5,8 --studies 1000
#
# HAPTICLAB (default: hapticlab on PATH) names the binary the jobs run,
# HAPTICLAB_CPUS_PER_SHARD (default 2) the CPUs each shard asks for; sbatch
# options of the site (partition, account, time limit) go in sbatch's own
# SBATCH_PARTITION, SBATCH_ACCOUNT, SBATCH_TIMELIMIT, ...
set -euo pipefail
if (($# < 2)); then
  echo "usage: $0 SHARDS OUT_DIR [plan power options...]" >&2
  exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
shards=$1
out=$2
shift 2
if ! [[ $shards =~ ^[1-9][0-9]*$ ]]; then
  echo "$0: SHARDS must be a positive whole number, not '$shards'" >&2
  exit 2
fi
mkdir -p "$out"
cpus=${HAPTICLAB_CPUS_PER_SHARD:-2}
array=$(sbatch --parsable --array="0-$((shards - 1))" --cpus-per-task="$cpus" --output="${out}/shard-%a.log" \
  "${here}/plan_power.sbatch" "$shards" "$out" "$@")
array=${array%%;*}
merge=$(sbatch --parsable --dependency="afterok:${array}" --kill-on-invalid-dep=yes \
  --output="${out}/merge.log" "${here}/plan_merge.sbatch" "$shards" "$out")
merge=${merge%%;*}
echo "array job ${array} (${shards} shards), merge job ${merge} after it; results in ${out}/merged"
