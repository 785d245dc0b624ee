# cmake -DSRC=<clients/python/study> -DDST=<build/python/coopdyn/study> -DREPO=<source tree> -P copy.cmake
# Copies the study package beside the bindings and records the source's commit (with -dirty when the
# tree has changes) in _commit.py, for the header of every result file. Run on every build.
file(GLOB sources ${SRC}/*.py)
file(MAKE_DIRECTORY ${DST})
file(COPY ${sources} DESTINATION ${DST})
execute_process(COMMAND git -C ${REPO} rev-parse HEAD OUTPUT_VARIABLE commit OUTPUT_STRIP_TRAILING_WHITESPACE
                RESULT_VARIABLE rc ERROR_QUIET)
if(NOT rc EQUAL 0)
  set(commit "unknown")
else()
  execute_process(COMMAND git -C ${REPO} diff --quiet HEAD RESULT_VARIABLE dirty ERROR_QUIET)
  if(NOT dirty EQUAL 0)
    string(APPEND commit "-dirty")
  endif()
endif()
set(text "COMMIT = \"${commit}\"\n")
if(EXISTS ${DST}/_commit.py)
  file(READ ${DST}/_commit.py old)
endif()
if(NOT old STREQUAL text)
  file(WRITE ${DST}/_commit.py "${text}")
endif()
