#!/usr/bin/env bash
# Proves that a build from bundle/ needs nothing else from Debian: in a private mount
# namespace (unshare -m, root), empty directories and files are bound over the system's
# OpenCL, CLBlast, Boost, nlohmann-json, OpenCV (with TBB, LAPACK, BLAS and GLX), stb, zlib's
# headers (libz itself stays: the system needs it) and OpenBLAS headers, libraries and CMake/pkg-config packages;
# scripts/gpu-build.sh then builds the whole of nova, ldd must resolve libOpenCL, libclblast
# and libopencv into the bundle,
# and the binaries run on PoCL (not bundled: its ICD entry and library stay visible for the
# run). It also checks env.sh's NVIDIA ICD set-up against a stand-in driver library.
# Usage (as root, after scripts/bundle-gpu.sh):
#   bash scripts/check-bundle.sh [BUILD_DIR] [--quick] [--reuse]
#     BUILD_DIR  default build-bundle-check (git-ignored)
#     --quick    run four suites instead of the whole core test set
#     --reuse    build on top of an earlier BUILD_DIR instead of from scratch
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=build-bundle-check
QUICK=0
REUSE=0
for a in "$@"; do
  case "$a" in
    --quick) QUICK=1 ;;
    --reuse) REUSE=1 ;;
    -*) echo "check-bundle: unknown option '$a'" >&2; exit 2 ;;
    *) BUILD=$a ;;
  esac
done
BUNDLE=$(pwd)/bundle
if [ ! -f "$BUNDLE/env.sh" ]; then
  echo "check-bundle: $BUNDLE/env.sh not found: run 'bash scripts/bundle-gpu.sh' first" >&2
  exit 2
fi
if [ "$(id -u)" -ne 0 ]; then
  echo "check-bundle: needs root for 'unshare -m' (private bind mounts)" >&2
  exit 2
fi

if [ -z "${NOVA_CHECK_IN_NAMESPACE:-}" ]; then
  exec unshare -m --propagation private env NOVA_CHECK_IN_NAMESPACE=1 bash "$0" "$@"
fi

# ---- inside the namespace: hide the system's packages ------------------------------------
empty_dir=$(mktemp -d)
empty_file=$(mktemp)
hidden=0
hide() {
  local p
  for p in "$@"; do
    [ -e "$p" ] || continue
    if [ -d "$p" ]; then mount --bind "$empty_dir" "$p"; else mount --bind "$empty_file" "$p"; fi
    hidden=$((hidden + 1))
  done
}
L=/usr/lib/x86_64-linux-gnu
hide /usr/include/CL /usr/include/boost /usr/include/opencv4 /usr/include/clblast*.h \
     /usr/include/nlohmann /usr/share/cmake/nlohmann_json \
     /usr/include/x86_64-linux-gnu/cblas*.h /usr/include/x86_64-linux-gnu/openblas* \
     $L/cmake $L/pkgconfig /usr/share/pkgconfig \
     $L/libOpenCL.so* $L/libclblast.so* $L/libclblast.a $L/libboost_* $L/libopencv_* \
     $L/libopenblas* $L/openblas* $L/libtbb* $L/liblapack* $L/libblas* $L/lapack $L/blas \
     $L/libGLX* /usr/include/stb /usr/include/zlib.h /usr/include/zconf.h
echo "check-bundle: $hidden system paths hidden, e.g.:"
for p in /usr/include/CL/cl.h /usr/include/clblast.h /usr/include/boost/version.hpp $L/libOpenCL.so.1 $L/libclblast.so.1; do
  if [ -s "$p" ]; then echo "check-bundle: $p is still visible" >&2; exit 1; fi
  echo "  $p: $( [ -e "$p" ] && echo "empty" || echo "gone")"
done

# ---- build from the bundle -----------------------------------------------------------------
[ "$REUSE" -eq 1 ] || rm -rf "$BUILD"
NOVA_JOBS=${NOVA_JOBS:-1} bash scripts/gpu-build.sh "$BUILD"

# ---- the binaries load OpenCL and CLBlast from the bundle ----------------------------------
status=0
for bin in "$BUILD/nova" "$BUILD/nova-bench" "$BUILD/examples/embed_core" "$BUILD/tests/nova_tests"; do
  loaded=$(ldd "$bin")
  echo "ldd $bin:"
  grep -E "libOpenCL|libclblast|libboost|opencv|blas|lapack|tbb|GLX" <<<"$loaded" | sed 's/^/ /'
  libs="libOpenCL.so.1 libclblast.so.1"
  [ "$bin" = "$BUILD/examples/embed_core" ] || libs="$libs libopencv_core.so.406 libtbb.so.12 liblapack.so.3"
  for lib in $libs; do
    if ! grep -q "$lib => $BUNDLE/" <<<"$loaded"; then
      echo "check-bundle: $bin does not load $lib from $BUNDLE" >&2
      status=1
    fi
  done
  if grep -qE "not found|libopenblas|lib(opencv_imgcodecs|opencv_videoio|gdal|avcodec)" <<<"$loaded"; then
    echo "check-bundle: $bin needs something outside the bundle" >&2
    status=1
  fi
done
[ "$status" -eq 0 ] || exit 1

# ---- run on PoCL ---------------------------------------------------------------------------
export POCL_CACHE_DIR=$(pwd)/$BUILD/pocl-cache
"$BUILD/examples/embed_core"
"$BUILD/nova-bench" mlp --batches 4099 --depth 6 --width 64 --repeats 1 | sed -n '1,8p'
"$BUILD/nova-bench" render --rays 4099 --samples 16 --repeats 1 | sed -n '1,10p'
if [ "$QUICK" -eq 1 ]; then
  ctest --test-dir "$BUILD" -j2 --output-on-failure \
    -R '^(warm_kernel_cache|op_table|kernel_portability|core_link_is_lean|image_codec|scene_io|visualize|cli_run)$'
else
  ctest --test-dir "$BUILD" -j2 --output-on-failure
fi

# ---- env.sh's NVIDIA ICD set-up, with a stand-in driver library -----------------------------
fake=$(mktemp -d)
: >"$fake/libnvidia-opencl.so.1"
(
  export NOVA_NVIDIA_LIB_DIRS=$fake
  unset OCL_ICD_VENDORS OPENCL_VENDOR_PATH
  # shellcheck source=/dev/null
  . "$BUNDLE/env.sh"
  [ "${OCL_ICD_VENDORS:-}" = "$BUNDLE/vendors" ] || { echo "check-bundle: env.sh did not set OCL_ICD_VENDORS" >&2; exit 1; }
  [ "$(cat "$BUNDLE/vendors/nvidia.icd")" = "$fake/libnvidia-opencl.so.1" ] || { echo "check-bundle: nvidia.icd is wrong" >&2; exit 1; }
  echo "check-bundle: env.sh made $(ls "$BUNDLE/vendors" | paste -sd' ') in $OCL_ICD_VENDORS"
  # The stand-in is no driver: the loader skips it and PoCL still answers.
  "$BUILD/examples/embed_core" >/dev/null
  echo "check-bundle: with that vendor folder the loader still finds PoCL"
)
rm -rf "$fake" "$BUNDLE/vendors"
echo "check-bundle: OK"
