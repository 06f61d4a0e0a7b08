// Shared by localizer_api.cpp and library_localizer_api.cpp: a localizer_config, a small map and
// tactile frames decoded from the fuzz input (fuzz_input.hpp), and the checks every result and
// belief must pass.
//
// Maps are small (at most 32 x 32 px) and pose grids have at most 3 headings: building a
// localizer is the expensive part of an execution (measured under ASan and libFuzzer's
// instrumentation: up to 210 ms for one seed's localizer with maps of up to 48 x 48 px, against
// about 6 ms for its touches on the cached localizer), so the targets cache built localizers and
// keep what a cache miss costs small.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "tacmap/localizer.hpp"

namespace tacmap_fuzz {

/// A double as a float, saturating (a double beyond the float range becomes +-infinity instead
/// of the undefined conversion); NaN stays NaN.
inline float to_float(double v) {
  if (std::isnan(v)) return std::numeric_limits<float>::quiet_NaN();
  constexpr double top = std::numeric_limits<float>::max();
  if (v > top) return std::numeric_limits<float>::infinity();
  if (v < -top) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(v);
}

inline tacmap::localizer_config read_config(input& in) {
  tacmap::localizer_config c;
  c.model = in.choice<tacmap::measurement_kind>(3);
  c.pairs = in.choice<tacmap::pairing>(2);
  c.shape = in.choice<tacmap::likelihood_shape>(2);
  c.features = in.choice<tacmap::window_features>(2);
  c.storage = in.choice<tacmap::descriptor_storage>(2);
  c.tau = in.maybe_real(0.01, 1.0);
  if (in.flag()) c.patch_spacing = in.between(-1, 24);
  c.tempering = in.real(0.0, 2.0);
  c.motion_sigma_mm = in.real(0.1, 5.0);
  c.motion_k = in.between(-1, 12);
  c.preprocessing.min_peak = to_float(in.real(0.0, 500.0));
  c.preprocessing.min_total = to_float(in.real(0.0, 1500.0));
  c.preprocessing.min_contrast = to_float(in.real(0.0, 1.0));
  c.preprocessing.resize = in.choice<tacmap::resize_method>(2);
  c.confidence.radius_mm = in.real(0.5, 10.0);
  c.confidence.threshold = in.real(0.0, 1.0);
  c.confidence.heading_tolerance_rad = in.real(0.05, 1.0);
  c.confidence.contradiction = in.real(-5.0, 0.0);
  // Mostly the known heading (the cheap planar filter); otherwise a few headings or a
  // negative count.
  const std::uint8_t headings = in.byte();
  c.headings = headings < 192 ? 0 : static_cast<int>(headings % 5) - 1;
  c.turn_sigma_rad = in.real(0.01, 0.5);
  c.appearance = in.choice<tacmap::appearance_handling>(4);
  c.appearance_switch = in.maybe_real(0.0, 0.5);
  c.lost_probability = in.maybe_real(0.0, 0.1);
  c.wide_probability = in.maybe_real(0.0, 0.5);
  c.wide_sigma_mm = in.real(0.5, 10.0);
  c.broad_probability = in.maybe_real(0.0, 0.2);
  c.broad_sigma_mm = in.real(1.0, 20.0);
  return c;
}

/// A sensor: mostly the paper's 14 x 6 array at 3.4 mm, else a small random one.
inline tacmap::taxel_geometry read_sensor(input& in) {
  if (!in.flag()) return {};
  return {.rows = in.between(0, 16), .cols = in.between(0, 16), .pitch_mm = in.real(0.5, 6.0)};
}

/// A map of at most 32 x 32 px: noise, a constant, blobs, stripes, any intensity range, or one
/// non-finite pixel.
inline tacmap::image<float> read_map(input& in) {
  const Eigen::Index rows = in.between(1, 32);
  const Eigen::Index cols = in.between(1, 32);
  const std::uint8_t mode = in.byte();
  const double offset = in.real(0.0, 1.0);
  const double scale = in.real(0.0, 1.0);
  random_bits bits(in.u32());
  tacmap::image<float> map(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c) {
      double v = 0.0;
      switch (mode % 5) {
        case 0:  // noise
          v = bits.unit();
          break;
        case 1:  // constant
          v = 0.0;
          break;
        case 2:  // stripes
          v = ((r / 3 + c / 5) % 2 == 0) ? 1.0 : 0.0;
          break;
        case 3:  // smooth blobs
          v = std::sin(0.37 * static_cast<double>(r)) * std::cos(0.23 * static_cast<double>(c));
          break;
        default:  // coarse noise: 4 x 4 px cells
          v = static_cast<double>(random_bits(static_cast<std::uint64_t>((r / 4) * 64 + c / 4) +
                                              static_cast<std::uint64_t>(mode))
                                      .unit());
          break;
      }
      map(r, c) = to_float(offset + scale * v);
    }
  if ((mode & 0x80U) != 0U) {  // one pixel from the edge table (often non-finite)
    const Eigen::Index k =
        static_cast<Eigen::Index>(bits.next() % static_cast<std::uint64_t>(map.size()));
    map.data()[k] = to_float(input::edge(static_cast<std::uint8_t>(mode >> 3U)));
  }
  return map;
}

/// A frame for `sensor`: a pressed blob (the common case), nothing, a flat or saturated press,
/// a value from the edge table in one taxel, or counts of the wrong shape.
inline tacmap::tactile_frame read_frame(input& in, const tacmap::taxel_geometry& sensor) {
  tacmap::tactile_frame f;
  f.geometry = sensor;
  const std::uint8_t mode = in.byte();
  const Eigen::Index rows = std::max<Eigen::Index>(sensor.rows, 0);
  const Eigen::Index cols = std::max<Eigen::Index>(sensor.cols, 0);
  f.counts = tacmap::image<float>::Zero(rows, cols);
  const double amplitude = in.real(0.0, 4095.0);
  random_bits bits(in.u16());
  switch (mode % 6) {
    case 0:
    case 1:
    case 2: {  // a blob at a random place, with noise
      const double cr = static_cast<double>(rows) * bits.unit();
      const double cc = static_cast<double>(cols) * bits.unit();
      const double spread = 0.5 + 3.0 * bits.unit();
      for (Eigen::Index r = 0; r < rows; ++r)
        for (Eigen::Index c = 0; c < cols; ++c) {
          const double d2 = (static_cast<double>(r) - cr) * (static_cast<double>(r) - cr) +
                            (static_cast<double>(c) - cc) * (static_cast<double>(c) - cc);
          f.counts(r, c) =
              to_float(amplitude * std::exp(-d2 / (2.0 * spread * spread)) + 20.0 * bits.unit());
        }
      break;
    }
    case 3:  // no contact
      break;
    case 4:  // flat: every taxel alike
      f.counts.setConstant(to_float(amplitude));
      break;
    default:  // counts of another shape
      f.counts = tacmap::image<float>::Constant(static_cast<Eigen::Index>(mode % 3) + rows / 2,
                                                cols + 1, to_float(amplitude));
      break;
  }
  if ((mode & 0x80U) != 0U && f.counts.size() > 0) {
    const Eigen::Index k =
        static_cast<Eigen::Index>(bits.next() % static_cast<std::uint64_t>(f.counts.size()));
    f.counts.data()[k] = to_float(input::edge(static_cast<std::uint8_t>(mode >> 3U)));
  }
  return f;
}

/// How far from 1 a float belief's sum may be: normalised in float lanes (issue 37, section 2),
/// the beliefs here (at most 32 x 32 positions x 3 headings x 2 appearances) have been seen
/// 2.9e-6 off; 1e-4 leaves room without hiding lost mass.
inline constexpr double sum_tolerance = 1e-4;

/// A probability computed from a float belief: in [0, 1] up to the float sums' rounding (an
/// appearance posterior of 1.0000029 has been seen: a hypothesis holding all the mass of a
/// belief that sums to 1 + 2.9e-6).
inline bool probability(double p) { return p >= 0.0 && p <= 1.0 + sum_tolerance; }

/// A belief image (position belief, conditioned or marginal): finite, non-negative, summing
/// to 1.
inline void check_belief(const tacmap::image<float>& b) {
  TACMAP_FUZZ_CHECK(b.size() > 0);
  TACMAP_FUZZ_CHECK(b.allFinite());
  TACMAP_FUZZ_CHECK((b >= 0.0F).all());
  const double sum = b.cast<double>().sum();
  TACMAP_FUZZ_CHECK_MSG(std::abs(sum - 1.0) < sum_tolerance, "belief sum %.17g over %ld states",
                        sum, static_cast<long>(b.size()));
}

/// Hypothesis posteriors (appearances, objects): each a probability, summing to 1.
inline void check_distribution(const std::vector<double>& p) {
  TACMAP_FUZZ_CHECK(!p.empty());
  double sum = 0.0;
  for (const double v : p) {
    TACMAP_FUZZ_CHECK_MSG(probability(v), "posterior %.17g", v);
    sum += v;
  }
  TACMAP_FUZZ_CHECK_MSG(std::abs(sum - 1.0) < sum_tolerance, "%zu posteriors sum to %.17g",
                        p.size(), sum);
}

}  // namespace tacmap_fuzz
