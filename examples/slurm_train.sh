#!/bin/bash
# A batch job that trains a NOVA scene with one rank per GPU and survives preemption: Slurm
# requeues it, and the next run continues from the last checkpoint (written atomically every
# --checkpoint-every steps) with `nova train --resume`, bit for bit as if never stopped.
#
#   sbatch examples/slurm_train.sh SCENE_DIR RUN_DIR [nova train options...]
#   sbatch --nodes=2 --ntasks-per-node=4 --gpus-per-task=1 examples/slurm_train.sh ...
#
# With more than one task the ranks train data-parallel (nova built with MPI): every rank
# takes the GPU of its node-local rank; a requeued job with the same number of tasks resumes
# bit for bit (with another it continues, rounding differently). `rays` must divide by the
# number of tasks. A checkpoint is
# written every NOVA_CHECKPOINT_EVERY steps (200): what a requeue can lose.
#SBATCH --job-name=nova-train
#SBATCH --ntasks=1
#SBATCH --gpus-per-task=1
#SBATCH --cpus-per-task=4
#SBATCH --time=04:00:00
#SBATCH --requeue
#SBATCH --open-mode=append
#SBATCH --output=nova-train-%j.log
set -euo pipefail
scene=${1:?usage: sbatch slurm_train.sh SCENE_DIR RUN_DIR [options]}
run=${2:?usage: sbatch slurm_train.sh SCENE_DIR RUN_DIR [options]}
shift 2
nova=${NOVA:-nova}  # an installed nova (cmake --install) on PATH, or NOVA=/path/to/nova
tasks=${SLURM_NTASKS:-1}
echo "job ${SLURM_JOB_ID:-?} (restart ${SLURM_RESTART_COUNT:-0}) on $(hostname): $tasks task(s)"

# Tune the GEMMs once per GPU model (the cache is per device and driver; later jobs reuse it).
# NOVA_TUNE=0 skips it (a CPU device uses its host BLAS and needs none).
export NOVA_TUNING_CACHE=${NOVA_TUNING_CACHE:-$HOME/.cache/nova/gemm-tuning.tsv}
if [ "${NOVA_TUNE:-1}" != 0 ] && [ ! -s "$NOVA_TUNING_CACHE" ]; then
  "$nova" tune --quick --widths 64 --inputs 32 --batch 4096
fi

# One rank per task: Open MPI's mpirun starts them through Slurm (a plain srun starts lone
# processes unless Slurm and the MPI share a PMI; nova refuses that). Each rank takes the GPU
# of its node-local rank (NOVA_DEVICE may name another; `nova devices` lists them).
launch=()
if [ "$tasks" -gt 1 ]; then launch=(mpirun -np "$tasks"); fi

if [ -f "$run/checkpoint.bin" ]; then
  echo "resuming $run"
  "${launch[@]}" "$nova" train --scene "$scene" --out "$run" --resume "$@"
else
  "${launch[@]}" "$nova" train --scene "$scene" --out "$run" --checkpoint-every "${NOVA_CHECKPOINT_EVERY:-200}" "$@"
fi
"${launch[@]}" "$nova" eval --run "$run"
