# The rooms of nova, one per stage of the data path, in layer order: a file may include headers
# of its own room and of the rooms before it. Each room is a folder under host/ (sources and
# private headers) with the same path under include/nova/ (its public headers), so a file's
# room is its folder; tests/include_layers.cmake checks every include against this order.
#
# nova_core, which links OpenCL and CLBlast only: from the device runtime up to training.
set(NOVA_CORE_ROOMS runtime tuning graph ops/tensor ops/linalg ops/encoding sampling render loss
                    model train)
# nova_io (OpenCV), after the core so that the core can include none of it. metrics (plain C++
# scores) comes before io because pictures are quantised as the metrics assume.
set(NOVA_IO_ROOMS metrics io data masks eval)
# The nova CLI: commands, no public headers.
set(NOVA_CLI_ROOMS cli)
set(NOVA_ROOMS ${NOVA_CORE_ROOMS} ${NOVA_IO_ROOMS} ${NOVA_CLI_ROOMS})

# The .cpp files of `rooms` under `root`, into `out`.
function(nova_room_sources out root)
  set(globs "")
  foreach(room IN LISTS ARGN)
    list(APPEND globs ${root}/${room}/*.cpp)
  endforeach()
  file(GLOB sources CONFIGURE_DEPENDS ${globs})
  set(${out} ${sources} PARENT_SCOPE)
endfunction()
