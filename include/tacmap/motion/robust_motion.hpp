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
//
// Between the two, optional components for moves wrong by millimetres or centimetres:
//     bel_bar = (1 - lambda) [(1 - w - b) P + w G_wide P + b G_broad P] / Z + lambda / N
// with P = base.predict(bel), G a Gaussian blur of each plane (wide: an odometry outlier or
// noise larger than configured, a few mm; broad: the object slipped in the grasp, about a
// centimetre) and Z what remains on the grid. The broad component is computed on blocks of
// about sigma / 2 states and interpolated back, pooled over the planes (a slip moves the
// object; one density for all planes keeps its cost to about a plane's pass).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <span>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "tacmap/config.hpp"
#include "tacmap/detail/mass_sum.hpp"
#include "tacmap/detail/setting_ranges.hpp"
#include "tacmap/grid/concept.hpp"
#include "tacmap/image.hpp"
#include "tacmap/motion/concept.hpp"
#include "tacmap/simd.hpp"

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
  /// b: the probability that a move is off by centimetres — the object slipped in the grasp,
  /// the sensor was put down elsewhere nearby — a broad component of `broad_sigma_mm` per axis
  /// around the base prediction. 0: none. Computed on a coarser lattice (see `predict`).
  double broad_probability = 0.0;
  double broad_sigma_mm = 10.0;  ///< the broad component's spread, mm per axis

  void validate() const {
    if (!(std::isfinite(lost_probability) && lost_probability >= 0.0 && lost_probability < 1.0))
      detail::fail("robust_motion_params: lost_probability = ", lost_probability,
                   "; expected a probability in [0, 1) (e.g. 0.001; 0 = trust the odometry)");
    if (!(std::isfinite(wide_probability) && wide_probability >= 0.0 &&
          wide_probability + lost_probability < 1.0))
      detail::fail("robust_motion_params: wide_probability = ", wide_probability,
                   " (with lost_probability ", lost_probability,
                   "); expected >= 0 with the two summing to less than 1 (e.g. 0.1)");
    detail::check_range("robust_motion_params", "wide_sigma_mm", wide_sigma_mm,
                        detail::min_sigma_mm, 100.0, " mm", "the wide component's spread",
                        "give it in millimetres (e.g. 3)");
    if (!(std::isfinite(broad_probability) && broad_probability >= 0.0 &&
          broad_probability + wide_probability + lost_probability < 1.0))
      detail::fail("robust_motion_params: broad_probability = ", broad_probability,
                   " (with wide_probability ", wide_probability, " and lost_probability ",
                   lost_probability,
                   "); expected >= 0 with the three summing to less than 1 (e.g. 0.05)");
    detail::check_range("robust_motion_params", "broad_sigma_mm", broad_sigma_mm,
                        detail::min_sigma_mm, 1000.0, " mm", "the broad component's spread",
                        "give it in millimetres (e.g. 10)");
  }
};

/// A second look at a touch that doubts its prediction (`localizer_config::slip_recheck`): the
/// touch's update is done again from the belief before the move, predicted with a broad
/// component of `broad_probability` and `broad_sigma_mm` on top of the filter's own motion
/// model — the hypothesis that the object slipped in the grasp before this touch, weighed by
/// the touch like any other. The floor alone (`lost_probability`, 0.001) gives a slip's place
/// too little prior mass for one touch of an ambiguous map to move the belief there, and the
/// belief stays, confidently, on the place it had before the slip; a broad component on every
/// move costs a predict's time and hedges claims without faults, while the touches that doubt
/// their prediction are few (about 1 % without faults).
struct slip_recheck_params {
  /// The touch's `update_report::log_prediction_support` below which the touch is looked at
  /// again: it is e^-doubt times more probable anywhere on the map than where the filter
  /// expected it.
  double doubt = -1.0;
  double broad_probability = 0.3;  ///< the slip hypothesis's share of the prediction, [0, 1)
  double broad_sigma_mm = 10.0;    ///< its spread, mm per axis

  void validate() const {
    if (!(std::isfinite(doubt) && doubt <= 0.0))
      detail::fail("slip_recheck_params: doubt = ", doubt,
                   "; expected a finite log Bayes factor <= 0 (e.g. -1: the touch 2.7 times "
                   "more probable elsewhere); turn the recheck off with an empty slip_recheck");
    if (!(std::isfinite(broad_probability) && broad_probability > 0.0 && broad_probability < 1.0))
      detail::fail("slip_recheck_params: broad_probability = ", broad_probability,
                   "; expected a probability in (0, 1) (e.g. 0.3)");
    detail::check_range("slip_recheck_params", "broad_sigma_mm", broad_sigma_mm,
                        detail::min_sigma_mm, 1000.0, " mm", "the slip's spread",
                        "give it in millimetres (e.g. 10)");
  }
};

/// `M`'s prediction mixed with a uniform floor (see the file's comment). Models
/// `motion_model<G>` for every grid `M` does. Keeps the wide and broad components' workspaces
/// between predictions, like the base models: one object is not reentrant (one filter per
/// thread).
template <class M>
class robust_motion {
 public:
  using control_type = typename M::control_type;
  using base_type = M;

  /// Throws std::invalid_argument for parameters `robust_motion_params::validate` refuses.
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
    const double w = params_.wide_probability, wb = params_.broad_probability;
    if (w > 0.0 || wb > 0.0) {
      // out = (1 - w - b) out + w blur(out) + b broad(out), the blur a Gaussian of
      // wide_sigma_mm made of three box passes per axis (variance r (r + 1) px^2 for radius r)
      // over every rows x cols plane, `broad` one of broad_sigma_mm on blocks (`broad_density`);
      // mass blurred off a plane's edge is dropped (zero outside, at every pass) and the rest
      // renormalised, as the base model does with mass moved off the grid.
      const Eigen::Index rows = grid.rows(), cols = grid.cols(), plane = rows * cols;
      const auto [pitch_x, pitch_y] = detail::lattice_pitch_mm(grid);
      const Eigen::Index rx = box_radius(params_.wide_sigma_mm / pitch_x);
      const Eigen::Index ry = box_radius(params_.wide_sigma_mm / pitch_y);
      const auto keep = static_cast<scalar>(1.0 - w - wb);
      // The broad component's density, from the base prediction before the planes are mixed.
      if (wb > 0.0)
        broad_density(out, rows, cols, params_.broad_sigma_mm / pitch_x,
                      params_.broad_sigma_mm / pitch_y);
      // Float beliefs: direct sums for small radii; double beliefs keep the double sums.
      const bool direct = std::is_same_v<scalar, float> && std::max(rx, ry) <= direct_radius;
      // The planes' mass after mixing: summed while they are written by the direct blur (the
      // normalisation below needs no pass of its own), in a pass of its own after the sliding
      // sums.
      double total = 0.0;
      for (Eigen::Index at = 0, layer = 0; at < out.size(); at += plane, ++layer) {
        Eigen::Map<image<scalar>> img(out.data() + at, rows, cols);
        if (w <= 0.0) {
          img *= keep;
          total += img.template cast<double>().sum();
        } else if (direct) {
          if constexpr (std::is_same_v<scalar, float>) {
            // The passes summed 2 r + 1 values each without dividing: (2 rx + 1)^3 (2 ry + 1)^3.
            const double norm = std::pow(static_cast<double>(2 * rx + 1), -3.0) *
                                std::pow(static_cast<double>(2 * ry + 1), -3.0);
            total += blur_direct_mix(img, rx, ry, keep, static_cast<float>(w * norm));
          }
        } else {
          // Wide radii: sliding sums in double, whole rows at a time (vectorised); the plane is
          // transposed once so both axes run that way.
          down_ = img.template cast<double>();
          box3_down(down_, scratch_, row_sum_, ry);  // along y
          across_ = down_.transpose();
          box3_down(across_, scratch_, row_sum_, rx);  // along x
          img = img * keep + (across_.transpose() * w).template cast<scalar>();
          total += img.template cast<double>().sum();
        }
        if (wb > 0.0) {
          // This plane's part of the broad component: its share of the mass, spread like the
          // position marginal (one density for all planes, `broad_density`).
          const double share = wb * broad_mass_[static_cast<std::size_t>(layer)] / broad_total_;
          img += (broad_ * share).template cast<scalar>();
          total += share * broad_sum_;
        }
      }
      // Mass blurred off the edges is dropped, the rest renormalised; in the same pass as the
      // floor: out = (1 - lambda) out / total + lambda / N.
      if (!(total > 0.0 && std::isfinite(total)))
        detail::fail<std::logic_error>(
            "robust_motion: the prediction's mass after the wide and broad components is ", total,
            "; expected a positive finite sum (the base model's prediction held no "
            "finite mass)");
      out = out * static_cast<scalar>((1.0 - lambda) / total) +
            static_cast<scalar>(lambda / static_cast<double>(out.size()));
      return report;
    }
    if (lambda > 0.0)
      out = out * static_cast<scalar>(1.0 - lambda) +
            static_cast<scalar>(lambda / static_cast<double>(out.size()));
    return report;
  }

  /// The floor's share lambda (`has_uniform_floor`, motion/concept.hpp): every prediction puts
  /// lambda / N on every state. A tracking filter carries it as one number rather than moving it
  /// (`bayes_filter::set_tracking`).
  [[nodiscard]] double uniform_floor() const { return params_.lost_probability; }

  /// Tracking mode (`moves_box`, motion/concept.hpp): the base model's `predict_boxes`, then the
  /// wide component on the windows where the moved mass landed, each grown by the blur's reach
  /// (three box passes of radius r reach 3 r cells) and clipped to the grid: in every plane,
  /// window = (1 - w) window + w blur(window), the blur zero outside the window at every pass as
  /// `predict`'s is outside the grid (so at the grid's edge the same truncation, and inside it
  /// none of the moved mass reaches the window's border). The states outside the windows keep
  /// their values; so does the floor, which the caller carries (`uniform_floor`): this adds no
  /// lambda / N and does not scale by 1 - lambda. `dropped`: the base model's, plus what the
  /// blur carried past the windows' edges. Not renormalised. False, the belief unchanged, when
  /// the base model cannot move the boxes or with a broad component (its density pools the
  /// whole grid's position marginal).
  template <state_grid G>
  requires moves_box<M, G>
  bool predict_boxes(const G& grid, belief_array<G>& b, std::span<const grid_box> boxes,
                     const control_type& u, std::vector<grid_box>& landed, double& dropped) const {
    using scalar = typename G::scalar_type;
    if (params_.broad_probability > 0.0) return false;
    if (!base_.predict_boxes(grid, b, boxes, u, landed, dropped)) return false;
    const double w = params_.wide_probability;
    if (!(w > 0.0)) return true;
    const Eigen::Index rows = grid.rows(), cols = grid.cols(), plane = rows * cols;
    const Eigen::Index layers = b.size() / plane;
    const auto [pitch_x, pitch_y] = detail::lattice_pitch_mm(grid);
    const Eigen::Index rx = box_radius(params_.wide_sigma_mm / pitch_x);
    const Eigen::Index ry = box_radius(params_.wide_sigma_mm / pitch_y);
    for (grid_box& l : landed)
      l = detail::clip_box({l.row - 3 * ry, l.col - 3 * rx, l.rows + 6 * ry, l.cols + 6 * rx}, rows,
                           cols);
    // Overlapping windows united (each state blurred once): pairwise disjoint after.
    windows_ = landed;
    for (bool merged = true; merged;) {
      merged = false;
      for (std::size_t i = 0; i < windows_.size() && !merged; ++i)
        for (std::size_t j = i + 1; j < windows_.size() && !merged; ++j) {
          const grid_box &a = windows_[i], &c = windows_[j];
          if (a.row < c.row + c.rows && c.row < a.row + a.rows && a.col < c.col + c.cols &&
              c.col < a.col + a.cols) {
            const Eigen::Index r0 = std::min(a.row, c.row), c0 = std::min(a.col, c.col);
            const Eigen::Index r1 = std::max(a.row + a.rows, c.row + c.rows);
            const Eigen::Index c1 = std::max(a.col + a.cols, c.col + c.cols);
            windows_[i] = {r0, c0, r1 - r0, c1 - c0};
            windows_.erase(windows_.begin() + static_cast<std::ptrdiff_t>(j));
            merged = true;
          }
        }
    }
    const auto keep = static_cast<scalar>(1.0 - w);
    for (const grid_box& win : windows_)
      for (Eigen::Index a = 0; a < layers; ++a) {
        Eigen::Map<image<scalar>> img(b.data() + a * plane, rows, cols);
        auto block = img.block(win.row, win.col, win.rows, win.cols);
        down_ = block.template cast<double>();
        const double before = down_.sum();
        if (!(before > 0.0)) continue;
        box3_down(down_, scratch_, row_sum_, ry);  // along y
        across_ = down_.transpose();
        box3_down(across_, scratch_, row_sum_, rx);  // along x
        const double after = across_.sum();
        block = block * keep + (across_.transpose() * w).template cast<scalar>();
        dropped += w * std::max(0.0, before - after);
      }
    return true;
  }

  [[nodiscard]] const M& base() const { return base_; }
  [[nodiscard]] M& base() { return base_; }
  [[nodiscard]] const robust_motion_params& params() const { return params_; }
  /// Replaces the parameters (`slip_recheck_params`: one prediction with a broad component).
  /// Throws std::invalid_argument, the model unchanged, for parameters `validate` refuses.
  void set_params(const robust_motion_params& params) {
    params.validate();
    params_ = params;
  }

 private:
  // Radius r of the box whose three passes have variance r (r + 1) closest to sigma^2 (px).
  static Eigen::Index box_radius(double sigma_px) {
    // Clamped before the conversion (a grid of 1e-160 mm steps made it 1e160 states, beyond
    // Eigen::Index); the front doors refuse such scales (detail::min_mm_per_px), a grid built
    // by hand may still have one. 2^25 states is past any grid's side: the same blur.
    return std::max<Eigen::Index>(
        1, static_cast<Eigen::Index>(std::lround(std::min(
               0.5 * (std::sqrt(1.0 + 4.0 * sigma_px * sigma_px) - 1.0), max_states_per_axis))));
  }
  static constexpr double max_states_per_axis = 33554432.0;  // 2^25

  // The broad component's density over one plane (`broad_`, rows x cols), from the position
  // marginal of `b` (its planes summed; `broad_mass_` each plane's mass, `broad_total_` their
  // sum), on a lattice of block centres f = sigma / 2 states apart (rounded down: they still
  // resolve the spread) reaching one centre past each end of the grid: each state's mass split
  // between its two nearest centres per axis (bilinear weights), blurred there by a Gaussian of
  // the spread the split and the way back do not already give (f^2 / 6 each on average), and
  // spread back with the same weights (each centre's tent sums to f over the states, so its
  // mass divided by f per axis; what lands past the grid's ends is dropped, like what the blur
  // carries past the lattice). The split is the transpose of the way back: the mean stays where
  // it was. `broad_sum_`: the mass kept on the grid. One density for all planes is what keeps
  // the cost to about a plane's pass: a cost approximation (each plane blurred on its own would
  // keep, e.g., each heading's broad mass near that heading's own mass).
  template <class Belief>
  void broad_density(const Belief& b, Eigen::Index rows, Eigen::Index cols, double sx,
                     double sy) const {
    using scalar = typename Belief::Scalar;
    const Eigen::Index plane = rows * cols, layers = b.size() / plane;
    broad_mass_.assign(static_cast<std::size_t>(layers), 0.0);
    // Spreads in states clamped as box_radius's (past any grid's side: flat over it either
    // way), so that the blocks, their product and the Gaussian's reach stay finite integers.
    sx = std::min(sx, max_states_per_axis);
    sy = std::min(sy, max_states_per_axis);
    const auto block = [](double sigma) {
      return std::max<Eigen::Index>(1, static_cast<Eigen::Index>(std::floor(sigma / 2.0)));
    };
    const Eigen::Index fx = block(sx), fy = block(sy);
    // Block centres f states apart, centre k + 1 at state k f + (f - 1) / 2, with one more
    // beyond each end of the grid, so that every state lies between two centres and each
    // centre's weights (a tent) are whole: none clamped at the ends, the mean kept everywhere.
    // Per state: the index of the centre below and the weight of the one above.
    const auto weights = [](Eigen::Index n, Eigen::Index f, std::vector<Eigen::Index>& lo,
                            std::vector<double>& a) {
      lo.resize(static_cast<std::size_t>(n));
      a.resize(static_cast<std::size_t>(n));
      const double fd = static_cast<double>(f), offset = 0.5 * (fd - 1.0);
      for (Eigen::Index k = 0; k < n; ++k) {
        const double u = (static_cast<double>(k) - offset) / fd;
        const double below = std::floor(u);
        lo[static_cast<std::size_t>(k)] = static_cast<Eigen::Index>(below) + 1;
        a[static_cast<std::size_t>(k)] = u - below;
      }
      return (n + f - 1) / f + 2;
    };
    const Eigen::Index cc = weights(cols, fx, x_lo_, x_a_);
    const Eigen::Index rc = weights(rows, fy, y_lo_, y_a_);
    // To the blocks: each state's mass (every plane's) split between its two nearest centres
    // along y, whole rows at a time, then along x — the transpose of the interpolation back, so
    // the mean stays where it was.
    coarse_rows_.setZero(rc, cols);
    block_row_.resize(cols);
    for (Eigen::Index i = 0; i < rows; ++i) {
      block_row_.setZero();
      for (Eigen::Index layer = 0; layer < layers; ++layer) {
        const Eigen::Map<const Eigen::Array<scalar, Eigen::Dynamic, 1>> row(
            b.data() + layer * plane + i * cols, cols);
        // The plane's mass a row at a time: short chunks in the row's own precision
        // (vectorised; a sum of casts is a chain of dependent adds), added up in double.
        broad_mass_[static_cast<std::size_t>(layer)] += detail::mass_sum(row);
        block_row_ += row.template cast<double>();
      }
      const auto y0 = y_lo_[static_cast<std::size_t>(i)];
      const double a = y_a_[static_cast<std::size_t>(i)];
      coarse_rows_.row(y0) += (1.0 - a) * block_row_.transpose();
      if (a > 0.0) coarse_rows_.row(y0 + 1) += a * block_row_.transpose();
    }
    broad_total_ = 0.0;
    for (const double m : broad_mass_) broad_total_ += m;
    coarse_.setZero(rc, cc);
    for (Eigen::Index r = 0; r < rc; ++r)
      for (Eigen::Index j = 0; j < cols; ++j) {
        const auto x0 = x_lo_[static_cast<std::size_t>(j)];
        const double a = x_a_[static_cast<std::size_t>(j)];
        coarse_(r, x0) += (1.0 - a) * coarse_rows_(r, j);
        if (a > 0.0) coarse_(r, x0 + 1) += a * coarse_rows_(r, j);
      }
    // What is left to spread on the blocks, in blocks: a Gaussian of that spread along each
    // axis (truncated at 3 sigma + 1 block, zero outside), one matrix product per axis. Splitting
    // and interpolating each spread f^2 / 6 states^2 on average over a state's place between
    // centres.
    const auto residual = [](double sigma, Eigen::Index f) {
      const double fd = static_cast<double>(f);
      const double split = f > 1 ? fd * fd / 3.0 : 0.0;
      return std::sqrt(std::max(0.0, sigma * sigma - split)) / fd;
    };
    gaussian_matrix(rc, residual(sy, fy), gauss_y_, gauss_y_key_);
    gaussian_matrix(cc, residual(sx, fx), gauss_x_, gauss_x_key_);
    coarse_scratch_.resize(rc, cc);
    coarse_scratch_.matrix().noalias() = gauss_y_ * coarse_.matrix();
    coarse_.matrix().noalias() = coarse_scratch_.matrix() * gauss_x_.transpose();
    // Back to the states: along x into rc rows of cols values, then along y row by row.
    for (Eigen::Index r = 0; r < rc; ++r)
      for (Eigen::Index j = 0; j < cols; ++j) {
        const auto x0 = x_lo_[static_cast<std::size_t>(j)];
        const double a = x_a_[static_cast<std::size_t>(j)];
        coarse_rows_(r, j) = (1.0 - a) * coarse_(r, x0) + (a > 0.0 ? a * coarse_(r, x0 + 1) : 0.0);
      }
    broad_.resize(rows, cols);
    const double density = 1.0 / static_cast<double>(fx * fy);  // a tent sums to f over states
    for (Eigen::Index i = 0; i < rows; ++i) {
      const auto y0 = y_lo_[static_cast<std::size_t>(i)];
      const double a = y_a_[static_cast<std::size_t>(i)];
      broad_.row(i) = ((1.0 - a) * density) * coarse_rows_.row(y0);
      if (a > 0.0) broad_.row(i) += (a * density) * coarse_rows_.row(y0 + 1);
    }
    broad_sum_ = broad_.sum();
  }

  // `m`: the n x n matrix of a Gaussian blur of `sigma` samples along n (m(i, j): the share of
  // sample j's mass that lands on i; truncated at 3 sigma + 1, each column normalised as if
  // nothing were truncated, so what lands outside is dropped). Kept while n and sigma do not
  // change (`key`): the kernel's exponentials cost more than the products.
  static void gaussian_matrix(Eigen::Index n, double sigma, Eigen::MatrixXd& m,
                              std::pair<Eigen::Index, double>& key) {
    if (key.first == n && key.second == sigma && m.rows() == n) return;
    m.setZero(n, n);
    // sigma^2 = 0 (a spread far below a block, e.g. on a grid of metre-sized pixels): no blur;
    // 0 / 0 at the centre would be NaN.
    if (!(sigma * sigma > 0.0)) {
      m.setIdentity();
    } else {
      const auto reach = static_cast<Eigen::Index>(std::ceil(3.0 * sigma)) + 1;
      double sum = 0.0;
      for (Eigen::Index d = -reach; d <= reach; ++d)
        sum += std::exp(-0.5 * static_cast<double>(d * d) / (sigma * sigma));
      for (Eigen::Index i = 0; i < n; ++i)
        for (Eigen::Index j = std::max<Eigen::Index>(0, i - reach); j <= std::min(n - 1, i + reach);
             ++j)
          m(i, j) = std::exp(-0.5 * static_cast<double>((i - j) * (i - j)) / (sigma * sigma)) / sum;
    }
    key = {n, sigma};
  }

  // Radii up to which a float belief's blur sums 2 r + 1 values per output directly, in float,
  // rather than sliding sums in double over transposed planes: the direct sums need no
  // transposes and no running sum (each output is a sum of non-negative floats: no
  // cancellation, relative error a few float ulps), but their cost grows with r. Measured on
  // the paper's grid (`predict_wide_sigma`, direct / sliding, a predict with the floor): r = 2
  // 19.7 / 28.1 us, r = 3 23.6 / 28.1, r = 4 29.1 / 28.3, r = 10 57.7 / 28.8 (r = 4 and 10
  // before the passes along x ran row by row, one run each).
  static constexpr Eigen::Index direct_radius = 3;

  // Three box passes of radius rx along x, then three of radius ry along y, over `img`, the
  // last one mixed into `img` itself: img = keep img + scale blur(img); returns img's new sum.
  // The passes run in padded planes of rows + 2 ry by cols + 2 rx floats whose margins stay
  // zero ("zero outside" at every pass, as `box3_down`). Unnormalised: every pass sums 2 r + 1
  // values (`scale` undoes it). The passes along x run row by row in two padded row buffers (a
  // row stays in the L1 cache for its three passes); those along y add whole rows of taps. Each
  // pass is contiguous runs of taps added in registers, never a strided access.
  template <class Img>
  double blur_direct_mix(Img& img, Eigen::Index rx, Eigen::Index ry, float keep,
                         float scale) const {
    const Eigen::Index rows = img.rows(), cols = img.cols();
    const Eigen::Index stride = cols + 2 * rx, height = rows + 2 * ry;
    // The margins' place depends on the radii as well as the padded shape (20 columns with
    // rx = 1 and 18 with rx = 2 are both 22 wide): zeroed again whenever any of them changes.
    const std::array<Eigen::Index, 4> shape{rows, cols, rx, ry};
    if (padded_shape_ != shape) {
      padded_a_.assign(static_cast<std::size_t>(height * stride), 0.0F);
      padded_b_.assign(padded_a_.size(), 0.0F);
      row_a_.assign(static_cast<std::size_t>(stride), 0.0F);
      row_b_.assign(static_cast<std::size_t>(stride), 0.0F);
      padded_shape_ = shape;
    }
    float* a = padded_a_.data();
    float* b = padded_b_.data();
    float* r0 = row_a_.data();
    float* r1 = row_b_.data();
    for (Eigen::Index i = 0; i < rows; ++i) {
      for (Eigen::Index c = 0; c < cols; ++c) r0[rx + c] = static_cast<float>(img(i, c));
      sum_taps(r0, 1, rx, cols, store_sink{r1 + rx});
      sum_taps(r1, 1, rx, cols, store_sink{r0 + rx});
      sum_taps(r0, 1, rx, cols, store_sink{a + (i + ry) * stride + rx});
    }
    for (int pass = 0; pass < 2; ++pass) {
      for (Eigen::Index i = ry; i < ry + rows; ++i)
        sum_taps(a + (i - ry) * stride + rx, stride, ry, cols, store_sink{b + i * stride + rx});
      std::swap(a, b);
    }
    // (Strips of 32 columns, each strip's three passes in the L1 cache, measured slower: 21.3
    // against 19.7 us a predict on the paper's grid.)
    double total = 0.0;
    for (Eigen::Index i = 0; i < rows; ++i) {
      mix_sink sink{img.data() + i * cols, keep, scale};
      sum_taps(a + i * stride + rx, stride, ry, cols, sink);
      total += sink.total();
    }
    return total;
  }

  using float_batch = xsimd::batch<float, detail::kernel_arch<float>>;

  // Where `sum_taps` puts its sums: stored as they are ...
  struct store_sink {
    float* out;
    void operator()(const float_batch& s, Eigen::Index c) const { s.store_unaligned(out + c); }
    void operator()(float s, Eigen::Index c) const { out[c] = s; }
  };
  // ... or mixed into the belief's row, o = keep o + scale s, and the row's new mass summed
  // (a register of partial sums, moved to double every `mass_sum_chunk_batches` registers so
  // that a long row's lanes do not grow far above what they add: see mass_sum.hpp).
  struct mix_sink {
    float* out;
    float keep, scale;
    float_batch acc = float_batch(0.0F);
    double rest = 0.0;
    Eigen::Index pending = 0;
    void operator()(const float_batch& s, Eigen::Index c) {
      const float_batch o =
          xsimd::fma(float_batch::load_unaligned(out + c), float_batch(keep), s * scale);
      o.store_unaligned(out + c);
      acc += o;
      if (++pending == detail::mass_sum_chunk_batches) {
        rest += static_cast<double>(xsimd::hadd(acc));
        acc = float_batch(0.0F);
        pending = 0;
      }
    }
    void operator()(float s, Eigen::Index c) {
      out[c] = out[c] * keep + s * scale;
      rest += static_cast<double>(out[c]);
    }
    [[nodiscard]] double total() const {
      alignas(64) std::array<float, float_batch::size> lanes{};
      acc.store_aligned(lanes.data());
      double t = rest;
      for (const float v : lanes) t += static_cast<double>(v);
      return t;
    }
  };

  // sink(sum over k in [0, 2 r] of in[k step + c], c) for c in [0, n): a register of sums at
  // a time, its taps added in registers (one load per tap), the rest one at a time in the same
  // order. (Tap after tap over the whole row cost a load and a store of the partial sums per
  // tap: no faster than the sliding sums.)
  template <class Sink>
  static void sum_taps(const float* in, Eigen::Index step, Eigen::Index r, Eigen::Index n,
                       Sink&& sink) {
    using batch = float_batch;
    constexpr auto width = static_cast<Eigen::Index>(batch::size);
    const Eigen::Index taps = 2 * r + 1;
    Eigen::Index c = 0;
    // Four registers of outputs side by side: four independent chains of adds, so the loop
    // runs at the loads' pace rather than the adds' latency (a predict on the paper's grid:
    // 24.2 -> 20.1 us).
    for (; c + 4 * width <= n; c += 4 * width) {
      const float* t = in + c;
      batch s0 = batch::load_unaligned(t), s1 = batch::load_unaligned(t + width);
      batch s2 = batch::load_unaligned(t + 2 * width), s3 = batch::load_unaligned(t + 3 * width);
      for (Eigen::Index k = 1; k < taps; ++k) {
        t += step;
        s0 += batch::load_unaligned(t);
        s1 += batch::load_unaligned(t + width);
        s2 += batch::load_unaligned(t + 2 * width);
        s3 += batch::load_unaligned(t + 3 * width);
      }
      sink(s0, c);
      sink(s1, c + width);
      sink(s2, c + 2 * width);
      sink(s3, c + 3 * width);
    }
    for (; c + width <= n; c += width) {
      batch s = batch::load_unaligned(in + c);
      for (Eigen::Index k = 1; k < taps; ++k) s += batch::load_unaligned(in + k * step + c);
      sink(s, c);
    }
    for (; c < n; ++c) {
      float s = in[c];
      for (Eigen::Index k = 1; k < taps; ++k) s += in[k * step + c];
      sink(s, c);
    }
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
  mutable std::vector<grid_box> windows_;  // predict_boxes: the wide component's windows
  // Scratch of the wide component (reused between predictions): a plane, its transpose, and
  // the passes' other buffer, the running sum of rows.
  mutable image<double> down_, across_, scratch_;
  mutable std::vector<double> row_sum_;
  // The direct blur's two padded planes, two padded rows, and the plane's shape and radii they
  // were zeroed for.
  mutable std::vector<float> padded_a_, padded_b_, row_a_, row_b_;
  mutable std::array<Eigen::Index, 4> padded_shape_{};  // rows, cols, rx, ry
  // The broad component's workspaces (`broad_density`): the position marginal on the centres
  // (and the products' other buffer), the centres interpolated along x, the density, a row of
  // the marginal, the weights' indices and values, the planes' masses.
  mutable image<double> coarse_, coarse_scratch_, coarse_rows_, broad_;
  mutable Eigen::MatrixXd gauss_y_, gauss_x_;  // the blocks' blurs (`gaussian_matrix`)
  mutable std::pair<Eigen::Index, double> gauss_y_key_{-1, 0.0}, gauss_x_key_{-1, 0.0};
  mutable Eigen::ArrayXd block_row_;
  mutable std::vector<Eigen::Index> x_lo_, y_lo_;
  mutable std::vector<double> x_a_, y_a_, broad_mass_;
  mutable double broad_total_ = 0.0, broad_sum_ = 0.0;
};

}  // namespace tacmap
