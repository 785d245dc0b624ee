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
# the live example (coopdyn.Client) against coopdynd over udpm on loopback; --auth: with auth.key_file.
# Reported as skipped (77) where the bindings are not built (COOPDYN_SANITIZE).
set(live_env "${py_env};COOPDYND=$<TARGET_FILE:coopdynd>;COOPDYN_PYTHON_MODULE=${COOPDYN_PYTHON_MODULE}")
foreach(variant live_client live_client_auth)
  set(args "")
  if(variant STREQUAL "live_client_auth")
    set(args --auth)
  endif()
  add_test(NAME python.${variant}
           COMMAND ${COOPDYN_PYTHON3} -B ${CMAKE_CURRENT_LIST_DIR}/live_client_test.py ${args})
  set_tests_properties(python.${variant} PROPERTIES ENVIRONMENT "${live_env}" SKIP_RETURN_CODE 77
                       LABELS "python;daemon" TIMEOUT 120)
endforeach()
# the plots' +-sigma bands (clients/cli/log_plot.py); skipped (exit 77) without matplotlib
add_test(NAME clients.log_plot COMMAND ${COOPDYN_PYTHON3} -B ${PROJECT_SOURCE_DIR}/tests/clients/cli/log_plot_test.py -v)
set_tests_properties(clients.log_plot PROPERTIES ENVIRONMENT "${py_env}" SKIP_RETURN_CODE 77 LABELS python TIMEOUT 120)
