#!/usr/bin/env bash
# Gathers what nova's core, nova-bench and the core test suites need on a machine that has a
# compiler, CMake and a GPU driver but no Debian packages and no registry (the GPU machines)
# into bundle/ (git-ignored), unpacked from the Debian packages with dpkg-deb -x and trimmed:
#
#   usr/include/CL, usr/lib/.../libOpenCL.so*   OpenCL headers and the ocl-icd ICD loader
#   usr/include/clblast*.h, libclblast.so*      CLBlast (GEMMs) and its CMake package
#   usr/include/boost (Boost.Test's headers only), libboost_unit_test_framework.so*
#   usr/include/nlohmann, usr/share/cmake/nlohmann_json   nlohmann-json (header-only: metrics.jsonl)
#   env.sh                                      CMake arguments and the NVIDIA ICD set-up
#
# Not bundled: OpenCV (nova_io, the CLI and its suites are left out there: NOVA_BUILD_IO=OFF),
# OpenBLAS (nova-bench's host column only), PoCL. Usage, on a Debian 12 machine:
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
boost_includes=$(grep -ho '#include <boost/[^>]*>' tests/*.cpp tests/*.hpp | sort -u)
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
