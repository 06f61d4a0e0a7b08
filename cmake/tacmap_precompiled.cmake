# tacmap::precompiled: an optional static library beside the header-only tacmap::tacmap.
#
# * Run-time instruction sets: the float kernels of the measurement and the update compiled once
#   per level (src/simd_dispatch.cpp: the SSE2 baseline, with the consumer's flags;
#   src/simd_avx2.cpp: -mavx2 -mfma) and chosen once from what the CPU offers. A consumer that
#   links it gets TACMAP_PRECOMPILED=1, and the headers route those kernels through it.
# * Compile time: explicit instantiations of the common models (src/instantiations*.cpp), which
#   the headers declare `extern template` under TACMAP_PRECOMPILED.
#
# x86-64 with GCC or Clang only (the dispatch asks the CPU with __builtin_cpu_supports).
set(_tacmap_precompiled_possible OFF)
if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$"
   AND CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
  set(_tacmap_precompiled_possible ON)
endif()
set(_tacmap_precompiled_default OFF)
if(PROJECT_IS_TOP_LEVEL AND _tacmap_precompiled_possible)
  set(_tacmap_precompiled_default ON)
endif()
option(TACMAP_BUILD_PRECOMPILED
       "Build tacmap::precompiled (run-time SIMD dispatch, precompiled common models)"
       ${_tacmap_precompiled_default})

if(TACMAP_BUILD_PRECOMPILED)
  if(NOT _tacmap_precompiled_possible)
    message(FATAL_ERROR
      "TACMAP_BUILD_PRECOMPILED=ON needs an x86-64 target and GCC or Clang (found "
      "${CMAKE_SYSTEM_PROCESSOR}, ${CMAKE_CXX_COMPILER_ID}); configure with "
      "-DTACMAP_BUILD_PRECOMPILED=OFF and use the header-only tacmap::tacmap")
  endif()
  # simd_dispatch.cpp first: see the comment at its top (which copy of shared inline code the
  # linker keeps).
  add_library(tacmap_precompiled STATIC
    src/simd_dispatch.cpp
    src/instantiations.cpp
    src/simd_avx2.cpp)
  add_library(tacmap::precompiled ALIAS tacmap_precompiled)
  set_target_properties(tacmap_precompiled PROPERTIES
    EXPORT_NAME precompiled
    OUTPUT_NAME tacmap_precompiled
    POSITION_INDEPENDENT_CODE ON)
  target_link_libraries(tacmap_precompiled PUBLIC tacmap)
  target_compile_definitions(tacmap_precompiled PUBLIC TACMAP_PRECOMPILED=1)
  set_source_files_properties(src/simd_avx2.cpp PROPERTIES COMPILE_OPTIONS "-mavx2;-mfma")
  # Optimised in Debug builds too: it holds the hot kernels and the heavy members of the common
  # filters (a map's per-window descriptors take about a minute at -O0), and tacmap's own tools,
  # Python module and examples link it in every build. There and in the other targets optimised
  # in Debug builds, -g1 (line tables, for backtraces): full debug information of optimised
  # template code is a third of their compile time and debugs poorly anyway.
  target_compile_options(tacmap_precompiled PRIVATE "$<$<CONFIG:Debug>:-O2;-g1>")
  # Our own strict warnings, never exported (tacmap_dev_flags exists in top-level builds).
  target_link_libraries(tacmap_precompiled
    PRIVATE "$<BUILD_INTERFACE:$<$<TARGET_EXISTS:tacmap_dev_flags>:tacmap_dev_flags>>")
  if(NOT DEFINED TACMAP_INSTALL OR TACMAP_INSTALL)
    install(TARGETS tacmap_precompiled EXPORT tacmap-targets
            ARCHIVE DESTINATION "${CMAKE_INSTALL_LIBDIR}")
  endif()
endif()
unset(_tacmap_precompiled_possible)
unset(_tacmap_precompiled_default)
