#!/bin/bash
# A batch job that trains a NOVA scene on one GPU and survives preemption: Slurm requeues it,
# and the next run continues from the last checkpoint (written atomically every
# --checkpoint-every steps) with `nova train --resume`, bit for bit as if never stopped.
#
#   sbatch examples/slurm_train.sh SCENE_DIR RUN_DIR [nova train options...]
#
#SBATCH --job-name=nova-train
#SBATCH --gres=gpu:1
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

# nova takes the first GPU it finds; NOVA_DEVICE may name another (`nova devices` lists them).
# Tune the GEMMs once per GPU model (the cache is per device and driver; later jobs reuse it).
export NOVA_TUNING_CACHE=${NOVA_TUNING_CACHE:-$HOME/.cache/nova/gemm-tuning.tsv}
if [ ! -s "$NOVA_TUNING_CACHE" ]; then
  "$nova" tune --quick --widths 64 --inputs 32 --batch 4096
fi

if [ -f "$run/checkpoint.bin" ]; then
  echo "resuming $run"
  "$nova" train --scene "$scene" --out "$run" --resume "$@"
else
  "$nova" train --scene "$scene" --out "$run" --checkpoint-every 200 "$@"
fi
"$nova" eval --run "$run"
