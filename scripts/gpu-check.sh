#!/usr/bin/env bash
# One pass over a GPU machine that has the driver, a compiler and CMake but no packages: builds
# nova from bundle/ (scripts/bundle-gpu.sh), runs the test suites on the GPU, the benchmarks,
# and the main job, and writes what it saw to OUT_DIR:
#   machine.txt   GPU, driver, compiler, CMake, torch, and the device embed_core runs on
#   build.log     the build          ctest.log   the suites, one line each, failures in full
#   suites/       each suite that did not pass, run again alone: NAME.log (every case and its
#                 time), stacks.txt (its processes' stacks if it still ran after NOVA_GPU_STACK_S)
#   mlp.txt       nova-bench mlp, GEMMs as chosen (tuned: split-K weight gradient) and CLBlast
#                 unsplit, beside PyTorch on the same GPU where python3 has CUDA torch
#   step.txt      nova-bench step: quick and reference, 1 and 2 objects, default synthetic scene
#   anchor.txt    with NOVA_GPU_ANCHOR=DIR: nova-bench step --anchor DIR (nova's reference steps
#                 and the NOVA code's, alternating on this GPU, and their ratio); with also
#                 NOVA_GPU_ANCHOR_TRAIN=P,J a reference run trained P pretraining steps and one
#                 trained J joint steps after them stand for nova's side (anchor-train.txt: their
#                 training; the steps then skip empty space as the runs' grids say)
#   main.txt      the main job (nova synth, train --preset quick, eval), with its times
#   eval/         its camera-0 and composition pictures
#   render.txt    nova-bench render  ops.txt     nova-bench ops (every op at its table shape)
#   tune.txt, mlp-tuned.txt, gemm-tuning.tsv   with NOVA_GPU_TUNE=1: nova tune --quick on the
#                 256-wide layer at 65536 rows, and the MLP again with its winners
# The suites run three at a time (NOVA_GPU_TEST_JOBS): they share the one GPU, and with ten
# at once five of them did not finish within 300 s on an H200. Each stage has a time limit, so
# one that hangs leaves the others their time; NOVA_GPU_SKIP names stages to leave out (e.g.
# "render ops").
set -uo pipefail
cd "$(dirname "$0")/.." || exit 1
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

skip() { case " ${NOVA_GPU_SKIP:-} " in *" $1 "*) echo "gpu-check: $1 skipped"; return 0 ;; esac; return 1; }

if ! skip ctest; then
  stage "test suites"
  timeout "${NOVA_GPU_TEST_S:-300}" ctest --test-dir "$BUILD" -j"${NOVA_GPU_TEST_JOBS:-3}" --timeout 240 \
    --output-on-failure >"$OUT_DIR/ctest.log" 2>&1
  echo "ctest exit $?" >>"$OUT_DIR/ctest.log"
  grep -E "tests passed|tests failed|\*\*\*Failed|Timeout|ctest exit" "$OUT_DIR/ctest.log" | tail -20
  # Suites that did not pass (failed, timed out or still running when the stage ended), again
  # one at a time with every test case logged (suites/NAME.log); one still running after
  # NOVA_GPU_STACK_S seconds has its processes' stacks written (suites/stacks.txt) where
  # cuda-gdb or gdb is at hand, and ends after NOVA_GPU_ALONE_S.
  started=$(grep -oE "Start +[0-9]+: [A-Za-z0-9_]+" "$OUT_DIR/ctest.log" | awk '{print $3}' | sort -u)
  passed=$(grep -oE "Test +#[0-9]+: [A-Za-z0-9_]+ \.+ +Passed" "$OUT_DIR/ctest.log" | awk '{print $3}' | sort -u)
  debugger=$(command -v cuda-gdb || command -v gdb || true)
  descendants() { local c; for c in $(pgrep -P "$1"); do echo "$c"; descendants "$c"; done; }
  suites=$("$BUILD/tests/nova_tests" --list_content 2>&1 | grep -oE "^[A-Za-z0-9_]+" | sort -u)
  for s in $(comm -23 <(echo "$started") <(echo "$passed")); do
    grep -qx "$s" <<<"$suites" || continue  # a test that is no suite of nova_tests
    stage "suite $s alone"
    mkdir -p "$OUT_DIR/suites"
    (cd "$BUILD/tests" && exec timeout -s KILL "${NOVA_GPU_ALONE_S:-120}" stdbuf -oL -eL ./nova_tests --run_test="$s" \
      --log_level=unit_scope --report_level=short) >"$OUT_DIR/suites/$s.log" 2>&1 &
    job=$!
    for _ in $(seq "${NOVA_GPU_STACK_S:-60}"); do kill -0 $job 2>/dev/null || break; sleep 1; done
    if kill -0 $job 2>/dev/null && [ -n "$debugger" ]; then
      for p in $(descendants $job); do
        case $(ps -o comm= -p "$p") in nova_tests|nova) ;; *) continue ;; esac
        echo "== $s: pid $p: $(tr '\0' ' ' <"/proc/$p/cmdline" | cut -c1-300)"
        timeout 20 "$debugger" -p "$p" -batch -ex "thread apply all bt 16" 2>&1 | grep -E "^Thread|^#"
      done >>"$OUT_DIR/suites/stacks.txt"
    fi
    wait $job
    echo "exit $?" >>"$OUT_DIR/suites/$s.log"
    grep -E "Leaving test case|has passed|failed|exit" "$OUT_DIR/suites/$s.log" | tail -6
  done
fi

if ! skip mlp; then
  stage "nova-bench mlp"
  torch=off
  python3 -c 'import torch, sys; sys.exit(0 if torch.cuda.is_available() else 1)' 2>/dev/null && torch=$(command -v python3)
  timeout "${NOVA_GPU_MLP_S:-150}" "$BUILD/nova-bench" mlp --batches "${NOVA_GPU_MLP_BATCHES:-16384,65536,262144}" --repeats 5 \
    --gemm "${NOVA_GPU_MLP_GEMM:-tuned,clblast}" --torch "$torch" --torch-device cuda >"$OUT_DIR/mlp.txt" 2>&1
  echo "exit $?" >>"$OUT_DIR/mlp.txt"
  sed -n '1,/^CSV$/p' "$OUT_DIR/mlp.txt" | head -80
fi

# Optional (NOVA_GPU_TUNE=1): nova tune on the 256-wide layer's shapes, then the MLP again with
# the winners (the GEMMs above ran on CLBlast's own parameters).
if [ "${NOVA_GPU_TUNE:-0}" = 1 ]; then
  stage "nova tune"
  export NOVA_TUNING_CACHE="$OUT_DIR/gemm-tuning.tsv"
  timeout "${NOVA_GPU_TUNE_S:-240}" "$BUILD/nova" tune --quick --widths 256 --inputs 63 \
    --batch 65536 --budget 60 >"$OUT_DIR/tune.txt" 2>&1
  echo "exit $?" >>"$OUT_DIR/tune.txt"
  tail -12 "$OUT_DIR/tune.txt"
  timeout "${NOVA_GPU_MLP_S:-150}" "$BUILD/nova-bench" mlp --batches 65536 --repeats 5 \
    --gemm tuned,clblast --torch off >"$OUT_DIR/mlp-tuned.txt" 2>&1
  sed -n '1,/^CSV$/p' "$OUT_DIR/mlp-tuned.txt" | head -30
fi

work=$(mktemp -d)
if ! skip step || ! skip main; then
  "$BUILD/nova" synth --out "$work/scene" >/dev/null
fi

if ! skip step; then
  stage "nova-bench step"
  timeout "${NOVA_GPU_STEP_S:-150}" "$BUILD/nova-bench" step --scene "$work/scene" --presets quick,reference \
    --objects 1,2 --steps 10 --warmup 3 --torch off >"$OUT_DIR/step.txt" 2>&1
  echo "exit $?" >>"$OUT_DIR/step.txt"
  grep -vE "^ +[a-z_]+ +[0-9]" "$OUT_DIR/step.txt" | head -40
fi

# With NOVA_GPU_ANCHOR=DIR (the NOVA code anchor, nova_ref, carried along): nova's reference
# steps and the NOVA code's on Balloon1 480x270, alternating on this GPU, and their ratio.
if [ -n "${NOVA_GPU_ANCHOR:-}" ] && ! skip anchor; then
  anchor_runs=()
  if [ -n "${NOVA_GPU_ANCHOR_TRAIN:-}" ]; then
    stage "reference runs on the NOVA code's scene"
    pre_steps=${NOVA_GPU_ANCHOR_TRAIN%,*}
    joint_steps=${NOVA_GPU_ANCHOR_TRAIN#*,}
    runs="$work/anchor-runs"
    rm -rf "$runs" && mkdir -p "$runs"
    {
      # The reference's own occupancy settings; --steps 0 ends the first run in pretraining.
      timeout "${NOVA_GPU_ANCHOR_TRAIN_S:-300}" "$BUILD/nova" train --preset reference \
        --scene "$NOVA_GPU_ANCHOR/data/Balloon1" --factor 2 --out "$runs/pre" --pretrain-steps "$pre_steps" \
        --steps 0 --log-every 250 &&
        cp -r "$runs/pre" "$runs/joint" &&
        timeout "${NOVA_GPU_ANCHOR_TRAIN_S:-300}" "$BUILD/nova" train --out "$runs/joint" --resume \
          --steps "$joint_steps" --log-every 250
      echo "exit $?"
    } >"$OUT_DIR/anchor-train.txt" 2>&1
    tail -3 "$OUT_DIR/anchor-train.txt"
    if [ -f "$runs/joint/checkpoint.bin" ] && tail -1 "$OUT_DIR/anchor-train.txt" | grep -q "exit 0"; then
      anchor_runs=(--run "$runs/pre,$runs/joint")
    fi
  fi
  stage "nova-bench step beside the NOVA code"
  timeout "${NOVA_GPU_ANCHOR_S:-240}" "$BUILD/nova-bench" step --anchor "$NOVA_GPU_ANCHOR" "${anchor_runs[@]}" \
    --anchor-python "$(command -v python3)" --steps 10 --warmup 3 --rounds "${NOVA_GPU_ANCHOR_ROUNDS:-2}" >"$OUT_DIR/anchor.txt" 2>&1
  echo "exit $?" >>"$OUT_DIR/anchor.txt"
  grep -vE "^ +[a-z_]+ +[0-9]" "$OUT_DIR/anchor.txt" | head -40
fi

if ! skip main; then
  stage "main job"
  {
    t0=$(date +%s%N)
    timeout "${NOVA_GPU_MAIN_S:-240}" "$BUILD/nova" train --scene "$work/scene" --out "$work/run" --preset quick
    echo "train exit $? after $(( ($(date +%s%N) - t0) / 1000000 )) ms"
    t1=$(date +%s%N)
    timeout "${NOVA_GPU_EVAL_S:-120}" "$BUILD/nova" eval --run "$work/run"
    echo "eval exit $? after $(( ($(date +%s%N) - t1) / 1000000 )) ms"
  } >"$OUT_DIR/main.txt" 2>&1
  grep -vE "^step|^ *[0-9]+/" "$OUT_DIR/main.txt" | tail -25
  mkdir -p "$OUT_DIR/eval"
  cp "$work"/run/eval/*.png "$OUT_DIR/eval/" 2>/dev/null
fi
rm -rf "$work"

if ! skip render; then
  stage "nova-bench render"
  timeout "${NOVA_GPU_RENDER_S:-90}" "$BUILD/nova-bench" render --repeats 5 >"$OUT_DIR/render.txt" 2>&1
  echo "exit $?" >>"$OUT_DIR/render.txt"
  head -30 "$OUT_DIR/render.txt"
fi

if ! skip ops; then
  stage "nova-bench ops"
  timeout "${NOVA_GPU_OPS_S:-90}" "$BUILD/nova-bench" ops --reps 20 >"$OUT_DIR/ops.txt" 2>&1
  echo "exit $?" >>"$OUT_DIR/ops.txt"
  tail -8 "$OUT_DIR/ops.txt"
fi
stage "done"
