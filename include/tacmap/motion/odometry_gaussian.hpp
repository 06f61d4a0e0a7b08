// tacmap: `odometry_gaussian` — the paper's motion model (Sec. III-B).
//
// The arm (or haptic device) acts as an odometer: between two touches the sensor centre moved by
// u_t = (dx, dy) in the map frame. The paper models p(x_t | x_{t-1}, u_t) as a Gaussian
// N(x_t; x_hat_t, Sigma) centred on x_hat_t = x_{t-1} + u_t and "locally weighted" over the
// nearest k states (k = 8 in the paper, i.e. the 3 x 3 neighbourhood).
//
// Whole-grid implementation: because the displacement is the same for every state, the
// transition is a convolution. We split u_t (in pixels) into an integer part and a fraction
// f in [0, 1)^2, shift by the integer part, apply the bilinear 2 x 2 kernel for f (so the
// predicted mean equals the odometry exactly, not rounded to a pixel), and spread with the
// Gaussian stencil over each state and its k nearest neighbours (weights normalised over the
// stencil). Shift, bilinear and Gaussian are folded into one small composite stencil. The square
// stencils (k = 8: 3 x 3, k = 24: 5 x 5) factor into x and y: two passes in which every output is
// written once as the weighted sum of its taps; other discs are applied as one block multiply-add
// per tap over the whole belief image.
//
// Covariance: per axis, the predicted spread is the truncated Gaussian's variance plus the
// bilinear split's f(1 - f) px^2 (zero for whole-pixel motions). With the paper's k = 8 the
// stencil is 3 x 3, so sigma larger than about one pixel is truncated; choose a larger k
// (any count of lattice neighbours within a disc: 4, 8, 12, 20, 24, ...) for larger noise.
//
// Mass pushed off the grid: with `off_grid::renormalize` (default) it is dropped and the rest
// renormalised — the filter then conditions on "the sensor is still over the map" — and the
// fraction dropped is reported in `prediction_report::mass_lost`. With `off_grid::clamp` it is
// piled onto the nearest edge state instead. If a motion would leave no mass on the grid the
// model throws std::domain_error and the filter keeps its previous belief.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <sstream>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "tacmap/detail/mass_sum.hpp"
#include "tacmap/detail/setting_ranges.hpp"
#include "tacmap/detail/weighted_sum.hpp"
#include "tacmap/grid/concept.hpp"
#include "tacmap/image.hpp"
#include "tacmap/motion/concept.hpp"

namespace tacmap {

/// Planar odometry: the sensor centre's displacement since the previous step, map frame, mm.
struct odometry {
  double dx_mm = 0.0;  ///< along the map's x axis (columns, to the right)
  double dy_mm = 0.0;  ///< along the map's y axis (rows, downwards)
};

/// What happens to belief mass that a motion carries off the grid.
enum class off_grid {
  renormalize,  ///< drop it and renormalise the rest (reported as mass_lost)
  clamp,        ///< pile it onto the nearest edge state
};

/// Configuration of `odometry_gaussian`. Defaults are the paper's k = 8 with sigma 1 mm.
struct odometry_gaussian_params {
  double sigma_mm = 1.0;  ///< standard deviation of the motion noise, per axis
  int k = 8;              ///< neighbours of each state the noise spreads over
  off_grid boundary = off_grid::renormalize;
};

namespace detail {

/// Largest stencil radius in pixels; bounds the composite stencil so it lives on the stack.
inline constexpr int max_stencil_radius = 10;

/// Neighbour counts k that select a whole disc of lattice points (no ties broken arbitrarily):
/// the number of points with 0 < ox^2 + oy^2 <= r2, for each r2 that occurs.
inline std::vector<int> supported_neighbour_counts() {
  std::vector<int> counts;
  constexpr int r = max_stencil_radius;
  for (int r2 = 1; r2 <= r * r; ++r2) {
    int n = 0;
    bool shell = false;
    for (int oy = -r; oy <= r; ++oy)
      for (int ox = -r; ox <= r; ++ox) {
        const int d2 = ox * ox + oy * oy;
        n += (d2 > 0 && d2 <= r2) ? 1 : 0;
        shell = shell || d2 == r2;
      }
    if (shell) counts.push_back(n);
  }
  return counts;
}

/// One tap of a stencil: integer offset (in pixels) and the squared distance it represents.
struct stencil_offset {
  int dy = 0;
  int dx = 0;
  int d2 = 0;
};

/// Adds w * (in shifted by (oy, ox)) to out for whole images, handling the grid's edges.
/// Along each axis the source range splits into the part that lands inside the grid and the
/// parts that fall off below/above; `clamp` decides whether those parts pile onto the edge.
template <class T>
void shifted_accumulate(const Eigen::Map<const image<T>>& in, Eigen::Map<image<T>>& out,
                        Eigen::Index oy, Eigen::Index ox, T w, bool clamp) {
  struct segment {
    Eigen::Index src, dst, len;
    bool collapsed;  // all of `len` sources land on the single edge index `dst`
  };
  const auto split = [](Eigen::Index n, Eigen::Index o) {
    std::array<segment, 3> s{};
    const Eigen::Index lo = std::clamp<Eigen::Index>(-o, 0, n);      // sources with dst < 0
    const Eigen::Index hi = std::clamp<Eigen::Index>(n - o, lo, n);  // first source with dst >= n
    s[0] = {0, 0, lo, true};
    s[1] = {lo, lo + o, hi - lo, false};
    s[2] = {hi, n - 1, n - hi, true};
    return s;
  };
  const auto rows = split(in.rows(), oy);
  const auto cols = split(in.cols(), ox);
  for (const segment& r : rows) {
    if (r.len == 0 || (r.collapsed && !clamp)) continue;
    for (const segment& c : cols) {
      if (c.len == 0 || (c.collapsed && !clamp)) continue;
      const auto src = in.block(r.src, c.src, r.len, c.len);
      if (!r.collapsed && !c.collapsed)
        out.block(r.dst, c.dst, r.len, c.len) += w * src;
      else if (r.collapsed && !c.collapsed)
        out.row(r.dst).segment(c.dst, c.len) += w * src.colwise().sum();
      else if (!r.collapsed && c.collapsed)
        out.col(c.dst).segment(r.dst, r.len) += w * src.rowwise().sum();
      else
        out(r.dst, c.dst) += w * src.sum();
    }
  }
}

/// The end of every prediction: `out` (what the motion kept of `in`) renormalised to sum 1, and
/// the fraction lost reported. When nothing is left, `nothing_left()` throws (it names the
/// motion) and `out` is garbage; the filter then keeps its belief.
template <class Array, class Fail>
prediction_report renormalise_prediction(const Array& in, Array& out, const Fail& nothing_left) {
  // In double over short float chunks (mass_sum.hpp): a flat float sum of a 16-million-state
  // prediction came to 0.981.
  const double kept = mass_sum(out);
  const double before = mass_sum(in);
  if (!(kept > 0.0) || !std::isfinite(kept)) nothing_left();
  out *= static_cast<typename Array::Scalar>(1.0 / kept);
  return {std::clamp(1.0 - kept / before, 0.0, 1.0)};
}

}  // namespace detail

/// Grids `odometry_gaussian` can move over: a 2-D image of states on a metric map.
template <class G>
concept metric_planar_grid = state_grid<G> && G::dimension == 2 && requires(const G& g) {
  { g.mm_per_px() } -> std::convertible_to<double>;
};

/// The paper's motion model: shift by odometry, spread with a Gaussian over k neighbours.
class odometry_gaussian {
 public:
  using control_type = odometry;

  /// Throws std::invalid_argument for a sigma outside [detail::min_sigma_mm,
  /// detail::max_sigma_mm] (1e-3 to 1e6 mm: setting_ranges.hpp), or an unsupported k (the
  /// message lists the supported values).
  explicit odometry_gaussian(odometry_gaussian_params params = {}) : params_(params) {
    detail::check_range("odometry_gaussian", "sigma_mm", params.sigma_mm, detail::min_sigma_mm,
                        detail::max_sigma_mm, " mm", "the motion noise's standard deviation",
                        "give the odometry's noise per axis in millimetres (the paper: 1)");
    const std::vector<int> counts = detail::supported_neighbour_counts();
    if (std::find(counts.begin(), counts.end(), params.k) == counts.end()) {
      std::ostringstream list;
      for (std::size_t i = 0; i < 8 && i < counts.size(); ++i) list << counts[i] << ", ";
      detail::fail("odometry_gaussian: k = ", params.k,
                   " neighbours is not supported; expected a count that selects a whole disc of "
                   "neighbouring states (",
                   list.str(), "... up to ", counts.back(),
                   "); the paper uses k = 8 (the 3 x 3 neighbourhood)");
    }
    for (int oy = -detail::max_stencil_radius; oy <= detail::max_stencil_radius; ++oy)
      for (int ox = -detail::max_stencil_radius; ox <= detail::max_stencil_radius; ++ox)
        offsets_.push_back({oy, ox, ox * ox + oy * oy});
    std::stable_sort(offsets_.begin(), offsets_.end(),
                     [](const auto& a, const auto& b) { return a.d2 < b.d2; });
    offsets_.resize(static_cast<std::size_t>(params.k) + 1);
    for (const auto& o : offsets_) radius_ = std::max({radius_, std::abs(o.dx), std::abs(o.dy)});
    separable_ = offsets_.size() == static_cast<std::size_t>((2 * radius_ + 1) * (2 * radius_ + 1));
  }

  [[nodiscard]] const odometry_gaussian_params& params() const { return params_; }
  /// Half-width in pixels of the Gaussian stencil selected by k.
  [[nodiscard]] int radius_px() const { return radius_; }

  /// The control update for the whole grid (see the file comment for the maths).
  template <metric_planar_grid G>
  prediction_report predict(const G& grid, const belief_array<G>& in, belief_array<G>& out,
                            const odometry& u) const {
    using T = typename G::scalar_type;
    if (!(std::isfinite(u.dx_mm) && std::isfinite(u.dy_mm)))
      detail::fail("odometry_gaussian: odometry (dx_mm, dy_mm) = (", u.dx_mm, ", ", u.dy_mm,
                   "); expected finite displacements in millimetres — check the position "
                   "source for dropped or invalid samples");
    TACMAP_ASSERT(in.size() == grid.size() && out.size() == grid.size(),
                  "belief buffers must match the grid");

    TACMAP_ASSERT(grid.size() == grid.rows() * grid.cols(),
                  "odometry_gaussian moves single-layer (x, y) grids");
    const Eigen::Map<const image<T>> in_img(in.data(), grid.rows(), grid.cols());
    Eigen::Map<image<T>> out_img(out.data(), grid.rows(), grid.cols());
    transport(in_img, out_img, u.dx_mm / grid.mm_per_px(), u.dy_mm / grid.mm_per_px(),
              grid.mm_to_px(params_.sigma_mm));

    return detail::renormalise_prediction(in, out, [&] {
      detail::fail<std::domain_error>(
          "odometry_gaussian: odometry (", u.dx_mm, ", ", u.dy_mm, ") mm moves all belief mass ",
          "off the grid; expected a displacement that keeps the sensor over the map — check the "
          "units (millimetres) and the map-frame calibration, or use off_grid::clamp");
    });
  }

  /// Tracking mode (`moves_box`): the mass inside each of the pairwise disjoint `boxes` moved as
  /// `predict` moves it, in place; every state outside them keeps its value. Each box is copied,
  /// with R + 1 zero cells on each side (the reach of the stencil and the bilinear split), into
  /// a small window that is transported by the shift's fraction only and added back at the box's
  /// place moved by the integer part: each output is the same weighted sum of the same taps as
  /// in `predict`, less the taps that read outside the boxes. Every box is read (and cleared)
  /// before any moved window is added, so a window may overlap another box. `landed[i]` is box
  /// i's window on the grid (where its mass now is). Mass a window carries past the grid's edge
  /// is dropped, as `predict` drops it with `off_grid::renormalize`, and its sum returned in
  /// `dropped` (not renormalised: the caller decides). False, `belief` unchanged, when a window
  /// would reach past the edge with `off_grid::clamp` (which piles mass on edge states), when
  /// it would leave the grid entirely, or when the odometry is not finite.
  /// `belief`: the grid's belief, or a map of it (`latent_motion` moves each hypothesis's
  /// block in place).
  template <metric_planar_grid G, class Belief>
  bool predict_boxes(const G& grid, Belief& belief, std::span<const grid_box> boxes,
                     const odometry& u, std::vector<grid_box>& landed, double& dropped) const {
    using T = typename G::scalar_type;
    if (!(std::isfinite(u.dx_mm) && std::isfinite(u.dy_mm))) return false;
    const Eigen::Index rows = grid.rows(), cols = grid.cols();
    if (grid.size() != rows * cols || belief.size() != grid.size()) return false;
    const double sx = u.dx_mm / grid.mm_per_px(), sy = u.dy_mm / grid.mm_per_px();
    const double fx_floor = std::floor(sx), fy_floor = std::floor(sy);
    if (!(std::abs(fx_floor) < static_cast<double>(cols) &&
          std::abs(fy_floor) < static_cast<double>(rows)))
      return false;
    const Eigen::Index pad = radius_ + 1;
    landed.clear();
    for (const grid_box& box : boxes) {
      TACMAP_ASSERT(box.rows > 0 && box.cols > 0 && box.row >= 0 && box.col >= 0 &&
                        box.row + box.rows <= rows && box.col + box.cols <= cols,
                    "predict_boxes: a box must lie inside the belief image");
      const grid_box w{box.row - pad + static_cast<Eigen::Index>(fy_floor),
                       box.col - pad + static_cast<Eigen::Index>(fx_floor), box.rows + 2 * pad,
                       box.cols + 2 * pad};
      const bool inside =
          w.row >= 0 && w.col >= 0 && w.row + w.rows <= rows && w.col + w.cols <= cols;
      if (!inside && params_.boundary == off_grid::clamp) return false;
      if (w.row + w.rows <= 0 || w.col + w.cols <= 0 || w.row >= rows || w.col >= cols)
        return false;
      landed.push_back(w);
    }
    separable_scratch<T>& s = workspace<T>();
    Eigen::Map<image<T>> img(belief.data(), rows, cols);
    // 1. Every box into its zero-margined window (one buffer, windows one after another).
    Eigen::Index total = 0;
    for (const grid_box& w : landed) total += w.rows * w.cols;
    s.box_in.setZero(total);
    s.box_out.resize(total);
    Eigen::Index at = 0;
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      const grid_box& box = boxes[i];
      const grid_box& w = landed[i];
      Eigen::Map<image<T>> in_box(s.box_in.data() + at, w.rows, w.cols);
      auto source = img.block(box.row, box.col, box.rows, box.cols);
      in_box.block(pad, pad, box.rows, box.cols) = source;
      source.setZero();
      at += w.rows * w.cols;
    }
    // 2. Each window transported and added where it lands; what falls off the grid dropped.
    at = 0;
    dropped = 0.0;
    for (grid_box& w : landed) {
      Eigen::Map<image<T>> out_box(s.box_out.data() + at, w.rows, w.cols);
      transport(Eigen::Map<const image<T>>(s.box_in.data() + at, w.rows, w.cols), out_box,
                sx - fx_floor, sy - fy_floor, grid.mm_to_px(params_.sigma_mm));
      const grid_box c = detail::clip_box(w, rows, cols);
      const auto kept = out_box.block(c.row - w.row, c.col - w.col, c.rows, c.cols);
      if (c.rows != w.rows || c.cols != w.cols) dropped += detail::mass_outside(out_box, w, c);
      img.block(c.row, c.col, c.rows, c.cols) += kept;
      at += w.rows * w.cols;
      w = c;
    }
    return true;
  }

  /// `predict_boxes` for one box.
  template <metric_planar_grid G>
  bool predict_box(const G& grid, belief_array<G>& belief, const grid_box& box,
                   const odometry& u) const {
    std::vector<grid_box> landed;
    double dropped = 0.0;
    return predict_boxes(grid, belief, std::span<const grid_box>(&box, 1), u, landed, dropped);
  }

  /// The un-normalised core of `predict` for one belief image: out = in shifted by
  /// (shift_x_px, shift_y_px) (bilinear for the fraction) and spread by the Gaussian stencil of
  /// `sigma_px`; mass leaving the image is dropped or clamped per `params().boundary`, never
  /// renormalised. Used per layer by
  /// multi-layer motion models (`pose_odometry_gaussian`).
  template <class T>
  void transport(const Eigen::Map<const image<T>>& in_img, Eigen::Map<image<T>>& out_img,
                 double shift_x_px, double shift_y_px, double sigma_px) const {
    const double sx = shift_x_px;
    const double sy = shift_y_px;
    const double fx_floor = std::floor(sx);
    const double fy_floor = std::floor(sy);
    const double limit = static_cast<double>(in_img.rows() + in_img.cols()) + 4.0 * radius_;
    if (std::abs(fx_floor) > limit || std::abs(fy_floor) > limit) {
      if (params_.boundary == off_grid::renormalize)
        detail::fail<std::domain_error>(
            "odometry_gaussian: a shift of (", shift_x_px, ", ", shift_y_px,
            ") px moves the sensor farther than the whole grid (", in_img.cols(), " x ",
            in_img.rows(),
            " states); expected a displacement since the previous touch, in millimetres");
    }
    const auto ix = static_cast<Eigen::Index>(std::clamp(fx_floor, -limit, limit));
    const auto iy = static_cast<Eigen::Index>(std::clamp(fy_floor, -limit, limit));
    const double fx = std::clamp(sx - fx_floor, 0.0, 1.0);
    const double fy = std::clamp(sy - fy_floor, 0.0, 1.0);

    // exp(-d2 / (2 sigma^2)), exactly 1 at d2 = 0: a sigma far below a pixel (a coarse grid's
    // pitch) overflows 1 / (2 sigma^2) to infinity, and 0 * infinity would be NaN.
    const double inv_two_var = 0.5 / (sigma_px * sigma_px);
    const auto gauss = [inv_two_var](int d2) {
      return d2 == 0 ? 1.0 : std::exp(-static_cast<double>(d2) * inv_two_var);
    };
    const bool clamp = params_.boundary == off_grid::clamp;
    if (separable_) {
      // Square stencils (k = 8: 3 x 3, k = 24: 5 x 5): the Gaussian and the bilinear kernel both
      // factor into x and y, so two 1-D passes of 2R + 2 taps replace (2R + 2)^2 2-D taps.
      // Clamping and dropping also act per axis, so the factorisation is exact.
      const auto taps = [&](double f) {
        std::array<double, 2 * detail::max_stencil_radius + 2> w{};
        double norm = 0.0;
        for (int o = -radius_; o <= radius_; ++o) norm += gauss(o * o);
        for (int o = -radius_; o <= radius_; ++o) {
          const double g = gauss(o * o) / norm;
          w[static_cast<std::size_t>(o + radius_)] += g * (1.0 - f);
          w[static_cast<std::size_t>(o + radius_ + 1)] += g * f;
        }
        return w;
      };
      const auto wx = taps(fx);
      const auto wy = taps(fy);
      separable_transport(in_img, out_img, ix - radius_, wx.data(), iy - radius_, wy.data(),
                          2 * radius_ + 2, clamp);
    } else {
      // Any other disc: composite stencil = Gaussian (k + 1 taps) convolved with the bilinear
      // 2 x 2 kernel, applied as one whole-image multiply-add per tap.
      constexpr int side = 2 * detail::max_stencil_radius + 2;
      std::array<double, static_cast<std::size_t>(side * side)> composite{};
      double gauss_sum = 0.0;
      for (const auto& o : offsets_) gauss_sum += gauss(o.d2);
      const std::array<double, 4> bilinear{(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy,
                                           fx * fy};
      for (const auto& o : offsets_) {
        const double g = gauss(o.d2) / gauss_sum;
        for (int b = 0; b < 4; ++b) {
          const int cy = o.dy + (b / 2) + detail::max_stencil_radius;
          const int cx = o.dx + (b % 2) + detail::max_stencil_radius;
          composite[static_cast<std::size_t>(cy * side + cx)] +=
              g * bilinear[static_cast<std::size_t>(b)];
        }
      }
      out_img.setZero();
      for (int cy = 0; cy < side; ++cy)
        for (int cx = 0; cx < side; ++cx) {
          const double w = composite[static_cast<std::size_t>(cy * side + cx)];
          if (w <= 0.0) continue;
          detail::shifted_accumulate(in_img, out_img, iy + cy - detail::max_stencil_radius,
                                     ix + cx - detail::max_stencil_radius, static_cast<T>(w),
                                     clamp);
        }
    }
  }

 private:
  // The separable path's buffers, kept between calls so that predict() does not allocate. This
  // makes one model object non-reentrant: give each thread its own filter (models are small
  // values and cheap to copy).
  template <class T>
  struct separable_scratch {
    Eigen::Array<T, Eigen::Dynamic, 1> rows_padded;  // the input with zero rows above and below
    Eigen::Array<T, Eigen::Dynamic, 1> cols_padded;  // the vertical pass, zero columns each side
    std::vector<const T*> sources;                   // per kept tap: its source at row 0
    std::vector<const T*> row_sources;               // the same at the current row
    std::vector<T> weights;
    Eigen::Array<T, Eigen::Dynamic, 1> box_in;   // predict_box: the box with zero margins
    Eigen::Array<T, Eigen::Dynamic, 1> box_out;  // its prediction, added back in place
  };
  template <class T>
  separable_scratch<T>& workspace() const {
    if constexpr (std::is_same_v<T, float>)
      return workspace_f_;
    else
      return workspace_d_;
  }

  // The taps of one axis of a separable stencil: tap t moves mass by origin + t cells of an
  // axis n cells long, with weight w[t]. A tap "keeps" mass on the grid when some cells stay on
  // it (|shift| < n); with clamp, every tap also piles what it moves past either end onto that
  // end.
  struct axis_taps {
    Eigen::Index origin;
    const double* w;
    int count;
    Eigen::Index n;

    // f(shift, weight) for every tap that keeps mass on the grid.
    template <class F>
    void each_kept(F&& f) const {
      for (int t = 0; t < count; ++t) {
        const Eigen::Index shift = origin + t;
        if (w[t] > 0.0 && std::abs(shift) < n) f(shift, w[t]);
      }
    }
    // The zero padding the kept taps read: their largest |shift|.
    [[nodiscard]] Eigen::Index padding() const {
      Eigen::Index pad = 0;
      each_kept([&](Eigen::Index shift, double) { pad = std::max(pad, std::abs(shift)); });
      return pad;
    }
    // f(weight, low, high): the tap moves the first `low` cells past the start and the last
    // `high` cells past the end (either may be 0).
    template <class F>
    void each_pile(F&& f) const {
      for (int t = 0; t < count; ++t) {
        const Eigen::Index shift = origin + t;
        if (!(w[t] > 0.0)) continue;
        const Eigen::Index low = std::clamp<Eigen::Index>(-shift, 0, n);  // cells j < -shift
        const Eigen::Index high = std::clamp<Eigen::Index>(shift, 0, n);  // cells j >= n - shift
        if (low > 0 || high > 0) f(w[t], low, high);
      }
    }
  };

  // rows x len outputs, row y at dst + y * dst_stride: the weighted sum of the kept taps'
  // sources, tap `shift` reading src + y * src_stride - shift * unit (a zero-padded buffer, so
  // mass moved off the grid reads zeros). All zero when no tap keeps anything.
  template <class T>
  void apply_taps(const axis_taps& taps, const T* src, Eigen::Index unit, Eigen::Index src_stride,
                  T* dst, Eigen::Index dst_stride, Eigen::Index rows, Eigen::Index len,
                  separable_scratch<T>& s) const {
    s.sources.clear();
    s.weights.clear();
    taps.each_kept([&](Eigen::Index shift, double w) {
      s.sources.push_back(src - shift * unit);
      s.weights.push_back(static_cast<T>(w));
    });
    s.row_sources.resize(s.sources.size());
    for (Eigen::Index y = 0; y < rows; ++y) {
      T* row = dst + y * dst_stride;
      if (s.sources.empty()) {
        std::fill(row, row + len, T(0));
        continue;
      }
      for (std::size_t k = 0; k < s.sources.size(); ++k)
        s.row_sources[k] = s.sources[k] + y * src_stride;
      detail::weighted_sum(s.row_sources.data(), s.weights.data(), s.sources.size(), row, len);
    }
  }

  // out = the stencil's x taps (tap t moves mass by x0 + t columns, weight wx[t]) applied to the
  // y taps (y0 + t rows, wy[t]) of `in`: the vertical pass into a buffer with zero columns on
  // both sides, then the horizontal pass straight into `out`, each output written once as a
  // weighted sum of its taps' sources (detail::weighted_sum) out of zero-padded copies — no
  // per-tap pass over the whole image. Mass landing off the grid is dropped, or with `clamp`
  // added to the edge row or column it crossed (summed directly: a difference of running sums
  // could lose, in float, a small pile next to a large one).
  template <class T>
  void separable_transport(const Eigen::Map<const image<T>>& in, Eigen::Map<image<T>>& out,
                           Eigen::Index x0, const double* wx, Eigen::Index y0, const double* wy,
                           int taps, bool clamp) const {
    const Eigen::Index h = in.rows();
    const Eigen::Index w = in.cols();
    const axis_taps along_y{y0, wy, taps, h};
    const axis_taps along_x{x0, wx, taps, w};
    separable_scratch<T>& s = workspace<T>();
    const Eigen::Index pad_y = along_y.padding();
    const Eigen::Index pad_x = along_x.padding();
    // Vertical: mid(y, pad_x + x) = sum_t wy[t] in(y - sy_t, x), rows off the grid zero.
    s.rows_padded.resize((h + 2 * pad_y) * w);
    s.rows_padded.head(pad_y * w).setZero();
    s.rows_padded.tail(pad_y * w).setZero();
    Eigen::Map<image<T>>(s.rows_padded.data() + pad_y * w, h, w) = in;
    const Eigen::Index wp = w + 2 * pad_x;
    s.cols_padded.resize(h * wp);
    Eigen::Map<image<T>> mid(s.cols_padded.data(), h, wp);
    mid.leftCols(pad_x).setZero();
    mid.rightCols(pad_x).setZero();
    apply_taps(along_y, s.rows_padded.data() + pad_y * w, w, w, mid.data() + pad_x, wp, h, w, s);
    if (clamp)
      along_y.each_pile([&](double wt, Eigen::Index above, Eigen::Index below) {
        const auto k = static_cast<T>(wt);
        if (above > 0) mid.row(0).segment(pad_x, w) += k * in.topRows(above).colwise().sum();
        if (below > 0) mid.row(h - 1).segment(pad_x, w) += k * in.bottomRows(below).colwise().sum();
      });
    // Horizontal: out(y, x) = sum_t wx[t] mid(y, pad_x + x - sx_t).
    apply_taps(along_x, mid.data() + pad_x, 1, wp, out.data(), w, h, w, s);
    if (clamp)
      along_x.each_pile([&](double wt, Eigen::Index left, Eigen::Index right) {
        const auto k = static_cast<T>(wt);
        if (left > 0) out.col(0) += k * mid.middleCols(pad_x, left).rowwise().sum();
        if (right > 0)
          out.col(w - 1) += k * mid.middleCols(pad_x + w - right, right).rowwise().sum();
      });
  }

  odometry_gaussian_params params_;
  std::vector<detail::stencil_offset> offsets_;
  int radius_ = 0;
  bool separable_ = false;
  mutable separable_scratch<float> workspace_f_;
  mutable separable_scratch<double> workspace_d_;
};

}  // namespace tacmap
