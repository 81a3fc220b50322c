#!/bin/bash
# A study as a SLURM job array (docs/studies.md, "Job arrays"): task i of N computes shard i/N
# into the shared folder; a last job, started when every task succeeded, assembles the results.
#   sbatch --array=1-32 docs/studies/slurm-array.sh docs/studies/regime_map.json /scratch/$USER/map
#   sbatch --dependency=afterok:<array job id> --wrap "rubref study-merge /scratch/$USER/map"
#SBATCH --job-name=rubref-study
#SBATCH --cpus-per-task=4
#SBATCH --time=02:00:00
#SBATCH --output=rubref-study-%A_%a.log
set -euo pipefail
spec=$1
dir=$2
# Resubmitting a failed or killed task resumes it: rows already journalled are not computed again.
rubref study "$spec" --out "$dir" --shard "${SLURM_ARRAY_TASK_ID}/${SLURM_ARRAY_TASK_COUNT}" --threads "${SLURM_CPUS_PER_TASK}"
