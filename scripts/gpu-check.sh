#!/usr/bin/env bash
# One pass over a GPU machine that has the driver, a compiler and CMake but no packages: builds
# nova from bundle/ (scripts/bundle-gpu.sh), runs the test suites of that build on the GPU, then
# the benchmarks that need no scene, and writes what it saw to OUT_DIR (at most 8 files):
#   machine.txt   GPU, driver, compiler, CMake, torch, and the device embed_core runs on
#   build.log     the build          ctest.log   the suites, one line each, failures in full
#   mlp.txt       nova-bench mlp (beside PyTorch on the same GPU where python3 has CUDA torch)
#   render.txt    nova-bench render  ops.txt     nova-bench ops (every op at its largest shape)
# Each stage has a time limit, so one that hangs leaves the others their time.
# Usage: bash scripts/gpu-check.sh OUT_DIR [BUILD_DIR]      (BUILD_DIR: build-gpu)
set -uo pipefail
cd "$(dirname "$0")/.."
OUT_DIR=${1:?usage: bash scripts/gpu-check.sh OUT_DIR [BUILD_DIR]}
BUILD=${2:-build-gpu}
mkdir -p "$OUT_DIR"
OUT_DIR=$(cd "$OUT_DIR" && pwd)
stage() { echo "gpu-check: $1 ($(date +%T))"; }

stage "machine"
{
  nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm,clocks.max.sm --format=csv 2>&1
  echo "cpu: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
  g++ --version | head -1
  cmake --version | head -1
  echo "OpenCL vendor files: $(ls /etc/OpenCL/vendors 2>/dev/null | paste -sd' ')"
  python3 -c 'import torch; print("python3 torch", torch.__version__, "cuda", torch.cuda.is_available())' 2>&1
} >"$OUT_DIR/machine.txt"

stage "build"
if ! NOVA_JOBS=${NOVA_JOBS:-$(nproc)} timeout 420 bash scripts/gpu-build.sh "$BUILD" >"$OUT_DIR/build.log" 2>&1; then
  tail -40 "$OUT_DIR/build.log"
  echo "gpu-check: the build failed (build.log)" >&2
  exit 1
fi
# shellcheck source=/dev/null
. bundle/env.sh 2>>"$OUT_DIR/machine.txt"
echo "--- embed_core" >>"$OUT_DIR/machine.txt"
timeout 60 "$BUILD/examples/embed_core" >>"$OUT_DIR/machine.txt" 2>&1
cat "$OUT_DIR/machine.txt"

stage "test suites"
timeout "${NOVA_GPU_TEST_S:-300}" ctest --test-dir "$BUILD" -j"${NOVA_GPU_TEST_JOBS:-8}" --timeout 240 \
  --output-on-failure >"$OUT_DIR/ctest.log" 2>&1
echo "ctest exit $?" >>"$OUT_DIR/ctest.log"
grep -E "tests passed|tests failed|\*\*\*Failed|Timeout|ctest exit" "$OUT_DIR/ctest.log" | tail -20

stage "nova-bench mlp"
torch=off
python3 -c 'import torch, sys; sys.exit(0 if torch.cuda.is_available() else 1)' 2>/dev/null && torch=$(command -v python3)
timeout "${NOVA_GPU_MLP_S:-150}" "$BUILD/nova-bench" mlp --batches 16384,65536,262144 --repeats 5 \
  --torch "$torch" --torch-device cuda >"$OUT_DIR/mlp.txt" 2>&1
echo "exit $?" >>"$OUT_DIR/mlp.txt"
sed -n '1,/^CSV$/p' "$OUT_DIR/mlp.txt" | head -60

stage "nova-bench render"
timeout "${NOVA_GPU_RENDER_S:-90}" "$BUILD/nova-bench" render --repeats 5 >"$OUT_DIR/render.txt" 2>&1
echo "exit $?" >>"$OUT_DIR/render.txt"
head -30 "$OUT_DIR/render.txt"

stage "nova-bench ops"
timeout "${NOVA_GPU_OPS_S:-90}" "$BUILD/nova-bench" ops --reps 20 >"$OUT_DIR/ops.txt" 2>&1
echo "exit $?" >>"$OUT_DIR/ops.txt"
tail -8 "$OUT_DIR/ops.txt"
stage "done"
