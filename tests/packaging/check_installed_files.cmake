# cmake -DPREFIX=<install prefix> -DBINDIR=<rel> -DDATADIR=<rel> -DDOCDIR=<rel> -DTOOLS=<names>
#       -DPKG_CONFIG=<pkg-config> -DCXX=<compiler> -DVERSION=<tacmap version>
#       -DCONSUMER=<a .cpp using tacmap> -DWORK_DIR=<scratch> -P check_installed_files.cmake
#
# After `cmake --install`: the tools (tacmap-evaluate finding the installed data), the docs (with
# the session format and its readers), the evaluation plot script, the data, the Find module, and
# a pkg-config file with which a consumer compiles without CMake.
set(expected
  "${DOCDIR}/README.md" "${DOCDIR}/LICENSE" "${DOCDIR}/SESSION_FORMAT.md"
  "${DATADIR}/tacmap/plot_evaluation.py" "${DATADIR}/tacmap/data/gecko/protocol.txt"
  "${DATADIR}/pkgconfig/tacmap.pc"
  "${DATADIR}/cmake/tacmap/tacmapConfig.cmake" "${DATADIR}/cmake/tacmap/FindOpenHaptics.cmake"
  "${DATADIR}/cmake/tacmap/tacmap_phantom_omni.cmake"
  "include/tacmap/tacmap.hpp" "include/tacmap/devices/phantom_omni_hdapi.hpp")
foreach(tool IN LISTS TOOLS)
  list(APPEND expected "${BINDIR}/${tool}")
endforeach()
set(missing "")
foreach(file IN LISTS expected)
  if(NOT EXISTS "${PREFIX}/${file}")
    list(APPEND missing "${file}")
  endif()
endforeach()
if(missing)
  list(JOIN missing "\n  " missing)
  message(FATAL_ERROR "not installed under ${PREFIX}:\n  ${missing}")
endif()

# The installed tools run from the install tree.
foreach(tool IN LISTS TOOLS)
  execute_process(COMMAND "${PREFIX}/${BINDIR}/${tool}" --help
                  RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "installed ${tool} --help failed (${status}):\n${out}")
  endif()
endforeach()

# The installed tacmap-evaluate finds the installed gecko protocol by default (not the source
# tree it was built from, which still exists here): one short evaluation, one sequence with NCC,
# must say it used <prefix>/<datadir>/tacmap/data/gecko.
list(FIND TOOLS tacmap-evaluate evaluate_index)  # (a -P script has no policies: no IN_LIST)
if(evaluate_index GREATER -1)
  file(MAKE_DIRECTORY "${WORK_DIR}")
  execute_process(COMMAND "${PREFIX}/${BINDIR}/tacmap-evaluate" --quiet --sequences 1 --model ncc
                          --output "${WORK_DIR}/installed_evaluate.csv"
                  WORKING_DIRECTORY "${WORK_DIR}"
                  RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "installed tacmap-evaluate --sequences 1 --model ncc failed (${status}):\n"
                        "${err}\n${out}")
  endif()
  # /proc/self/exe has no symbolic links: compare real paths.
  get_filename_component(installed_gecko "${PREFIX}/${DATADIR}/tacmap/data/gecko" REALPATH)
  if(NOT err MATCHES "(^|\n)gecko: ([^\n]*)\n")
    message(FATAL_ERROR "installed tacmap-evaluate did not say which gecko protocol it used:\n${err}")
  endif()
  get_filename_component(used_gecko "${CMAKE_MATCH_2}" REALPATH)
  if(NOT used_gecko STREQUAL installed_gecko)
    message(FATAL_ERROR "installed tacmap-evaluate used the gecko protocol in ${CMAKE_MATCH_2}; "
                        "expected the installed one, ${installed_gecko}")
  endif()
endif()

# pkg-config, relocated: the prefix is not the one configured.
if(NOT PKG_CONFIG)
  message(FATAL_ERROR "pkg-config not found; install the Debian package pkgconf "
                      "(scripts/deps.sh lists it)")
endif()
set(pc_env "PKG_CONFIG_PATH=${PREFIX}/${DATADIR}/pkgconfig")
execute_process(COMMAND "${CMAKE_COMMAND}" -E env "${pc_env}" "${PKG_CONFIG}" --modversion tacmap
                RESULT_VARIABLE status OUTPUT_VARIABLE pc_version ERROR_VARIABLE err
                OUTPUT_STRIP_TRAILING_WHITESPACE)
if(NOT status EQUAL 0 OR NOT pc_version STREQUAL VERSION)
  message(FATAL_ERROR "pkg-config --modversion tacmap: '${pc_version}' (expected ${VERSION})\n${err}")
endif()
execute_process(COMMAND "${CMAKE_COMMAND}" -E env "${pc_env}" "${PKG_CONFIG}" --cflags tacmap
                RESULT_VARIABLE status OUTPUT_VARIABLE cflags ERROR_VARIABLE err
                OUTPUT_STRIP_TRAILING_WHITESPACE)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "pkg-config --cflags tacmap failed:\n${err}")
endif()
if(NOT cflags MATCHES "-I[^ ]*/include( |$)")
  message(FATAL_ERROR "pkg-config --cflags tacmap: '${cflags}' has no include folder")
endif()
separate_arguments(cflags_list UNIX_COMMAND "${cflags}")
file(MAKE_DIRECTORY "${WORK_DIR}")
execute_process(COMMAND "${CXX}" -std=c++20 ${cflags_list} "${CONSUMER}"
                        -o "${WORK_DIR}/pkg_config_consumer"
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "compiling with `pkg-config --cflags tacmap` (${cflags}) failed:\n${out}")
endif()
execute_process(COMMAND "${WORK_DIR}/pkg_config_consumer" RESULT_VARIABLE status
                OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "the pkg-config consumer failed:\n${out}")
endif()
message(STATUS "installed: ${TOOLS}, docs, data, Find module; pkg-config tacmap ${pc_version}: ${cflags}")
