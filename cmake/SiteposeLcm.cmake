# LCM (liblcm-dev 1.3, liblcm-bin): the library through pkg-config and the
# C++ message classes generated from config/lcm/*.lcm by lcm-gen at build
# time into the build tree (never committed).
#
#   sitepose_lcm_types(<target> LCM_FILES <file.lcm>...)
# defines the INTERFACE library <target>: include directory of the generated
# headers (#include "sitepose/pose_t.hpp" for package sitepose), liblcm, and
# a build dependency so the headers exist before any consumer compiles.

if(NOT TARGET PkgConfig::SITEPOSE_LCM)
  pkg_check_modules(SITEPOSE_LCM REQUIRED IMPORTED_TARGET GLOBAL lcm)
endif()
find_program(SITEPOSE_LCM_GEN lcm-gen REQUIRED)

function(sitepose_lcm_types target)
  cmake_parse_arguments(ARG "" "" "LCM_FILES" ${ARGN})
  set(out_dir ${CMAKE_CURRENT_BINARY_DIR}/lcm_gen)
  set(headers)
  foreach(lcm_file IN LISTS ARG_LCM_FILES)
    # lcm-gen writes <package>/<struct>.hpp; one struct per file, named like it.
    get_filename_component(type_name ${lcm_file} NAME_WE)
    file(STRINGS ${lcm_file} package_line REGEX "^[ \t]*package[ \t]+[A-Za-z0-9_.]+[ \t]*;")
    if(NOT package_line)
      message(FATAL_ERROR "${lcm_file}: no 'package <name>;' line")
    endif()
    string(REGEX REPLACE "^[ \t]*package[ \t]+([A-Za-z0-9_.]+).*" "\\1" package "${package_line}")
    string(REPLACE "." "/" package_dir ${package})
    list(APPEND headers ${out_dir}/${package_dir}/${type_name}.hpp)
  endforeach()
  set(names)
  foreach(lcm_file IN LISTS ARG_LCM_FILES)
    get_filename_component(name ${lcm_file} NAME)
    list(APPEND names ${name})
  endforeach()
  list(JOIN names " " names)
  add_custom_command(
    OUTPUT ${headers}
    COMMAND ${SITEPOSE_LCM_GEN} --cpp --cpp-std c++11 --cpp-hpath ${out_dir} ${ARG_LCM_FILES}
    DEPENDS ${ARG_LCM_FILES}
    COMMENT "lcm-gen: C++ message types from ${names}"
    VERBATIM)
  add_custom_target(${target}_generate DEPENDS ${headers})
  add_library(${target} INTERFACE)
  # SYSTEM: generated code is not held to our warning flags.
  target_include_directories(${target} SYSTEM INTERFACE ${out_dir})
  target_link_libraries(${target} INTERFACE PkgConfig::SITEPOSE_LCM)
  add_dependencies(${target} ${target}_generate)
endfunction()

# The same messages for integrators' receivers in C, Python and Java,
# generated at build time and installed by sitepose-dev
# (cmake/SiteposePackaging.cmake; examples/lcm/ uses each):
#
#   sitepose_lcm_bindings(<prefix> PACKAGE <name> LCM_FILES <file.lcm>...)
# defines
#   <prefix>_c       static library lib<name>_lcmtypes.a (PIC), its headers
#                    as #include <name/<name>_<type>.h>, linking liblcm;
#   <prefix>_python  the package <name>/ (<type>.py, __init__.py); encode and
#                    decode need only the standard library (Debian 12 has no
#                    Python lcm module);
#   <prefix>_java    <name>-lcmtypes.jar (a link to <name>-lcmtypes-<version>.jar),
#                    compiled against liblcm-java's lcm.jar (SITEPOSE_LCM_JAR).
# Their folders: the target properties SITEPOSE_INCLUDE_DIR (C),
# SITEPOSE_PYTHON_DIR (python) and the jar's JAR_FILE (java).
find_file(SITEPOSE_LCM_JAR lcm.jar PATHS /usr/share/java NO_DEFAULT_PATH)
if(NOT SITEPOSE_LCM_JAR)
  message(FATAL_ERROR "lcm.jar not found in /usr/share/java: install liblcm-java (tools/install-deps.sh)")
endif()

function(sitepose_lcm_bindings prefix)
  cmake_parse_arguments(ARG "" "PACKAGE" "LCM_FILES" ${ARGN})
  set(out ${CMAKE_CURRENT_BINARY_DIR}/lcm_bindings)
  set(c_sources)
  set(c_headers)
  set(python_files ${out}/python/${ARG_PACKAGE}/__init__.py)
  set(java_files)
  foreach(lcm_file IN LISTS ARG_LCM_FILES)
    get_filename_component(type_name ${lcm_file} NAME_WE)
    list(APPEND c_sources ${out}/c/${ARG_PACKAGE}_${type_name}.c)
    list(APPEND c_headers ${out}/c/include/${ARG_PACKAGE}/${ARG_PACKAGE}_${type_name}.h)
    list(APPEND python_files ${out}/python/${ARG_PACKAGE}/${type_name}.py)
    list(APPEND java_files ${out}/java/${ARG_PACKAGE}/${type_name}.java)
  endforeach()

  add_custom_command(
    OUTPUT ${c_sources} ${c_headers}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${out}/c/include/${ARG_PACKAGE}
    COMMAND ${SITEPOSE_LCM_GEN} --c --c-cpath ${out}/c --c-hpath ${out}/c/include/${ARG_PACKAGE}
            --cinclude ${ARG_PACKAGE} ${ARG_LCM_FILES}
    DEPENDS ${ARG_LCM_FILES}
    COMMENT "lcm-gen: C message types"
    VERBATIM)
  add_library(${prefix}_c STATIC ${c_sources})
  set_target_properties(${prefix}_c PROPERTIES
    OUTPUT_NAME ${ARG_PACKAGE}_lcmtypes
    POSITION_INDEPENDENT_CODE ON
    SITEPOSE_INCLUDE_DIR ${out}/c/include)
  target_include_directories(${prefix}_c SYSTEM PUBLIC ${out}/c/include)
  target_link_libraries(${prefix}_c PUBLIC PkgConfig::SITEPOSE_LCM)

  # lcm-gen adds to an existing __init__.py: start from none.
  add_custom_command(
    OUTPUT ${python_files}
    COMMAND ${CMAKE_COMMAND} -E rm -rf ${out}/python/${ARG_PACKAGE}
    COMMAND ${SITEPOSE_LCM_GEN} --python --ppath ${out}/python ${ARG_LCM_FILES}
    DEPENDS ${ARG_LCM_FILES}
    COMMENT "lcm-gen: Python message types"
    VERBATIM)
  add_custom_target(${prefix}_python ALL DEPENDS ${python_files})
  set_target_properties(${prefix}_python PROPERTIES SITEPOSE_PYTHON_DIR ${out}/python)

  add_custom_command(
    OUTPUT ${java_files}
    COMMAND ${SITEPOSE_LCM_GEN} --java --jpath ${out}/java ${ARG_LCM_FILES}
    DEPENDS ${ARG_LCM_FILES}
    COMMENT "lcm-gen: Java message types"
    VERBATIM)
  # <name>-lcmtypes-<version>.jar and the link <name>-lcmtypes.jar, as
  # Debian's Java policy names public jars.
  add_jar(${prefix}_java
    SOURCES ${java_files}
    INCLUDE_JARS ${SITEPOSE_LCM_JAR}
    OUTPUT_NAME ${ARG_PACKAGE}-lcmtypes
    VERSION ${PROJECT_VERSION})
endfunction()
