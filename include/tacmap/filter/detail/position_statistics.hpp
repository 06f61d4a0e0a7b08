// tacmap: the statistics `bayes_filter` reports about a belief over one grid's positions —
// estimate(), probability_within(), most_probable_disc(), heading_probability_within() — kept
// apart from the filter so that a belief made of several grids' blocks (a `library_grid`: one
// block per object, each with its own map) gets the same statistics for one block.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "tacmap/angle.hpp"
#include "tacmap/config.hpp"
#include "tacmap/detail/mass_sum.hpp"
#include "tacmap/filter/detail/changed_cells.hpp"
#include "tacmap/filter/state_estimate.hpp"
#include "tacmap/grid/concept.hpp"
#include "tacmap/grid/latent_grid.hpp"
#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/image.hpp"

namespace tacmap::detail {

/// True for grids whose every heading layer holds the first layer's positions at one angle by
/// construction (`pose_grid`, and latent grids of it): position_statistics then keeps the first
/// layer's coordinates and one angle per layer instead of every state's.
template <class G>
struct repeats_positions_per_layer : std::false_type {};
template <class T>
struct repeats_positions_per_layer<pose_grid<T>> : std::true_type {};
template <class G>
struct repeats_positions_per_layer<latent_grid<G>> : repeats_positions_per_layer<G> {};

/// Position statistics of beliefs over a grid `G` (any `state_grid`; over a `latent_grid` the
/// hypotheses are marginalised out). Caches the states' coordinates (relative to the first
/// state, which keeps them small) once, so that each statistic is a pass over the belief, not
/// N grid calls. The belief is passed as a view of `G::size()` values; it need not sum to one
/// (a block of a larger belief): masses come out in the belief's own units, and `estimate()`
/// wants a normalised belief. Keeps scratch (`estimate`, `most_probable_disc`): one object per
/// filter, not for concurrent calls.
template <state_grid G>
class position_statistics {
 public:
  using scalar_type = typename G::scalar_type;
  using estimate_type = state_estimate<G::dimension>;
  using view_type = Eigen::Map<const Eigen::Array<scalar_type, Eigen::Dynamic, 1>>;

  explicit position_statistics(const G& grid)
      : origin_mm_(grid.state_mm(0)), position_count_(position_count(grid)) {
    TACMAP_ASSERT(grid.size() > 0 && grid.size() % (grid.rows() * grid.cols()) == 0,
                  "a state_grid's size must be a positive multiple of rows * cols");
    // A latent grid repeats its positions in every hypothesis block: the first block's suffice.
    // A pose grid repeats its first layer's positions in every heading layer (by construction,
    // repeats_positions_per_layer): the first layer's and one angle per layer suffice — on
    // 640 x 480 px with 36 headings the whole 3 x N matrix was 254 MB of doubles and a third
    // of building the localizer (perf).
    Eigen::Index stored = position_count_;
    if constexpr (G::dimension == 3 && repeats_positions_per_layer<G>::value)
      stored = grid.rows() * grid.cols();
    offsets_mm_.resize(G::dimension, stored);
    for (Eigen::Index i = 0; i < stored; ++i) offsets_mm_.col(i) = grid.state_mm(i) - origin_mm_;
    if constexpr (G::dimension >= 2) lattice_step_ = lattice_step(grid);
    if constexpr (G::dimension == 3 && has_circular_coordinates<G>)
      if (G::circular[2] && !G::circular[0] && !G::circular[1] && positions_form_lattice())
        summarises_ = layered_lattice(grid);
    if constexpr (G::dimension == 2 && !has_circular_coordinates<G>)  // linear moments
      if (positions_form_lattice() && grid.rows() * grid.cols() == position_count_) {
        summarises_ = true;  // one layer: the plane's rows
        if constexpr (latent_state_grid<G>) hypotheses_ = grid.hypotheses();
      }
    plane_only_ = stored < position_count_;
    if (plane_only_ && !summarises_) {  // not a lattice after all: every state's coordinates
      offsets_mm_.resize(G::dimension, position_count_);
      for (Eigen::Index i = 0; i < position_count_; ++i)
        offsets_mm_.col(i) = grid.state_mm(i) - origin_mm_;
      plane_only_ = false;
    }
  }

  /// True when the statistics can come from a summary of the belief kept row by row
  /// (`refresh`, then the `*_summarised` members): a pose grid's positions, each heading layer
  /// the same lattice at one angle, or a planar lattice (one layer; the moments then divided by
  /// the mass, as `estimate`'s). The summary holds, for every (heading layer, image row) of
  /// the position belief p (the hypotheses summed), the sums of p, c p and c^2 p (c the
  /// column), of p log p, its largest value and first column, each hypothesis's mass, and the
  /// position marginal (headings and hypotheses summed) as an image. A refresh recomputes only
  /// the rows whose cells changed (`changed_cells`: after a tracked touch the few rows of its
  /// boxes), so a localized touch's estimate and verdict cost those rows and a pass over the
  /// rows' sums, not a pass over every state. Every row's figures are recomputed whole from the
  /// row's values, in the same order each time: a refreshed summary is the summary computed
  /// afresh, bit for bit. The statistics from it match the per-state passes (`estimate`,
  /// `most_probable_disc`, `heading_probability_within`) to rounding: the MAP state and the
  /// disc exactly, the moments and probabilities within 1e-9, the entropy within 1e-6
  /// (relative, tested; the mean heading where the headings' resultant is not ~0, where it is
  /// rounding noise in both).
  [[nodiscard]] bool summarises() const { return summarises_; }

  /// Brings the summary up to date with `b` after the cells `changed` (every layer) changed
  /// since the last refresh (`changed.all()`: recomputed whole, as the first refresh must be).
  void refresh(const G& grid, view_type b, const changed_cells& changed) const
      requires(G::dimension >= 2) {
    TACMAP_ASSERT(summarises_, "position_statistics::refresh: no summary for this grid");
    const Eigen::Index rows = grid.rows();
    if (changed.all() || !summary_ready_) {
      const Eigen::Index cols = grid.cols();
      summary_.assign(static_cast<std::size_t>(heading_layers_ * rows), row_summary{});
      hypothesis_rows_.assign(static_cast<std::size_t>(hypotheses_ * heading_layers_ * rows), 0.0);
      summary_marginal_.resize(rows, cols);
      for (Eigen::Index r = 0; r < rows; ++r) refresh_row(b, r, rows, cols);
      summary_ready_ = true;
      return;
    }
    for (const Eigen::Index r : changed.touched_rows()) refresh_row(b, r, rows, grid.cols());
  }

  /// `estimate(grid, b)` from the summary (`refresh`ed with `b`).
  [[nodiscard]] estimate_type estimate_summarised(const G& grid) const requires(G::dimension >= 2) {
    TACMAP_ASSERT(summary_ready_, "position_statistics: estimate_summarised before refresh");
    estimate_type e;
    const Eigen::Index rows = grid.rows(), cols = grid.cols();
    const Eigen::Index n = position_count_;
    if constexpr (latent_state_grid<G>) {
      e.hypothesis_probability.assign(static_cast<std::size_t>(hypotheses_), 0.0);
      for (Eigen::Index h = 0; h < hypotheses_; ++h) {
        double m = 0.0;
        for (Eigen::Index k = 0; k < heading_layers_ * rows; ++k)
          m += hypothesis_rows_[static_cast<std::size_t>(h * heading_layers_ * rows + k)];
        e.hypothesis_probability[static_cast<std::size_t>(h)] = m;
      }
      for (std::size_t h = 1; h < e.hypothesis_probability.size(); ++h)
        if (e.hypothesis_probability[h] >
            e.hypothesis_probability[static_cast<std::size_t>(e.map_hypothesis)])
          e.map_hypothesis = static_cast<Eigen::Index>(h);
    }
    // The first state holding the largest value: the first row whose largest reaches it.
    scalar_type top = -std::numeric_limits<scalar_type>::infinity();
    for (const row_summary& s : summary_) top = std::max(top, s.top);
    TACMAP_ASSERT(!std::isnan(top), "position_statistics::estimate: the belief holds a NaN");
    Eigen::Index best = 0;
    for (Eigen::Index k = 0; k < heading_layers_ * rows; ++k)
      if (summary_[static_cast<std::size_t>(k)].top >= top) {
        best = k * cols + summary_[static_cast<std::size_t>(k)].top_col;
        break;
      }
    e.map_probability = static_cast<double>(top);
    e.map_index = best + e.map_hypothesis * n;
    e.map_mm = grid.state_mm(e.map_index);
    if constexpr (G::dimension == 2) {
      summarised_plane_moments(rows, e);
      return e;
    } else {
      return summarised_pose_moments(rows, e);
    }
  }

 private:
  // estimate_summarised of a planar lattice: lattice_moments' arithmetic on the rows' sums, and
  // the entropy.
  void summarised_plane_moments(Eigen::Index rows, estimate_type& e) const
      requires(G::dimension == 2) {
    double m0 = 0.0, mc = 0.0, mcc = 0.0, mr = 0.0, mrr = 0.0, mrc = 0.0, plogp = 0.0;
    for (Eigen::Index r = 0; r < rows; ++r) {
      const row_summary& s = summary_[static_cast<std::size_t>(r)];
      const auto y = static_cast<double>(r);
      m0 += s.s0;
      mc += s.s1;
      mcc += s.s2;
      mr += y * s.s0;
      mrr += y * y * s.s0;
      mrc += y * s.s1;
      plogp += s.plogp;
    }
    const double mass = m0;
    set_lattice_moments(e, m0, mc, mcc, mr, mrr, mrc);
    if (mass > 0.0 && std::isfinite(mass)) {
      const double h = -plogp / mass + std::log(mass);
      e.entropy_nats = std::clamp(h, 0.0, std::log(static_cast<double>(position_count_)));
    }
  }

  // estimate_summarised of a pose grid: the moments over the heading layers.
  estimate_type summarised_pose_moments(Eigen::Index rows, estimate_type& e) const
      requires(G::dimension == 3) {
    const Eigen::Index n = position_count_;
    // Moments in index units (c, r) per heading layer, then scaled: as circular_moments, the
    // sums of p are not divided by the mass (a normalised belief's is 1 within rounding).
    double m_all = 0.0, c_all = 0.0, cc_all = 0.0, r_all = 0.0, rr_all = 0.0, rc_all = 0.0;
    double sum_cos = 0.0, sum_sin = 0.0, plogp = 0.0;
    layer_mass_.assign(static_cast<std::size_t>(heading_layers_), 0.0);
    layer_c_.assign(static_cast<std::size_t>(heading_layers_), 0.0);
    layer_r_.assign(static_cast<std::size_t>(heading_layers_), 0.0);
    for (Eigen::Index l = 0; l < heading_layers_; ++l) {
      double m = 0.0, c = 0.0, rsum = 0.0;
      for (Eigen::Index r = 0; r < rows; ++r) {
        const row_summary& s = summary_[static_cast<std::size_t>(l * rows + r)];
        const auto y = static_cast<double>(r);
        m += s.s0;
        c += s.s1;
        cc_all += s.s2;
        rsum += y * s.s0;
        rr_all += y * y * s.s0;
        rc_all += y * s.s1;
        plogp += s.plogp;
      }
      const auto lu = static_cast<std::size_t>(l);
      layer_mass_[lu] = m;
      layer_c_[lu] = c;
      layer_r_[lu] = rsum;
      m_all += m;
      c_all += c;
      r_all += rsum;
      sum_cos += m * layer_cos_[lu];
      sum_sin += m * layer_sin_[lu];
    }
    const double sx = lattice_step_(0), sy = lattice_step_(1);
    const double mc = c_all, mr = r_all;  // E[c], E[r] (unnormalised, as circular_moments)
    typename estimate_type::vector_type mean = origin_mm_;
    mean(0) += sx * mc;
    mean(1) += sy * mr;
    mean(2) = wrap_angle(std::atan2(sum_sin, sum_cos));
    e.mean_mm = mean;
    typename estimate_type::matrix_type cov = estimate_type::matrix_type::Zero();
    // sum p (c - mc)^2 = sum c^2 p - 2 mc sum c p + mc^2 sum p, and so on.
    cov(0, 0) = sx * sx * std::max(cc_all - 2.0 * mc * c_all + mc * mc * m_all, 0.0);
    cov(1, 1) = sy * sy * std::max(rr_all - 2.0 * mr * r_all + mr * mr * m_all, 0.0);
    cov(0, 1) = cov(1, 0) = sx * sy * (rc_all - mr * c_all - mc * r_all + mc * mr * m_all);
    for (Eigen::Index l = 0; l < heading_layers_; ++l) {
      const auto lu = static_cast<std::size_t>(l);
      const double d = wrap_angle(layer_angle_[lu] - mean(2));
      cov(2, 2) += layer_mass_[lu] * d * d;
      cov(0, 2) += d * sx * (layer_c_[lu] - mc * layer_mass_[lu]);
      cov(1, 2) += d * sy * (layer_r_[lu] - mr * layer_mass_[lu]);
    }
    cov(2, 0) = cov(0, 2);
    cov(2, 1) = cov(1, 2);
    e.covariance_mm2 = cov;
    if (m_all > 0.0 && std::isfinite(m_all)) {
      const double h = -plogp / m_all + std::log(m_all);
      e.entropy_nats = std::clamp(h, 0.0, std::log(static_cast<double>(n)));
    }
    return e;
  }

 public:
  /// `most_probable_disc(grid, b, radius_mm)` from the summary (`refresh`ed with `b`): the same
  /// position marginal, so the same disc bit for bit.
  [[nodiscard]] std::pair<Eigen::Vector2d, double> most_probable_disc_summarised(
      const G& grid, double radius_mm) const {
    TACMAP_ASSERT(summary_ready_, "position_statistics: most_probable_disc_summarised first");
    return disc_on(grid, summary_marginal_, radius_mm);
  }

  /// `heading_probability_within(b, heading_rad, tolerance_rad)` from the summary (`refresh`ed
  /// with `b`): the heading layers' masses.
  [[nodiscard]] double heading_probability_summarised(const G& grid, double heading_rad,
                                                      double tolerance_rad) const
      requires(G::dimension == 3) {
    TACMAP_ASSERT(summary_ready_, "position_statistics: heading_probability_summarised first");
    const Eigen::Index rows = grid.rows();
    double mass = 0.0;
    for (Eigen::Index l = 0; l < heading_layers_; ++l) {
      if (!(std::abs(wrap_angle(layer_angle_[static_cast<std::size_t>(l)] - heading_rad)) <=
            tolerance_rad))
        continue;
      // Each hypothesis's rows, summed in double from the belief (as the per-state pass).
      for (Eigen::Index h = 0; h < hypotheses_; ++h)
        for (Eigen::Index r = 0; r < rows; ++r)
          mass += hypothesis_rows_[static_cast<std::size_t>((h * heading_layers_ + l) * rows + r)];
    }
    return std::min(mass, 1.0);
  }

  /// True when the grid's positions form an axis-aligned regular lattice (planar_grid,
  /// pose_grid): what `most_probable_disc` needs.
  [[nodiscard]] bool positions_form_lattice() const { return lattice_step_.allFinite(); }

  /// `bayes_filter::estimate()` of a normalised belief `b` over `grid`.
  [[nodiscard]] estimate_type estimate(const G& grid, view_type b) const {
    return estimate(grid, b, true);
  }
  /// `estimate` with the mean and covariance summed state by state even on a lattice (the
  /// tests' reference for the lattice's row sums).
  [[nodiscard]] estimate_type estimate_per_state(const G& grid, view_type b) const {
    return estimate(grid, b, false);
  }

 private:
  [[nodiscard]] estimate_type estimate(const G& grid, view_type b, bool use_lattice) const {
    estimate_type e;
    // The belief over positions: the belief itself, or summed over the hypotheses (in scratch
    // kept between calls: a touch allocates nothing).
    Eigen::Array<scalar_type, Eigen::Dynamic, 1>& marginal = estimate_marginal_;
    const scalar_type* positions = b.data();
    const Eigen::Index n = position_count_;
    if constexpr (latent_state_grid<G>) {
      marginal = b.head(n);
      for (Eigen::Index h = 1; h < grid.hypotheses(); ++h) marginal += b.segment(h * n, n);
      positions = marginal.data();
      e.hypothesis_probability.resize(static_cast<std::size_t>(grid.hypotheses()));
      for (Eigen::Index h = 0; h < grid.hypotheses(); ++h)
        e.hypothesis_probability[static_cast<std::size_t>(h)] = double_sum(b.data() + h * n, n);
      for (std::size_t h = 1; h < e.hypothesis_probability.size(); ++h)
        if (e.hypothesis_probability[h] >
            e.hypothesis_probability[static_cast<std::size_t>(e.map_hypothesis)])
          e.map_hypothesis = static_cast<Eigen::Index>(h);
    }
    const view_type p(positions, n);
    // The largest value first (vectorised), then its first state: maxCoeff(&index) is a scalar
    // chain of dependent compares, a third of estimate() on the paper's grid.
    const scalar_type top = p.maxCoeff();
    TACMAP_ASSERT(!std::isnan(top), "position_statistics::estimate: the belief holds a NaN");
    Eigen::Index best = 0;
    while (best + 1 < n && !(p(best) >= top)) ++best;
    e.map_probability = static_cast<double>(top);
    e.map_index = best + e.map_hypothesis * n;
    e.map_mm = grid.state_mm(e.map_index);
    // Moments of the cached coordinates relative to the grid's first state: small numbers, so
    // E[o o^T] - E[o] E[o]^T does not cancel catastrophically even on a far-from-origin map.
    if constexpr (has_circular_coordinates<G>) {
      circular_moments(p, e);
    } else {
      bool on_lattice = false;
      if constexpr (G::dimension == 2) {
        on_lattice = use_lattice && positions_form_lattice() && grid.rows() * grid.cols() == n;
        if (on_lattice) lattice_moments(grid.rows(), grid.cols(), p, e);
      }
      if (!on_lattice) {
        typename estimate_type::vector_type mean_offset = estimate_type::vector_type::Zero();
        typename estimate_type::matrix_type second = estimate_type::matrix_type::Zero();
        double mass = 0.0;
        for (Eigen::Index i = 0; i < n; ++i) {
          const double w = static_cast<double>(p(i));
          const typename estimate_type::vector_type o = offset(i);
          mass += w;
          mean_offset += w * o;
          second.noalias() += (w * o) * o.transpose();
        }
        // Divided by the mass: a float belief sums to 1 only within ~1e-7, and E[o o^T] -
        // E[o] E[o]^T of unnormalised sums is off by that times |o|^2 (a belief on one column
        // of the paper's grid had a variance of -1e-3 mm^2).
        if (mass > 0.0) {
          mean_offset /= mass;
          second /= mass;
        }
        e.covariance_mm2 = second - mean_offset * mean_offset.transpose();
        e.mean_mm = origin_mm_ + mean_offset;
      }
    }
    // 0 log 0 = 0: the tiny offset keeps log finite where p = 0 without changing other terms.
    // Summed in double over short float chunks (mass_sum.hpp), and of p / mass: the entropy of
    // the distribution the belief is, -sum (p/m) log(p/m) = -(sum p log p) / m + log m. A flat
    // float sum gave 17.11 nats on 16 million states, above their log N = 16.59 (issue 37). What
    // is left above log N (or below 0) is the float logarithm's rounding, and clipped.
    const scalar_type tiny = std::numeric_limits<scalar_type>::min();
    const double mass = mass_sum(p);
    if (mass > 0.0 && std::isfinite(mass)) {
      const double h = -chunked_sum(p * (p + tiny).log()) / mass + std::log(mass);
      e.entropy_nats = std::clamp(h, 0.0, std::log(static_cast<double>(n)));
    }
    return e;
  }

  // Mean and covariance of a belief over a lattice (position (r, c) at origin + (c sx, r sy)):
  // from the rows' sums of p, c p and c^2 p (one matrix product over the belief in double),
  // instead of a 2 x 2 outer product per state. The central moments are taken in index units
  // and scaled last: whole-number indices make a one-state belief's variance exactly 0 (scaled
  // first, E[x^2] - E[x]^2 rounded to -4e-12 mm^2). The coordinates are c sx and r sy, not the
  // cached offsets, which match them within lattice_step's tolerance (1e-6 of a step);
  // tested against estimate_per_state.
  void lattice_moments(Eigen::Index rows, Eigen::Index cols, view_type p, estimate_type& e) const
      requires(G::dimension == 2) {
    Eigen::MatrixXd& weights = moment_weights_;  // columns: 1, c, c^2
    if (weights.rows() != cols) {
      weights.resize(cols, 3);
      for (Eigen::Index c = 0; c < cols; ++c) {
        const auto x = static_cast<double>(c);
        weights.row(c) << 1.0, x, x * x;
      }
    }
    auto& belief = moment_belief_;
    belief = Eigen::Map<
                 const Eigen::Matrix<scalar_type, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
                 p.data(), rows, cols)
                 .template cast<double>();
    Eigen::MatrixXd& per_row = moment_rows_;  // row r: sum p, sum c p, sum c^2 p
    // Coefficient by coefficient (a vectorised dot product of contiguous rows each): a general
    // matrix product packed the 8,000-value belief first, for three columns.
    per_row.noalias() = belief.lazyProduct(weights);
    double m0 = 0.0, mc = 0.0, mcc = 0.0, mr = 0.0, mrr = 0.0, mrc = 0.0;
    for (Eigen::Index r = 0; r < rows; ++r) {
      const auto y = static_cast<double>(r);
      m0 += per_row(r, 0);
      mc += per_row(r, 1);
      mcc += per_row(r, 2);
      mr += y * per_row(r, 0);
      mrr += y * y * per_row(r, 0);
      mrc += y * per_row(r, 1);
    }
    set_lattice_moments(e, m0, mc, mcc, mr, mrr, mrc);
  }

  // A planar lattice's mean and covariance from its sums over cells (col c, row r, in cells):
  // m0 = sum p, mc = sum c p, mcc = sum c^2 p, mr = sum r p, mrr = sum r^2 p, mrc = sum r c p.
  // Expectations are divided by the mass (see estimate's per-state sums); the covariance is
  // clamped at 0 on the diagonal against rounding.
  void set_lattice_moments(estimate_type& e, double m0, double mc, double mcc, double mr,
                           double mrr, double mrc) const {
    if (m0 > 0.0) {
      mc /= m0;
      mcc /= m0;
      mr /= m0;
      mrr /= m0;
      mrc /= m0;
    }
    const double sx = lattice_step_(0), sy = lattice_step_(1);
    typename estimate_type::vector_type mean_offset = estimate_type::vector_type::Zero();
    mean_offset(0) = sx * mc;
    mean_offset(1) = sy * mr;
    typename estimate_type::matrix_type cov = estimate_type::matrix_type::Zero();
    cov(0, 0) = sx * sx * std::max(mcc - mc * mc, 0.0);
    cov(1, 1) = sy * sy * std::max(mrr - mr * mr, 0.0);
    cov(0, 1) = cov(1, 0) = sx * sy * (mrc - mr * mc);
    e.covariance_mm2 = cov;
    e.mean_mm = origin_mm_ + mean_offset;
  }

 public:
  /// The mass of `b` whose position lies within `radius_mm` of `center_mm` (both validated by
  /// the caller).
  [[nodiscard]] double probability_within(view_type b, const Eigen::Vector2d& center_mm,
                                          double radius_mm) const requires(G::dimension >= 2) {
    const Eigen::Vector2d c = center_mm - origin_mm_.template head<2>();
    const double r2 = radius_mm * radius_mm;
    return masked_mass(
        b, [&](Eigen::Index i) { return (offset(i).template head<2>() - c).squaredNorm() <= r2; });
  }

  /// `bayes_filter::most_probable_disc` of `b` over `grid` (radius validated by the caller;
  /// throws std::logic_error when the positions are no lattice).
  [[nodiscard]] std::pair<Eigen::Vector2d, double> most_probable_disc(const G& grid, view_type b,
                                                                      double radius_mm) const
      requires(G::dimension >= 2) {
    const Eigen::Index rows = grid.rows(), cols = grid.cols(), plane = rows * cols;
    if (!positions_form_lattice())
      fail<std::logic_error>(
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
    for (Eigen::Index at = 0; at < b.size(); at += plane)
      p_flat += view_type(b.data() + at, plane).template cast<double>();
    return disc_on(grid, p, radius_mm);
  }

 private:
  // most_probable_disc of the position marginal p (rows x cols, every layer summed).
  std::pair<Eigen::Vector2d, double> disc_on(const G& grid, const image<double>& p,
                                             double radius_mm) const requires(G::dimension >= 2) {
    const Eigen::Index rows = grid.rows(), cols = grid.cols();
    const double sx = std::abs(lattice_step_(0)), sy = std::abs(lattice_step_(1));
    // Reaches clamped to the grid (a disc wider than the grid covers all of it): a radius of
    // 1e300 mm would otherwise overflow the integer conversion.
    const auto reach_r = static_cast<Eigen::Index>(
        std::min(std::floor(radius_mm / sy + 1e-9), static_cast<double>(rows)));
    std::vector<Eigen::Index> half(static_cast<std::size_t>(reach_r + 1));
    for (Eigen::Index dr = 0; dr <= reach_r; ++dr) {
      const double dy = static_cast<double>(dr) * sy;
      half[static_cast<std::size_t>(dr)] = static_cast<Eigen::Index>(std::min(
          std::floor(std::sqrt(std::max(0.0, radius_mm * radius_mm - dy * dy)) / sx + 1e-9),
          static_cast<double>(cols)));
    }
    const Eigen::Index pad = half[0];
    image<double>& prefix = disc_prefix_;  // prefix(r, pad + j) = sum of p(r, 0..j-1)
    prefix.resize(rows, cols + 1 + 2 * pad);
    // Built for the rows a scanned disc row reaches only (see the bound below), four rows at a
    // time: a row's running sum is a chain of dependent adds, and four chains hide each other's
    // latency (the same sums, in the same order per row, whichever rows are built together).
    constexpr Eigen::Index group = 4;
    std::vector<char>& built = disc_built_;
    built.assign(static_cast<std::size_t>(rows), 0);
    const auto build_group = [&](const std::array<Eigen::Index, group>& todo, Eigen::Index k_end) {
      std::array<double, group> run{};
      for (Eigen::Index k = 0; k < k_end; ++k)
        for (Eigen::Index j = 0; j <= pad; ++j) prefix(todo[static_cast<std::size_t>(k)], j) = 0.0;
      if (k_end == group) {
        for (Eigen::Index c = 0; c < cols; ++c)
          for (std::size_t k = 0; k < group; ++k)
            prefix(todo[k], pad + c + 1) = run[k] += p(todo[k], c);
      } else {
        for (std::size_t k = 0; k < static_cast<std::size_t>(k_end); ++k)
          for (Eigen::Index c = 0; c < cols; ++c)
            prefix(todo[k], pad + c + 1) = run[k] += p(todo[k], c);
      }
      for (std::size_t k = 0; k < static_cast<std::size_t>(k_end); ++k)
        for (Eigen::Index j = pad + cols + 1; j < prefix.cols(); ++j) prefix(todo[k], j) = run[k];
    };
    const auto build_rows = [&](Eigen::Index from, Eigen::Index to) {  // rows [from, to]
      std::array<Eigen::Index, group> todo{};
      Eigen::Index k_end = 0;
      for (Eigen::Index r = std::max<Eigen::Index>(from, 0); r <= std::min(to, rows - 1); ++r) {
        if (built[static_cast<std::size_t>(r)] != 0) continue;
        built[static_cast<std::size_t>(r)] = 1;
        todo[static_cast<std::size_t>(k_end++)] = r;
        if (k_end == group) {
          build_group(todo, k_end);
          k_end = 0;
        }
      }
      if (k_end > 0) build_group(todo, k_end);
    };
    // Plain loops over contiguous rows (vectorised by the compiler): rows are short (~100), and
    // an Eigen expression per (row, run) costs more than its arithmetic.
    image<double>& disc = disc_mass_;
    disc.resize(rows, cols);
    const Eigen::Index stride = prefix.cols();
    const auto disc_row = [&](Eigen::Index r) {  // row r's discs; returns their largest mass
      build_rows(r - reach_r, r + reach_r);
      double* out = disc.data() + r * cols;
      std::fill(out, out + cols, 0.0);
      for (Eigen::Index dr = -reach_r; dr <= reach_r; ++dr) {
        const Eigen::Index rr = r + dr;
        if (rr < 0 || rr >= rows) continue;
        const Eigen::Index h = half[static_cast<std::size_t>(dr < 0 ? -dr : dr)];
        // Row rr's run c - h .. c + h for every c at once.
        const double* hi = prefix.data() + rr * stride + pad + h + 1;
        const double* lo = prefix.data() + rr * stride + pad - h;
        for (Eigen::Index c = 0; c < cols; ++c) out[c] += hi[c] - lo[c];
      }
      return Eigen::Map<const Eigen::ArrayXd>(out, cols).maxCoeff();
    };
    // A bound on each row's discs: the totals of the rows they reach. A run's computed mass
    // hi - lo is at most its row's running total (the prefix sums of non-negative values never
    // decrease, lo >= 0, and rounding is monotone), so a disc's sum of runs is at most the sum
    // of those totals in the runs' order, rounding included; the totals here are summed in
    // another order (vectorised: no prefix is built for them), which differs from that by far
    // less than the 1e-9 (relative) and 1e-300 (subnormal) slack added. Only rows whose bound
    // reaches the best mass found can hold the best disc: once localized, the few rows around
    // the peak are scanned and their prefixes built, not the grid's (the whole-grid scan was
    // most of the disc's cost at known heading). The same disc, bit for bit, as scanning every
    // row: the first cell (row-major) holding the most mass.
    std::vector<double>& total = disc_total_;
    total.resize(static_cast<std::size_t>(rows));
    for (Eigen::Index r = 0; r < rows; ++r)
      total[static_cast<std::size_t>(r)] = double_sum(p.data() + r * cols, cols);
    std::vector<double>& bound = disc_bound_;
    bound.assign(static_cast<std::size_t>(rows), 0.0);
    Eigen::Index first = 0;
    for (Eigen::Index r = 0; r < rows; ++r) {
      double b = 0.0;
      for (Eigen::Index rr = std::max<Eigen::Index>(0, r - reach_r);
           rr <= std::min(rows - 1, r + reach_r); ++rr)
        b += total[static_cast<std::size_t>(rr)];
      bound[static_cast<std::size_t>(r)] = b * (1.0 + 1e-9) + 1e-300;
      if (bound[static_cast<std::size_t>(r)] > bound[static_cast<std::size_t>(first)]) first = r;
    }
    double best_mass = disc_row(first);
    Eigen::Index best_row = first;
    for (Eigen::Index r = 0; r < rows; ++r) {
      if (r == first || bound[static_cast<std::size_t>(r)] < best_mass) continue;
      const double row_best = disc_row(r);
      if (row_best > best_mass || (row_best == best_mass && r < best_row)) {
        best_mass = row_best;
        best_row = r;
      }
    }
    Eigen::Index best_col = 0;
    const double* best_cells = disc.data() + best_row * cols;
    while (best_col + 1 < cols && !(best_cells[best_col] >= best_mass)) ++best_col;
    const Eigen::Index best_r = best_row, best_c = best_col;
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

 public:
  /// The mass of `b` whose heading lies within `tolerance_rad` of `heading_rad` (validated by
  /// the caller).
  [[nodiscard]] double heading_probability_within(view_type b, double heading_rad,
                                                  double tolerance_rad) const
      requires(G::dimension == 3 && has_circular_coordinates<G>) {
    // Remembered from the previous state, as in circular_moments: states come heading by
    // heading.
    double last_angle = std::numeric_limits<double>::quiet_NaN();
    bool last_inside = false;
    return masked_mass(b, [&](Eigen::Index i) {
      const double angle = origin_mm_(2) + offset(i)(2);
      if (!(angle == last_angle)) {
        last_angle = angle;
        last_inside = std::abs(wrap_angle(angle - heading_rad)) <= tolerance_rad;
      }
      return last_inside;
    });
  }

 private:
  // Mean and covariance when some coordinates are angles (G::circular[k]): the mean angle is
  // the circular mean atan2(E[sin], E[cos]) in [-pi, pi), and deviations from it are wrapped
  // into [-pi, pi) before the (co)variances are taken — a belief split between -179 and +179
  // degrees has mean 180 degrees and a small spread, not mean 0 and a huge one. Two passes: the
  // mean first, then the wrapped deviations.
  void circular_moments(view_type belief,
                        estimate_type& e) const requires has_circular_coordinates<G> {
    constexpr int dim = G::dimension;
    typename estimate_type::vector_type mean_offset = estimate_type::vector_type::Zero();
    std::array<double, static_cast<std::size_t>(dim)> sum_cos{};
    std::array<double, static_cast<std::size_t>(dim)> sum_sin{};
    // An angle's cosine, sine and wrapped deviation are remembered from the previous state: a
    // pose grid's states come heading by heading, so consecutive states share their angle and
    // each pass computes a few dozen of them, not one per state (sincos and fmod per state were
    // 60 % of a tracked touch over 36 headings). The same values, bit for bit.
    constexpr double none = std::numeric_limits<double>::quiet_NaN();
    std::array<double, static_cast<std::size_t>(dim)> last_angle, last_cos{}, last_sin{};
    last_angle.fill(none);
    for (Eigen::Index i = 0; i < belief.size(); ++i) {
      const double p = static_cast<double>(belief(i));
      if (p == 0.0) continue;
      const typename estimate_type::vector_type o = offset(i);
      for (int k = 0; k < dim; ++k) {
        const auto ku = static_cast<std::size_t>(k);
        if (G::circular[ku]) {
          const double angle = origin_mm_(k) + o(k);
          if (!(angle == last_angle[ku])) {
            last_angle[ku] = angle;
            last_cos[ku] = std::cos(angle);
            last_sin[ku] = std::sin(angle);
          }
          sum_cos[ku] += p * last_cos[ku];
          sum_sin[ku] += p * last_sin[ku];
        } else {
          mean_offset(k) += p * o(k);
        }
      }
    }
    typename estimate_type::vector_type mean = origin_mm_ + mean_offset;
    for (int k = 0; k < dim; ++k)
      if (G::circular[static_cast<std::size_t>(k)])
        mean(k) = wrap_angle(
            std::atan2(sum_sin[static_cast<std::size_t>(k)], sum_cos[static_cast<std::size_t>(k)]));
    e.mean_mm = mean;
    typename estimate_type::matrix_type cov = estimate_type::matrix_type::Zero();
    typename estimate_type::vector_type d;
    std::array<double, static_cast<std::size_t>(dim)> last_deviation{};
    last_angle.fill(none);
    for (Eigen::Index i = 0; i < belief.size(); ++i) {
      const double p = static_cast<double>(belief(i));
      if (p == 0.0) continue;
      const typename estimate_type::vector_type o = offset(i);
      for (int k = 0; k < dim; ++k) {
        const auto ku = static_cast<std::size_t>(k);
        if (G::circular[ku]) {
          const double angle = origin_mm_(k) + o(k);
          if (!(angle == last_angle[ku])) {
            last_angle[ku] = angle;
            last_deviation[ku] = wrap_angle(angle - mean(k));
          }
          d(k) = last_deviation[ku];
        } else {
          d(k) = o(k) - mean_offset(k);
        }
      }
      cov.noalias() += (p * d) * d.transpose();
    }
    e.covariance_mm2 = cov;
  }

  // Mass of the states whose position (the base grid's state for latent grids, in every
  // hypothesis block) satisfies `inside(position index)`, accumulated in double.
  template <class Inside>
  double masked_mass(view_type b, Inside inside) const {
    const Eigen::Index n = position_count_;
    double mass = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (!inside(i)) continue;
      for (Eigen::Index s = i; s < b.size(); s += n) mass += static_cast<double>(b(s));
    }
    return std::min(mass, 1.0);
  }

  // The steps (column, row) of the plane's positions when every position of the first plane is
  // origin + c * step_x + r * step_y (checked on every state); NaN otherwise.
  Eigen::Vector2d lattice_step(const G& grid) const requires(G::dimension >= 2) {
    const Eigen::Index rows = grid.rows(), cols = grid.cols();
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

  // One (heading layer, image row) of the summary (see `summarises`).
  struct row_summary {
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, plogp = 0.0;
    scalar_type top = -std::numeric_limits<scalar_type>::infinity();
    Eigen::Index top_col = 0;
  };

  // True when every heading layer's positions are the first layer's lattice and each layer's
  // states share one angle; caches the layers' angles, cosines and sines.
  // A pose grid (repeats_positions_per_layer) is such by construction: each layer's angle is
  // read from its first state, the positions are not compared state by state.
  bool layered_lattice(const G& grid) requires(G::dimension == 3) {
    const Eigen::Index plane = grid.rows() * grid.cols(), n = position_count_;
    if (n % plane != 0) return false;
    heading_layers_ = n / plane;
    if constexpr (latent_state_grid<G>)
      hypotheses_ = grid.hypotheses();
    else
      hypotheses_ = 1;
    const double tolerance = 1e-6 * (std::abs(lattice_step_(0)) + std::abs(lattice_step_(1)));
    const bool by_construction = offsets_mm_.cols() < n;
    for (Eigen::Index l = 0; l < heading_layers_; ++l) {
      const double angle =
          by_construction ? grid.state_mm(l * plane)(2) - origin_mm_(2) : offsets_mm_(2, l * plane);
      for (Eigen::Index i = 0; !by_construction && i < plane; ++i) {
        const auto o = offsets_mm_.col(l * plane + i);
        if (!(o(2) == angle) || std::abs(o(0) - offsets_mm_(0, i)) > tolerance ||
            std::abs(o(1) - offsets_mm_(1, i)) > tolerance)
          return false;
      }
      layer_offset_.push_back(angle);
      const double a = origin_mm_(2) + angle;
      layer_angle_.push_back(a);
      layer_cos_.push_back(std::cos(a));
      layer_sin_.push_back(std::sin(a));
    }
    return true;
  }

  // Recomputes image row r of every heading layer: the position belief's row (the hypotheses
  // summed in float, in order, as estimate's marginal), its sums and largest value, each
  // hypothesis's row mass, and the position marginal's row (every layer summed in double, in
  // order, as most_probable_disc's).
  void refresh_row(view_type b, Eigen::Index r, Eigen::Index rows, Eigen::Index cols) const {
    const Eigen::Index plane = rows * cols, n = heading_layers_ * plane;
    auto& row = summary_row_;
    if (column_weights_.size() != cols) {
      column_weights_.resize(cols);
      column_squares_.resize(cols);
      for (Eigen::Index c = 0; c < cols; ++c) {
        column_weights_(c) = static_cast<double>(c);
        column_squares_(c) = static_cast<double>(c) * static_cast<double>(c);
      }
    }
    auto marginal = summary_marginal_.row(r);
    marginal.setZero();
    const scalar_type tiny = std::numeric_limits<scalar_type>::min();
    for (Eigen::Index l = 0; l < heading_layers_; ++l) {
      const Eigen::Index at = l * plane + r * cols;
      row = b.segment(at, cols);
      hypothesis_rows_[static_cast<std::size_t>(l * rows + r)] = double_sum(b.data() + at, cols);
      for (Eigen::Index h = 1; h < hypotheses_; ++h) {
        const auto part = b.segment(h * n + at, cols);
        hypothesis_rows_[static_cast<std::size_t>((h * heading_layers_ + l) * rows + r)] =
            double_sum(part.data(), cols);
        row += part;
      }
      row_summary& s = summary_[static_cast<std::size_t>(l * rows + r)];
      row_double_ = row.template cast<double>();
      s.s0 = row_double_.sum();
      s.s1 = (row_double_ * column_weights_).sum();
      s.s2 = (row_double_ * column_squares_).sum();
      s.plogp = chunked_sum(row * (row + tiny).log());
      s.top = row.maxCoeff();
      Eigen::Index c = 0;
      while (c + 1 < cols && !(row(c) >= s.top)) ++c;
      s.top_col = c;
    }
    // Layer after layer in the belief's order (hypothesis-major), as most_probable_disc.
    for (Eigen::Index h = 0; h < hypotheses_; ++h)
      for (Eigen::Index l = 0; l < heading_layers_; ++l)
        marginal +=
            b.segment(h * n + l * plane + r * cols, cols).template cast<double>().transpose();
  }

  // State i's coordinates relative to the first state (i < position_count_): from the first
  // layer's positions and the layer's angle when only those are kept (plane_only_).
  typename estimate_type::vector_type offset(Eigen::Index i) const {
    if constexpr (G::dimension == 3) {
      if (plane_only_) {
        const Eigen::Index plane = offsets_mm_.cols();
        typename estimate_type::vector_type o = offsets_mm_.col(i % plane);
        o(2) = layer_offset_[static_cast<std::size_t>(i / plane)];
        return o;
      }
    }
    return offsets_mm_.col(i);
  }

  // Positions the estimate describes: the base grid's states for latent grids, else all states.
  static Eigen::Index position_count(const G& grid) {
    if constexpr (latent_state_grid<G>)
      return grid.hypothesis_size();
    else
      return grid.size();
  }

  typename estimate_type::vector_type origin_mm_;
  Eigen::Index position_count_ = 0;
  // Every position's coordinates relative to origin_mm_, or with plane_only_ the first heading
  // layer's (a pose grid: see offset()); layer_offset_: each heading layer's angle, relative.
  Eigen::Matrix<double, G::dimension, Eigen::Dynamic> offsets_mm_;
  bool plane_only_ = false;
  std::vector<double> layer_offset_;

  // See lattice_step(); NaN: not a lattice (or fewer than two coordinates).
  Eigen::Vector2d lattice_step_ =
      Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  // most_probable_disc's scratch: the position marginal, its row prefix sums, the disc masses.
  mutable image<double> disc_marginal_, disc_prefix_, disc_mass_;
  mutable std::vector<double> disc_bound_, disc_total_;
  mutable std::vector<char> disc_built_;
  // estimate's scratch: the position marginal (latent grids), and lattice_moments' weights,
  // belief in double and per-row sums.
  mutable Eigen::Array<scalar_type, Eigen::Dynamic, 1> estimate_marginal_;
  mutable Eigen::MatrixXd moment_weights_, moment_rows_;
  mutable Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> moment_belief_;
  // The summary (see `summarises`): per (heading layer, row), per (hypothesis, heading layer,
  // row) the mass, the position marginal; the layers' angles; refresh's scratch.
  bool summarises_ = false;
  Eigen::Index heading_layers_ = 1, hypotheses_ = 1;
  std::vector<double> layer_angle_, layer_cos_, layer_sin_;
  mutable bool summary_ready_ = false;
  mutable std::vector<row_summary> summary_;
  mutable std::vector<double> hypothesis_rows_;
  mutable image<double> summary_marginal_;
  mutable std::vector<double> layer_mass_, layer_c_, layer_r_;
  mutable Eigen::Array<scalar_type, Eigen::Dynamic, 1> summary_row_;
  mutable Eigen::ArrayXd row_double_, column_weights_, column_squares_;
};

}  // namespace tacmap::detail
