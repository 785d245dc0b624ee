# coopdynd tests: the loop (tick by tick through an in-memory bus), no allocation in the loop,
# real LCM round trips (memq://, and udpm:// against build/bin/coopdynd as a child process),
# lcm-logger + coopdyn log, a flood of junk against build/bin/coopdynd. Included at the end of
# tests/CMakeLists.txt.
coopdyn_test(coopdynd_tests
  FILES
    io/transport/lcm_wire_test.cc
    io/transport/input_gate_test.cc
    io/transport/rx_in_loop_test.cc
    io/codec/direct_decoder_test.cc
    io/transport/lcm_bus_test.cc
    io/codec/convert_test.cc
    io/transport/multicast_route_test.cc
    runtime/service_loop_test.cc
    runtime/triple_buffer_test.cc
    runtime/publisher_thread_test.cc
    runtime/histogram_test.cc
    runtime/service_loop_no_allocation_test.cc
    runtime/estimate_friction_loop_test.cc
    runtime/config_test.cc
    runtime/fifo_guard_test.cc
    runtime/vehicle_command_test.cc
    daemon/lcm_daemon_test.cc
    daemon/estimate_friction_test.cc
    daemon/flood_daemon_test.cc
    daemon/netns_test.cc
    daemon/auth_daemon_test.cc
    daemon/signals_daemon_test.cc
    daemon/sched_fifo_daemon_test.cc
    dynamics/vehicle_test.cc
    clients/cli/sim_test.cc
    clients/csv/step_csv_test.cc
  LIBS coopdyn_runtime coopdyn_scene coopdyn_step_csv
  DEPENDS coopdynd coopdyn
  PROPERTIES LABELS daemon)

# output_t's one field list: every older layout through the upgrader, messages.md's table (its own
# executable, with the generated types: it writes old layouts)
coopdyn_test(coopdyn_output_fields_tests FILES io/codec/output_fields_test.cc LIBS coopdyn_io coopdyn_scene coopdyn_lcmtypes)
# The safe torque through the loop: a held subset, brought to rest; joint limits checked by the loop and
# published over memq:// (its own executable: small to build)
coopdyn_test(coopdyn_safe_torque_tests FILES runtime/safe_torque_test.cc dynamics/joint_limits_test.cc
  daemon/limits_wire_test.cc
  LIBS coopdyn_runtime coopdyn_scene
  PROPERTIES LABELS daemon)

# Seeded mutation fuzzing of the decoders and the scene and config loaders (tests/fuzz/fuzz_test.cc),
# a bounded number of inputs per target; the seed corpus is tests/fuzz/corpus.
coopdyn_test(coopdyn_fuzz_tests NO_MAIN
  FILES fuzz/fuzz_test.cc
  LIBS coopdyn_runtime coopdyn_scene
  PROPERTIES LABELS fuzz TIMEOUT 300)

# The command lines of coopdyn and coopdynd, run as processes (tests/clients/cli/cli_test.cc), and
# coopdyn spy (tests/clients/cli/spy_test.cc: the java command, and lcm-spy itself where a JDK and
# the jars are installed).
coopdyn_test(coopdyn_cli_tests
  FILES clients/cli/cli_test.cc clients/cli/spy_test.cc
  LIBS coopdyn_io yaml-cpp
  DEPENDS coopdynd coopdyn
  PROPERTIES LABELS cli)
target_compile_definitions(coopdyn_cli_tests PRIVATE COOPDYN_PROJECT_VERSION="${PROJECT_VERSION}")
