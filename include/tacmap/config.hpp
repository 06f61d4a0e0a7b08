// tacmap: version macros and the one overridable contract hook.
//
// The version below is the single source of truth: CMake reads it from this file.
#pragma once

#define TACMAP_VERSION_MAJOR 0
#define TACMAP_VERSION_MINOR 1
#define TACMAP_VERSION_PATCH 0
#define TACMAP_VERSION \
  (TACMAP_VERSION_MAJOR * 10000 + TACMAP_VERSION_MINOR * 100 + TACMAP_VERSION_PATCH)

// TACMAP_ASSERT(cond, message) guards *programming errors* inside tacmap (a broken invariant,
// an index a caller already validated). It is not for bad input: device, file and user-input
// errors are reported as exceptions whose messages name the value, the expectation and the fix.
//
// Define TACMAP_ASSERT before including any tacmap header to route contract failures into your
// own handler (throw, log, break into a debugger). By default a failure prints where and why
// and aborts, in every build type: a broken invariant must not continue into a NaN belief.
#ifndef TACMAP_ASSERT
#include <cstdio>
#include <cstdlib>
#define TACMAP_ASSERT(cond, message)                                                            \
  do {                                                                                          \
    if (!(cond)) {                                                                              \
      std::fprintf(stderr, "tacmap: contract violated at %s:%d: %s (%s)\n", __FILE__, __LINE__, \
                   message, #cond);                                                             \
      std::abort();                                                                             \
    }                                                                                           \
  } while (false)
#endif
