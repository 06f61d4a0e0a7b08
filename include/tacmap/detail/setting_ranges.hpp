// tacmap: the ranges in which the models' numeric settings keep every touch finite (issue 37,
// "No silent resets"), and the check that refuses a setting outside its range up front.
//
// "Finite and > 0" was not enough: a motion sigma of 1e-160 mm squares to 0 in double, the
// stencil's 1 / (2 sigma^2) overflows and every weight became NaN ("moves all belief mass off the
// grid"); tempering 1e300 or tau 1e-300 overflow the float log-likelihood's factor
// tempering / tau to infinity, and a touch became -infinity or NaN everywhere. The localizer then
// restarted from a uniform belief at every touch, silently. Each bound below is where the model
// stops being finite, moved a few orders of magnitude inward so that the edge itself is an
// ordinary, tested setting (tests/localizer/test_setting_ranges.cpp).
#pragma once

#include <cmath>
#include <stdexcept>

#include "tacmap/image.hpp"

namespace tacmap::detail {

/// Motion noise (odometry_gaussian, pose odometry, the localizer's motion_sigma_mm), mm: from
/// a micrometre (far below any arm's repeatability; a stencil's 1 / (2 sigma^2) overflows
/// double only below ~1e-154 px) to a kilometre.
inline constexpr double min_sigma_mm = 1e-3;
inline constexpr double max_sigma_mm = 1e6;
/// Turn noise (pose odometry), radians: from a microradian; any larger spread is a wrapped
/// Gaussian that is flat at worst.
inline constexpr double min_sigma_rad = 1e-6;
inline constexpr double max_sigma_rad = 1e6;
/// Temperature of the exponential and NCC likelihoods (descriptor distance units, or NCC units).
inline constexpr double min_tau = 1e-6;
inline constexpr double max_tau = 1e6;
/// Exponent on the likelihood. With tau >= min_tau the float factor tempering / tau is at most
/// 1e9: the exponential shape's log-likelihood -tempering d / tau overflows float only for a
/// touch's summed descriptor distance d above 3e29 (1.5e29 pairs of unit-norm descriptors, more
/// than any memory holds), eq. (2)'s is at most 1e3 x 69 in size, and NCC's (|ncc| <= 1) at
/// most 1e9.
inline constexpr double max_tempering = 1e3;
/// Eq. (2)'s guard epsilon: log(d + epsilon) finite in float (normal floats start at 1.2e-38,
/// the largest is 3.4e38).
inline constexpr double min_epsilon = 1e-30;
inline constexpr double max_epsilon = 1e30;

/// The sensor's spread on the map (localizer_config::pad_spread_mm), mm: 0 (none) to 100 mm, a
/// blur wider than any tactile array; its size in map pixels is checked where the map's scale
/// is known (`gaussian_blurred`: at most 1000 px).
inline constexpr double max_pad_spread_mm = 100.0;

/// A map's scale, mm per pixel: from a nanometre per pixel (an electron micrograph) to a metre
/// (an aerial photograph). The grids' lattice step is this scale, and the motion models turn a
/// spread in mm into whole states (sigma / step, an Eigen::Index): with every spread <= 1e6 mm
/// and the step >= 1e-6 mm that is at most 1e12 states, where 1e-160 mm overflowed it.
inline constexpr double min_mm_per_px = 1e-6;
inline constexpr double max_mm_per_px = 1e3;

/// Throws std::invalid_argument unless lo <= value <= hi (NaN fails): "<who>: <name> = <value>;
/// expected <what> in [lo, hi] <unit> (<why>); <advice>".
inline void check_range(const char* who, const char* name, double value, double lo, double hi,
                        const char* unit, const char* what, const char* advice) {
  if (value >= lo && value <= hi) return;
  fail(who, ": ", name, " = ", value, "; expected ", what, " in [", lo, ", ", hi, "]", unit,
       ", the range in which the model stays finite; ", advice);
}

}  // namespace tacmap::detail
