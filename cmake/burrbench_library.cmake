# One library per top-level folder: sources are every .cpp under <folder>/src, public
# headers live under <folder>/include/burrbench/<folder>/. Globbing (re-checked at
# build time) lets a new source file join its library without editing this file.
function(burrbench_add_library folder)
  cmake_parse_arguments(ARG "" "" "PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  file(GLOB_RECURSE _sources CONFIGURE_DEPENDS "${CMAKE_CURRENT_SOURCE_DIR}/src/*.cpp")
  set(_target burrbench_${folder})
  if(_sources)
    add_library(${_target} STATIC ${_sources})
    target_include_directories(${_target} PUBLIC "${CMAKE_CURRENT_SOURCE_DIR}/include"
                                          PRIVATE "${CMAKE_CURRENT_SOURCE_DIR}/src")
    target_link_libraries(${_target} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
    target_compile_options(${_target} PRIVATE ${BURRBENCH_WARNINGS})
    set_target_properties(${_target} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  else()
    add_library(${_target} INTERFACE)
    target_include_directories(${_target} INTERFACE "${CMAKE_CURRENT_SOURCE_DIR}/include")
    target_link_libraries(${_target} INTERFACE ${ARG_PUBLIC_DEPS})
  endif()
  add_library(burrbench::${folder} ALIAS ${_target})
endfunction()
