# tacmap's install rules, included by the top-level CMakeLists.txt when TACMAP_INSTALL is ON
# (default only when tacmap is the top-level project). What lands where (GNUInstallDirs):
#   include/tacmap/...                   the headers
#   share/cmake/tacmap/                  tacmapConfig.cmake, its version file, the exported
#                                        targets and the modules the config includes:
#                                        tacmap::image_file's, tacmap::phantom_omni's,
#                                        tacmap::tbb's and
#                                        FindOpenHaptics.cmake (the SDK is found on the
#                                        consumer's machine)
#   share/pkgconfig/tacmap.pc            for builds without CMake (header-only: no libdir, so
#                                        arch-independent like Debian's eigen3.pc)
#   share/doc/tacmap/                    README.md, LICENSE, SESSION_FORMAT.md (the session log
#                                        format with its Python and MATLAB readers)
#   share/tacmap/plot_evaluation.py      figures from tacmap-evaluate's CSV (python3-matplotlib)
#   share/tacmap/data/                   the bundled maps and protocols (tacmap-evaluate --gecko)
#   bin/tacmap-evaluate, tacmap-calibrate (tools/CMakeLists.txt, when TACMAP_BUILD_TOOLS built them)
install(TARGETS tacmap EXPORT tacmap-targets)
install(DIRECTORY include/ DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}"
        FILES_MATCHING PATTERN "*.hpp")

set(tacmap_cmake_dir "${CMAKE_INSTALL_DATADIR}/cmake/tacmap")
install(EXPORT tacmap-targets NAMESPACE tacmap:: FILE tacmapTargets.cmake
        DESTINATION "${tacmap_cmake_dir}")
configure_package_config_file(cmake/tacmapConfig.cmake.in
  "${CMAKE_CURRENT_BINARY_DIR}/tacmapConfig.cmake"
  INSTALL_DESTINATION "${tacmap_cmake_dir}")
# Headers only: any architecture may use the package. With tacmap::precompiled (a compiled
# library) only a consumer of the same pointer size may (CMake's check without ARCH_INDEPENDENT).
set(tacmap_version_arch ARCH_INDEPENDENT)
if(TARGET tacmap_precompiled)
  set(tacmap_version_arch "")
endif()
write_basic_package_version_file("${CMAKE_CURRENT_BINARY_DIR}/tacmapConfigVersion.cmake"
  COMPATIBILITY SameMinorVersion ${tacmap_version_arch})
install(FILES "${CMAKE_CURRENT_BINARY_DIR}/tacmapConfig.cmake"
              "${CMAKE_CURRENT_BINARY_DIR}/tacmapConfigVersion.cmake"
              cmake/tacmap_xsimd_compat.cmake
              cmake/tacmap_image_file.cmake
              cmake/tacmap_phantom_omni.cmake
              cmake/tacmap_tbb.cmake
              cmake/FindOpenHaptics.cmake
        DESTINATION "${tacmap_cmake_dir}")

# pkg-config: relocatable (${pcfiledir}), so that `cmake --install --prefix <anywhere>` works.
set(tacmap_pc_dir "${CMAKE_INSTALL_DATADIR}/pkgconfig")
if(IS_ABSOLUTE "${tacmap_pc_dir}")
  set(tacmap_pc_prefix "${CMAKE_INSTALL_PREFIX}")
else()
  file(RELATIVE_PATH tacmap_pc_prefix "/tacmap_prefix/${tacmap_pc_dir}" "/tacmap_prefix")
  string(REGEX REPLACE "/$" "" tacmap_pc_prefix "${tacmap_pc_prefix}")
  set(tacmap_pc_prefix "\${pcfiledir}/${tacmap_pc_prefix}")
endif()
if(IS_ABSOLUTE "${CMAKE_INSTALL_INCLUDEDIR}")
  set(tacmap_pc_includedir "${CMAKE_INSTALL_INCLUDEDIR}")
else()
  set(tacmap_pc_includedir "\${prefix}/${CMAKE_INSTALL_INCLUDEDIR}")
endif()
configure_file(cmake/tacmap.pc.in "${CMAKE_CURRENT_BINARY_DIR}/tacmap.pc" @ONLY)
install(FILES "${CMAKE_CURRENT_BINARY_DIR}/tacmap.pc" DESTINATION "${tacmap_pc_dir}")

install(FILES README.md LICENSE include/tacmap/io/SESSION_FORMAT.md
        DESTINATION "${CMAKE_INSTALL_DOCDIR}")
install(PROGRAMS scripts/plot_evaluation.py DESTINATION "${CMAKE_INSTALL_DATADIR}/tacmap")
install(DIRECTORY data/ DESTINATION "${CMAKE_INSTALL_DATADIR}/tacmap/data")
