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
//    `tacmap::localizer`, the default instantiation of the generic `basic_localizer`), and
//    their measurement-independent base `detail::filter_core` (the robust, latent motion's
//    `predict`, the estimate and its statistics, applying a log-likelihood, tracking's search),
//    which every `descriptor_localizer<D>` shares: a user's descriptor compiles only what
//    depends on it (its model and the filter's constructor and `update`) where it is used.
// Any other type works as before, compiled where it is used. The heavy members of these classes
// are defined out of the class (not inline): GCC instantiates inline members of an `extern
// template` anyway, to inline them, which would keep most of the cost.
#pragma once

// TACMAP_EXTERN_TEMPLATE: `extern template` for consumers of tacmap::precompiled, `template`
// (the definitions) in src/instantiations.cpp, undefined for header-only use.
// TACMAP_EXTERN_INSTANTIATIONS=1 declares the same instantiations `extern template` without the
// run-time SIMD dispatch: the header-only kernels, with the common models compiled once in
// another translation unit of the same build (src/instantiations.cpp compiled with the same
// flags and without TACMAP_PRECOMPILED). tacmap's benchmarks use it (bench/CMakeLists.txt:
// -O3 -march=x86-64-v3, which tacmap::precompiled is not built with).
#if defined(TACMAP_PRECOMPILED_DEFINE)
#define TACMAP_EXTERN_TEMPLATE template
#elif (defined(TACMAP_PRECOMPILED) && TACMAP_PRECOMPILED) || \
    (defined(TACMAP_EXTERN_INSTANTIATIONS) && TACMAP_EXTERN_INSTANTIATIONS)
#define TACMAP_EXTERN_TEMPLATE extern template
#endif

// A filter's heavy members, one by one rather than `template class bayes_filter<...>`: Clang 14
// instantiates constrained members whose constraints fail in a whole-class instantiation
// (bayes_filter::circular_moments on a planar grid), which the standard says it must not.
// TACMAP_EXTERN_FILTER: what depends on the measurement model (the constructor, `update`);
// TACMAP_EXTERN_FILTER_CORE: the rest, `detail::filter_core<Grid, Motion>` (`predict`, the
// estimate and its statistics, applying a log-likelihood, tracking's search), once per grid and
// motion model however many measurement models share them.
#define TACMAP_EXTERN_FILTER(Grid, Motion, Measurement)                                      \
  TACMAP_EXTERN_TEMPLATE bayes_filter<Grid, Motion, Measurement>::bayes_filter(Grid, Motion, \
                                                                               Measurement); \
  TACMAP_EXTERN_TEMPLATE update_report bayes_filter<Grid, Motion, Measurement>::update(      \
      const Measurement::measurement_type&)
#define TACMAP_EXTERN_FILTER_CORE(Grid, Motion)                                                 \
  TACMAP_EXTERN_TEMPLATE detail::filter_core<Grid, Motion>::filter_core(Grid, Motion);          \
  TACMAP_EXTERN_TEMPLATE prediction_report detail::filter_core<Grid, Motion>::predict(          \
      const Motion::control_type&);                                                             \
  TACMAP_EXTERN_TEMPLATE update_path detail::filter_core<Grid, Motion>::tracked_update(         \
      double, evaluate_on, update_report&, const tracked_region*);                              \
  TACMAP_EXTERN_TEMPLATE update_report detail::filter_core<Grid, Motion>::apply_log_likelihood( \
      const belief_array<Grid>&, const char*);                                                  \
  TACMAP_EXTERN_TEMPLATE state_estimate<Grid::dimension>                                        \
  detail::filter_core<Grid, Motion>::estimate() const;                                          \
  TACMAP_EXTERN_TEMPLATE double detail::filter_core<Grid, Motion>::probability_within(          \
      const Eigen::Vector2d&, double) const;                                                    \
  TACMAP_EXTERN_TEMPLATE std::pair<Eigen::Vector2d, double>                                     \
  detail::filter_core<Grid, Motion>::most_probable_disc(double) const
