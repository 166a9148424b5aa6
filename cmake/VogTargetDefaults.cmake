# Language standard, warnings and sanitizers for every target of the project, in one place.
# Warnings are PRIVATE: a consumer never inherits our warning policy.

if(VOG_SANITIZER STREQUAL "address")
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=address,undefined)
  # Eigen turns off its use of malloc's 16-byte alignment under __SANITIZE_ADDRESS__ and allocates
  # with its own aligned malloc, whose blocks plain free() cannot release. Ceres (not sanitized) was
  # built with malloc's alignment, and both copies of Eigen's inline allocation functions end up in
  # one binary: keep ours as Ceres' (ASan's malloc is 16-byte aligned; Eigen asserts it).
  add_compile_definitions(EIGEN_MALLOC_ALREADY_ALIGNED=1)
elseif(VOG_SANITIZER STREQUAL "thread")
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
elseif(NOT VOG_SANITIZER STREQUAL "")
  message(FATAL_ERROR "VOG_SANITIZER: '${VOG_SANITIZER}' is not address, thread or empty")
endif()

function(vog_target_defaults target)
  target_compile_features(${target} PUBLIC cxx_std_20)
  set_target_properties(${target} PROPERTIES CXX_EXTENSIONS OFF POSITION_INDEPENDENT_CODE ON)
  if(VOG_UNITY_BUILD)
    set_target_properties(${target} PROPERTIES UNITY_BUILD ON)
  endif()
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
    -Wunused -Woverloaded-virtual -Wnull-dereference -Wdouble-promotion -Wformat=2
    -Wimplicit-fallthrough)
  if(VOG_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# A library of the project: sources given, headers under include/.
function(vog_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_link_libraries(${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  vog_target_defaults(${name})
endfunction()

# A header-only library of the project: headers under include/, no sources.
function(vog_add_header_library name)
  cmake_parse_arguments(ARG "" "" "DEPS" ${ARGN})
  add_library(${name} INTERFACE)
  target_include_directories(${name} INTERFACE ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_compile_features(${name} INTERFACE cxx_std_20)
  target_link_libraries(${name} INTERFACE ${ARG_DEPS})
endfunction()
