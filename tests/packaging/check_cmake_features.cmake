# cmake -DTACMAP_SOURCE_DIR=<tacmap> -P check_cmake_features.cmake
#
# tacmap's build must run on CMake 3.22 (Ubuntu 22.04, ROS 2 Humble). Debian 12, where tacmap is
# developed and tested, has no CMake older than 3.25, and 3.25 accepts everything newer without a
# word even under cmake_minimum_required(VERSION 3.22) (that line only sets the policies). So
# this script reads tacmap's CMake code (CMakeLists.txt, *.cmake, *.cmake.in, outside build
# folders), CMakePresets.json and scripts/ for the features below, each newer than 3.22, and
# fails naming file, feature and the version that introduced it. The list is a denylist: what we
# know of, not a proof — extend it when a new feature is considered. Comments are ignored.
#
#   feature (regular expression)                     since   what it is
set(tacmap_denylist
  "FILE_SET"                                          3.23  "target_sources/install FILE_SET"
  "VERIFY_INTERFACE_HEADER_SETS"                      3.24  "header set verification"
  "(^|[^A-Za-z0-9_])block[ \t]*\\("                   3.25  "block()"
  "(^|[^A-Za-z0-9_])endblock[ \t]*\\("                3.25  "endblock()"
  "return[ \t]*\\([ \t]*PROPAGATE"                    3.25  "return(PROPAGATE)"
  "GET_MESSAGE_LOG_LEVEL"                             3.25  "cmake_language(GET_MESSAGE_LOG_LEVEL)"
  "\\$<LIST:"                                         3.27  "$<LIST:...>"
  "\\$<PATH:"                                         3.24  "$<PATH:...>"
  "PATH_EQUAL"                                        3.24  "if(PATH_EQUAL)"
  "\\$<LINK_LIBRARY:"                                 3.24  "$<LINK_LIBRARY:...>"
  "\\$<LINK_GROUP:"                                   3.24  "$<LINK_GROUP:...>"
  "\\$<COMPILE_ONLY:"                                 3.27  "$<COMPILE_ONLY:...>"
  "\\$<TARGET_RUNTIME_DLL_DIRS:"                      3.27  "$<TARGET_RUNTIME_DLL_DIRS:...>"
  "COMPILE_WARNING_AS_ERROR"                          3.24  "COMPILE_WARNING_AS_ERROR"
  "find_package[ \t]*\\([^)]*[ \t\n]GLOBAL[ \t\n)]"   3.24  "find_package(... GLOBAL)"
  "add_subdirectory[ \t]*\\([^)]*[ \t\n]SYSTEM[ \t\n)]" 3.25 "add_subdirectory(... SYSTEM)"
  "FetchContent_Declare[ \t]*\\([^)]*[ \t\n]SYSTEM[ \t\n)]" 3.25 "FetchContent_Declare(... SYSTEM)"
  "PROPERTIES[^)]*[ \t\n]SYSTEM[ \t\n]"               3.25  "the SYSTEM target property"
  "EXPORT_NO_SYSTEM"                                  3.25  "EXPORT_NO_SYSTEM"
  "SOURCE_FROM_(CONTENT|VAR|FILE)"                    3.25  "try_compile(SOURCE_FROM_...)"
  "[ \t\n]VALIDATOR[ \t\n]"                           3.25  "find_*(VALIDATOR)"
  "WINDOWS_REGISTRY"                                  3.24  "cmake_host_system_information(QUERY WINDOWS_REGISTRY)"
  "CMAKE_PROJECT_TOP_LEVEL_INCLUDES"                  3.24  "CMAKE_PROJECT_TOP_LEVEL_INCLUDES"
  "DOWNLOAD_EXTRACT_TIMESTAMP"                        3.24  "DOWNLOAD_EXTRACT_TIMESTAMP"
  "CMP01(29|[3-9][0-9])"                              3.23  "a policy newer than 3.22 (CMP0129 on)"
  "--workflow"                                        3.25  "cmake --workflow"
  "--fresh"                                           3.24  "cmake --fresh"
  "(^|[ \t])cmake[ \t]+-E[ \t]+env[ \t]+--modify"     3.27  "cmake -E env --modify")

if(NOT TACMAP_SOURCE_DIR)
  message(FATAL_ERROR "usage: cmake -DTACMAP_SOURCE_DIR=<tacmap source> -P ${CMAKE_CURRENT_LIST_FILE}")
endif()

# The files: every CMake file outside build folders and .git, and the scripts.
file(GLOB top_entries LIST_DIRECTORIES true "${TACMAP_SOURCE_DIR}/*")
set(files "")
foreach(entry IN LISTS top_entries)
  get_filename_component(name "${entry}" NAME)
  if(name MATCHES "^(build.*|out|\\..*)$")
    continue()
  endif()
  if(IS_DIRECTORY "${entry}")
    file(GLOB_RECURSE found "${entry}/CMakeLists.txt" "${entry}/*.cmake" "${entry}/*.cmake.in")
    list(APPEND files ${found})
    if(name STREQUAL "scripts")
      file(GLOB found "${entry}/*")
      list(APPEND files ${found})
    endif()
  elseif(name STREQUAL "CMakeLists.txt")
    list(APPEND files "${entry}")
  endif()
endforeach()
list(REMOVE_ITEM files "${CMAKE_CURRENT_LIST_FILE}")  # holds the list itself
list(REMOVE_DUPLICATES files)

set(problems "")
set(checked 0)
foreach(file IN LISTS files)
  if(IS_DIRECTORY "${file}")
    continue()
  endif()
  math(EXPR checked "${checked} + 1")
  file(READ "${file}" text)
  # Drop comments (a '#' to the end of its line), so that a comment may name a feature.
  string(REGEX REPLACE "#[^\n]*" "" text "${text}")
  file(RELATIVE_PATH shown "${TACMAP_SOURCE_DIR}" "${file}")
  set(rest ${tacmap_denylist})
  while(rest)
    list(POP_FRONT rest pattern since what)
    if(text MATCHES "${pattern}")
      string(STRIP "${CMAKE_MATCH_0}" matched)
      list(APPEND problems "${shown}: ${what} needs CMake ${since} (matched '${matched}')")
    endif()
  endwhile()
  # cmake_minimum_required must not ask for more than 3.22 anywhere.
  string(REGEX MATCHALL "cmake_minimum_required[ \t]*\\([ \t]*VERSION[ \t]+[0-9.]+" requires
         "${text}")
  foreach(require IN LISTS requires)
    string(REGEX MATCH "[0-9.]+$" version "${require}")
    if(version VERSION_GREATER 3.22)
      list(APPEND problems "${shown}: cmake_minimum_required(VERSION ${version}) is above 3.22")
    endif()
  endforeach()
endforeach()

# CMake 3.22 reads presets files up to version 3.
set(presets "${TACMAP_SOURCE_DIR}/CMakePresets.json")
if(EXISTS "${presets}")
  file(READ "${presets}" json)
  string(JSON presets_version GET "${json}" version)
  if(presets_version GREATER 3)
    list(APPEND problems "CMakePresets.json: version ${presets_version} needs CMake "
                         "3.23 or later (3.22 reads version 3)")
  endif()
  string(JSON has_workflows ERROR_VARIABLE no_workflows GET "${json}" workflowPresets)
  if(NOT no_workflows)
    list(APPEND problems "CMakePresets.json: workflowPresets need CMake 3.25")
  endif()
endif()

if(checked LESS 10)
  message(FATAL_ERROR "only ${checked} files found under ${TACMAP_SOURCE_DIR}; wrong folder?")
endif()
if(problems)
  list(JOIN problems "\n  " problems)
  message(FATAL_ERROR "tacmap must build with CMake 3.22; found newer features:\n  ${problems}")
endif()
list(LENGTH tacmap_denylist n)
math(EXPR n "${n} / 3")
message(STATUS "${checked} files checked against ${n} features newer than CMake 3.22: none used")
