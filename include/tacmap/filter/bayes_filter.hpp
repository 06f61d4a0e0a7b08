// tacmap: `bayes_filter` — THE recursive Bayes filter of the paper's Table 1, over a grid.
//
//   control update:      bel_bar(x_t) = sum_{x_{t-1}} p(x_t | u_t, x_{t-1}) bel(x_{t-1})
//   measurement update:  bel(x_t)     = eta p(z_t | x_t) bel_bar(x_t)
//
// The grid, the motion model and the measurement model are policies (configured values) that
// act on the whole belief at once. The initial belief is uniform: the paper assumes no prior
// knowledge of where the sensor is (Sec. III-A); `set_prior` takes a user prior instead.
#pragma once

#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "tacmap/angle.hpp"
#include "tacmap/filter/detail/posterior_kernel.hpp"
#include "tacmap/grid/concept.hpp"
#include "tacmap/grid/latent_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/measurement/concept.hpp"
#include "tacmap/motion/concept.hpp"

namespace tacmap {

/// Summary of a belief in the map frame (millimetres; radians for angles).
///
/// Over a `latent_grid` (a discrete latent variable such as the object's appearance) every
/// figure describes the *position* marginal p(x) = sum_h bel(h, x) — where the sensor is,
/// whatever the hypothesis — and `hypothesis_probability` holds p(h) = sum_x bel(h, x).
template <int Dimension>
struct state_estimate {
  using vector_type = Eigen::Matrix<double, Dimension, 1>;
  using matrix_type = Eigen::Matrix<double, Dimension, Dimension>;
  /// Index of the most probable state (MAP). Latent grids: the most probable position, in the
  /// block of the most probable hypothesis (`map_hypothesis`).
  Eigen::Index map_index = 0;
  vector_type map_mm;            ///< the MAP state's coordinates
  double map_probability = 0.0;  ///< its posterior probability (latent: summed over hypotheses)
  vector_type mean_mm;           ///< posterior mean
  matrix_type covariance_mm2;    ///< posterior covariance
  /// -sum p log p of the position belief: 0 when certain, log(N) when uniform over N positions.
  double entropy_nats = 0.0;
  /// Latent grids: the posterior of each hypothesis (sums to 1; names in the grid's
  /// `hypothesis_name(h)`). Empty for grids without a latent variable.
  std::vector<double> hypothesis_probability;
  /// Latent grids: the most probable hypothesis (0 otherwise). Equal posteriors (e.g. a map
  /// whose appearances cannot be told apart) show as equal `hypothesis_probability` values;
  /// the lowest index is named here.
  Eigen::Index map_hypothesis = 0;
};

/// What one measurement update reports.
struct update_report {
  /// log of the normaliser eta^-1 = sum_x p(z | x) bel_bar(x), relative to the likelihood's
  /// maximum: 0 when the prediction put all its mass on the best-matching states, very negative
  /// when the measurement contradicts the prediction (a hint of a bad touch or bad odometry).
  double log_evidence = 0.0;
  /// The largest log-likelihood of the touch, max_x log p(z | x), in the model's own units.
  double log_likelihood_max = 0.0;
  /// log p(z_t | z_1..t-1) = log sum_x p(z | x) bel_bar(x) in the model's units: the evidence of
  /// the whole touch. Summed over a sequence it is the log marginal likelihood of the data under
  /// the filter, so two filters whose models share a likelihood scale (the same descriptor and
  /// tau, e.g. on two different maps) are compared by the difference of their sums: the log
  /// Bayes factor. Meaningful as a probability only with a calibrated scale (tacmap-calibrate).
  [[nodiscard]] double log_marginal_likelihood() const { return log_likelihood_max + log_evidence; }
  /// How much better the prediction explains the touch than not knowing where the sensor is:
  /// log [ sum_x p(z | x) bel_bar(x) / (1/N sum_x p(z | x)) ], the log Bayes factor of the
  /// predicted belief against a uniform one over the N states. 0 when the prediction is
  /// uniform (the first touch), up to log N when the prediction sits exactly on the best
  /// matches, negative when the touch fits somewhere the filter did not expect better than
  /// where it did: the signal that odometry, a slip or a kidnap broke the prediction. Unlike
  /// `log_evidence` it needs no reference level: it is a ratio of two evidences of one touch
  /// (`confidence_params::contradiction` in filter/confidence.hpp turns it into a verdict).
  double log_prediction_support = 0.0;
};

/// Grids that flag some coordinates as angles: `static constexpr std::array<bool, dimension>
/// circular` (pose_grid: theta). `estimate()` then uses circular statistics for them.
template <class G>
concept has_circular_coordinates = requires {
  { G::circular[0] } -> std::convertible_to<bool>;
  requires std::tuple_size_v<std::remove_cvref_t<decltype(G::circular)>>
  == G::dimension;
};

/// The recursive Bayes filter over `Grid`, with the `Motion` and `Measurement` policies.
/// The belief's precision is `Grid::scalar_type` (float or double).
template <state_grid Grid, motion_model<Grid> Motion, measurement_model<Grid> Measurement>
class bayes_filter {
 public:
  using grid_type = Grid;
  using motion_type = Motion;
  using measurement_model_type = Measurement;
  using scalar_type = typename Grid::scalar_type;
  using belief_type = belief_array<Grid>;
  using control_type = typename Motion::control_type;
  using measurement_type = typename Measurement::measurement_type;
  using estimate_type = state_estimate<Grid::dimension>;

  /// A filter with a uniform initial belief.
  bayes_filter(Grid grid, Motion motion, Measurement measurement);

  /// Back to the uniform belief (no knowledge of where the sensor is).
  void reset() { belief_.setConstant(scalar_type(1) / static_cast<scalar_type>(grid_.size())); }

  /// Replaces the belief by a user prior: either a flat array of `size()` values or an image of
  /// `rows() x cols()` (single-layer grids). Values must be finite and >= 0 with a positive
  /// sum; they are normalised. Throws std::invalid_argument otherwise, belief unchanged.
  template <class Derived>
  void set_prior(const Eigen::DenseBase<Derived>& prior) {
    const Eigen::Index n = grid_.size();
    if (prior.rows() == n && prior.cols() == 1) {
      scratch_ = prior.derived().template cast<scalar_type>();
    } else if (prior.rows() == grid_.rows() && prior.cols() == grid_.cols() &&
               n == grid_.rows() * grid_.cols()) {
      Eigen::Map<image<scalar_type>>(scratch_.data(), grid_.rows(), grid_.cols()) =
          prior.derived().template cast<scalar_type>();
    } else {
      detail::fail("bayes_filter::set_prior: prior is ", prior.rows(), " x ", prior.cols(),
                   "; expected ", n, " x 1 (one value per state) or the belief image ",
                   grid_.rows(), " x ", grid_.cols());
    }
    for (Eigen::Index i = 0; i < n; ++i)
      if (!(std::isfinite(scratch_(i)) && scratch_(i) >= 0))
        detail::fail("bayes_filter::set_prior: prior value ", scratch_(i), " at state ", i,
                     "; expected finite probabilities >= 0");
    const double total = static_cast<double>(scratch_.sum());
    if (!(total > 0.0 && std::isfinite(total)))
      detail::fail("bayes_filter::set_prior: the prior sums to ", total,
                   "; expected a positive, finite total (it is normalised for you)");
    normalise(scratch_, total);
    belief_.swap(scratch_);
  }

  /// Control update with odometry `u`. If the motion model throws (invalid odometry, all mass
  /// off the grid) the exception propagates and the belief is unchanged.
  prediction_report predict(const control_type& u);

  /// Measurement update with measurement `z`, through the measurement model.
  update_report update(const measurement_type& z);

  /// Measurement update with a log-likelihood computed elsewhere: a flat array of `size()`
  /// values, or an image of `rows() x cols()` for single-layer grids.
  template <class Derived>
  update_report update_log_likelihood(const Eigen::DenseBase<Derived>& log_likelihood) {
    const Eigen::Index n = grid_.size();
    if (log_likelihood.rows() == n && log_likelihood.cols() == 1) {
      log_likelihood_ = log_likelihood.derived().template cast<scalar_type>();
    } else if (log_likelihood.rows() == grid_.rows() && log_likelihood.cols() == grid_.cols() &&
               n == grid_.rows() * grid_.cols()) {
      Eigen::Map<image<scalar_type>>(log_likelihood_.data(), grid_.rows(), grid_.cols()) =
          log_likelihood.derived().template cast<scalar_type>();
    } else {
      detail::fail("bayes_filter::update_log_likelihood: log-likelihood is ", log_likelihood.rows(),
                   " x ", log_likelihood.cols(), "; expected ", n,
                   " x 1 (one value per state) or the belief image ", grid_.rows(), " x ",
                   grid_.cols());
    }
    return apply_log_likelihood(log_likelihood_, "the given log-likelihood");
  }

  /// Predict with `u`, then update with `z` (one step of Table 1).
  update_report step(const control_type& u, const measurement_type& z) {
    predict(u);
    return update(z);
  }

  /// The belief, one probability per state (sums to 1).
  [[nodiscard]] const belief_type& belief() const { return belief_; }

  /// One layer of the belief as a `rows() x cols()` image (row-major), e.g. for a heat map.
  [[nodiscard]] Eigen::Map<const image<scalar_type>> belief_image(Eigen::Index layer = 0) const {
    const Eigen::Index plane = grid_.rows() * grid_.cols();
    TACMAP_ASSERT(layer >= 0 && (layer + 1) * plane <= grid_.size(), "belief layer out of range");
    return {belief_.data() + layer * plane, grid_.rows(), grid_.cols()};
  }

  /// MAP state, mean, covariance and entropy of the belief, in the map frame (mm); over a
  /// latent grid, of the position marginal, with each hypothesis's posterior (see
  /// `state_estimate`).
  [[nodiscard]] estimate_type estimate() const;

  /// The belief's probability that the sensor's position (x, y) lies within `radius_mm` of
  /// `center_mm` (map frame, mm), whatever its heading or latent hypothesis: the mass of the
  /// states whose centres are at most `radius_mm` away. With `center_mm` the estimate, this is
  /// the belief's own claim that the estimate is within `radius_mm` of the truth — calibrated
  /// when it matches how often that is so (README, "Confidence"). Throws std::invalid_argument
  /// for a non-finite centre or a radius that is negative or not finite.
  [[nodiscard]] double probability_within(const Eigen::Vector2d& center_mm, double radius_mm) const
      requires(Grid::dimension >= 2) {
    if (!center_mm.allFinite())
      detail::fail("bayes_filter::probability_within: centre (", center_mm(0), ", ", center_mm(1),
                   ") mm; expected finite map coordinates");
    if (!(std::isfinite(radius_mm) && radius_mm >= 0.0))
      detail::fail("bayes_filter::probability_within: radius ", radius_mm,
                   " mm; expected a finite radius >= 0");
    const Eigen::Vector2d c = center_mm - origin_mm_.template head<2>();
    const double r2 = radius_mm * radius_mm;
    return masked_mass([&](Eigen::Index i) {
      return (offsets_mm_.col(i).template head<2>() - c).squaredNorm() <= r2;
    });
  }

  /// The position whose disc of `radius_mm` holds the most belief (x, y; whatever the heading
  /// or latent hypothesis: the belief's mean inside the best disc of the lattice), and the mass
  /// of its disc: the estimate most probably within `radius_mm` of the truth, and the belief's
  /// probability that it is. Where the MAP state is one sharp peak the
  /// two agree; where the belief is spread over a region (a smooth map, a repeated texture)
  /// the disc's centre sits where most of the mass is, not on the highest single state. The
  /// grid's positions must form a regular lattice (planar_grid, pose_grid: one state per map
  /// pixel); throws std::logic_error otherwise, std::invalid_argument for a radius that is
  /// negative or not finite. Uses scratch kept in the filter: not for concurrent calls on one
  /// filter (like every other member).
  [[nodiscard]] std::pair<Eigen::Vector2d, double> most_probable_disc(double radius_mm) const
      requires(Grid::dimension >= 2) {
    if (!(std::isfinite(radius_mm) && radius_mm >= 0.0))
      detail::fail("bayes_filter::most_probable_disc: radius ", radius_mm,
                   " mm; expected a finite radius >= 0");
    const Eigen::Index rows = grid_.rows(), cols = grid_.cols(), plane = rows * cols;
    if (!positions_form_lattice())
      detail::fail<std::logic_error>(
          "bayes_filter::most_probable_disc: the grid's positions are not an axis-aligned regular "
          "lattice (as planar_grid's and pose_grid's are); use probability_within instead");
    // Position marginal (the planes summed), then per-row prefix sums: the disc is a stack of
    // row runs, each a difference of two prefix sums. The prefix rows are padded by the widest
    // run on both sides (clamped values), so every run of a row is one shifted vector
    // difference over the whole row.
    // Scratch kept between calls: three fresh images per touch cost more (page faults of the
    // allocations) than the scan itself.
    image<double>& p = disc_marginal_;
    p.setZero(rows, cols);
    Eigen::Map<Eigen::ArrayXd> p_flat(p.data(), plane);
    for (Eigen::Index at = 0; at < belief_.size(); at += plane)
      p_flat += Eigen::Map<const belief_type>(belief_.data() + at, plane).template cast<double>();
    const double sx = std::abs(lattice_step_(0)), sy = std::abs(lattice_step_(1));
    const auto reach_r = static_cast<Eigen::Index>(std::floor(radius_mm / sy + 1e-9));
    std::vector<Eigen::Index> half(static_cast<std::size_t>(reach_r + 1));
    for (Eigen::Index dr = 0; dr <= reach_r; ++dr) {
      const double dy = static_cast<double>(dr) * sy;
      half[static_cast<std::size_t>(dr)] = static_cast<Eigen::Index>(
          std::floor(std::sqrt(std::max(0.0, radius_mm * radius_mm - dy * dy)) / sx + 1e-9));
    }
    const Eigen::Index pad = half[0];
    image<double>& prefix = disc_prefix_;  // prefix(r, pad + j) = sum of p(r, 0..j-1)
    prefix.resize(rows, cols + 1 + 2 * pad);
    for (Eigen::Index r = 0; r < rows; ++r) {
      double run = 0.0;
      for (Eigen::Index j = 0; j <= pad; ++j) prefix(r, j) = 0.0;
      for (Eigen::Index c = 0; c < cols; ++c) prefix(r, pad + c + 1) = run += p(r, c);
      for (Eigen::Index j = pad + cols + 1; j < prefix.cols(); ++j) prefix(r, j) = run;
    }
    // Plain loops over contiguous rows (vectorised by the compiler): rows are short (~100), and
    // an Eigen expression per (row, run) costs more than its arithmetic.
    image<double>& disc = disc_mass_;
    disc.setZero(rows, cols);
    const Eigen::Index stride = prefix.cols();
    for (Eigen::Index r = 0; r < rows; ++r) {
      double* out = disc.data() + r * cols;
      for (Eigen::Index dr = -reach_r; dr <= reach_r; ++dr) {
        const Eigen::Index rr = r + dr;
        if (rr < 0 || rr >= rows) continue;
        const Eigen::Index h = half[static_cast<std::size_t>(dr < 0 ? -dr : dr)];
        // Row rr's run c - h .. c + h for every c at once.
        const double* hi = prefix.data() + rr * stride + pad + h + 1;
        const double* lo = prefix.data() + rr * stride + pad - h;
        for (Eigen::Index c = 0; c < cols; ++c) out[c] += hi[c] - lo[c];
      }
    }
    Eigen::Index best = 0;
    for (Eigen::Index i = 1; i < plane; ++i)
      if (disc.data()[i] > disc.data()[best]) best = i;
    const Eigen::Index best_r = best / cols, best_c = best % cols;
    // Discs around a sharp peak all hold (nearly) the same mass, and the scan keeps the first:
    // the centre is the mean of the belief inside the best disc instead, which sits on the
    // peak (or the middle of a plateau), and the probability is that of its own disc.
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    double inside = 0.0;
    for (Eigen::Index dr = -reach_r; dr <= reach_r; ++dr) {
      const Eigen::Index rr = best_r + dr;
      if (rr < 0 || rr >= rows) continue;
      const Eigen::Index h = half[static_cast<std::size_t>(dr < 0 ? -dr : dr)];
      for (Eigen::Index cc = std::max<Eigen::Index>(0, best_c - h);
           cc <= std::min(cols - 1, best_c + h); ++cc) {
        sum += p(rr, cc) * offsets_mm_.col(rr * cols + cc).template head<2>();
        inside += p(rr, cc);
      }
    }
    const Eigen::Vector2d centre =
        origin_mm_.template head<2>() +
        (inside > 0.0
             ? Eigen::Vector2d(sum / inside)
             : Eigen::Vector2d(offsets_mm_.col(best_r * cols + best_c).template head<2>()));
    // Its own disc's mass (what probability_within(centre, radius_mm) gives), from the cells
    // near the best one only: the centre is a mean of cells within the radius of the best, so
    // every cell within the radius of the centre is within twice the radius of the best.
    const Eigen::Vector2d c = centre - origin_mm_.template head<2>();
    const double r2 = radius_mm * radius_mm;
    double mass = 0.0;
    for (Eigen::Index rr = std::max<Eigen::Index>(0, best_r - 2 * reach_r - 2);
         rr <= std::min(rows - 1, best_r + 2 * reach_r + 2); ++rr)
      for (Eigen::Index cc = std::max<Eigen::Index>(0, best_c - 2 * pad - 2);
           cc <= std::min(cols - 1, best_c + 2 * pad + 2); ++cc)
        if ((offsets_mm_.col(rr * cols + cc).template head<2>() - c).squaredNorm() <= r2)
          mass += p(rr, cc);
    return {centre, std::min(mass, 1.0)};
  }

  /// True when the grid's positions form an axis-aligned regular lattice (planar_grid,
  /// pose_grid): what `most_probable_disc` needs.
  [[nodiscard]] bool positions_form_lattice() const { return lattice_step_.allFinite(); }

  /// Grids with a heading (pose_grid): the belief's probability that the heading is within
  /// `tolerance_rad` of `heading_rad`, the angle difference wrapped into [-pi, pi). Throws
  /// std::invalid_argument for a non-finite heading or a negative or non-finite tolerance.
  [[nodiscard]] double heading_probability_within(double heading_rad, double tolerance_rad) const
      requires(Grid::dimension == 3 && has_circular_coordinates<Grid>) {
    if (!std::isfinite(heading_rad))
      detail::fail("bayes_filter::heading_probability_within: heading ", heading_rad,
                   " rad; expected a finite angle");
    if (!(std::isfinite(tolerance_rad) && tolerance_rad >= 0.0))
      detail::fail("bayes_filter::heading_probability_within: tolerance ", tolerance_rad,
                   " rad; expected a finite angle >= 0");
    return masked_mass([&](Eigen::Index i) {
      return std::abs(wrap_angle(origin_mm_(2) + offsets_mm_(2, i) - heading_rad)) <= tolerance_rad;
    });
  }

  [[nodiscard]] const Grid& grid() const { return grid_; }
  [[nodiscard]] const Motion& motion() const { return motion_; }
  [[nodiscard]] const Measurement& measurement_model() const { return measurement_; }
  [[nodiscard]] Motion& motion() { return motion_; }
  [[nodiscard]] Measurement& measurement_model() { return measurement_; }

 private:
  // Mean and covariance when some coordinates are angles (Grid::circular[k]): the mean angle is
  // the circular mean atan2(E[sin], E[cos]) in [-pi, pi), and deviations from it are wrapped
  // into [-pi, pi) before the (co)variances are taken — a belief split between -179 and +179
  // degrees has mean 180 degrees and a small spread, not mean 0 and a huge one. Two passes: the
  // mean first, then the wrapped deviations.
  void circular_moments(const belief_type& belief,
                        estimate_type& e) const requires has_circular_coordinates<Grid> {
    constexpr int dim = Grid::dimension;
    typename estimate_type::vector_type mean_offset = estimate_type::vector_type::Zero();
    std::array<double, static_cast<std::size_t>(dim)> sum_cos{};
    std::array<double, static_cast<std::size_t>(dim)> sum_sin{};
    for (Eigen::Index i = 0; i < belief.size(); ++i) {
      const double p = static_cast<double>(belief(i));
      if (p == 0.0) continue;
      const auto o = offsets_mm_.col(i);
      for (int k = 0; k < dim; ++k) {
        if (Grid::circular[static_cast<std::size_t>(k)]) {
          const double angle = origin_mm_(k) + o(k);
          sum_cos[static_cast<std::size_t>(k)] += p * std::cos(angle);
          sum_sin[static_cast<std::size_t>(k)] += p * std::sin(angle);
        } else {
          mean_offset(k) += p * o(k);
        }
      }
    }
    typename estimate_type::vector_type mean = origin_mm_ + mean_offset;
    for (int k = 0; k < dim; ++k)
      if (Grid::circular[static_cast<std::size_t>(k)])
        mean(k) = wrap_angle(
            std::atan2(sum_sin[static_cast<std::size_t>(k)], sum_cos[static_cast<std::size_t>(k)]));
    e.mean_mm = mean;
    typename estimate_type::matrix_type cov = estimate_type::matrix_type::Zero();
    typename estimate_type::vector_type d;
    for (Eigen::Index i = 0; i < belief.size(); ++i) {
      const double p = static_cast<double>(belief(i));
      if (p == 0.0) continue;
      const auto o = offsets_mm_.col(i);
      for (int k = 0; k < dim; ++k)
        d(k) = Grid::circular[static_cast<std::size_t>(k)]
                   ? wrap_angle(origin_mm_(k) + o(k) - mean(k))
                   : o(k) - mean_offset(k);
      cov.noalias() += (p * d) * d.transpose();
    }
    e.covariance_mm2 = cov;
  }

  // bel = eta * exp(ll - max ll) * bel_bar. Subtracting the maximum first means the best state's
  // factor is exactly 1, so no likelihood underflows to an all-zero posterior by itself.
  update_report apply_log_likelihood(const belief_type& ll, const char* source) {
    const auto scan = detail::scan_log_likelihood(ll.data(), ll.size());
    if (scan.first_nan >= 0)
      detail::fail<std::domain_error>("bayes_filter::update: ", source, " is NaN at state ",
                                      scan.first_nan,
                                      "; expected finite log-likelihoods (or -infinity for "
                                      "excluded states). The belief is unchanged");
    const scalar_type top = scan.max;
    if (top == std::numeric_limits<scalar_type>::infinity())
      detail::fail<std::domain_error>("bayes_filter::update: ", source,
                                      " contains +infinity; expected finite log-likelihoods. "
                                      "The belief is unchanged");
    if (top == -std::numeric_limits<scalar_type>::infinity())
      detail::fail<std::domain_error>("bayes_filter::update: ", source,
                                      " is -infinity everywhere (it rules out every state); "
                                      "expected at least one finite value. The belief is "
                                      "unchanged");
    const detail::weight_sums sums =
        detail::weight_by_likelihood(belief_.data(), ll.data(), top, scratch_.data(), ll.size());
    const double total = sums.posterior;
    if (!(total > 0.0) || !std::isfinite(total))
      detail::fail<std::domain_error>(
          "bayes_filter::update: ", source, " gives zero probability to every state the belief ",
          "still allows (posterior sum ", total,
          "); the measurement contradicts the prediction. "
          "The belief is unchanged; call reset() to start again from a uniform belief");
    normalise(scratch_, total);
    belief_.swap(scratch_);
    // sums.likelihood >= 1 (the maximum's own factor), so the logarithm is finite.
    const double log_evidence = std::log(total);
    return {.log_evidence = log_evidence,
            .log_likelihood_max = static_cast<double>(top),
            .log_prediction_support = log_evidence - std::log(sums.likelihood) +
                                      std::log(static_cast<double>(ll.size()))};
  }

  // b /= total (b's sum, > 0). When 1 / total overflows the belief's precision (a float sum
  // below ~3e-39: a sharp touch far from where the prediction put its mass) the factor would
  // be +infinity and 0 * infinity NaN; b is then divided by its largest value first (which
  // becomes exactly 1) and by its new sum after.
  static void normalise(belief_type& b, double total) {
    const double inverse = 1.0 / total;
    if (inverse < static_cast<double>(std::numeric_limits<scalar_type>::max())) {
      b *= static_cast<scalar_type>(inverse);
      return;
    }
    b /= b.maxCoeff();
    b /= b.sum();
  }

  // Mass of the states whose position (the base grid's state for latent grids, in every
  // hypothesis block) satisfies `inside(position index)`, accumulated in double.
  template <class Inside>
  double masked_mass(Inside inside) const {
    const Eigen::Index n = offsets_mm_.cols();
    double mass = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (!inside(i)) continue;
      for (Eigen::Index b = i; b < belief_.size(); b += n) mass += static_cast<double>(belief_(b));
    }
    return std::min(mass, 1.0);
  }

  // The steps (column, row) of the plane's positions when every position of the first plane is
  // origin + c * step_x + r * step_y (checked on every state); NaN otherwise.
  Eigen::Vector2d lattice_step() const requires(Grid::dimension >= 2) {
    const Eigen::Index rows = grid_.rows(), cols = grid_.cols();
    const double sx = cols > 1 ? offsets_mm_(0, 1) : 1.0;
    const double sy = rows > 1 ? offsets_mm_(1, cols) : 1.0;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    if (!(std::abs(sx) > 0.0 && std::abs(sy) > 0.0)) return {nan, nan};
    const double tolerance = 1e-6 * (std::abs(sx) + std::abs(sy));
    for (Eigen::Index r = 0; r < rows; ++r)
      for (Eigen::Index c = 0; c < cols; ++c) {
        const auto o = offsets_mm_.col(r * cols + c);
        if (std::abs(o(0) - static_cast<double>(c) * sx) > tolerance ||
            std::abs(o(1) - static_cast<double>(r) * sy) > tolerance)
          return {nan, nan};
      }
    return {sx, sy};
  }

  // Positions the estimate describes: the base grid's states for latent grids, else all states.
  static Eigen::Index position_count(const Grid& grid) {
    if constexpr (latent_state_grid<Grid>)
      return grid.hypothesis_size();
    else
      return grid.size();
  }

  Grid grid_;
  Motion motion_;
  Measurement measurement_;
  belief_type belief_;
  belief_type scratch_;
  // most_probable_disc's scratch: the position marginal, its row prefix sums, the disc masses.
  mutable image<double> disc_marginal_, disc_prefix_, disc_mass_;
  belief_type log_likelihood_;
  typename estimate_type::vector_type origin_mm_;
  Eigen::Matrix<double, Grid::dimension, Eigen::Dynamic> offsets_mm_;
  // See lattice_step(); NaN: not a lattice (or fewer than two coordinates).
  Eigen::Vector2d lattice_step_ =
      Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
};

// The heavy members, defined out of the class: not inline, so that where tacmap::precompiled
// declares an instantiation `extern template` (tacmap/precompiled.hpp) the compiler does not
// instantiate them again for inlining. (Not being inline, an instantiation on a type local to a
// translation unit that leaves one unused would be reported by -Wunused-function.)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"

template <state_grid Grid, motion_model<Grid> Motion, measurement_model<Grid> Measurement>
bayes_filter<Grid, Motion, Measurement>::bayes_filter(Grid grid, Motion motion,
                                                      Measurement measurement)
    : grid_(std::move(grid)),
      motion_(std::move(motion)),
      measurement_(std::move(measurement)),
      belief_(grid_.size()),
      scratch_(grid_.size()),
      log_likelihood_(grid_.size()),
      origin_mm_(grid_.state_mm(0)),
      offsets_mm_(Grid::dimension, position_count(grid_)) {
  TACMAP_ASSERT(grid_.size() > 0 && grid_.size() % (grid_.rows() * grid_.cols()) == 0,
                "a state_grid's size must be a positive multiple of rows * cols");
  // State coordinates are fixed for the filter's life: cache them (relative to the first
  // state, which keeps them small) so estimate() is two matrix products, not N grid calls.
  // A latent grid repeats its positions in every hypothesis block: the first block's suffice.
  for (Eigen::Index i = 0; i < offsets_mm_.cols(); ++i)
    offsets_mm_.col(i) = grid_.state_mm(i) - origin_mm_;
  if constexpr (Grid::dimension >= 2) lattice_step_ = lattice_step();
  reset();
}

template <state_grid Grid, motion_model<Grid> Motion, measurement_model<Grid> Measurement>
prediction_report bayes_filter<Grid, Motion, Measurement>::predict(const control_type& u) {
  const prediction_report report = motion_.predict(grid_, belief_, scratch_, u);
  // A user's motion model that breaks its contract must not poison the belief.
  const double total = static_cast<double>(scratch_.sum());
  if (!(std::isfinite(total) && total > 0.0) || scratch_.minCoeff() < 0)
    detail::fail<std::logic_error>(
        "bayes_filter::predict: the motion model returned a belief summing to ", total,
        " (or with negative values); expected finite probabilities >= 0 with a positive sum. "
        "The belief is unchanged; check the motion model");
  normalise(scratch_, total);
  belief_.swap(scratch_);
  return report;
}

template <state_grid Grid, motion_model<Grid> Motion, measurement_model<Grid> Measurement>
update_report bayes_filter<Grid, Motion, Measurement>::update(const measurement_type& z) {
  measurement_.log_likelihood(grid_, z, log_likelihood_);
  if (log_likelihood_.size() != grid_.size()) {
    const Eigen::Index got = log_likelihood_.size();
    log_likelihood_.resize(grid_.size());
    detail::fail("bayes_filter::update: the measurement model resized its output to ", got,
                 " values; expected ", grid_.size(), " (one per state). The belief is unchanged");
  }
  return apply_log_likelihood(log_likelihood_, "the measurement model");
}

template <state_grid Grid, motion_model<Grid> Motion, measurement_model<Grid> Measurement>
auto bayes_filter<Grid, Motion, Measurement>::estimate() const -> estimate_type {
  estimate_type e;
  // The belief over positions: the belief itself, or summed over the hypotheses.
  const belief_type* positions = &belief_;
  belief_type marginal;
  if constexpr (latent_state_grid<Grid>) {
    marginal = marginal_belief(grid_, belief_);
    positions = &marginal;
    e.hypothesis_probability = hypothesis_posterior(grid_, belief_);
    for (std::size_t h = 1; h < e.hypothesis_probability.size(); ++h)
      if (e.hypothesis_probability[h] >
          e.hypothesis_probability[static_cast<std::size_t>(e.map_hypothesis)])
        e.map_hypothesis = static_cast<Eigen::Index>(h);
  }
  const belief_type& p = *positions;
  Eigen::Index best = 0;
  e.map_probability = static_cast<double>(p.maxCoeff(&best));
  e.map_index = best + e.map_hypothesis * p.size();
  e.map_mm = grid_.state_mm(e.map_index);
  // Moments of the cached coordinates relative to the grid's first state: small numbers, so
  // E[o o^T] - E[o] E[o]^T does not cancel catastrophically even on a far-from-origin map.
  if constexpr (has_circular_coordinates<Grid>) {
    circular_moments(p, e);
  } else {
    typename estimate_type::vector_type mean_offset = estimate_type::vector_type::Zero();
    typename estimate_type::matrix_type second = estimate_type::matrix_type::Zero();
    for (Eigen::Index i = 0; i < p.size(); ++i) {
      const double w = static_cast<double>(p(i));
      const auto o = offsets_mm_.col(i);
      mean_offset += w * o;
      second.noalias() += (w * o) * o.transpose();
    }
    e.covariance_mm2 = second - mean_offset * mean_offset.transpose();
    e.mean_mm = origin_mm_ + mean_offset;
  }
  // 0 log 0 = 0: the tiny offset keeps log finite where p = 0 without changing other terms.
  const scalar_type tiny = std::numeric_limits<scalar_type>::min();
  e.entropy_nats = -static_cast<double>((p * (p + tiny).log()).sum());
  return e;
}

#pragma GCC diagnostic pop
}  // namespace tacmap
