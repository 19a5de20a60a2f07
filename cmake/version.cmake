# The software version (git describe) is written at build time, so every output file
# records the commit it was made with, even when CMake is not re-run.
set(BURRBENCH_VERSION_CPP "${CMAKE_BINARY_DIR}/generated/burrbench_version.cpp")
add_custom_target(burrbench_version_file
  COMMAND ${CMAKE_COMMAND} -DSRC=${CMAKE_SOURCE_DIR} -DOUT=${BURRBENCH_VERSION_CPP}
          -P ${CMAKE_SOURCE_DIR}/cmake/write_version.cmake
  BYPRODUCTS ${BURRBENCH_VERSION_CPP}
  COMMENT "" VERBATIM)
