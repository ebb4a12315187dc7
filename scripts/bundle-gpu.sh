#!/usr/bin/env bash
# Gathers what nova's core, nova-bench and the core test suites need on a machine that has a
# compiler, CMake and a GPU driver but no Debian packages and no registry (the GPU machines)
# into bundle/ (git-ignored), unpacked from the Debian packages with dpkg-deb -x and trimmed:
#
#   usr/include/CL, usr/lib/.../libOpenCL.so*   OpenCL headers and the ocl-icd ICD loader
#   usr/include/clblast*.h, libclblast.so*      CLBlast (GEMMs) and its CMake package
#   usr/include/boost (Boost.Test's headers only), libboost_unit_test_framework.so*
#   usr/include/nlohmann, usr/share/cmake/nlohmann_json   nlohmann-json (header-only: metrics.jsonl)
#   usr/include/opencv4, libopencv_{core,imgproc}.so*   OpenCV's two small modules (nova_io) with
#                                               a CMake package of their own (cmake/opencv4),
#                                               libtbb.so.12, and stubs of liblapack.so.3,
#                                               libblas.so.3 and libGLX.so.0 (BIND_NOW needs
#                                               their symbols; nova calls none of them)
#   usr/include/stb                             stb_image / stb_image_write: nova_io's codec there
#   libboost_program_options.so*, zlib          the CLI's options, .npz members
#   env.sh                                      CMake arguments and the NVIDIA ICD set-up
#
# So the whole of nova builds there (CLI, nova-bench, every suite) with NOVA_OPENCV_CODECS=OFF:
# OpenCV's imgcodecs and videoio pull in GDAL, FFmpeg and GStreamer (over 300 MB), so images go
# through stb_image and no videos are written. Not bundled: OpenBLAS (nova-bench's host column
# only), PoCL, MPI. Usage, on a Debian 12 machine:
#   bash scripts/bundle-gpu.sh [DIR]     (DIR defaults to bundle; prints the size)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-bundle}
LIMIT_MIB=64  # what the GPU machine takes along (the device tool's carry limit)
ARCH=x86_64-linux-gnu

PACKAGES=(
  ocl-icd-libopencl1     # libOpenCL.so.1, the ICD loader nova links
  ocl-icd-opencl-dev     # libOpenCL.so, the link-time name
  opencl-c-headers       # CL/cl.h; nova uses the C API only (no opencl-clhpp-headers)
  libclblast1            # libclblast.so.1
  libclblast-dev         # clblast.h and the CMake package CLBlast (libclblast.a is dropped)
  libboost-test1.74.0    # libboost_unit_test_framework.so.1.74.0
  libboost-test1.74-dev  # its link-time name and CMake package (static libraries dropped)
  libboost1.74-dev       # Boost headers and CMake packages, trimmed to what Boost.Test needs
  nlohmann-json3-dev     # JSON headers and their CMake package (the trainer writes metrics.jsonl)
  libopencv-core406 libopencv-core-dev          # nova_io: cv::Mat, the metrics' arithmetic
  libopencv-imgproc406 libopencv-imgproc-dev    # nova_io: resizing, colour conversion, charts
  libtbb12               # OpenCV core's thread pool
  libstb-dev             # stb_image.h, stb_image_write.h (header-only here)
  libboost-program-options1.74.0 libboost-program-options1.74-dev  # the CLI's options
  zlib1g zlib1g-dev      # .npz members (nova_io)
)

for tool in apt-get dpkg-deb g++; do
  command -v "$tool" >/dev/null || { echo "bundle-gpu: '$tool' not found (run on Debian 12 with g++)" >&2; exit 2; }
done
if [ "$(dpkg --print-architecture)" != amd64 ]; then
  echo "bundle-gpu: this machine is $(dpkg --print-architecture); the GPU machines are amd64" >&2
  exit 2
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
chmod 0777 "$work"  # apt's download user must be able to write there
echo "bundle-gpu: downloading ${PACKAGES[*]}"
if ! (cd "$work" && apt-get download -qq "${PACKAGES[@]}" 2>"$work/apt.err"); then
  if [ "$(id -u)" -eq 0 ]; then
    apt-get update -qq
    (cd "$work" && apt-get download -qq "${PACKAGES[@]}")
  else
    cat "$work/apt.err" >&2
    echo "bundle-gpu: apt-get download failed; run 'sudo apt-get update' and try again" >&2
    exit 1
  fi
fi

root="$work/root"
for deb in "$work"/*.deb; do dpkg-deb -x "$deb" "$root"; done

rm -rf "$OUT/usr" "$OUT/vendors"
mkdir -p "$OUT/usr/include" "$OUT/usr/lib/$ARCH/cmake" "$OUT/usr/share/doc" "$OUT/usr/share/cmake"
lib="$root/usr/lib/$ARCH"
cp -a "$root/usr/include/CL" "$root"/usr/include/clblast*.h "$root/usr/include/nlohmann" "$OUT/usr/include/"
# Found through CMAKE_PREFIX_PATH (<prefix>/share/cmake/nlohmann_json); its paths are relative.
cp -a "$root/usr/share/cmake/nlohmann_json" "$OUT/usr/share/cmake/"
cp -a "$lib"/libOpenCL.so* "$lib"/libclblast.so* "$lib"/libboost_unit_test_framework.so* "$OUT/usr/lib/$ARCH/"
cp -a "$lib/cmake/CLBlast" "$lib/cmake/Boost-1.74.0" "$lib/cmake/boost_headers-1.74.0" \
      "$lib/cmake/boost_unit_test_framework-1.74.0" "$lib/cmake/BoostDetectToolset-1.74.0.cmake" \
      "$OUT/usr/lib/$ARCH/cmake/"
# OpenCV core + imgproc: headers, libraries, and a CMake package naming these two only (the
# system's OpenCVModules.cmake checks that every module's library exists).
mkdir -p "$OUT/usr/include/opencv4/opencv2" "$OUT/usr/lib/$ARCH/cmake/opencv4"
cp -a "$root/usr/include/opencv4/opencv2/"{core,core.hpp,imgproc,imgproc.hpp,opencv_modules.hpp,cvconfig.h} \
      "$OUT/usr/include/opencv4/opencv2/" 2>/dev/null || true
for h in core.hpp imgproc.hpp opencv_modules.hpp; do
  [ -e "$OUT/usr/include/opencv4/opencv2/$h" ] || { echo "bundle-gpu: OpenCV header $h missing" >&2; exit 1; }
done
cp -a "$lib"/libopencv_core.so* "$lib"/libopencv_imgproc.so* "$lib"/libtbb.so.12* "$OUT/usr/lib/$ARCH/"
mkdir -p "$OUT/usr/include/stb"
cp -a "$root/usr/include/stb/stb_image.h" "$root/usr/include/stb/stb_image_write.h" "$OUT/usr/include/stb/"
cp -a "$root"/usr/include/zlib.h "$root"/usr/include/zconf.h "$OUT/usr/include/"
cp -a "$lib"/libz.so "$OUT/usr/lib/$ARCH/"
cp -a "$root"/lib/$ARCH/libz.so.1* "$root"/usr/lib/$ARCH/libz.so.1* "$OUT/usr/lib/$ARCH/" 2>/dev/null || true
[ -e "$OUT/usr/lib/$ARCH/libz.so.1" ] || { echo "bundle-gpu: libz.so.1 missing from zlib1g" >&2; exit 1; }
cp -a "$lib"/libboost_program_options.so* "$OUT/usr/lib/$ARCH/"
rm -f "$OUT/usr/lib/$ARCH/"*.a
cp -a "$lib/cmake/boost_program_options-1.74.0" "$OUT/usr/lib/$ARCH/cmake/"
rm -f "$OUT/usr/lib/$ARCH/cmake/boost_program_options-1.74.0/"*-variant-static.cmake
cat >"$OUT/usr/lib/$ARCH/cmake/opencv4/OpenCVConfig.cmake" <<'CMAKE'
# OpenCV core and imgproc from nova's GPU bundle (scripts/bundle-gpu.sh); no other module.
get_filename_component(_nova_cv_usr "${CMAKE_CURRENT_LIST_DIR}/../../../.." ABSOLUTE)
set(OpenCV_VERSION 4.6.0)
set(OpenCV_INCLUDE_DIRS "${_nova_cv_usr}/include/opencv4")
foreach(_m core imgproc)
  if(NOT TARGET opencv_${_m})
    add_library(opencv_${_m} SHARED IMPORTED)
    set_target_properties(opencv_${_m} PROPERTIES
      IMPORTED_LOCATION "${_nova_cv_usr}/lib/x86_64-linux-gnu/libopencv_${_m}.so.406"
      INTERFACE_INCLUDE_DIRECTORIES "${OpenCV_INCLUDE_DIRS}")
  endif()
endforeach()
set_property(TARGET opencv_imgproc PROPERTY INTERFACE_LINK_LIBRARIES opencv_core)
set(OpenCV_LIBS opencv_core opencv_imgproc)
foreach(_c ${OpenCV_FIND_COMPONENTS})
  if(TARGET opencv_${_c})
    set(OpenCV_${_c}_FOUND TRUE)
  elseif(OpenCV_FIND_REQUIRED_${_c})
    set(OpenCV_FOUND FALSE)
    set(OpenCV_NOT_FOUND_MESSAGE "nova's GPU bundle has OpenCV core and imgproc only, not ${_c}")
  endif()
endforeach()
CMAKE
# Stubs for the libraries OpenCV core loads (BIND_NOW) but nova never calls into: LAPACK and
# BLAS (cv::solve, cv::SVD, cv::gemm) and GLX (OpenGL interop). Each defines the symbols the
# two modules import from it; calling one aborts with its name.
stub_dir="$work/stubs"
mkdir -p "$stub_dir"
nm -D --undefined-only "$lib/libopencv_core.so.406" "$lib/libopencv_imgproc.so.406" |
  awk '$1 == "U" {print $2}' | sed 's/@.*//' | sort -u >"$stub_dir/imported.txt"
for soname in liblapack.so.3 libblas.so.3 libGLX.so.0; do
  # This machine's library gives the symbol list (awk reads to the end: no SIGPIPE under pipefail).
  real=$(ldconfig -p | awk -v n="$soname" '$1 == n && /x86-64/ && !f {print $NF; f = 1}')
  [ -n "$real" ] || { echo "bundle-gpu: $soname not on this machine (its symbol list is needed)" >&2; exit 1; }
  nm -D --defined-only "$real" | awk '{print $3}' | sed 's/@.*//' | sort -u | comm -12 - "$stub_dir/imported.txt" >"$stub_dir/$soname.txt"
  {
    echo '#include <stdio.h>'
    echo '#include <stdlib.h>'
    echo 'static void nova_stub(const char* f) { fprintf(stderr, "nova bundle: %s is a stub ('"$soname"')\n", f); abort(); }'
    while read -r f; do echo "void $f(void) { nova_stub(\"$f\"); }"; done <"$stub_dir/$soname.txt"
  } >"$stub_dir/$soname.c"
  gcc -shared -fPIC -o "$OUT/usr/lib/$ARCH/$soname" -Wl,-soname,"$soname" "$stub_dir/$soname.c"
  echo "bundle-gpu: stub $soname ($(wc -l <"$stub_dir/$soname.txt") symbols)"
done

# pkg-config files of OpenCL and CLBlast (nova.pc requires both), relocated to the bundle.
mkdir -p "$OUT/usr/lib/$ARCH/pkgconfig"
for pc in OpenCL clblast; do
  sed 's#^prefix=/usr$#prefix=${pcfiledir}/../../..#' "$lib/pkgconfig/$pc.pc" >"$OUT/usr/lib/$ARCH/pkgconfig/$pc.pc"
done
# The static Boost.Test library is not bundled, so neither is its CMake variant.
rm -f "$OUT/usr/lib/$ARCH/cmake/boost_unit_test_framework-1.74.0/"*-variant-static.cmake
# CLBlast's package names the system's loader by absolute path; point it into the bundle.
sed -i "s#\"/usr/lib/$ARCH/libOpenCL.so\"#\"\${_IMPORT_PREFIX}/lib/$ARCH/libOpenCL.so\"#" \
    "$OUT/usr/lib/$ARCH/cmake/CLBlast/CLBlastConfig-none.cmake"
if grep -q '"/usr/' "$OUT/usr/lib/$ARCH/cmake/CLBlast/CLBlastConfig-none.cmake"; then
  echo "bundle-gpu: CLBlast's CMake package still names a system path" >&2
  exit 1
fi

# Boost headers: those the suites include (every Boost header named in tests/, data-driven
# cases too; the compiler's own list, with and without BOOST_TEST_MODULE), plus all of
# boost/config and boost/test, whose choice of files depends on the compiler and its version
# (the GPU machine's g++ may differ from this one).
boost_includes=$(grep -ho '#include <boost/[^>]*>' tests/*.cpp tests/*.hpp host/cli/*.cpp host/cli/*.hpp bench/*.cpp 2>/dev/null | sort -u)
printf '#define BOOST_TEST_MODULE m\n#define BOOST_TEST_DYN_LINK\n%s\n' "$boost_includes" >"$work/a.cpp"
printf '#define BOOST_TEST_DYN_LINK\n%s\n' "$boost_includes" >"$work/b.cpp"
dest=$(mkdir -p "$OUT/usr/include" && cd "$OUT/usr/include" && pwd)
{
  for tu in a b; do g++ -std=c++20 -I"$root/usr/include" -M "$work/$tu.cpp"; done |
    tr ' \\' '\n\n' | grep "^$root/usr/include/boost/" | sed "s#^$root/usr/include/##"
  (cd "$root/usr/include" && find boost/config boost/test -type f)
} | sort -u >"$work/boost-headers.txt"
(cd "$root/usr/include" && xargs -a "$work/boost-headers.txt" cp --parents -t "$dest")

# Licences of what is redistributed.
for p in "${PACKAGES[@]}"; do
  if [ -f "$root/usr/share/doc/$p/copyright" ]; then
    install -D -m 644 "$root/usr/share/doc/$p/copyright" "$OUT/usr/share/doc/$p/copyright"
  fi
done
for deb in "$work"/*.deb; do dpkg-deb --show --showformat='${Package} ${Version}\n' "$deb"; done >"$OUT/MANIFEST"
cp scripts/bundle-env.sh "$OUT/env.sh"

size=$(du -sb "$OUT" | cut -f1)
echo "bundle-gpu: $OUT is $((size / 1024 / 1024)) MiB ($size bytes, limit $LIMIT_MIB MiB):"
sed 's/^/  /' "$OUT/MANIFEST"
if [ "$size" -gt $((LIMIT_MIB * 1024 * 1024)) ]; then
  echo "bundle-gpu: $OUT is over $LIMIT_MIB MiB" >&2
  exit 1
fi
