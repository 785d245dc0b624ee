# coopdynd and its layers: LCM types, the codec (service/io), the runtime (service/runtime).
# Included at the end of service/CMakeLists.txt.
add_subdirectory(${PROJECT_SOURCE_DIR}/lcmtypes ${CMAKE_BINARY_DIR}/lcmtypes)

# coopdyn_io: the only library that sees generated lcmtypes (privately)
add_library(coopdyn_io
  ${CMAKE_CURRENT_LIST_DIR}/io/transport/auth.cc
  ${CMAKE_CURRENT_LIST_DIR}/io/codec/codec.cc
  ${CMAKE_CURRENT_LIST_DIR}/io/codec/convert.cc
  ${CMAKE_CURRENT_LIST_DIR}/io/codec/direct_decoder.cc
  ${CMAKE_CURRENT_LIST_DIR}/io/transport/input_gate.cc
  ${CMAKE_CURRENT_LIST_DIR}/io/transport/lcm_bus.cc
  ${CMAKE_CURRENT_LIST_DIR}/io/transport/lcm_wire.cc
  ${CMAKE_CURRENT_LIST_DIR}/io/transport/rx_in_loop.cc
  ${CMAKE_CURRENT_LIST_DIR}/io/transport/rx_isolated.cc
  ${CMAKE_CURRENT_LIST_DIR}/io/transport/udpm_socket.cc
  ${CMAKE_CURRENT_LIST_DIR}/io/transport/multicast_route.cc
)
# libsodium: HMAC-SHA256 of authenticated inputs (io/transport/auth.h), allocation-free; its header is in auth.h
pkg_check_modules(SODIUM REQUIRED IMPORTED_TARGET GLOBAL libsodium)
target_link_libraries(coopdyn_io PUBLIC coopdyn_core Threads::Threads PkgConfig::LCM PkgConfig::SODIUM
                                 PRIVATE coopdyn_lcmtypes)
add_dependencies(coopdyn_io coopdyn_lcmtypes_gen)

# coopdyn_runtime: the fixed-rate loop, handoff, statistics, config, real-time options
add_library(coopdyn_runtime
  ${CMAKE_CURRENT_LIST_DIR}/runtime/config.cc
  ${CMAKE_CURRENT_LIST_DIR}/runtime/config_fields.cc
  ${CMAKE_CURRENT_LIST_DIR}/runtime/config_reference.cc
  ${CMAKE_CURRENT_LIST_DIR}/runtime/publisher_thread.cc
  ${CMAKE_CURRENT_LIST_DIR}/runtime/realtime.cc
  ${CMAKE_CURRENT_LIST_DIR}/runtime/service_loop.cc
)
target_link_libraries(coopdyn_runtime PUBLIC coopdyn_io coopdyn_text yaml-cpp Threads::Threads)

add_executable(coopdynd
  ${CMAKE_CURRENT_LIST_DIR}/daemon/main.cc
  ${CMAKE_CURRENT_LIST_DIR}/daemon/options.cc
  ${CMAKE_CURRENT_LIST_DIR}/daemon/receive.cc
  ${CMAKE_CURRENT_LIST_DIR}/daemon/reports.cc
)
target_link_libraries(coopdynd PRIVATE coopdyn_runtime coopdyn_scene spdlog::spdlog CLI11::CLI11)
