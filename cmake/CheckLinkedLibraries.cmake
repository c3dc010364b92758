# Fails when a binary's link took in what the binary must not use (run as a
# test: cmake -D... -P CheckLinkedLibraries.cmake).
# The lists are comma-separated.
#   LINK_MAP              the linker's map of the link (-Wl,-Map=...): its
#                         LOAD lines list every input of the link line
#   REQUIRED_LIBRARIES    names that must be among them (lib<name>.a/.so), so
#                         a map this script cannot read never passes
#   FORBIDDEN_LIBRARIES   names that must not be among them, whether or not
#                         the linker used an object of theirs
#   BINARY, NM            the linked file and nm: no demangled symbol may
#   FORBIDDEN_NAMESPACES  start with one of these (code compiled straight
#                         into a permitted library or the binary)
foreach(var LINK_MAP BINARY NM REQUIRED_LIBRARIES FORBIDDEN_LIBRARIES FORBIDDEN_NAMESPACES)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "CheckLinkedLibraries.cmake: ${var} is not set")
  endif()
endforeach()
foreach(var REQUIRED_LIBRARIES FORBIDDEN_LIBRARIES FORBIDDEN_NAMESPACES)
  string(REPLACE "," ";" ${var} "${${var}}")
endforeach()
if(NOT EXISTS "${LINK_MAP}")
  message(FATAL_ERROR "no link map ${LINK_MAP}: build the binary first")
endif()

file(STRINGS "${LINK_MAP}" loads REGEX "^LOAD ")
list(TRANSFORM loads REPLACE "^LOAD " "")
set(problems "")
# lib<name>.a, lib<name>.so or lib<name>.so.<version>, as the last path element.
function(find_library_inputs name out)
  set(found "")
  foreach(input IN LISTS loads)
    get_filename_component(file "${input}" NAME)
    if(file MATCHES "^lib${name}\\.(a|so)(\\.[0-9.]+)?$")
      list(APPEND found "${input}")
    endif()
  endforeach()
  set(${out} "${found}" PARENT_SCOPE)
endfunction()

foreach(name IN LISTS REQUIRED_LIBRARIES)
  find_library_inputs(${name} found)
  if(NOT found)
    string(APPEND problems "\n  lib${name} is not on the link line: is ${LINK_MAP} the map of this binary?")
  endif()
endforeach()
foreach(name IN LISTS FORBIDDEN_LIBRARIES)
  find_library_inputs(${name} found)
  foreach(input IN LISTS found)
    string(APPEND problems "\n  links ${input}")
  endforeach()
endforeach()

execute_process(COMMAND "${NM}" --demangle --defined-only "${BINARY}"
  OUTPUT_VARIABLE symbols RESULT_VARIABLE nm_status ERROR_VARIABLE nm_error)
if(NOT nm_status EQUAL 0)
  message(FATAL_ERROR "${NM} ${BINARY} failed: ${nm_error}")
endif()
foreach(namespace IN LISTS FORBIDDEN_NAMESPACES)
  string(REGEX MATCHALL "[^\n]* ${namespace}::[^\n]*" hits "${symbols}")
  list(LENGTH hits count)
  if(count GREATER 0)
    list(GET hits 0 first)
    string(APPEND problems "\n  ${count} symbols of ${namespace}, e.g. ${first}")
  endif()
endforeach()

list(LENGTH loads inputs)
if(problems)
  message(FATAL_ERROR "${BINARY}:${problems}")
endif()
message(STATUS "${BINARY}: ${inputs} link inputs, none of ${FORBIDDEN_LIBRARIES}; "
               "no symbol of ${FORBIDDEN_NAMESPACES}")
