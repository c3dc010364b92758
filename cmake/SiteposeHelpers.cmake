# Shared build rules: one warnings target, one library rule, one test rule.

# Warnings are errors by default (one compiler, Debian 12's GCC): a warning
# fails the build, in CI too. -DSITEPOSE_WERROR=OFF for other compilers.
option(SITEPOSE_WERROR "Treat compiler warnings as errors" ON)
add_library(sitepose_warnings INTERFACE)
target_compile_options(sitepose_warnings INTERFACE
  $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wpedantic $<$<BOOL:${SITEPOSE_WERROR}>:-Werror>>)

# sitepose_add_library(<module> SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
# Defines sitepose_<module> with alias sitepose::<module>; headers live in
# include/sitepose/<module>/.
function(sitepose_add_library module)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  set(target sitepose_${module})
  add_library(${target} STATIC ${ARG_SOURCES})
  add_library(sitepose::${module} ALIAS ${target})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>
    PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  target_link_libraries(${target} PUBLIC ${ARG_PUBLIC_DEPS}
    PRIVATE sitepose_warnings ${ARG_PRIVATE_DEPS})
  set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON)
endfunction()

# Every test executable labelled asan joins the target sitepose_asan_tests,
# which the asan build preset builds (tools/asan.sh); one labelled tsan joins
# sitepose_tsan_tests, which the tsan build preset builds. The label alone
# decides what runs under a sanitizer, so a new such test cannot be left
# unbuilt.
add_custom_target(sitepose_asan_tests)
add_custom_target(sitepose_tsan_tests)
function(sitepose_register_sanitizer_test target labels)
  foreach(sanitizer asan tsan)
    if(sanitizer IN_LIST labels)
      add_dependencies(sitepose_${sanitizer}_tests ${target})
    endif()
  endforeach()
endfunction()

# sitepose_add_test(<name> SOURCES ... DEPS ... LABELS unit|integration|regression
#                   [TIMEOUT seconds] [SERIAL])
# One GoogleTest executable; each TEST() is registered with ctest so failures
# name the case. SERIAL: ctest runs its cases alone (RUN_SERIAL), for tests
# whose figures depend on having the machine's cores, such as the ATE of a
# live pipeline whose mapper thread otherwise starves.
function(sitepose_add_test name)
  cmake_parse_arguments(ARG "SERIAL" "TIMEOUT" "SOURCES;DEPS;LABELS" ${ARGN})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 120)
  endif()
  set(serial_property "")
  if(ARG_SERIAL)
    set(serial_property RUN_SERIAL TRUE)
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main
    sitepose_warnings)
  target_compile_definitions(${name} PRIVATE
    SITEPOSE_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    SITEPOSE_SITEPOSE_EXE="$<TARGET_FILE_DIR:sitepose>/sitepose")
  sitepose_register_sanitizer_test(${name} "${ARG_LABELS}")
  include(GoogleTest)
  gtest_discover_tests(${name}
    TEST_LIST ${name}_TESTS
    PROPERTIES TIMEOUT ${ARG_TIMEOUT} ${serial_property}
    DISCOVERY_TIMEOUT 60)
  # The labels from a script ctest reads after the discovered tests:
  # gtest_discover_tests' PROPERTIES splits a list of labels into property
  # names (LABELS unit asan would set the label unit and a property asan).
  set(labels_script ${CMAKE_CURRENT_BINARY_DIR}/${name}_labels.cmake)
  file(WRITE ${labels_script}
    "foreach(test IN LISTS ${name}_TESTS)\n"
    "  set_tests_properties(\"\${test}\" PROPERTIES LABELS \"${ARG_LABELS}\")\n"
    "endforeach()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${labels_script})
endfunction()
