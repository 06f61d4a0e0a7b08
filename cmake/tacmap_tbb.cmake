# tacmap::tbb — the oneTBB executor (include/tacmap/executor/tbb_executor.hpp). Optional, like
# tacmap::image_file: the target exists only where oneTBB is found (Debian: libtbb-dev), and
# tacmap::tacmap never needs it (thread_pool_executor uses the standard library's threads).
# Included by tacmap's CMakeLists.txt and by the installed tacmapConfig.cmake, so that
# find_package(tacmap) and add_subdirectory(tacmap) consumers get the same target; oneTBB is
# looked up on the consumer's machine.
#
# tacmap_tbb_request (TACMAP_WITH_TBB in tacmap's build; unset in the installed package, which
# means AUTO): AUTO creates the target where oneTBB is found, ON fails the configure without it,
# OFF never creates it.
if(TARGET tacmap::tbb)
  return()
endif()
# Unset or empty only: `if(NOT <var>)` would also take OFF (a false constant) for AUTO.
if("${tacmap_tbb_request}" STREQUAL "")
  set(tacmap_tbb_request AUTO)
endif()
string(TOUPPER "${tacmap_tbb_request}" tacmap_tbb_request)
if(NOT tacmap_tbb_request MATCHES "^(AUTO|ON|OFF)$")
  message(FATAL_ERROR "tacmap: TACMAP_WITH_TBB is '${tacmap_tbb_request}'; expected AUTO (where "
                      "oneTBB is found), ON (required) or OFF")
endif()
if(tacmap_tbb_request STREQUAL "OFF")
  return()
endif()
find_package(TBB QUIET CONFIG)
if(NOT TARGET TBB::tbb)
  if(tacmap_tbb_request STREQUAL "ON")
    message(FATAL_ERROR
      "tacmap: TACMAP_WITH_TBB is ON but oneTBB (TBBConfig.cmake) was not found. Install the "
      "Debian package libtbb-dev (scripts/deps.sh lists it), or set TBB_DIR to the folder holding "
      "TBBConfig.cmake, or configure with -DTACMAP_WITH_TBB=AUTO (or OFF) to build without the "
      "oneTBB executor (thread_pool_executor needs nothing).")
  endif()
  message(STATUS "tacmap: oneTBB not found (Debian: libtbb-dev); tacmap::tbb (tbb_executor) is not available")
  return()
endif()
# GLOBAL: an add_subdirectory consumer sees it from its own folder, like tacmap::tacmap.
add_library(tacmap::tbb INTERFACE IMPORTED GLOBAL)
target_link_libraries(tacmap::tbb INTERFACE tacmap::tacmap TBB::tbb)
