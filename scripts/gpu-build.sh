#!/usr/bin/env bash
# Builds nova (core, nova_io, the CLI, nova-bench, examples/embed_core and the test suites)
# from bundle/ (scripts/bundle-gpu.sh) and nothing else: the GPU machines have a compiler,
# CMake and the driver but no Debian packages. The bundle has OpenCV's core and imgproc only,
# so images go through stb_image and no videos are written (NOVA_OPENCV_CODECS=OFF).
# Usage: bash scripts/gpu-build.sh [BUILD_DIR]   (default build-gpu; NOVA_JOBS, default nproc)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build-gpu}
BUNDLE=${NOVA_BUNDLE_DIR:-bundle}
if [ ! -f "$BUNDLE/env.sh" ]; then
  echo "gpu-build: $BUNDLE/env.sh not found: run 'bash scripts/bundle-gpu.sh' on a Debian 12 machine and carry $BUNDLE along" >&2
  exit 2
fi
# shellcheck source=/dev/null
. "$BUNDLE/env.sh"
# shellcheck disable=SC2086  # NOVA_CMAKE_ARGS is a list of words
cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=Release $NOVA_CMAKE_ARGS
cmake --build "$BUILD" -j"${NOVA_JOBS:-$(nproc)}"
