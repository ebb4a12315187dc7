#!/usr/bin/env bash
# Set-up (scripts/setup.sh), then the whole test suite through CTest. PoCL's compile cache
# is kept in build/pocl-cache (tests/CMakeLists.txt), so a second run compiles nothing.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
ctest --test-dir build -j2 --output-on-failure
