# The compiled bindings coopdyn._core (clients/python/module) under pytest (Debian python3-pytest,
# python3-numpy), one ctest per file, labelled python and bindings. Not registered when the module is
# not built (COOPDYN_SANITIZE, or pybind11 missing: clients/python/CMakeLists.txt says which).
if(NOT COOPDYN_PYTHON_MODULE)
  return()
endif()
execute_process(COMMAND ${COOPDYN_PYTHON3} -c "import pytest, numpy" RESULT_VARIABLE pytest_rc OUTPUT_QUIET ERROR_QUIET)
if(NOT pytest_rc EQUAL 0)
  message(WARNING "pytest or numpy not found for ${COOPDYN_PYTHON3} (Debian: python3-pytest python3-numpy): "
                  "the tests of the Python bindings are not run")
  return()
endif()
set(bindings_env PYTHONPATH=${COOPDYN_PYTHON_DIR} COOPDYN_SOURCE_DIR=${PROJECT_SOURCE_DIR}
    COOPDYN=$<TARGET_FILE:coopdyn>
    COOPDYND=$<TARGET_FILE:coopdynd>)
foreach(t evaluate inputs batch simulate kinematics client)
  add_test(NAME python.bindings.${t}
           COMMAND ${COOPDYN_PYTHON3} -B -m pytest -q -p no:cacheprovider ${CMAKE_CURRENT_LIST_DIR}/test_${t}.py)
  set_tests_properties(python.bindings.${t} PROPERTIES ENVIRONMENT "${bindings_env}" LABELS "python;bindings"
                       TIMEOUT 120)
endforeach()
# the Client against coopdynd over udpm on loopback (private ports, ttl=0)
set_tests_properties(python.bindings.client PROPERTIES LABELS "python;bindings;daemon")
# coopdyn.study on Dask (Debian python3-dask python3-distributed python3-yaml): LocalClusters of 2 workers
execute_process(COMMAND ${COOPDYN_PYTHON3} -c "import distributed, yaml" RESULT_VARIABLE dask_rc
                OUTPUT_QUIET ERROR_QUIET)
if(dask_rc EQUAL 0)
  add_test(NAME python.study COMMAND ${COOPDYN_PYTHON3} -B -m pytest -q -p no:cacheprovider
                                     ${CMAKE_CURRENT_LIST_DIR}/test_study.py)
  set_tests_properties(python.study PROPERTIES ENVIRONMENT "${bindings_env}" LABELS "python;study" TIMEOUT 300)
else()
  message(STATUS "coopdyn: python3-distributed or python3-yaml missing: the study tests are not run")
endif()
