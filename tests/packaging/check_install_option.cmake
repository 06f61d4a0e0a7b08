# cmake -DCONSUMER_SOURCE=<add_subdirectory/> -DCONSUMER_BUILD=<its configured build>
#       -DWORK_DIR=<scratch> -DTACMAP_SOURCE_DIR=<tacmap> -DGENERATOR=<g> -DCXX=<compiler>
#       [-DPYTHON=<python3 with numpy, pybind11>] [-DPYTHON_INSTALL_SCRIPT=<cmake_install.cmake>]
#       -P check_install_option.cmake
#
# TACMAP_INSTALL: a parent project that adds tacmap with add_subdirectory installs none of
# tacmap's files with its own `cmake --install` (the option defaults to OFF in a subproject), and
# all of them with -DTACMAP_INSTALL=ON. A top-level build with -DTACMAP_INSTALL=OFF installs
# nothing either, not even the opt-in Python component (with PYTHON: the module configured, not
# built). PYTHON_INSTALL_SCRIPT, python/cmake_install.cmake of a build with TACMAP_INSTALL and
# the module, must hold the module's rule (the other side of the switch, without building it).
function(install_into build prefix)
  file(REMOVE_RECURSE "${prefix}")
  execute_process(COMMAND "${CMAKE_COMMAND}" -E env --unset=DESTDIR
                          "${CMAKE_COMMAND}" --install "${build}" --prefix "${prefix}"
                  RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "cmake --install ${build} failed:\n${out}")
  endif()
endfunction()

set(parent_file share/tacmap_add_subdirectory_consumer/main.cpp)
set(tacmap_files include/tacmap/tacmap.hpp share/cmake/tacmap/tacmapConfig.cmake
    share/pkgconfig/tacmap.pc share/doc/tacmap/README.md)

# 1. Default (OFF): the parent's file only.
install_into("${CONSUMER_BUILD}" "${WORK_DIR}/prefix_default")
if(NOT EXISTS "${WORK_DIR}/prefix_default/${parent_file}")
  message(FATAL_ERROR "the parent's own file ${parent_file} was not installed")
endif()
file(GLOB_RECURSE installed RELATIVE "${WORK_DIR}/prefix_default" "${WORK_DIR}/prefix_default/*")
list(REMOVE_ITEM installed "${parent_file}")
if(installed)
  list(JOIN installed "\n  " installed)
  message(FATAL_ERROR "with TACMAP_INSTALL at its subproject default the parent's install also "
                      "installed:\n  ${installed}")
endif()

# 2. -DTACMAP_INSTALL=ON: tacmap ships with the parent (no build needed: the parent installs no
# target).
file(REMOVE_RECURSE "${WORK_DIR}/build_install_on")
execute_process(COMMAND "${CMAKE_COMMAND}" -S "${CONSUMER_SOURCE}" -B "${WORK_DIR}/build_install_on"
                        -G "${GENERATOR}" "-DCMAKE_CXX_COMPILER=${CXX}"
                        "-DTACMAP_SOURCE_DIR=${TACMAP_SOURCE_DIR}" -DTACMAP_INSTALL=ON
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "configuring the parent with -DTACMAP_INSTALL=ON failed:\n${out}")
endif()
install_into("${WORK_DIR}/build_install_on" "${WORK_DIR}/prefix_on")
foreach(file IN LISTS parent_file tacmap_files)
  if(NOT EXISTS "${WORK_DIR}/prefix_on/${file}")
    message(FATAL_ERROR "-DTACMAP_INSTALL=ON in a subproject: ${file} was not installed")
  endif()
endforeach()

# 3. Top level with -DTACMAP_INSTALL=OFF: no install rule at all. Nothing is built: an install
# rule left for the (unbuilt) Python module would fail its install, any other would install a
# file.
set(top_options -DTACMAP_INSTALL=OFF -DTACMAP_BUILD_TESTS=OFF -DTACMAP_BUILD_EXAMPLES=OFF
    -DTACMAP_BUILD_TOOLS=OFF -DTACMAP_BUILD_PRECOMPILED=OFF)
if(PYTHON)
  list(APPEND top_options -DTACMAP_BUILD_PYTHON=ON "-DPython3_EXECUTABLE=${PYTHON}")
endif()
file(REMOVE_RECURSE "${WORK_DIR}/build_top_install_off")
execute_process(COMMAND "${CMAKE_COMMAND}" -S "${TACMAP_SOURCE_DIR}"
                        -B "${WORK_DIR}/build_top_install_off" -G "${GENERATOR}"
                        "-DCMAKE_CXX_COMPILER=${CXX}" ${top_options}
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "configuring tacmap with ${top_options} failed:\n${out}")
endif()
foreach(component IN ITEMS "" python)
  set(component_args "")
  set(what "cmake --install")
  if(component)
    set(component_args --component "${component}")
    set(what "cmake --install --component ${component}")
  endif()
  set(prefix "${WORK_DIR}/prefix_top_off_${component}")
  file(REMOVE_RECURSE "${prefix}")
  execute_process(COMMAND "${CMAKE_COMMAND}" -E env --unset=DESTDIR
                          "${CMAKE_COMMAND}" --install "${WORK_DIR}/build_top_install_off"
                          --prefix "${prefix}" ${component_args}
                  RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "${what} of a top-level build with -DTACMAP_INSTALL=OFF failed (an install "
                        "rule not gated by TACMAP_INSTALL?):\n${out}")
  endif()
  file(GLOB_RECURSE installed RELATIVE "${prefix}" "${prefix}/*")
  if(installed)
    list(JOIN installed "\n  " installed)
    message(FATAL_ERROR "${what} of a top-level build with -DTACMAP_INSTALL=OFF installed:\n  "
                        "${installed}")
  endif()
endforeach()
if(PYTHON_INSTALL_SCRIPT)
  file(READ "${PYTHON_INSTALL_SCRIPT}" script)
  if(NOT script MATCHES "CMAKE_INSTALL_COMPONENT STREQUAL \"python\"")
    message(FATAL_ERROR "${PYTHON_INSTALL_SCRIPT} has no install rule for the Python module "
                        "(component python), although TACMAP_INSTALL is ON")
  endif()
endif()
message(STATUS "TACMAP_INSTALL: off in a subproject installs only the parent's file; on installs "
               "tacmap too; off at the top level installs nothing (Python component: "
               "${PYTHON})")
