# cmake --install build --prefix P:
#   P/bin/coopdyn, P/bin/coopdynd
#   P/lib/libcoopdyn_*.a                       the libraries the service is built from
#   P/include/coopdyn/service/...              public headers (and service/version.h); use -I P/include/coopdyn
#   P/include/coopdyn/clients/cooperative_controller.h
#   P/include/coopdyn/coopdyn/*.hpp            the generated C++ LCM types
#   P/share/coopdyn/                           coopdynd.yaml, scenes/, robots/ (and java/coopdyn_types.jar if built)
#   P/share/coopdyn/examples/python/           log_wrenches.py, live_client.py
#   P/lib/pythonX.Y/site-packages/coopdyn/     the Python package: generated types and lcmlog (lcmtypes/, clients/python/)
#   P/lib/cmake/coopdyn/                       find_package(coopdyn CONFIG): coopdyn::coopdyn and its parts
#   P/lib/pkgconfig/coopdyn.pc                 pkg-config --cflags --libs coopdyn
# Included from the top-level CMakeLists.txt after the targets are defined.
include(CMakePackageConfigHelpers)

set(COOPDYN_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/coopdyn)

# coopdyn::coopdyn: everything (the parts are exported too: coopdyn::core, coopdyn::scene, ...)
add_library(coopdyn_all INTERFACE)
target_link_libraries(coopdyn_all INTERFACE coopdyn_scene coopdyn_control coopdyn_runtime coopdyn_io)
set_target_properties(coopdyn_all PROPERTIES EXPORT_NAME coopdyn)
foreach(part core text scene control io runtime lcmtypes)
  set_target_properties(coopdyn_${part} PROPERTIES EXPORT_NAME ${part})
endforeach()

install(TARGETS coopdyn coopdynd RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS coopdyn_core coopdyn_text coopdyn_scene coopdyn_control coopdyn_io coopdyn_runtime coopdyn_lcmtypes
                coopdyn_all
        EXPORT coopdynTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

# headers keep their "service/x/y.h" paths
install(DIRECTORY ${PROJECT_SOURCE_DIR}/service/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/coopdyn/service
        FILES_MATCHING PATTERN "*.h" PATTERN "*.def" PATTERN daemon EXCLUDE)
install(FILES ${PROJECT_BINARY_DIR}/generated/service/version.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/coopdyn/service)
install(FILES ${PROJECT_SOURCE_DIR}/clients/control/cooperative_controller.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/coopdyn/clients)

# the default config, the scenes and the robots they name (scenes/ refers to ../robots/)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/config/ DESTINATION ${CMAKE_INSTALL_DATADIR}/coopdyn)

# CMake package
install(EXPORT coopdynTargets NAMESPACE coopdyn:: DESTINATION ${COOPDYN_CMAKE_DIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/coopdynConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/coopdynConfig.cmake
                              INSTALL_DESTINATION ${COOPDYN_CMAKE_DIR}
                              PATH_VARS CMAKE_INSTALL_DATADIR)
# 0.x: a minor release may break the API
write_basic_package_version_file(${PROJECT_BINARY_DIR}/coopdynConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/coopdynConfig.cmake ${PROJECT_BINARY_DIR}/coopdynConfigVersion.cmake
        DESTINATION ${COOPDYN_CMAKE_DIR})

# pkg-config: relocatable (the prefix is found from the .pc file's own directory, so that
# cmake --install --prefix P works whatever CMAKE_INSTALL_PREFIX was at configure time)
set(COOPDYN_PC_DIR ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
file(RELATIVE_PATH COOPDYN_PC_TO_PREFIX /${COOPDYN_PC_DIR} /)
string(REGEX REPLACE "/$" "" COOPDYN_PC_TO_PREFIX "${COOPDYN_PC_TO_PREFIX}")
set(COOPDYN_PC_FLAGS "")
if(COOPDYN_NATIVE AND NOT COOPDYN_SANITIZE)
  set(COOPDYN_PC_FLAGS "-march=native")
endif()
if(COOPDYN_SANITIZE)
  set(COOPDYN_PC_FLAGS "-fsanitize=address,undefined")
endif()
configure_file(${CMAKE_CURRENT_LIST_DIR}/coopdyn.pc.in ${PROJECT_BINARY_DIR}/coopdyn.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/coopdyn.pc DESTINATION ${COOPDYN_PC_DIR})
