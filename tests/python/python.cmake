# Python: the generated types and the log reader against the C++ codec (tests/python/*_test.py), run
# by the python3 found for lcmtypes/ (Debian's /usr/bin/python3 when present) with no packages beyond
# the standard library. The C++ side is lcm_interop_helper. Included at the end of tests/CMakeLists.txt.
if(NOT COOPDYN_PYTHON3)
  message(WARNING "python3 not found (Debian: python3): the Python tests are not run")
  return()
endif()
add_executable(lcm_interop_helper ${CMAKE_CURRENT_LIST_DIR}/lcm_interop_helper.cc)
target_link_libraries(lcm_interop_helper PRIVATE coopdyn_runtime coopdyn_scene)
target_include_directories(lcm_interop_helper PRIVATE ${PROJECT_SOURCE_DIR})
add_dependencies(lcm_interop_helper coopdyn_lcmtypes_python coopdyn)

set(py_env PYTHONPATH=${COOPDYN_PYTHON_DIR} COOPDYN_SOURCE_DIR=${PROJECT_SOURCE_DIR}
    COOPDYN_INTEROP_HELPER=$<TARGET_FILE:lcm_interop_helper> COOPDYN=$<TARGET_FILE:coopdyn>)
foreach(t python_types lcmlog output_fields)
  add_test(NAME python.${t} COMMAND ${COOPDYN_PYTHON3} -B ${CMAKE_CURRENT_LIST_DIR}/${t}_test.py -v)
  set_tests_properties(python.${t} PROPERTIES ENVIRONMENT "${py_env}" LABELS python TIMEOUT 120)
endforeach()
# the live example against coopdynd over udpm; skipped (exit 77) without the lcm Python module
add_test(NAME python.live_client COMMAND ${COOPDYN_PYTHON3} -B ${CMAKE_CURRENT_LIST_DIR}/live_client_test.py)
set_tests_properties(python.live_client PROPERTIES ENVIRONMENT "${py_env};COOPDYND=$<TARGET_FILE:coopdynd>"
                     SKIP_RETURN_CODE 77 LABELS "python;daemon" TIMEOUT 60)
# the same against the daemon through tests/python/udpm/lcm.py (LCM's udpm format in pure Python), never skipped
add_test(NAME python.live_client_udpm COMMAND ${COOPDYN_PYTHON3} -B ${CMAKE_CURRENT_LIST_DIR}/live_client_test.py
                                              --udpm-stand-in)
set_tests_properties(python.live_client_udpm PROPERTIES ENVIRONMENT "${py_env};COOPDYND=$<TARGET_FILE:coopdynd>"
                     LABELS "python;daemon" TIMEOUT 60)
# authentication on: the example signs with --key-file (applied) and without it is refused (stand-in udpm)
add_test(NAME python.live_client_udpm_auth COMMAND ${COOPDYN_PYTHON3} -B ${CMAKE_CURRENT_LIST_DIR}/live_client_test.py
                                                   --udpm-stand-in --auth)
set_tests_properties(python.live_client_udpm_auth PROPERTIES ENVIRONMENT "${py_env};COOPDYND=$<TARGET_FILE:coopdynd>"
                     LABELS "python;daemon" TIMEOUT 60)
# the plots' +-sigma bands (clients/cli/log_plot.py); skipped (exit 77) without matplotlib
add_test(NAME clients.log_plot COMMAND ${COOPDYN_PYTHON3} -B ${PROJECT_SOURCE_DIR}/tests/clients/cli/log_plot_test.py -v)
set_tests_properties(clients.log_plot PROPERTIES ENVIRONMENT "${py_env}" SKIP_RETURN_CODE 77 LABELS python TIMEOUT 120)
