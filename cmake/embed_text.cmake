# cmake -DIN=FILE -DOUT=FILE.inc -P embed_text.cmake: FILE as a C++ raw string literal (for #include).
file(READ "${IN}" text)
string(FIND "${text}" ")coopdyn_embed\"" bad)
if(NOT bad EQUAL -1)
  message(FATAL_ERROR "${IN} contains the raw-string delimiter")
endif()
file(WRITE "${OUT}.tmp" "R\"coopdyn_embed(${text})coopdyn_embed\"\n")
execute_process(COMMAND ${CMAKE_COMMAND} -E copy_if_different "${OUT}.tmp" "${OUT}")
file(REMOVE "${OUT}.tmp")
