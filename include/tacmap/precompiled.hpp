// tacmap: the common models that tacmap::precompiled compiles once (issue 17: compile time).
//
// With tacmap::precompiled linked (TACMAP_PRECOMPILED), the headers that define them declare
// these instantiations `extern template`, so a translation unit that uses them links the
// library's copy (src/instantiations.cpp) instead of compiling it again:
//  * dense_sift.hpp: sift_lite and classic_sift (float);
//  * descriptor_likelihood.hpp: descriptor_likelihood<sift_lite / classic_sift> (with its
//    log_likelihood on planar_grid<float>) and bayes_filter<planar_grid<float>,
//    odometry_gaussian, descriptor_likelihood<...>>;
//  * rotated_descriptor_likelihood.hpp: rotated_descriptor_likelihood<sift_lite / classic_sift>
//    and bayes_filter<pose_grid<float>, pose_odometry_gaussian,
//    rotated_descriptor_likelihood<...>>.
//  * localizer.hpp: planar_localizer_filter and pose_localizer_filter (the filters of
//    `tacmap::localizer`, the default instantiation of the generic `basic_localizer`; a
//    `descriptor_localizer<D>` of a user's descriptor compiles its own where it is used).
// Any other type works as before, compiled where it is used. The heavy members of these classes
// are defined out of the class (not inline): GCC instantiates inline members of an `extern
// template` anyway, to inline them, which would keep most of the cost.
#pragma once

// TACMAP_EXTERN_TEMPLATE: `extern template` for consumers of tacmap::precompiled, `template`
// (the definitions) in src/instantiations.cpp, undefined for header-only use.
#if defined(TACMAP_PRECOMPILED_DEFINE)
#define TACMAP_EXTERN_TEMPLATE template
#elif defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED
#define TACMAP_EXTERN_TEMPLATE extern template
#endif

// A filter's heavy members, one by one rather than `template class bayes_filter<...>`: Clang 14
// instantiates constrained members whose constraints fail in a whole-class instantiation
// (bayes_filter::circular_moments on a planar grid), which the standard says it must not.
#define TACMAP_EXTERN_FILTER(Grid, Motion, Measurement)                                      \
  TACMAP_EXTERN_TEMPLATE bayes_filter<Grid, Motion, Measurement>::bayes_filter(Grid, Motion, \
                                                                               Measurement); \
  TACMAP_EXTERN_TEMPLATE prediction_report bayes_filter<Grid, Motion, Measurement>::predict( \
      const Motion::control_type&);                                                          \
  TACMAP_EXTERN_TEMPLATE update_report bayes_filter<Grid, Motion, Measurement>::update(      \
      const Measurement::measurement_type&);                                                 \
  TACMAP_EXTERN_TEMPLATE state_estimate<Grid::dimension>                                     \
  bayes_filter<Grid, Motion, Measurement>::estimate() const
