# coopdynd tests: the loop (tick by tick through an in-memory bus), no allocation in the loop,
# real LCM round trips (memq://, and udpm:// against build/bin/coopdynd as a child process),
# lcm-logger + coopdyn log, a flood of junk against build/bin/coopdynd. Included at the end of
# tests/CMakeLists.txt.
add_executable(coopdynd_tests
  ${CMAKE_CURRENT_LIST_DIR}/loop_test.cc
  ${CMAKE_CURRENT_LIST_DIR}/loop_no_allocation_test.cc
  ${CMAKE_CURRENT_LIST_DIR}/lcm_daemon_test.cc
  ${CMAKE_CURRENT_LIST_DIR}/daemon_config_test.cc
  ${CMAKE_CURRENT_LIST_DIR}/flood_daemon_test.cc
  ${CMAKE_CURRENT_LIST_DIR}/netns_test.cc
  ${CMAKE_CURRENT_LIST_DIR}/sim_csv_test.cc
  ${CMAKE_CURRENT_LIST_DIR}/vehicle_test.cc
  ${CMAKE_CURRENT_LIST_DIR}/step_csv_test.cc
  ${CMAKE_CURRENT_LIST_DIR}/vehicle_command_test.cc
)
target_link_libraries(coopdynd_tests PRIVATE coopdyn_runtime coopdyn_scene coopdyn_step_csv GTest::gtest GTest::gtest_main)
coopdyn_use_paths(coopdynd_tests)
target_include_directories(coopdynd_tests PRIVATE ${PROJECT_SOURCE_DIR})
add_dependencies(coopdynd_tests coopdynd coopdyn)
gtest_discover_tests(coopdynd_tests DISCOVERY_TIMEOUT 60 PROPERTIES LABELS daemon)

# Seeded mutation fuzzing of the decoders and the scene and config loaders (tests/fuzz/fuzz_test.cc),
# a bounded number of inputs per target; the seed corpus is tests/fuzz/corpus.
add_executable(coopdyn_fuzz_tests ${CMAKE_CURRENT_LIST_DIR}/fuzz/fuzz_test.cc)
target_link_libraries(coopdyn_fuzz_tests PRIVATE coopdyn_runtime coopdyn_scene GTest::gtest)
coopdyn_use_paths(coopdyn_fuzz_tests)
target_include_directories(coopdyn_fuzz_tests PRIVATE ${PROJECT_SOURCE_DIR})
gtest_discover_tests(coopdyn_fuzz_tests DISCOVERY_TIMEOUT 60 PROPERTIES LABELS fuzz TIMEOUT 300)

# The command lines of coopdyn and coopdynd, run as processes (tests/cli_test.cc), and coopdyn spy
# (tests/spy_test.cc: the java command, and lcm-spy itself where a JDK and the jars are installed).
add_executable(coopdyn_cli_tests ${CMAKE_CURRENT_LIST_DIR}/cli_test.cc ${CMAKE_CURRENT_LIST_DIR}/spy_test.cc)
target_link_libraries(coopdyn_cli_tests PRIVATE coopdyn_io yaml-cpp GTest::gtest GTest::gtest_main)
coopdyn_use_paths(coopdyn_cli_tests)
target_compile_definitions(coopdyn_cli_tests PRIVATE COOPDYN_PROJECT_VERSION="${PROJECT_VERSION}")
target_include_directories(coopdyn_cli_tests PRIVATE ${PROJECT_SOURCE_DIR})
add_dependencies(coopdyn_cli_tests coopdynd coopdyn)
gtest_discover_tests(coopdyn_cli_tests DISCOVERY_TIMEOUT 60 PROPERTIES LABELS cli)
