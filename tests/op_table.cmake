# The op table (op_table.hpp) as a library without Boost: each entry's builder, input values,
# shapes, float64 references and FLOP count. nova_tests checks it (with Boost.Test) and
# nova-bench times it (`nova-bench ops`), so either one builds it.
add_library(nova_op_table STATIC
            ${CMAKE_CURRENT_LIST_DIR}/op_table.cpp ${CMAKE_CURRENT_LIST_DIR}/op_table_core.cpp
            ${CMAKE_CURRENT_LIST_DIR}/op_table_losses.cpp ${CMAKE_CURRENT_LIST_DIR}/op_table_ray_losses.cpp
            ${CMAKE_CURRENT_LIST_DIR}/op_table_render.cpp ${CMAKE_CURRENT_LIST_DIR}/op_table_grid.cpp
            ${CMAKE_CURRENT_LIST_DIR}/op_table_ranks.cpp ${CMAKE_CURRENT_LIST_DIR}/op_table_motion.cpp
            ${CMAKE_CURRENT_LIST_DIR}/harness_values.cpp)
target_include_directories(nova_op_table PUBLIC ${CMAKE_CURRENT_LIST_DIR} PRIVATE ${PROJECT_SOURCE_DIR}/host)
target_link_libraries(nova_op_table PUBLIC nova_core)
