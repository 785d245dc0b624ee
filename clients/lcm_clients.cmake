# `coopdyn send`, `log`, `control`, `track` and `view --log`: LCM clients linked into the coopdyn command.
# Included at the end of clients/CMakeLists.txt.
target_sources(coopdyn PRIVATE ${CMAKE_CURRENT_LIST_DIR}/send.cc ${CMAKE_CURRENT_LIST_DIR}/log.cc
                               ${CMAKE_CURRENT_LIST_DIR}/control.cc ${CMAKE_CURRENT_LIST_DIR}/track.cc
                               ${CMAKE_CURRENT_LIST_DIR}/lcm_log.cc ${CMAKE_CURRENT_LIST_DIR}/view_log.cc
                               ${CMAKE_CURRENT_LIST_DIR}/view_live.cc)
target_link_libraries(coopdyn PRIVATE coopdyn_io)
