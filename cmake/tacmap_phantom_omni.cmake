# tacmap::phantom_omni — the Phantom Omni (Geomagic Touch) through the proprietary OpenHaptics
# SDK: links the SDK's HD library and defines TACMAP_HAVE_PHANTOM_OMNI=1, for
# include/tacmap/devices/phantom_omni_hdapi.hpp (the SDK-free logic is in phantom_omni.hpp and
# needs no target). Like tacmap::image_file: included by tacmap's CMakeLists.txt (so that
# add_subdirectory consumers get it) and by the installed tacmapConfig.cmake (find_package
# consumers), and the SDK is looked up on the consumer's machine by FindOpenHaptics.cmake, which
# sits next to this file in both places (hint: OpenHaptics_ROOT or the OH_SDK_BASE environment
# variable).
#
# tacmap_phantom_omni_request (TACMAP_WITH_PHANTOM_OMNI in tacmap's build; unset in the installed
# package, which means AUTO, quietly): AUTO creates the target where the SDK is found, ON fails
# the configure without it, OFF never creates it.
if(TARGET tacmap::phantom_omni)
  return()
endif()
set(tacmap_phantom_omni_quiet OFF)
# Unset or empty only: `if(NOT <var>)` would also take OFF (a false constant) for AUTO.
if("${tacmap_phantom_omni_request}" STREQUAL "")
  set(tacmap_phantom_omni_request AUTO)
  set(tacmap_phantom_omni_quiet ON)
endif()
string(TOUPPER "${tacmap_phantom_omni_request}" tacmap_phantom_omni_request)
if(NOT tacmap_phantom_omni_request MATCHES "^(AUTO|ON|OFF)$")
  message(FATAL_ERROR "tacmap: TACMAP_WITH_PHANTOM_OMNI is '${tacmap_phantom_omni_request}'; "
                      "expected AUTO (where OpenHaptics is found), ON (required) or OFF")
endif()
if(tacmap_phantom_omni_request STREQUAL "OFF")
  return()
endif()

# Our Find module, without leaving our folder on the caller's module path.
set(tacmap_saved_module_path "${CMAKE_MODULE_PATH}")
list(PREPEND CMAKE_MODULE_PATH "${CMAKE_CURRENT_LIST_DIR}")
find_package(OpenHaptics QUIET)
set(CMAKE_MODULE_PATH "${tacmap_saved_module_path}")
unset(tacmap_saved_module_path)

if(NOT OpenHaptics_FOUND)
  if(tacmap_phantom_omni_request STREQUAL "ON")
    message(FATAL_ERROR
      "tacmap: TACMAP_WITH_PHANTOM_OMNI is ON but the OpenHaptics SDK (3D Systems; the header "
      "HD/hd.h and the HD library) was not found (OpenHaptics_INCLUDE_DIR: "
      "${OpenHaptics_INCLUDE_DIR}, OpenHaptics_HD_LIBRARY: ${OpenHaptics_HD_LIBRARY}). It is "
      "proprietary and not packaged in Debian: install it from 3D Systems, then configure with "
      "-DOpenHaptics_ROOT=<its folder> (e.g. /opt/OpenHaptics/Developer; the installer's "
      "OH_SDK_BASE environment variable works too), or with -DTACMAP_WITH_PHANTOM_OMNI=AUTO (or "
      "OFF) to build without the Phantom Omni adapter.")
  endif()
  if(NOT tacmap_phantom_omni_quiet)
    message(STATUS "tacmap: OpenHaptics not found (proprietary; hint: OpenHaptics_ROOT); "
                   "tacmap::phantom_omni is not available")
  endif()
  return()
endif()
# GLOBAL, so that an add_subdirectory consumer sees it from its own folder. The SDK's library and
# header folder are named by path, not through OpenHaptics::HD: that imported target is local to
# the folder that found it, and a consumer elsewhere could not resolve it.
add_library(tacmap::phantom_omni INTERFACE IMPORTED GLOBAL)
set_target_properties(tacmap::phantom_omni PROPERTIES
  INTERFACE_INCLUDE_DIRECTORIES "${OpenHaptics_INCLUDE_DIR}"
  INTERFACE_LINK_LIBRARIES "tacmap::tacmap;${OpenHaptics_HD_LIBRARY}"
  INTERFACE_COMPILE_DEFINITIONS "TACMAP_HAVE_PHANTOM_OMNI=1")
if(NOT tacmap_phantom_omni_quiet)
  message(STATUS "tacmap: tacmap::phantom_omni with OpenHaptics ${OpenHaptics_HD_LIBRARY}")
endif()
