# `coopdyn send`, `log`, `control`, `track` and `view --log`, `view --live`: LCM clients linked into the
# coopdyn command. Included at the end of clients/CMakeLists.txt.
target_sources(coopdyn PRIVATE ${CMAKE_CURRENT_LIST_DIR}/send.cc ${CMAKE_CURRENT_LIST_DIR}/log.cc
                               ${CMAKE_CURRENT_LIST_DIR}/control.cc ${CMAKE_CURRENT_LIST_DIR}/track.cc
                               ${CMAKE_CURRENT_LIST_DIR}/lcm_log.cc ${CMAKE_CURRENT_LIST_DIR}/view_log.cc)
target_link_libraries(coopdyn PRIVATE coopdyn_io)
# coopdyn log's plotter (clients/log_plot.py), compiled in as a raw string
add_custom_command(
  OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/log_plot.inc
  COMMAND ${CMAKE_COMMAND} -DIN=${CMAKE_CURRENT_LIST_DIR}/log_plot.py
          -DOUT=${CMAKE_CURRENT_BINARY_DIR}/log_plot.inc -P ${CMAKE_CURRENT_LIST_DIR}/embed_text.cmake
  DEPENDS ${CMAKE_CURRENT_LIST_DIR}/log_plot.py ${CMAKE_CURRENT_LIST_DIR}/embed_text.cmake
  COMMENT "Embedding log_plot.py")
target_sources(coopdyn PRIVATE ${CMAKE_CURRENT_BINARY_DIR}/log_plot.inc)

# coopdyn view --live serves its page and a WebSocket with websocketpp (Debian libwebsocketpp-dev,
# header-only) on standalone asio (libasio-dev); without them --live says what to install.
find_package(websocketpp CONFIG QUIET)
find_path(COOPDYN_ASIO_INCLUDE_DIR asio.hpp)
if(websocketpp_FOUND AND COOPDYN_ASIO_INCLUDE_DIR)
  target_sources(coopdyn PRIVATE ${CMAKE_CURRENT_LIST_DIR}/view_live.cc)
  target_include_directories(coopdyn SYSTEM PRIVATE ${WEBSOCKETPP_INCLUDE_DIR} ${COOPDYN_ASIO_INCLUDE_DIR})
  set(COOPDYN_VIEW_LIVE ON CACHE INTERNAL "coopdyn view --live is built")
else()
  message(WARNING "websocketpp or standalone asio not found (Debian: libwebsocketpp-dev libasio-dev): coopdyn view --live is not built")
  target_sources(coopdyn PRIVATE ${CMAKE_CURRENT_LIST_DIR}/view_live_missing.cc)
  set(COOPDYN_VIEW_LIVE OFF CACHE INTERNAL "coopdyn view --live is built")
endif()
