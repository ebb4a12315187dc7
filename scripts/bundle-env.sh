# bundle/env.sh (copied there by scripts/bundle-gpu.sh). Source it from bash on the machine
# that builds and runs nova from the bundle:  . bundle/env.sh
#
# Sets NOVA_BUNDLE (this folder) and NOVA_CMAKE_ARGS, the CMake arguments of a build that
# takes OpenCL, CLBlast, Boost, OpenCV core/imgproc, stb and zlib from the bundle alone, with
# images through stb_image (NOVA_OPENCV_CODECS=OFF). The executables carry an old-style RPATH
# into the bundle (--disable-new-dtags: unlike RUNPATH it also serves the libraries' own
# dependencies, such as OpenCV core's libtbb), so nothing needs LD_LIBRARY_PATH:
#   cmake -S . -B build-gpu $NOVA_CMAKE_ARGS
#
# NVIDIA ICD: nova links the bundle's ocl-icd loader, which finds drivers through *.icd files
# in /etc/OpenCL/vendors. When none of them names NVIDIA's driver but the driver's
# libnvidia-opencl.so.1 is on the machine (ldconfig's cache, /usr/lib/x86_64-linux-gnu,
# /usr/lib64, /usr/local/nvidia/lib64), this makes $NOVA_BUNDLE/vendors with the existing
# entries plus nvidia.icd naming that library, and exports OCL_ICD_VENDORS to it.
# NOVA_NVIDIA_LIB_DIRS (space-separated) is searched first (used by scripts/check-bundle.sh).

NOVA_BUNDLE=$(cd "$(dirname "${BASH_SOURCE[0]:-$0}")" && pwd)
export NOVA_BUNDLE
_nova_lib="$NOVA_BUNDLE/usr/lib/x86_64-linux-gnu"
NOVA_CMAKE_ARGS="-DNOVA_OPENCV_CODECS=OFF -DNOVA_BENCH_HOST_BLAS=OFF"
NOVA_CMAKE_ARGS="$NOVA_CMAKE_ARGS -DOpenCV_DIR=$_nova_lib/cmake/opencv4 -DZLIB_ROOT=$NOVA_BUNDLE/usr"
NOVA_CMAKE_ARGS="$NOVA_CMAKE_ARGS -DCMAKE_EXE_LINKER_FLAGS=-Wl,--disable-new-dtags"
NOVA_CMAKE_ARGS="$NOVA_CMAKE_ARGS -DCMAKE_PREFIX_PATH=$NOVA_BUNDLE/usr"
NOVA_CMAKE_ARGS="$NOVA_CMAKE_ARGS -DOpenCL_INCLUDE_DIR=$NOVA_BUNDLE/usr/include"
NOVA_CMAKE_ARGS="$NOVA_CMAKE_ARGS -DOpenCL_LIBRARY=$_nova_lib/libOpenCL.so"
NOVA_CMAKE_ARGS="$NOVA_CMAKE_ARGS -DCLBlast_DIR=$_nova_lib/cmake/CLBlast"
NOVA_CMAKE_ARGS="$NOVA_CMAKE_ARGS -DBoost_DIR=$_nova_lib/cmake/Boost-1.74.0"
NOVA_CMAKE_ARGS="$NOVA_CMAKE_ARGS -DCMAKE_BUILD_RPATH=$_nova_lib"
export NOVA_CMAKE_ARGS
unset _nova_lib

_nova_nvidia_icd() {
  local vendors="${OCL_ICD_VENDORS:-${OPENCL_VENDOR_PATH:-/etc/OpenCL/vendors}}" lib="" d ldconfig
  if [ -d "$vendors" ] && grep -qs "libnvidia-opencl" "$vendors"/*.icd; then
    return 0  # the machine's own entry works
  fi
  ldconfig=$(command -v ldconfig || echo /sbin/ldconfig)
  for d in ${NOVA_NVIDIA_LIB_DIRS:-}; do
    [ -z "$lib" ] && [ -e "$d/libnvidia-opencl.so.1" ] && lib="$d/libnvidia-opencl.so.1"
  done
  if [ -z "$lib" ] && [ -x "$ldconfig" ]; then
    # awk reads to the end (no early exit): a SIGPIPE would fail callers under pipefail.
    lib=$("$ldconfig" -p 2>/dev/null | awk '/libnvidia-opencl\.so\.1 / && /x86-64/ && !n {print $NF; n = 1}' || true)
  fi
  for d in /usr/lib/x86_64-linux-gnu /usr/lib64 /usr/local/nvidia/lib64 /usr/local/nvidia/lib; do
    [ -z "$lib" ] && [ -e "$d/libnvidia-opencl.so.1" ] && lib="$d/libnvidia-opencl.so.1"
  done
  [ -n "$lib" ] || return 0  # no NVIDIA driver: other ICDs (PoCL) as they are
  mkdir -p "$NOVA_BUNDLE/vendors"
  rm -f "$NOVA_BUNDLE/vendors/"*.icd
  if [ -d "$vendors" ]; then
    for d in "$vendors"/*.icd; do [ -e "$d" ] && cp "$d" "$NOVA_BUNDLE/vendors/"; done
  fi
  echo "$lib" >"$NOVA_BUNDLE/vendors/nvidia.icd"
  export OCL_ICD_VENDORS="$NOVA_BUNDLE/vendors"
  # The driver's own dependencies (libnvidia-ptxjitcompiler ...) sit beside it.
  d=$(dirname "$lib")
  case "$("$ldconfig" -p 2>/dev/null || true)" in
    *"=> $d/"*) ;;
    *) export LD_LIBRARY_PATH="$d${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" ;;
  esac
  echo "env.sh: no OpenCL ICD entry for NVIDIA; OCL_ICD_VENDORS=$OCL_ICD_VENDORS (nvidia.icd: $lib)" >&2
}
_nova_nvidia_icd
unset -f _nova_nvidia_icd
