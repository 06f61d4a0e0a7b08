# tacmap::image_file — maps from PNG and JPEG files (include/tacmap/io/image_file.hpp) through
# stb_image. Optional, like the device adapters: the target exists only where stb_image.h is found
# (Debian: libstb-dev), and tacmap::tacmap never needs it. Included by tacmap's CMakeLists.txt and
# by the installed tacmapConfig.cmake, so that find_package(tacmap) and add_subdirectory(tacmap)
# consumers get the same target; stb is looked up on the consumer's machine, never a path
# recorded at build time.
#
# tacmap_image_file_request (TACMAP_WITH_IMAGE_FILE in tacmap's build; unset in the installed
# package, which means AUTO): AUTO creates the target where stb is found, ON fails the configure
# without it, OFF never creates it.
if(TARGET tacmap::image_file)
  return()
endif()
# Unset or empty only: `if(NOT <var>)` would also take OFF (a false constant) for AUTO.
if("${tacmap_image_file_request}" STREQUAL "")
  set(tacmap_image_file_request AUTO)
endif()
string(TOUPPER "${tacmap_image_file_request}" tacmap_image_file_request)
if(NOT tacmap_image_file_request MATCHES "^(AUTO|ON|OFF)$")
  message(FATAL_ERROR "tacmap: TACMAP_WITH_IMAGE_FILE is '${tacmap_image_file_request}'; expected "
                      "AUTO (where stb is found), ON (required) or OFF")
endif()
if(tacmap_image_file_request STREQUAL "OFF")
  return()
endif()
# <stb/stb_image.h> (Debian, Homebrew) or <stb_image.h> (vcpkg, Conan): the header takes either.
find_path(TACMAP_STB_IMAGE_INCLUDE_DIR NAMES stb/stb_image.h stb_image.h
          DOC "folder holding stb/stb_image.h or stb_image.h (tacmap::image_file)")
if(NOT TACMAP_STB_IMAGE_INCLUDE_DIR)
  if(tacmap_image_file_request STREQUAL "ON")
    message(FATAL_ERROR
      "tacmap: TACMAP_WITH_IMAGE_FILE is ON but stb_image.h (stb/stb_image.h or stb_image.h) "
      "was not found. Install the Debian package libstb-dev (scripts/deps.sh lists it), or set "
      "TACMAP_STB_IMAGE_INCLUDE_DIR to the folder holding it, or configure with "
      "-DTACMAP_WITH_IMAGE_FILE=AUTO (or OFF) to build without PNG/JPEG maps.")
  endif()
  message(STATUS "tacmap: stb_image.h not found (Debian: libstb-dev); tacmap::image_file (PNG/JPEG maps) is not available")
  return()
endif()
# GLOBAL: an add_subdirectory consumer sees it from its own folder, like tacmap::tacmap.
add_library(tacmap::image_file INTERFACE IMPORTED GLOBAL)
target_include_directories(tacmap::image_file INTERFACE "${TACMAP_STB_IMAGE_INCLUDE_DIR}")
target_link_libraries(tacmap::image_file INTERFACE tacmap::tacmap)
