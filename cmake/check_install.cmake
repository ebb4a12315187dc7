# The installed package works for a program outside nova's tree (examples/CMakeLists.txt runs
# this as the CTest test install_package):
#   1. cmake --install BUILD_DIR --prefix WORK_DIR/prefix: every room's headers at their path
#      under include/nova/ (the I/O rooms' only with nova_io), and no package file naming
#      nlohmann-json
#   2. examples/ configured on its own with CMAKE_PREFIX_PATH=prefix (find_package(nova CONFIG)),
#      built, and embed_core run
#   3. embed_core.cpp compiled with `pkg-config --cflags --libs nova` against the prefix, and run
# Any failing step stops the test with its output.
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)

function(step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}\n${err}")
  endif()
  message(STATUS "${what}: ok")
endfunction()

step("cmake --install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
foreach(f lib/cmake/nova/nova-config.cmake lib/pkgconfig/nova.pc include/nova/runtime/runtime.hpp lib/libnova_core.a)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "the install has no ${f}")
  endif()
endforeach()
# Every public header at its room's path; the I/O rooms' only where nova_io was built.
include(${SOURCE_DIR}/cmake/layers.cmake)
set(rooms ${NOVA_CORE_ROOMS})
if(EXISTS ${prefix}/lib/libnova_io.a)
  list(APPEND rooms ${NOVA_IO_ROOMS})
else()
  foreach(room IN LISTS NOVA_IO_ROOMS)
    if(EXISTS ${prefix}/include/nova/${room})
      message(FATAL_ERROR "the install has include/nova/${room} (an I/O room) without libnova_io.a")
    endif()
  endforeach()
endif()
foreach(room IN LISTS rooms)
  file(GLOB headers RELATIVE ${SOURCE_DIR}/include ${SOURCE_DIR}/include/nova/${room}/*.hpp)
  foreach(f IN LISTS headers)
    if(NOT EXISTS ${prefix}/include/${f})
      message(FATAL_ERROR "the install has no include/${f}")
    endif()
  endforeach()
endforeach()
# JSON is a build-time dependency only: the package and the pkg-config files do not name it.
file(GLOB_RECURSE package_files ${prefix}/lib/cmake/nova/*.cmake ${prefix}/lib/pkgconfig/*.pc)
foreach(f IN LISTS package_files)
  file(READ ${f} text)
  if(text MATCHES "nlohmann")
    message(FATAL_ERROR "${f} names nlohmann-json, which the installed nova must not require")
  endif()
endforeach()

# The dependencies where the build found them (DEP_PREFIXES, '|'-separated; CLBLAST_DIR,
# OPENCL_LIBRARY, OPENCL_INCLUDE_DIR): system paths on Debian, a bundle on a GPU machine. They
# reach the configure below through an initial cache file (-C), which keeps lists whole, as do
# the build's compiler and linker flags (CXX_FLAGS, EXE_LINKER_FLAGS: a sanitised nova needs a
# sanitised program to link it).
string(REPLACE "|" ";" dep_prefixes "${DEP_PREFIXES}")
set(initial "set(CMAKE_PREFIX_PATH \"${prefix};${dep_prefixes}\" CACHE STRING \"\")\n")
# NAME:GIVEN:TYPE: the cache entry NAME of type TYPE, from this script's variable GIVEN.
foreach(v CLBlast_DIR:CLBLAST_DIR:PATH OpenCL_LIBRARY:OPENCL_LIBRARY:PATH
          OpenCL_INCLUDE_DIR:OPENCL_INCLUDE_DIR:PATH CMAKE_CXX_FLAGS:CXX_FLAGS:STRING
          CMAKE_EXE_LINKER_FLAGS:EXE_LINKER_FLAGS:STRING)
  string(REPLACE ":" ";" entry ${v})
  list(GET entry 0 name)
  list(GET entry 1 given)
  list(GET entry 2 type)
  if(NOT "${${given}}" STREQUAL "")
    string(APPEND initial "set(${name} \"${${given}}\" CACHE ${type} \"\")\n")
  endif()
endforeach()
file(WRITE ${WORK_DIR}/dependencies.cmake "${initial}")
step("configure examples against the prefix" ${CMAKE_COMMAND} -C ${WORK_DIR}/dependencies.cmake
     -S ${SOURCE_DIR}/examples -B ${WORK_DIR}/examples -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_BUILD_TYPE=Release)
step("build examples" ${CMAKE_COMMAND} --build ${WORK_DIR}/examples)
step("run embed_core (CMake package)" ${WORK_DIR}/examples/embed_core)

find_program(PKG_CONFIG pkg-config)
if(NOT PKG_CONFIG)
  message(STATUS "no pkg-config on this machine: the pkg-config build is left out")
  return()
endif()
set(pc_path ${prefix}/lib/pkgconfig)
foreach(d IN LISTS dep_prefixes)
  string(APPEND pc_path ":${d}/lib/x86_64-linux-gnu/pkgconfig:${d}/lib/pkgconfig:${d}/share/pkgconfig")
endforeach()
set(ENV{PKG_CONFIG_PATH} ${pc_path})
execute_process(COMMAND ${PKG_CONFIG} --cflags --libs nova RESULT_VARIABLE rc OUTPUT_VARIABLE flags
                ERROR_VARIABLE err OUTPUT_STRIP_TRAILING_WHITESPACE)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "pkg-config nova failed: ${err}")
endif()
separate_arguments(flags UNIX_COMMAND "${flags}")
# Libraries outside the loader's own paths (a bundle's) are found at run time through an RPATH.
foreach(f IN LISTS flags)
  if(f MATCHES "^-L(.+)$")
    set(dir "${CMAKE_MATCH_1}")
    if(NOT dir MATCHES "^/usr/lib")
      list(APPEND flags "-Wl,-rpath,${dir}")
    endif()
  endif()
endforeach()
separate_arguments(build_flags UNIX_COMMAND "${CXX_FLAGS} ${EXE_LINKER_FLAGS}")
step("compile embed_core with pkg-config" ${CXX} -std=c++20 -O2 ${build_flags} ${SOURCE_DIR}/examples/embed_core.cpp
     ${flags} -o ${WORK_DIR}/embed_core_pc)
step("run embed_core (pkg-config)" ${WORK_DIR}/embed_core_pc)
