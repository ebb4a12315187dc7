#!/usr/bin/env bash
# Release check (not part of CI): the whole test suite under each kernel family of the host
# BLAS and with more threads, since cross-configuration bounds (ranks, devices, BLAS) must hold
# on any x86-64 machine, not only on the one CI runs on. Needs a build (scripts/setup.sh).
#
#   scripts/release-check.sh              every configuration below
#   scripts/release-check.sh Zen threads  only those (names as in the summary)
#   CTEST_ARGS="-R mpi_train" scripts/release-check.sh   a subset of the suites
#
# Configurations:
#   one-thread   the suite as CI runs it: every test with one PoCL thread and one host-BLAS
#                thread (OPENBLAS_NUM_THREADS=1, POCL_MAX_PTHREAD_COUNT=1; tests/CMakeLists.txt)
#   Haswell, SkylakeX, Cooperlake, Zen
#                the same with OPENBLAS_CORETYPE set: OpenBLAS's kernels for those CPUs (the
#                one a machine of that kind picks), each summing in its own order
#   threads      NOVA_TEST_THREADS = the machine's cores (PoCL and OpenBLAS threads of one
#                process), suites one at a time (ctest -j1); the build's test set-up is
#                configured back to one thread afterwards
# Prints one summary line per configuration and exits non-zero if any failed. Each
# configuration's CTest output is kept in build/release-check/<name>.log.
set -uo pipefail
cd "$(dirname "$0")/.."
[ -d build ] || { echo "release-check: no build/ (run scripts/setup.sh first)" >&2; exit 2; }

ALL=(one-thread Haswell SkylakeX Cooperlake Zen threads)
CONFIGS=("$@")
((${#CONFIGS[@]})) || CONFIGS=("${ALL[@]}")
read -r -a EXTRA <<< "${CTEST_ARGS:-}"
LOGS=build/release-check
mkdir -p "$LOGS"

restore_threads() { cmake -S . -B build -DNOVA_TEST_THREADS=1 >/dev/null; }

summary=()
failed=0
for name in "${CONFIGS[@]}"; do
  env=(env -u OPENBLAS_CORETYPE)
  jobs=2
  case "$name" in
    one-thread) ;;
    Haswell | SkylakeX | Cooperlake | Zen) env+=("OPENBLAS_CORETYPE=$name") ;;
    threads)
      trap restore_threads EXIT
      cmake -S . -B build -DNOVA_TEST_THREADS="$(nproc)" >/dev/null || exit 2
      jobs=1
      ;;
    *) echo "release-check: unknown configuration '$name' (one of: ${ALL[*]})" >&2; exit 2 ;;
  esac
  start=$(date +%s)
  "${env[@]}" ctest --test-dir build -j"$jobs" --output-on-failure "${EXTRA[@]}" > "$LOGS/$name.log" 2>&1
  code=$?
  if [ "$name" = threads ]; then
    restore_threads
    trap - EXIT
  fi
  result=$(grep -E "tests passed|No tests were found" "$LOGS/$name.log" | tail -1)
  line=$(printf "%-11s %s  %s (%ss)  %s" "$name" "$([ $code -eq 0 ] && echo PASS || echo FAIL)" \
         "${result:-no result}" "$(($(date +%s) - start))" "$LOGS/$name.log")
  echo "$line"
  summary+=("$line")
  [ $code -eq 0 ] || failed=1
done

echo "release-check summary:"
printf '  %s\n' "${summary[@]}"
exit $failed
