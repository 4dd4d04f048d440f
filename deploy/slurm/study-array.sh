#!/bin/sh
# The strategy study (hil study) as a Slurm job array: each array task runs one shard (hil
# takes it from SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT/SLURM_ARRAY_TASK_MIN), then a
# dependent job merges the shard reports into the report of the whole study.
#
#   sh deploy/slurm/study-array.sh [SHARDS] [RUNS] [OUT_DIR]      (from the checkout)
#
# HIL: the hil binary (default target/release/hil; build it with `cargo build --release -p
# host-harness`). Extra sbatch options: SBATCH_OPTS (e.g. "--partition=debug").
set -eu
SHARDS=${1:-4}
RUNS=${2:-50}
OUT=${3:-study-out}
HIL=${HIL:-target/release/hil}
mkdir -p "$OUT"
array=$(sbatch --parsable ${SBATCH_OPTS:-} --array=1-"$SHARDS" --job-name=hil-study \
  --output="$OUT/shard-%a.log" \
  --wrap="$HIL study --runs $RUNS --json $OUT/shard-\$SLURM_ARRAY_TASK_ID.json")
merge=$(sbatch --parsable ${SBATCH_OPTS:-} --dependency=afterok:"$array" --job-name=hil-study-merge \
  --output="$OUT/merge.log" \
  --wrap="$HIL study merge $OUT/shard-*.json --json $OUT/study.json --svg $OUT/study.svg")
echo "array job $array ($SHARDS shards), merge job $merge: $OUT/study.json, $OUT/study.svg"
