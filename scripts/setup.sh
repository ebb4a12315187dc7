#!/usr/bin/env bash
# Installs what nova needs from Debian 12 packages (only what is missing) and builds it in
# Release into build/. Idempotent: a second run installs nothing and rebuilds only changes.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  g++ cmake pkg-config
  ocl-icd-libopencl1 ocl-icd-opencl-dev opencl-headers pocl-opencl-icd clinfo
  libclblast-dev
  nlohmann-json3-dev  # JSON (header-only): scene readers, metrics.jsonl, eval.json, bench outputs
  libopencv-dev
  libstb-dev        # stb_image: nova_io's image codec where OpenCV's imgcodecs is missing (tested against it)
  zlib1g-dev        # .npz scenes (deflated ZIP members)
  libboost-program-options-dev libboost-test-dev
  libopenblas-dev   # host BLAS: the "host" GEMM provider of CPU devices (loaded at run time) and the benches
  libopenmpi-dev openmpi-bin  # MPI data-parallel `nova train` (mpirun -np N); the CLI alone links it
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)"
