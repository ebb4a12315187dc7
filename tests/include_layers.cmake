# The include graph follows the module layering (docs/architecture.md, "Layers"):
#
#   runtime < tuning < graph < ops < nerf < train < metrics < io < data < masks < render < cli
#
# A file may include headers of its own module and of the modules before it. runtime to train
# is the core (nova_core); metrics, io, data and render are the I/O modules (nova_io, OpenCV),
# after the core so that it can include none of them. metrics (plain C++ scores) comes before
# io because pictures are quantised as the metrics assume (visualize.cpp). tuning (the kernel
# parameter database) comes right after runtime: the ops ask it for their defines, and it needs
# nothing but the runtime (the GEMM search runs candidates through functions the GEMM op hands in).
#
# A header nova/X.hpp or nova/io/X.hpp belongs to the module whose host/ folder holds X.cpp,
# or, where no module has one (its code is split over several files, or it is plain data), to
# the module the table below names. A private header module/x.hpp belongs to `module`.
# Headers in include/nova/ are checked as files of their own module. host/cli has no public
# headers: its X.cpp are commands, not implementations.
#
# The public headers are split by library: include/nova/io/ holds exactly the headers of the
# I/O modules (the install puts them in include/nova/io/ too), include/nova/ those of the
# core, and a core file that includes "nova/io/..." fails whatever its owner.
#
# cmake -DSOURCE_DIR=<repository> -P include_layers.cmake
cmake_minimum_required(VERSION 3.20)
set(core runtime tuning graph ops nerf train)
set(io_modules metrics io data masks render)
set(layers ${core} ${io_modules} cli)

set(owner_camera ops)              # plain data: the camera rays.hpp generates rays of
set(owner_checkpoint nerf)         # checkpoint_file.cpp: a trained model on disk
set(owner_distributed ops)         # interfaces only: data-parallel training (rank_sum.cpp reads it)
set(owner_hash_grid ops)           # hash_encoding.cpp
set(owner_kernel_sources runtime)  # generated at build time
set(owner_losses ops)              # one op per *_loss*.cpp
set(owner_motion ops)              # rigid_motion.cpp
set(owner_occupancy ops)           # packing.cpp (the grid type: nerf/occupancy_grid.cpp)
set(owner_ops ops)                 # one op per file
set(owner_optim train)             # adam.cpp
set(owner_progress_line train)     # inline: formats a TrainProgress
set(owner_render ops)              # render_composite.cpp, stack.cpp
set(owner_scene nerf)              # plain data: what a model is trained and rendered from
set(owner_synth data)              # synth_*.cpp

function(owner_of header out)
  if(DEFINED owner_${header})
    set(${out} ${owner_${header}} PARENT_SCOPE)
    return()
  endif()
  file(GLOB impl RELATIVE ${SOURCE_DIR}/host ${SOURCE_DIR}/host/*/${header}.cpp)
  list(FILTER impl EXCLUDE REGEX "^cli/")
  list(LENGTH impl n)
  if(NOT n EQUAL 1)
    message(FATAL_ERROR "nova/${header}.hpp: ${n} host/*/${header}.cpp (${impl}); "
                        "name its module in the table of ${CMAKE_CURRENT_LIST_FILE}")
  endif()
  string(REGEX REPLACE "/.*" "" module "${impl}")
  set(${out} ${module} PARENT_SCOPE)
endfunction()

# The number of the line `line` of `file`, for the messages only.
function(line_of file line out)
  file(READ ${SOURCE_DIR}/${file} text)
  string(FIND "${text}" "${line}" at)
  string(SUBSTRING "${text}" 0 ${at} before)
  string(REGEX MATCHALL "\n" newlines "${before}")
  list(LENGTH newlines n)
  math(EXPR n "${n} + 1")
  set(${out} ${n} PARENT_SCOPE)
endfunction()

file(GLOB headers RELATIVE ${SOURCE_DIR} ${SOURCE_DIR}/include/nova/*.hpp ${SOURCE_DIR}/include/nova/io/*.hpp)
file(GLOB sources RELATIVE ${SOURCE_DIR} ${SOURCE_DIR}/host/*/*.cpp ${SOURCE_DIR}/host/*/*.hpp)
set(violations "")
foreach(file IN LISTS headers sources)
  if(file MATCHES "^include/nova/(io/)?(.*)\\.hpp$")
    owner_of(${CMAKE_MATCH_2} module)
  else()
    string(REGEX REPLACE "^host/([a-z]+)/.*" "\\1" module "${file}")
  endif()
  list(FIND layers ${module} rank)
  if(rank LESS 0)
    message(FATAL_ERROR "${file}: module '${module}' has no place in the layering: add it to `layers`")
  endif()
  file(STRINGS ${SOURCE_DIR}/${file} includes
       REGEX "^[ \t]*#[ \t]*include[ \t]*\"[a-z]+/([a-z]+/)?[a-z0-9_]+\\.hpp\"")
  foreach(line IN LISTS includes)
    string(REGEX MATCH "\"([a-z]+)/(([a-z]+)/)?([a-z0-9_]+)\\.hpp\"" header "${line}")
    if(CMAKE_MATCH_1 STREQUAL "nova" AND CMAKE_MATCH_3 STREQUAL "io" AND module IN_LIST core)
      line_of("${file}" "${line}" n)
      string(APPEND violations "\n  ${file}:${n}: ${module} includes ${header}, an I/O header, which the core may not use")
      continue()
    elseif(CMAKE_MATCH_1 STREQUAL "nova")
      owner_of(${CMAKE_MATCH_4} used)
    elseif(CMAKE_MATCH_1 IN_LIST layers)
      set(used ${CMAKE_MATCH_1})
    else()
      continue()
    endif()
    list(FIND layers ${used} used_rank)
    if(used_rank GREATER rank)
      line_of("${file}" "${line}" n)
      set(why "a later layer")
      if(module IN_LIST core AND used IN_LIST io_modules)
        set(why "an I/O module, which the core may not use")
      endif()
      string(APPEND violations "\n  ${file}:${n}: ${module} includes ${header} of ${used}, ${why}")
    endif()
  endforeach()
endforeach()

# include/nova/io/ holds the headers of the I/O modules and nothing else: the install and the
# core-only test build tell I/O headers by that folder.
foreach(file IN LISTS headers)
  string(REGEX MATCH "^include/nova/(io/)?(.*)\\.hpp$" matched "${file}")
  set(header ${CMAKE_MATCH_2})
  set(in_io_folder FALSE)
  if(CMAKE_MATCH_1)
    set(in_io_folder TRUE)
  endif()
  owner_of(${header} module)
  if(module IN_LIST io_modules AND NOT in_io_folder)
    string(APPEND violations "\n  ${file} belongs to ${module}, an I/O module: move it to include/nova/io/")
  elseif(NOT module IN_LIST io_modules AND in_io_folder)
    string(APPEND violations "\n  ${file} belongs to ${module}, a core module: move it to include/nova/")
  endif()
endforeach()

if(violations)
  string(REPLACE ";" " < " order "${layers}")
  message(FATAL_ERROR "the include graph breaks the layering ${order}:${violations}")
endif()
