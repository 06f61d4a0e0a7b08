// Shared by the fuzz targets: a property check that stops the fuzzer (and the corpus replay
// under CTest) with a message, in every build type.
#pragma once

#include <cstdio>
#include <cstdlib>

#define TACMAP_FUZZ_CHECK(cond)                                                                 \
  do {                                                                                          \
    if (!(cond)) {                                                                              \
      std::fprintf(stderr, "fuzz property violated at %s:%d: %s\n", __FILE__, __LINE__, #cond); \
      std::abort();                                                                             \
    }                                                                                           \
  } while (false)

// As TACMAP_FUZZ_CHECK, printing the values involved (printf format and arguments) first.
#define TACMAP_FUZZ_CHECK_MSG(cond, ...)                                                          \
  do {                                                                                            \
    if (!(cond)) {                                                                                \
      std::fprintf(stderr, "fuzz property violated at %s:%d: %s\n  ", __FILE__, __LINE__, #cond); \
      std::fprintf(stderr, __VA_ARGS__);                                                          \
      std::fprintf(stderr, "\n");                                                                 \
      std::abort();                                                                               \
    }                                                                                             \
  } while (false)
