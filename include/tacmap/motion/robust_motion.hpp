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

  void validate() const {
    if (!(std::isfinite(lost_probability) && lost_probability >= 0.0 && lost_probability < 1.0))
      detail::fail("robust_motion_params: lost_probability = ", lost_probability,
                   "; expected a probability in [0, 1) (e.g. 0.001; 0 = trust the odometry)");
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
    if (lambda > 0.0) {
      using scalar = typename G::scalar_type;
      out = out * static_cast<scalar>(1.0 - lambda) +
            static_cast<scalar>(lambda / static_cast<double>(out.size()));
    }
    return report;
  }

  [[nodiscard]] const M& base() const { return base_; }
  [[nodiscard]] M& base() { return base_; }
  [[nodiscard]] const robust_motion_params& params() const { return params_; }

 private:
  M base_;
  robust_motion_params params_;
};

}  // namespace tacmap
