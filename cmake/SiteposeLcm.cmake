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
