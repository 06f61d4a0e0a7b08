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
      // base model does with mass moved off the grid.
      wide_ = out.template cast<double>();
      const Eigen::Index rows = grid.rows(), cols = grid.cols(), plane = rows * cols;
      const double pitch_x = cols > 1 ? std::abs(grid.state_mm(1)(0) - grid.state_mm(0)(0)) : 1.0;
      const double pitch_y =
          rows > 1 ? std::abs(grid.state_mm(cols)(1) - grid.state_mm(0)(1)) : 1.0;
      for (Eigen::Index at = 0; at < out.size(); at += plane) {
        Eigen::Map<image<double>> img(wide_.data() + at, rows, cols);
        box_blur_rows(img, box_radius(params_.wide_sigma_mm / pitch_x));
        box_blur_cols(img, box_radius(params_.wide_sigma_mm / pitch_y));
      }
      out = out * static_cast<scalar>(1.0 - w) + (wide_ * w).template cast<scalar>();
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

  // Three box passes of radius r along each row (zero outside).
  template <class Img>
  void box_blur_rows(Img& img, Eigen::Index r) const {
    using scalar = typename Img::Scalar;
    const Eigen::Index cols = img.cols();
    line_.resize(cols + 1);
    const auto norm = static_cast<scalar>(1.0 / static_cast<double>(2 * r + 1));
    for (int pass = 0; pass < 3; ++pass)
      for (Eigen::Index row = 0; row < img.rows(); ++row) {
        line_(0) = 0;
        for (Eigen::Index c = 0; c < cols; ++c)
          line_(c + 1) = line_(c) + static_cast<double>(img(row, c));
        for (Eigen::Index c = 0; c < cols; ++c)
          img(row, c) = static_cast<scalar>(line_(std::min(cols, c + r + 1)) -
                                            line_(std::max<Eigen::Index>(0, c - r))) *
                        norm;
      }
  }

  // Three box passes of radius r down each column: running sums of whole rows.
  template <class Img>
  void box_blur_cols(Img& img, Eigen::Index r) const {
    using scalar = typename Img::Scalar;
    const Eigen::Index rows = img.rows(), cols = img.cols();
    prefix_.resize(rows + 1, cols);
    const double norm = 1.0 / static_cast<double>(2 * r + 1);
    for (int pass = 0; pass < 3; ++pass) {
      prefix_.row(0).setZero();
      for (Eigen::Index row = 0; row < rows; ++row)
        prefix_.row(row + 1) = prefix_.row(row) + img.row(row).template cast<double>();
      for (Eigen::Index row = 0; row < rows; ++row)
        img.row(row) = ((prefix_.row(std::min(rows, row + r + 1)) -
                         prefix_.row(std::max<Eigen::Index>(0, row - r))) *
                        norm)
                           .template cast<scalar>();
    }
  }

  M base_;
  robust_motion_params params_;
  // Scratch of the wide component (reused between predictions).
  mutable Eigen::ArrayXd wide_;
  mutable Eigen::ArrayXd line_;
  mutable image<double> prefix_;
};

}  // namespace tacmap
