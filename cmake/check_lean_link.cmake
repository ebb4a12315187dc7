# cmake -DBINARY=<executable> -P check_lean_link.cmake
# Fails unless BINARY (built from nova_core alone) needs only OpenCL, CLBlast and the C/C++
# runtime: its direct NEEDED entries (readelf -d) must all be on the list below, and nothing
# it loads transitively (ldd) may be OpenCV, Boost or a BLAS other than CLBlast.
if(NOT BINARY OR NOT EXISTS "${BINARY}")
  message(FATAL_ERROR "check_lean_link: BINARY '${BINARY}' does not exist")
endif()

find_program(READELF readelf)
if(NOT READELF)
  message(FATAL_ERROR "check_lean_link: readelf not found (binutils)")
endif()
execute_process(COMMAND ${READELF} -d "${BINARY}" OUTPUT_VARIABLE dynamic RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "check_lean_link: readelf -d ${BINARY} failed (${rc})")
endif()
string(REGEX MATCHALL "Shared library: \\[[^]]+\\]" needed "${dynamic}")
# The sanitizers' runtimes (a -fsanitize build) count as the C++ runtime.
set(allowed "^(libOpenCL|libclblast|libstdc\\+\\+|libm|libgcc_s|libc|libpthread|libdl|lib[atl]san|libubsan|ld-linux[-a-z0-9_.]*)\\.so")
set(names "")
set(bad "")
foreach(entry IN LISTS needed)
  string(REGEX REPLACE "Shared library: \\[([^]]+)\\]" "\\1" lib "${entry}")
  list(APPEND names ${lib})
  if(NOT lib MATCHES "${allowed}")
    list(APPEND bad ${lib})
  endif()
endforeach()
message(STATUS "NEEDED: ${names}")
if(NOT names MATCHES "libOpenCL" OR NOT names MATCHES "libclblast")
  message(FATAL_ERROR "check_lean_link: expected libOpenCL and libclblast among NEEDED of "
                      "${BINARY}, found: ${names}")
endif()
if(bad)
  message(FATAL_ERROR "check_lean_link: ${BINARY} (nova_core alone) needs ${bad}; the core "
                      "may link only OpenCL, CLBlast and the C++ runtime")
endif()

# Transitive: what the dynamic loader would actually load.
find_program(LDD ldd)
if(LDD)
  execute_process(COMMAND ${LDD} "${BINARY}" OUTPUT_VARIABLE loaded RESULT_VARIABLE rc)
  string(REGEX MATCHALL "lib(opencv|boost|openblas|blas|gfortran)[^ \t\n]*" heavy "${loaded}")
  if(heavy)
    message(FATAL_ERROR "check_lean_link: ${BINARY} loads ${heavy} transitively:\n${loaded}")
  endif()
  message(STATUS "ldd:\n${loaded}")
endif()
