#!/usr/bin/env bash
# A Slurm job array for a full-size study: each task runs one deterministic slice of the run
# list into its own directory; a final `magopt collect` merges them into one result, identical
# to an unsharded sweep (runs are identified by their parameters and seed).
#
#   sbatch --array=0-15 studies/slurm-array.sh studies/align-tau-vs-field-friction.toml
#   # when all tasks are done:
#   magopt collect results/shards/align-tau-vs-field-friction-* --out results/align-tau-vs-field-friction
#
#SBATCH --job-name=magopt
#SBATCH --cpus-per-task=4
#SBATCH --time=02:00:00
set -euo pipefail
study=$1
name=$(basename "$study" .toml)
magopt sweep "$study" \
  --shard "${SLURM_ARRAY_TASK_ID}/${SLURM_ARRAY_TASK_COUNT}" \
  --threads "${SLURM_CPUS_PER_TASK:-1}" \
  --out "results/shards/${name}-${SLURM_ARRAY_TASK_ID}" \
  --resume
