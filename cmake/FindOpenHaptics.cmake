# FindOpenHaptics
# ---------------
# Finds the OpenHaptics SDK (3D Systems, formerly SensAble) that drives the Phantom Omni /
# Geomagic Touch: its HDAPI header <HD/hd.h> and the HD and HDU libraries. The SDK is proprietary
# and installed separately; tacmap never ships any part of it.
#
# Hints: set OpenHaptics_ROOT (CMake variable or environment variable) or the OH_SDK_BASE
# environment variable the SDK's installer sets.
#
# Result variables:
#   OpenHaptics_FOUND, OpenHaptics_INCLUDE_DIR, OpenHaptics_HD_LIBRARY, OpenHaptics_HDU_LIBRARY
# Imported targets:
#   OpenHaptics::HD   the device API (hdInitDevice, the servo scheduler, ...); all tacmap needs
#   OpenHaptics::HDU  the utility library, when present (optional; tacmap does not need it)

find_path(OpenHaptics_INCLUDE_DIR
  NAMES HD/hd.h
  HINTS ${OpenHaptics_ROOT} ENV OpenHaptics_ROOT ENV OH_SDK_BASE
  PATH_SUFFIXES include
  PATHS /opt/OpenHaptics/Developer /usr/local /usr)

find_library(OpenHaptics_HD_LIBRARY
  NAMES HD
  HINTS ${OpenHaptics_ROOT} ENV OpenHaptics_ROOT ENV OH_SDK_BASE
  PATH_SUFFIXES lib lib64 lib/x64/Release lib/Win32/Release
  PATHS /opt/OpenHaptics/Developer /usr/local /usr)

find_library(OpenHaptics_HDU_LIBRARY
  NAMES HDU
  HINTS ${OpenHaptics_ROOT} ENV OpenHaptics_ROOT ENV OH_SDK_BASE
  PATH_SUFFIXES lib lib64 utilities/lib/x64/Release utilities/lib/Win32/Release
  PATHS /opt/OpenHaptics/Developer /usr/local /usr)

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(OpenHaptics
  REQUIRED_VARS OpenHaptics_HD_LIBRARY OpenHaptics_INCLUDE_DIR)
mark_as_advanced(OpenHaptics_INCLUDE_DIR OpenHaptics_HD_LIBRARY OpenHaptics_HDU_LIBRARY)

if(OpenHaptics_FOUND AND NOT TARGET OpenHaptics::HD)
  add_library(OpenHaptics::HD UNKNOWN IMPORTED)
  set_target_properties(OpenHaptics::HD PROPERTIES
    IMPORTED_LOCATION "${OpenHaptics_HD_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${OpenHaptics_INCLUDE_DIR}")
endif()
if(OpenHaptics_FOUND AND OpenHaptics_HDU_LIBRARY AND NOT TARGET OpenHaptics::HDU)
  add_library(OpenHaptics::HDU UNKNOWN IMPORTED)
  set_target_properties(OpenHaptics::HDU PROPERTIES
    IMPORTED_LOCATION "${OpenHaptics_HDU_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${OpenHaptics_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES OpenHaptics::HD)
endif()
