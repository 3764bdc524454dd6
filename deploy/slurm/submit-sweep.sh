#!/usr/bin/env bash
# deploy/slurm/submit-sweep.sh: submits a sweep as a Slurm job array and its gather.
#
# What: sizes the array from the case (`couplet validate CASE --sweep --count`), submits
# deploy/slurm/sweep.sbatch as an array of that many tasks, one sweep point each, and
# then the same script without --array as a job that runs after every task has ended
# (afterany) and gathers the rows into the sweep's table in OUT.
#
# Use, from the repository root on a login node:
#     deploy/slurm/submit-sweep.sh settling-sphere /shared/sweeps/settling-sphere [sbatch options…]
# Extra arguments go to both sbatch calls (--partition=gpu, --account=…).
#
# Assumes: `couplet` on PATH on the login node too (only --count runs there: no GPU, no
# simulation); OUT on a file system the compute nodes share. Not run here (no Slurm on
# the machine it was written on); its couplet command lines are checked by
# tests/tests/deploy.rs.
set -euo pipefail

if [ $# -lt 2 ]; then
    echo "usage: $0 CASE OUT [sbatch options…]" >&2
    exit 2
fi
case_name=$1
out=$2
shift 2
here=$(dirname "$0")

n=$(couplet validate "$case_name" --sweep --count)
mkdir -p "$out"
points=$(sbatch --parsable --array=0-$((n - 1)) "$@" "$here/sweep.sbatch" "$case_name" "$out")
gather=$(sbatch --parsable --dependency=afterany:"$points" --gres=none --time=00:10:00 "$@" "$here/sweep.sbatch" "$case_name" "$out")
echo "sweep of $case_name: $n points in array job $points, table by job $gather into $out"
