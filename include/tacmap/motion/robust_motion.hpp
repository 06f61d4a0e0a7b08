// tacmap: `robust_motion` — any motion model, allowing that a move may land anywhere.
//
// The paper's motion model trusts the odometry: the predicted belief is the previous one moved
// by u and spread by a Gaussian of a few millimetres. When the odometry is wrong by more than
// that — an outlier sample, an object that slipped, a sensor put down elsewhere — the truth
// leaves the belief's support and no later touch can bring it back (the product of likelihoods
// is zero there). A heavy-tailed transition keeps a floor under every state:
//     p(x_t | x_{t-1}, u_t) = (1 - lambda) p_base(x_t | x_{t-1}, u_t) + lambda / N
//     bel_bar = (1 - lambda) base.predict(bel) + lambda / N
// with lambda the probability that a move lands the sensor anywhere on the map (N states). One
// pass over the belief on top of the base model's prediction, for any grid and any motion
// model. A touch that contradicts the prediction then moves the mass to where the touch fits,
// at a cost of log(1 / lambda) in evidence — so lambda is the price of recovering, and 0 gives
// the paper's model exactly. A move the base model cannot apply because it carries every state off
// the map (it throws std::domain_error) leaves, with a floor, a uniform belief: the sensor is
// somewhere on the map, and the touches will say where.
#pragma once

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>
#include <vector>

#include "tacmap/config.hpp"
#include "tacmap/grid/concept.hpp"
#include "tacmap/image.hpp"
#include "tacmap/motion/concept.hpp"

namespace tacmap {

/// Configuration of `robust_motion`.
struct robust_motion_params {
  /// lambda: the probability that a move lands the sensor anywhere on the map. 0: the base
  /// model as it is.
  double lost_probability = 0.0;
  /// w: the probability that a move is off by more than the base model's noise — a wide
  /// Gaussian component of `wide_sigma_mm` per axis around the base prediction (odometry
  /// outliers, noise larger than configured). 0: none.
  double wide_probability = 0.0;
  double wide_sigma_mm = 4.0;  ///< the wide component's spread, mm per axis

  void validate() const {
    if (!(std::isfinite(lost_probability) && lost_probability >= 0.0 && lost_probability < 1.0))
      detail::fail("robust_motion_params: lost_probability = ", lost_probability,
                   "; expected a probability in [0, 1) (e.g. 0.001; 0 = trust the odometry)");
    if (!(std::isfinite(wide_probability) && wide_probability >= 0.0 &&
          wide_probability + lost_probability < 1.0))
      detail::fail("robust_motion_params: wide_probability = ", wide_probability,
                   " (with lost_probability ", lost_probability,
                   "); expected >= 0 with the two summing to less than 1 (e.g. 0.1)");
    if (!(std::isfinite(wide_sigma_mm) && wide_sigma_mm > 0.0 && wide_sigma_mm <= 100.0))
      detail::fail("robust_motion_params: wide_sigma_mm = ", wide_sigma_mm,
                   "; expected a spread in (0, 100] mm (e.g. 4)");
  }
};

/// `M`'s prediction mixed with a uniform floor (see the file's comment). Models
/// `motion_model<G>` for every grid `M` does.
template <class M>
class robust_motion {
 public:
  using control_type = typename M::control_type;
  using base_type = M;

  /// Throws std::invalid_argument for a lost probability outside [0, 1).
  explicit robust_motion(M base, robust_motion_params params = {})
      : base_(std::move(base)), params_(params) {
    params_.validate();
  }

  template <state_grid G>
  requires motion_model<M, G> prediction_report predict(const G& grid, const belief_array<G>& in,
                                                        belief_array<G>& out, const control_type& u)
  const {
    const double lambda = params_.lost_probability;
    prediction_report report;
    try {
      report = base_.predict(grid, in, out, u);
    } catch (const std::domain_error&) {
      // The odometry carried every state off the map: trusted, that is a contradiction; with a
      // floor, the sensor is somewhere on the map — anywhere.
      if (lambda <= 0.0) throw;
      out.setConstant(static_cast<typename G::scalar_type>(1.0 / static_cast<double>(out.size())));
      return {.mass_lost = 1.0};
    }
    using scalar = typename G::scalar_type;
    const double w = params_.wide_probability;
    if (w > 0.0) {
      // out = (1 - w) out + w blur(out), the blur a Gaussian of wide_sigma_mm made of three
      // box passes per axis (variance r (r + 1) px^2 for radius r) over every rows x cols
      // plane; mass blurred off a plane's edge is dropped and the rest renormalised, as the
      // base model does with mass moved off the grid. Sliding sums in double, whole rows at a
      // time (vectorised); the plane is transposed once so both axes run that way.
      const Eigen::Index rows = grid.rows(), cols = grid.cols(), plane = rows * cols;
      const double pitch_x = cols > 1 ? std::abs(grid.state_mm(1)(0) - grid.state_mm(0)(0)) : 1.0;
      const double pitch_y =
          rows > 1 ? std::abs(grid.state_mm(cols)(1) - grid.state_mm(0)(1)) : 1.0;
      const Eigen::Index rx = box_radius(params_.wide_sigma_mm / pitch_x);
      const Eigen::Index ry = box_radius(params_.wide_sigma_mm / pitch_y);
      const auto keep = static_cast<scalar>(1.0 - w);
      for (Eigen::Index at = 0; at < out.size(); at += plane) {
        Eigen::Map<image<scalar>> img(out.data() + at, rows, cols);
        down_ = img.template cast<double>();
        box3_down(down_, scratch_, row_sum_, ry);  // along y
        across_ = down_.transpose();
        box3_down(across_, scratch_, row_sum_, rx);  // along x
        img = img * keep + (across_.transpose() * w).template cast<scalar>();
      }
      out /= out.sum();
    }
    if (lambda > 0.0)
      out = out * static_cast<scalar>(1.0 - lambda) +
            static_cast<scalar>(lambda / static_cast<double>(out.size()));
    return report;
  }

  [[nodiscard]] const M& base() const { return base_; }
  [[nodiscard]] M& base() { return base_; }
  [[nodiscard]] const robust_motion_params& params() const { return params_; }

 private:
  // Radius r of the box whose three passes have variance r (r + 1) closest to sigma^2 (px).
  static Eigen::Index box_radius(double sigma_px) {
    return std::max<Eigen::Index>(
        1, static_cast<Eigen::Index>(
               std::lround(0.5 * (std::sqrt(1.0 + 4.0 * sigma_px * sigma_px) - 1.0))));
  }

  // Three box passes of radius r down the columns of `a` (zero outside), `b` as scratch: each
  // output row is the mean of the 2 r + 1 input rows around it, kept as a running sum of whole
  // rows (`sum`, reused: no allocation per prediction). Clamped at 0: the running sum's rounding
  // must not make a state negative.
  static void box3_down(image<double>& a, image<double>& b, std::vector<double>& sum,
                        Eigen::Index r) {
    const Eigen::Index rows = a.rows(), cols = a.cols();
    b.resize(rows, cols);
    const double norm = 1.0 / static_cast<double>(2 * r + 1);
    sum.resize(static_cast<std::size_t>(cols));
    double* s = sum.data();
    // Plain loops over contiguous rows (the compiler vectorises them): rows are short (~100),
    // and an Eigen expression per row costs more than its arithmetic.
    for (int pass = 0; pass < 3; ++pass) {
      std::fill(sum.begin(), sum.end(), 0.0);
      for (Eigen::Index i = 0; i < std::min(r, rows); ++i) {
        const double* in = a.data() + i * cols;
        for (Eigen::Index c = 0; c < cols; ++c) s[c] += in[c];
      }
      for (Eigen::Index i = 0; i < rows; ++i) {
        double* out = b.data() + i * cols;
        const double* hi = i + r < rows ? a.data() + (i + r) * cols : nullptr;
        const double* lo = i - r - 1 >= 0 ? a.data() + (i - r - 1) * cols : nullptr;
        if (hi && lo) {  // the common case, one fused loop
          for (Eigen::Index c = 0; c < cols; ++c) {
            s[c] += hi[c] - lo[c];
            out[c] = std::max(s[c] * norm, 0.0);
          }
          continue;
        }
        for (Eigen::Index c = 0; c < cols; ++c) {
          if (hi) s[c] += hi[c];
          if (lo) s[c] -= lo[c];
          out[c] = std::max(s[c] * norm, 0.0);
        }
      }
      a.swap(b);
    }
  }

  M base_;
  robust_motion_params params_;
  // Scratch of the wide component (reused between predictions): a plane, its transpose, and
  // the passes' other buffer, the running sum of rows.
  mutable image<double> down_, across_, scratch_;
  mutable std::vector<double> row_sum_;
};

}  // namespace tacmap
