# The include graph follows the order of the rooms (cmake/layers.cmake, docs/architecture.md,
# "Layers"):
#
#   runtime < tuning < graph < ops/tensor < ops/linalg < ops/encoding < sampling < render < loss
#   < model < train < metrics < io < data < masks < eval < cli
#
# A file's room is its folder: host/<room>/x.cpp and host/<room>/x.hpp (private headers) and
# include/nova/<room>/x.hpp (public headers) all belong to <room>, and an include names its
# room the same way ("nova/<room>/x.hpp" or "<room>/x.hpp"). A file may include headers of its
# own room and of the rooms before it. runtime to train is the core (nova_core); metrics to
# eval are the I/O rooms (nova_io, OpenCV), after the core so that it can include none of them.
#
# Checked besides: every folder of host/ and include/nova/ that holds a file is a room, every
# public room has its sources beside it (host/<room>/), and every include of a header of nova's
# own is written from the root (so that the room it names is the one it includes).
#
# cmake -DSOURCE_DIR=<repository> -P include_layers.cmake
cmake_minimum_required(VERSION 3.20)
include(${SOURCE_DIR}/cmake/layers.cmake)
set(core ${NOVA_CORE_ROOMS})
set(io_rooms ${NOVA_IO_ROOMS})
set(layers ${NOVA_ROOMS})

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

file(GLOB_RECURSE headers RELATIVE ${SOURCE_DIR} ${SOURCE_DIR}/include/nova/*)
file(GLOB_RECURSE sources RELATIVE ${SOURCE_DIR} ${SOURCE_DIR}/host/*)
set(violations "")
foreach(file IN LISTS headers sources)
  string(REGEX REPLACE "^(include/nova|host)/(.*)/[^/]+$" "\\2" room "${file}")
  if(room STREQUAL file)
    string(APPEND violations "\n  ${file} is in no room: put it in the folder of its stage")
    continue()
  endif()
  list(FIND layers ${room} rank)
  if(rank LESS 0)
    string(REPLACE ";" ", " known "${layers}")
    string(APPEND violations "\n  ${file}: '${room}' is no room (${known}): add it to cmake/layers.cmake in its place")
    continue()
  endif()
  if(file MATCHES "^include/" AND NOT IS_DIRECTORY ${SOURCE_DIR}/host/${room})
    string(APPEND violations "\n  ${file}: room ${room} has public headers but no host/${room}/ beside them")
  endif()
  if(NOT file MATCHES "\\.(cpp|hpp)$")
    continue()
  endif()
  file(STRINGS ${SOURCE_DIR}/${file} includes REGEX "^[ \t]*#[ \t]*include[ \t]*\"[^\"]+\\.hpp\"")
  foreach(line IN LISTS includes)
    string(REGEX MATCH "\"([^\"]+)\\.hpp\"" header "${line}")
    set(path ${CMAKE_MATCH_1})
    if(NOT path MATCHES "/")
      if(EXISTS ${SOURCE_DIR}/host/${room}/${path}.hpp)
        line_of("${file}" "${line}" n)
        string(APPEND violations "\n  ${file}:${n}: includes ${header} by its bare name: write \"${room}/${path}.hpp\"")
      endif()
      continue()
    endif()
    string(REGEX REPLACE "^nova/" "" path "${path}")
    string(REGEX REPLACE "/[^/]+$" "" used "${path}")
    list(FIND layers ${used} used_rank)
    if(used_rank LESS 0)
      if(header MATCHES "^\"nova/")
        line_of("${file}" "${line}" n)
        string(APPEND violations "\n  ${file}:${n}: includes ${header}, which is in no room")
      endif()
      continue()
    endif()
    if(used_rank GREATER rank)
      line_of("${file}" "${line}" n)
      set(why "a later room")
      if(room IN_LIST core AND used IN_LIST io_rooms)
        set(why "an I/O room, which the core may not use")
      endif()
      string(APPEND violations "\n  ${file}:${n}: ${room} includes ${header} of ${used}, ${why}")
    endif()
  endforeach()
endforeach()

if(violations)
  string(REPLACE ";" " < " order "${layers}")
  message(FATAL_ERROR "the include graph breaks the order of the rooms ${order}:${violations}")
endif()
