#!/usr/bin/env bash
# A Slurm array job that analyses an archive of recordings with ssl, one share per
# task, every task writing to one shared results directory:
#
#   sbatch --array=1-100 --cpus-per-task=2 contrib/slurm/ssl-array.sh \
#       ARCHIVE RESULTS GEOMETRY [more ssl analyze options]
#
# ARCHIVE is a directory (searched recursively for *.wav and *.flac; add --glob to
# choose) or a manifest: a file with one recording's path per line, relative paths
# giving the results' layout under RESULTS. Task K of N runs
#
#   ssl analyze ARCHIVE -g GEOMETRY --out-dir RESULTS --resume --shard K/N ...
#
# so each takes one share of the recordings (about equal audio each), writes each result atomically at the recording's
# relative path under RESULTS (byte for byte what one machine writes) and its summary
# as RESULTS/batch.K-of-N.json with --format json. Threads follow --cpus-per-task. Submitting the same array again
# after a failure, a time limit or a new recording redoes only what is not done.
# The array's IDs must be one contiguous range (1-100, 0-99, 1-100%10). SSL names the
# binary (default: ssl on the PATH). Every path must be visible from every node.
#SBATCH --job-name=ssl
#SBATCH --output=ssl-%A_%a.log
set -euo pipefail

if [ $# -lt 3 ]; then
    echo "usage: sbatch --array=1-N $0 ARCHIVE RESULTS GEOMETRY [ssl analyze options]" >&2
    exit 2
fi
archive=$1 results=$2 geometry=$3
shift 3

: "${SLURM_ARRAY_TASK_ID:?not an array task: submit with sbatch --array=1-N}"
: "${SLURM_ARRAY_TASK_MIN:?SLURM_ARRAY_TASK_MIN is not set}"
: "${SLURM_ARRAY_TASK_MAX:?SLURM_ARRAY_TASK_MAX is not set}"
count=${SLURM_ARRAY_TASK_COUNT:-$((SLURM_ARRAY_TASK_MAX - SLURM_ARRAY_TASK_MIN + 1))}
if [ "$((SLURM_ARRAY_TASK_MAX - SLURM_ARRAY_TASK_MIN + 1))" -ne "$count" ] \
    || [ "${SLURM_ARRAY_TASK_STEP:-1}" -ne 1 ]; then
    echo "ssl-array: the array's IDs must be one contiguous range (--array=1-N), not $SLURM_ARRAY_TASK_MIN-$SLURM_ARRAY_TASK_MAX in $count tasks with step ${SLURM_ARRAY_TASK_STEP:-1}" >&2
    exit 2
fi
share=$((SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN + 1))

if [ -d "$archive" ]; then
    inputs=("$archive")
else
    inputs=(--files-from "$archive")
fi
# Threads follow --cpus-per-task (without it, ssl uses every core it sees).
threads=()
if [ -n "${SLURM_CPUS_PER_TASK:-}" ]; then
    threads=(-j "$SLURM_CPUS_PER_TASK")
fi
exec "${SSL:-ssl}" analyze "${inputs[@]}" -g "$geometry" --out-dir "$results" --resume \
    --shard "$share/$count" "${threads[@]}" "$@"
