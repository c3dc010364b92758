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
# which the asan build preset builds (tools/asan.sh): the label alone decides
# what runs under the sanitizers, so a new asan test cannot be left unbuilt.
add_custom_target(sitepose_asan_tests)
function(sitepose_register_asan_test target labels)
  if("asan" IN_LIST labels)
    add_dependencies(sitepose_asan_tests ${target})
  endif()
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
  sitepose_register_asan_test(${name} "${ARG_LABELS}")
  include(GoogleTest)
  gtest_discover_tests(${name}
    PROPERTIES TIMEOUT ${ARG_TIMEOUT} ${serial_property}
    DISCOVERY_TIMEOUT 60)
  # Labels are set by a script ctest reads after the discovered list:
  # through gtest_discover_tests' PROPERTIES a list of labels ("unit;asan")
  # is flattened (CMake 3.25), the test got label unit only and the second
  # label became a property name.
  set(labels_script ${CMAKE_CURRENT_BINARY_DIR}/${name}_labels.cmake)
  file(WRITE ${labels_script}
    "if(DEFINED ${name}_TESTS)\n"
    "  set_tests_properties(\${${name}_TESTS} PROPERTIES LABELS \"${ARG_LABELS}\")\n"
    "endif()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${labels_script})
endfunction()
