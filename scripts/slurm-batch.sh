#!/usr/bin/env bash
# A mocap2d batch as a Slurm job array: array task k runs shard k of the sorted clip list
# (`mocap2d batch --shard k/N`), so the tasks split the clips with no coordinator. Every task
# writes its run folders and its own batch-summary-kofN.csv into $OUT (shared storage).
#
#   sbatch --array=1-16 scripts/slurm-batch.sh            # 16 workers
#   SHOTS=/data/shots OUT=/data/runs sbatch --array=1-16 scripts/slurm-batch.sh
#   sbatch --array=1-16 scripts/slurm-batch.sh --retarget robot.toml --render   # extra flags
#
# A task fails (exit 2: a clip's input is wrong; 1: anything else) when any of its clips
# failed; the others still got done. After fixing the inputs, submit the same array again:
# finished clips are skipped, so only what is left runs. Run locally to try it:
#   SLURM_ARRAY_TASK_ID=1 SLURM_ARRAY_TASK_MIN=1 SLURM_ARRAY_TASK_COUNT=2 scripts/slurm-batch.sh
#
#SBATCH --job-name=mocap2d
#SBATCH --cpus-per-task=2
#SBATCH --mem-per-cpu=512M
#SBATCH --time=02:00:00
#SBATCH --output=mocap2d-%A_%a.log
set -euo pipefail

SHOTS=${SHOTS:-shots}                       # folder(s) of clips, the same for every task
SEEDS=${SEEDS:-'{dir}/{stem}.toml'}         # each clip's seed file
OUT=${OUT:-runs}                            # run folders and summaries
MOCAP2D=${MOCAP2D:-mocap2d}                 # the binary

: "${SLURM_ARRAY_TASK_ID:?run with sbatch --array=1-N (or set SLURM_ARRAY_TASK_* to try it)}"
# Task ids may start anywhere (--array=0-15 or 1-16): shard index = position in the array.
index=$((SLURM_ARRAY_TASK_ID - ${SLURM_ARRAY_TASK_MIN:-1} + 1))
count=${SLURM_ARRAY_TASK_COUNT:?Slurm sets SLURM_ARRAY_TASK_COUNT for array jobs}
# One clip per allocated core: tracking a clip keeps one core busy.
jobs=${SLURM_CPUS_PER_TASK:-1}

exec "$MOCAP2D" batch $SHOTS --seeds "$SEEDS" --out-dir "$OUT" \
  --shard "$index/$count" --jobs "$jobs" --quiet "$@"
