# Strict warnings for tacmap's own targets only (tests, examples, bench). They live in a private
# INTERFACE target so that nothing here reaches a consumer of tacmap::tacmap.
add_library(tacmap_dev_flags INTERFACE)
if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
  target_compile_options(tacmap_dev_flags INTERFACE
    -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wsign-conversion -Wold-style-cast
    -Wnon-virtual-dtor -Woverloaded-virtual)
  if(TACMAP_WARNINGS_AS_ERRORS)
    target_compile_options(tacmap_dev_flags INTERFACE -Werror)
    # Known false positives from Eigen 3.4 and libstdc++ 12 under g++ 12 (see shared reference:
    # toolchain); -Wrestrict fires inside std::string concatenation at -O2.
    if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
      target_compile_options(tacmap_dev_flags INTERFACE
        -Wno-error=array-bounds -Wno-error=maybe-uninitialized -Wno-error=null-dereference
        -Wno-error=stringop-overflow -Wno-error=restrict)
    endif()
  endif()
endif()
