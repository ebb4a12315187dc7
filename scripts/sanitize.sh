#!/usr/bin/env bash
# Builds nova with AddressSanitizer and UndefinedBehaviorSanitizer (-O1 -g, no recovery from
# undefined behaviour) into BUILD_DIR and runs every suite there (install_package builds its
# program outside the tree with the same flags). Leak checking is off (the OpenCL ICD loader
# and PoCL keep allocations to process exit).
# About 15 minutes to build on 2 cores. Usage: bash scripts/sanitize.sh [BUILD_DIR] [CTEST ARGS...]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build-sanitize}
shift || true
flags="-O1 -g -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined"
cmake --build "$BUILD" -j"${NOVA_JOBS:-$(nproc)}"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0} UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
export POCL_CACHE_DIR=${POCL_CACHE_DIR:-$PWD/$BUILD/pocl-cache}
ctest --test-dir "$BUILD" -j"${NOVA_JOBS:-$(nproc)}" --output-on-failure "$@"
