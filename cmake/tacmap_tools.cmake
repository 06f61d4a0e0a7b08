# Whether tacmap's command-line tools are built (TACMAP_BUILD_TOOLS), decided before tests/ and
# tools/ are configured, so that both see the same answer. Included by the top-level
# CMakeLists.txt.
#
# tacmap-evaluate and tacmap-calibrate need CLI11 (Debian: libcli11-dev, header-only) and
# tacmap::image_file (stb_image, Debian: libstb-dev: they read photographs as maps). The request:
#   AUTO (default): built where both are found, so that a library-only or demo build (scripts/demo)
#                   configures on a machine without them;
#   ON:             required: a missing one is a configure error naming it and its Debian package
#                   (never a build that silently lacks the tools it was asked for);
#   OFF:            not built.
# The data generators in tools/ need neither and are built unless the request is OFF.
#
# Sets tacmap_tools_request (AUTO, ON or OFF) and tacmap_cli_tools (TRUE where tacmap-evaluate
# and tacmap-calibrate are built; tests/evaluation runs them only then).
string(TOUPPER "${TACMAP_BUILD_TOOLS}" tacmap_tools_request)
# CMake's boolean spellings too: the option used to be a BOOL (ON by default).
if(tacmap_tools_request MATCHES "^(ON|YES|TRUE|Y|1)$")
  set(tacmap_tools_request ON)
elseif(tacmap_tools_request MATCHES "^(OFF|NO|FALSE|N|0)$")
  set(tacmap_tools_request OFF)
elseif(NOT tacmap_tools_request STREQUAL "AUTO")
  message(FATAL_ERROR "tacmap: TACMAP_BUILD_TOOLS is '${TACMAP_BUILD_TOOLS}'; expected AUTO "
                      "(built where CLI11 and stb are found), ON (required) or OFF")
endif()

set(tacmap_cli_tools FALSE)
if(NOT tacmap_tools_request STREQUAL "OFF")
  # Debian's CLI11 2.1 exports CLI11::CLI11 (/usr/share/cmake/CLI11). Found here, in the top
  # directory, so that tools/ and tests/ see the same target and result.
  find_package(CLI11 CONFIG QUIET)
  set(tacmap_tools_missing "")  # one item per missing dependency (no ';' inside an item)
  if(NOT CLI11_FOUND)
    list(APPEND tacmap_tools_missing "CLI11 (Debian package libcli11-dev, or point CLI11_DIR or CMAKE_PREFIX_PATH at an installed CLI11)")
  endif()
  if(NOT TARGET tacmap::image_file)
    if(tacmap_image_file_request STREQUAL "OFF")
      list(APPEND tacmap_tools_missing "tacmap::image_file, which -DTACMAP_WITH_IMAGE_FILE=OFF turns off (set it to AUTO or ON, with stb: Debian package libstb-dev)")
    else()
      list(APPEND tacmap_tools_missing "stb_image.h for tacmap::image_file (Debian package libstb-dev, or set TACMAP_STB_IMAGE_INCLUDE_DIR to the folder holding it)")
    endif()
  endif()
  if(tacmap_tools_missing STREQUAL "")
    set(tacmap_cli_tools TRUE)
  elseif(tacmap_tools_request STREQUAL "ON")
    list(JOIN tacmap_tools_missing ", and " tacmap_tools_missing_text)
    message(FATAL_ERROR
      "tacmap: TACMAP_BUILD_TOOLS is ON but tacmap-evaluate and tacmap-calibrate need "
      "${tacmap_tools_missing_text}. Install what is missing (scripts/deps.sh lists the Debian "
      "packages), or configure with -DTACMAP_BUILD_TOOLS=AUTO (the tools are built only where "
      "their dependencies are found) or -DTACMAP_BUILD_TOOLS=OFF.")
  else()
    list(JOIN tacmap_tools_missing ", " tacmap_tools_missing_text)
    message(STATUS "tacmap: tacmap-evaluate and tacmap-calibrate are not built "
                   "(TACMAP_BUILD_TOOLS=AUTO); missing: ${tacmap_tools_missing_text}")
  endif()
endif()
