#!/usr/bin/env bash
# Set-up, then the main job. Until `nova train` lands (issue 5) the main job is the runtime
# smoke test: list the OpenCL devices and train the reference MLP on a smooth 3D function.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
export POCL_CACHE_DIR="${POCL_CACHE_DIR:-$PWD/build/pocl-cache}"
./build/nova devices
./build/nova train-mlp --steps 200 --batch 1024 --profile
