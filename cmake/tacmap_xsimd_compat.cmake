# Debian's xsimd 8.1 package exports a target `xsimd` whose INTERFACE_LINK_LIBRARIES names `xtl`
# without finding it, so linking anything against xsimd asks the linker for `-lxtl`, which does
# not exist (xtl is header-only and xsimd only uses it for optional xtl::xcomplex support).
# Use the real xtl target when it is installed, otherwise an empty stand-in.
if(TARGET xsimd AND NOT TARGET xtl)
  get_target_property(_tacmap_xsimd_links xsimd INTERFACE_LINK_LIBRARIES)
  if("xtl" IN_LIST _tacmap_xsimd_links)
    find_package(xtl QUIET)
    if(NOT TARGET xtl)
      add_library(xtl INTERFACE IMPORTED)
    endif()
  endif()
  unset(_tacmap_xsimd_links)
endif()
