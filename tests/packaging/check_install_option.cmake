# cmake -DCONSUMER_SOURCE=<add_subdirectory/> -DCONSUMER_BUILD=<its configured build>
#       -DWORK_DIR=<scratch> -DTACMAP_SOURCE_DIR=<tacmap> -DGENERATOR=<g> -DCXX=<compiler>
#       -P check_install_option.cmake
#
# TACMAP_INSTALL: a parent project that adds tacmap with add_subdirectory installs none of
# tacmap's files with its own `cmake --install` (the option defaults to OFF in a subproject), and
# all of them with -DTACMAP_INSTALL=ON.
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
message(STATUS "TACMAP_INSTALL: off in a subproject installs only the parent's file; on installs tacmap too")
