// Paths of this build for the tests and benchmarks (defined in build/generated/coopdyn_paths.cc,
// made by cmake/test_paths.cmake). Sources use them through the macros coopdyn_use_paths() defines:
// COOPDYN_SOURCE_DIR, COOPDYN_PATH, COOPDYND_PATH, COOPDYN_LCM_JAR, COOPDYN_TYPES_JAR.
#pragma once
namespace coopdyn_paths {
extern const char* const source_dir;  // the source tree (config/, tests/, ...)
extern const char* const coopdyn;     // the coopdyn program
extern const char* const coopdynd;    // the coopdynd program
extern const char* const lcm_jar;     // lcm.jar (Debian liblcm-java)
extern const char* const types_jar;   // coopdyn_types.jar of this build (made when a JDK is present)
}  // namespace coopdyn_paths
