// tacmap: `pose_odometry_gaussian` — the motion model over (x, y, theta) pose grids.
//
// Odometry from an arm or a finger is naturally expressed in the sensor's own frame: "moved
// 4 mm along the array's columns and turned 5 degrees". For a state with heading theta the
// displacement in the map frame is R(theta) (du, dv) (pose_grid.hpp gives the convention), so it
// differs from layer to layer; the turn moves belief from heading layer to heading layer.
// The model applies, in this order (translate in the frame of the previous heading, then turn):
//  1. Per heading layer a: the planar model (`odometry_gaussian`: bilinear sub-pixel shift and
//     Gaussian spread over k neighbours, sigma_mm) with the map-frame displacement
//     R(theta_a) (du, dv). Mass leaving the layer's image is dropped or clamped per `boundary`.
//  2. Across layers: a circular convolution along the heading axis — the turn dtheta split into
//     whole steps and a fraction (linear interpolation between the two nearest layers, so the
//     predicted mean heading equals the odometry's) and a wrapped Gaussian of sigma_rad.
// Everything is whole-layer array work; layers without belief mass are skipped.
#pragma once

#include <cmath>
#include <span>
#include <vector>

#include "tacmap/detail/weighted_sum.hpp"
#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"

namespace tacmap {

/// Odometry in the sensor frame at the previous pose: a translation along the array's columns
/// (du) and rows (dv), mm, then a turn, radians (positive: clockwise on screen, as pose_grid's
/// headings).
struct sensor_odometry {
  double du_mm = 0.0;
  double dv_mm = 0.0;
  double dtheta_rad = 0.0;
};

/// Configuration of `pose_odometry_gaussian`.
struct pose_odometry_gaussian_params {
  double sigma_mm = 1.0;  ///< translation noise per axis (as odometry_gaussian)
  /// Translation noise neighbours (as odometry_gaussian). 24 (a 5 x 5 stencil) rather than the
  /// planar model's 8: the heading cells' width adds spread (see `heading_cell_spread`) that a
  /// 3 x 3 stencil would truncate.
  int k = 24;
  double sigma_rad = 0.0873;  ///< turn noise, radians (5 degrees)
  off_grid boundary = off_grid::renormalize;
  /// A layer stands for every heading within half a step of its own, so a move of length d
  /// translated with the layer's heading is off by up to d * step / 2 sideways. When true (and
  /// there is more than one heading) that uncertainty is added to the translation noise as the
  /// variance of a uniform heading error over the cell: sigma^2 + (d * step)^2 / 12. Without it
  /// the belief drifts confidently away on long moves (measured on the gecko protocol at random
  /// orientations, 36 headings: 19 of 22 sequences localized without, see README).
  bool heading_cell_spread = true;
};

/// Grids `pose_odometry_gaussian` moves over: layers of headings over a metric planar grid.
template <class G>
concept metric_pose_grid = state_grid<G> && G::dimension == 3 &&
                           requires(const G& g, Eigen::Index a) {
  { g.mm_per_px() } -> std::convertible_to<double>;
  { g.angle_count() } -> std::convertible_to<int>;
  { g.heading(a) } -> std::convertible_to<double>;
  { g.layer_size() } -> std::convertible_to<Eigen::Index>;
};

/// Sensor-frame odometry with Gaussian noise on translation and turn, over a `pose_grid`.
class pose_odometry_gaussian {
 public:
  using control_type = sensor_odometry;

  /// Throws std::invalid_argument for a translation sigma or k that `odometry_gaussian` rejects,
  /// or a turn sigma outside [1e-6, 1e6] rad (detail::min_sigma_rad, max_sigma_rad).
  explicit pose_odometry_gaussian(pose_odometry_gaussian_params params = {})
      : params_(params),
        planar_({.sigma_mm = params.sigma_mm, .k = params.k, .boundary = params.boundary}) {
    detail::check_range("pose_odometry_gaussian", "sigma_rad", params.sigma_rad,
                        detail::min_sigma_rad, detail::max_sigma_rad, " rad",
                        "the turn noise's standard deviation",
                        "give it in radians (e.g. 0.0873 = 5 degrees)");
  }

  [[nodiscard]] const pose_odometry_gaussian_params& params() const { return params_; }

  template <metric_pose_grid G>
  prediction_report predict(const G& grid, const belief_array<G>& in, belief_array<G>& out,
                            const sensor_odometry& u) const {
    using T = typename G::scalar_type;
    if (!(std::isfinite(u.du_mm) && std::isfinite(u.dv_mm) && std::isfinite(u.dtheta_rad)))
      detail::fail("pose_odometry_gaussian: odometry (du_mm, dv_mm, dtheta_rad) = (", u.du_mm, ", ",
                   u.dv_mm, ", ", u.dtheta_rad,
                   "); expected finite values (mm, mm, rad) — a NaN usually means a dropped "
                   "position or orientation sample");
    const auto layers = static_cast<Eigen::Index>(grid.angle_count());
    const Eigen::Index plane = grid.layer_size();
    TACMAP_ASSERT(in.size() == plane * layers && out.size() == in.size(),
                  "belief buffers must match the grid");
    if (std::abs(u.dtheta_rad) > 1e3)
      detail::fail("pose_odometry_gaussian: turn dtheta = ", u.dtheta_rad,
                   " rad; expected the turn since the previous touch (radians, not degrees?)");

    // 1. Translate every layer in its own heading's frame.
    auto& moved = moved_<T>();
    moved.resize(in.size());
    // Pixels via mm_per_px(): the only scale metric_pose_grid promises.
    const double sigma_px = translation_sigma_mm(u, layers) / grid.mm_per_px();
    for (Eigen::Index a = 0; a < layers; ++a) {
      const Eigen::Map<const image<T>> src(in.data() + a * plane, grid.rows(), grid.cols());
      Eigen::Map<image<T>> dst(moved.data() + a * plane, grid.rows(), grid.cols());
      if (!(src.maxCoeff() > T(0))) {
        dst.setZero();
        continue;
      }
      const double c = std::cos(grid.heading(a));
      const double s = std::sin(grid.heading(a));
      const double dx = c * u.du_mm - s * u.dv_mm;
      const double dy = s * u.du_mm + c * u.dv_mm;
      planar_.transport(src, dst, dx / grid.mm_per_px(), dy / grid.mm_per_px(), sigma_px);
    }

    // 2. Turn: out_b = sum_a moved_a w(b - a), circular (see `turn_taps`). Output layer by
    //    output layer, each written once as the weighted sum of its taps' source layers, instead
    //    of every tap sweeping all of `out` (36 planes, 1.2 MB for the 120 px grid) once more.
    const turn t = turn_taps(u.dtheta_rad, layers);
    const auto wrap = [layers](Eigen::Index o) { return ((o % layers) + layers) % layers; };
    std::vector<Eigen::Index> offsets;  // taps nonzero in T only
    std::vector<T> weights;
    for (std::size_t k = 0; k < t.offsets.size(); ++k) {
      const auto w = static_cast<T>(t.weights[k]);
      if (w > T(0)) {
        offsets.push_back(t.offsets[k]);
        weights.push_back(w);
      }
    }
    std::vector<const T*> sources(offsets.size());
    for (Eigen::Index b = 0; b < layers; ++b) {
      for (std::size_t k = 0; k < offsets.size(); ++k)
        sources[k] = moved.data() + wrap(b - offsets[k]) * plane;
      if (sources.empty())
        out.segment(b * plane, plane).setZero();
      else
        detail::weighted_sum(sources.data(), weights.data(), sources.size(), out.data() + b * plane,
                             plane);
    }

    return detail::renormalise_prediction(in, out, [&] {
      detail::fail<std::domain_error>(
          "pose_odometry_gaussian: odometry (", u.du_mm, ", ", u.dv_mm, ") mm, turn ", u.dtheta_rad,
          " rad moves all belief mass off the grid; expected a motion that keeps the sensor "
          "over the map — check the units (mm, rad) and the frame (sensor frame, not map "
          "frame), or use off_grid::clamp");
    });
  }

  /// Tracking mode (`moves_box`): the mass inside each of the pairwise disjoint `boxes`, in
  /// every heading layer, moved as `predict` moves it, in place; every state outside them (in
  /// any layer) keeps its value. Per box and layer a, the box is copied with the planar model's
  /// reach of zero cells on each side, transported by the fraction of that layer's map-frame
  /// shift only, and the turn's taps add each moved window, at the box's place moved by the
  /// layer's integer shift, into the layers the turn carries it to: each output is the same
  /// weighted sum of the same taps as in `predict`, less the taps that read outside the boxes.
  /// Every box is read (and cleared) before any window is added, so windows may overlap other
  /// boxes. `landed[i]`: the rectangle of the grid covering box i's windows in every layer.
  /// Mass a window carries past the grid's edge is dropped, as `predict` drops it with
  /// `off_grid::renormalize`, and its sum returned in `dropped` (not renormalised). False,
  /// `belief` unchanged, when a moved window would reach past the edge with `off_grid::clamp`
  /// or leave the grid entirely, or the odometry is not finite or a turn `predict` refuses.
  /// `belief`: the grid's belief, or a map of it (`latent_motion` moves each hypothesis's
  /// block in place).
  template <metric_pose_grid G, class Belief>
  bool predict_boxes(const G& grid, Belief& belief, std::span<const grid_box> boxes,
                     const sensor_odometry& u, std::vector<grid_box>& landed,
                     double& dropped) const {
    using T = typename G::scalar_type;
    if (!(std::isfinite(u.du_mm) && std::isfinite(u.dv_mm) && std::isfinite(u.dtheta_rad)) ||
        std::abs(u.dtheta_rad) > 1e3)
      return false;
    const auto layers = static_cast<Eigen::Index>(grid.angle_count());
    const Eigen::Index rows = grid.rows(), cols = grid.cols(), plane = grid.layer_size();
    if (plane != rows * cols || belief.size() != plane * layers) return false;
    const Eigen::Index pad = planar_.radius_px() + 1;
    // Each layer's integer shift and its fraction, all windows checked before anything moves.
    std::vector<grid_cell>& shift = box_at_;
    shift.resize(static_cast<std::size_t>(layers));
    std::vector<double>& fraction = box_fraction_;
    fraction.resize(static_cast<std::size_t>(2 * layers));
    for (Eigen::Index a = 0; a < layers; ++a) {
      const double c = std::cos(grid.heading(a)), s = std::sin(grid.heading(a));
      const double sx = (c * u.du_mm - s * u.dv_mm) / grid.mm_per_px();
      const double sy = (s * u.du_mm + c * u.dv_mm) / grid.mm_per_px();
      const double fx = std::floor(sx), fy = std::floor(sy);
      if (!(std::abs(fx) < static_cast<double>(cols) && std::abs(fy) < static_cast<double>(rows)))
        return false;
      shift[static_cast<std::size_t>(a)] = {static_cast<Eigen::Index>(fy),
                                            static_cast<Eigen::Index>(fx)};
      fraction[static_cast<std::size_t>(2 * a)] = sx - fx;
      fraction[static_cast<std::size_t>(2 * a + 1)] = sy - fy;
    }
    landed.clear();
    Eigen::Index total = 0;  // window cells over every box and layer
    for (const grid_box& box : boxes) {
      TACMAP_ASSERT(box.rows > 0 && box.cols > 0 && box.row >= 0 && box.col >= 0 &&
                        box.row + box.rows <= rows && box.col + box.cols <= cols,
                    "predict_boxes: a box must lie inside the belief image");
      const Eigen::Index h = box.rows + 2 * pad, w = box.cols + 2 * pad;
      Eigen::Index r0 = rows, c0 = cols, r1 = 0, c1 = 0;
      for (const grid_cell& d : shift) {
        const Eigen::Index top = box.row - pad + d.row, left = box.col - pad + d.col;
        if ((top < 0 || left < 0 || top + h > rows || left + w > cols) &&
            params_.boundary == off_grid::clamp)
          return false;
        if (top + h <= 0 || left + w <= 0 || top >= rows || left >= cols) return false;
        r0 = std::min(r0, top);
        c0 = std::min(c0, left);
        r1 = std::max(r1, top + h);
        c1 = std::max(c1, left + w);
      }
      landed.push_back(detail::clip_box({r0, c0, r1 - r0, c1 - c0}, rows, cols));
      total += layers * h * w;
    }
    // 1. Each box of each layer, moved by its fraction into a window of its own (box after
    // box, layer after layer in one buffer).
    const double sigma_px = translation_sigma_mm(u, layers) / grid.mm_per_px();
    auto& moved = moved_<T>();
    moved.setZero(total);
    std::vector<char>& has_mass = box_has_mass_;
    has_mass.assign(static_cast<std::size_t>(layers) * boxes.size(), 0);
    Eigen::Array<T, Eigen::Dynamic, 1> padded;
    Eigen::Index at = 0;
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      const grid_box& box = boxes[i];
      const Eigen::Index h = box.rows + 2 * pad, w = box.cols + 2 * pad;
      padded.setZero(h * w);
      for (Eigen::Index a = 0; a < layers; ++a, at += h * w) {
        Eigen::Map<image<T>> img(belief.data() + a * plane, rows, cols);
        auto source = img.block(box.row, box.col, box.rows, box.cols);
        if (!(source.maxCoeff() > T(0))) continue;
        has_mass[i * static_cast<std::size_t>(layers) + static_cast<std::size_t>(a)] = 1;
        Eigen::Map<image<T>> in_box(padded.data(), h, w);
        in_box.block(pad, pad, box.rows, box.cols) = source;
        Eigen::Map<image<T>> out_box(moved.data() + at, h, w);
        planar_.transport(Eigen::Map<const image<T>>(padded.data(), h, w), out_box,
                          fraction[static_cast<std::size_t>(2 * a)],
                          fraction[static_cast<std::size_t>(2 * a + 1)], sigma_px);
        source.setZero();
      }
    }
    // 2. The turn: layer b receives w_o times layer (b - o)'s moved window, where it landed;
    // what lands off the grid is dropped.
    const turn t = turn_taps(u.dtheta_rad, layers);
    const auto wrap = [layers](Eigen::Index o) { return ((o % layers) + layers) % layers; };
    at = 0;
    dropped = 0.0;
    for (std::size_t i = 0; i < boxes.size(); ++i) {
      const grid_box& box = boxes[i];
      const Eigen::Index h = box.rows + 2 * pad, w = box.cols + 2 * pad;
      for (Eigen::Index b = 0; b < layers; ++b) {
        Eigen::Map<image<T>> img(belief.data() + b * plane, rows, cols);
        for (std::size_t k = 0; k < t.offsets.size(); ++k) {
          const Eigen::Index a = wrap(b - t.offsets[k]);
          const auto weight = static_cast<T>(t.weights[k]);
          if (!has_mass[i * static_cast<std::size_t>(layers) + static_cast<std::size_t>(a)] ||
              !(weight > T(0)))
            continue;
          const grid_cell d = shift[static_cast<std::size_t>(a)];
          const grid_box win{box.row - pad + d.row, box.col - pad + d.col, h, w};
          const grid_box c = detail::clip_box(win, rows, cols);
          const Eigen::Map<const image<T>> from(moved.data() + at + a * h * w, h, w);
          const auto kept = from.block(c.row - win.row, c.col - win.col, c.rows, c.cols);
          if (c.rows != h || c.cols != w)
            dropped += static_cast<double>(weight) * detail::mass_outside(from, win, c);
          img.block(c.row, c.col, c.rows, c.cols) += kept * weight;
        }
      }
      at += layers * h * w;
    }
    return true;
  }

  /// `predict_boxes` for one box.
  template <metric_pose_grid G>
  bool predict_box(const G& grid, belief_array<G>& belief, const grid_box& box,
                   const sensor_odometry& u) const {
    std::vector<grid_box> landed;
    double dropped = 0.0;
    return predict_boxes(grid, belief, std::span<const grid_box>(&box, 1), u, landed, dropped);
  }

 private:
  // The turn's taps: the weight of offset o (layer a's mass to layer a + o, mod the layer
  // count), nonzero ones only. A Gaussian of sigma_rad over whole steps (normalised over the
  // taps kept), each split bilinearly by the turn's fraction of a step.
  struct turn {
    std::vector<Eigen::Index> offsets;
    std::vector<double> weights;
  };
  [[nodiscard]] turn turn_taps(double dtheta_rad, Eigen::Index layers) const {
    const double step = 2.0 * std::numbers::pi / static_cast<double>(layers);
    const double shift = dtheta_rad / step;
    const double whole = std::floor(shift);
    const double frac = shift - whole;
    const double sigma_steps = params_.sigma_rad / step;
    const auto radius = static_cast<Eigen::Index>(
        std::min<double>(std::ceil(3.0 * sigma_steps), static_cast<double>(layers)));
    std::vector<double> tap(static_cast<std::size_t>(layers), 0.0);  // weight per offset mod L
    // Exactly 1 at j = 0: a turn noise far below a step would make 0 / 0 there.
    const auto gauss = [sigma_steps](Eigen::Index j) {
      return j == 0 ? 1.0
                    : std::exp(-0.5 * static_cast<double>(j * j) / (sigma_steps * sigma_steps));
    };
    double norm = 0.0;
    for (Eigen::Index j = -radius; j <= radius; ++j) norm += gauss(j);
    const auto base = static_cast<Eigen::Index>(whole);
    const auto wrap = [layers](Eigen::Index o) { return ((o % layers) + layers) % layers; };
    for (Eigen::Index j = -radius; j <= radius; ++j) {
      const double g = gauss(j) / norm;
      tap[static_cast<std::size_t>(wrap(j + base))] += g * (1.0 - frac);
      tap[static_cast<std::size_t>(wrap(j + base + 1))] += g * frac;
    }
    turn t;
    for (Eigen::Index o = 0; o < layers; ++o)
      if (tap[static_cast<std::size_t>(o)] > 0.0) {
        t.offsets.push_back(o);
        t.weights.push_back(tap[static_cast<std::size_t>(o)]);
      }
    return t;
  }

  // The translation noise with the heading cell's spread (`heading_cell_spread`).
  [[nodiscard]] double translation_sigma_mm(const sensor_odometry& u, Eigen::Index layers) const {
    double sigma_mm = params_.sigma_mm;
    if (params_.heading_cell_spread && layers > 1) {
      const double step = 2.0 * std::numbers::pi / static_cast<double>(layers);
      const double d = std::hypot(u.du_mm, u.dv_mm) * step;
      sigma_mm = std::sqrt(sigma_mm * sigma_mm + d * d / 12.0);
    }
    return sigma_mm;
  }

  template <class T>
  Eigen::Array<T, Eigen::Dynamic, 1>& moved_() const {
    if constexpr (std::is_same_v<T, float>)
      return moved_f_;
    else
      return moved_d_;
  }

  pose_odometry_gaussian_params params_;
  odometry_gaussian planar_;
  // Per-layer translated belief, kept between calls (no allocation per predict): one model
  // object is not reentrant, like odometry_gaussian.
  mutable Eigen::ArrayXf moved_f_;
  mutable Eigen::ArrayXd moved_d_;
  // predict_boxes' scratch: each layer's integer shift and its fractions, and whether a box's
  // layer has mass.
  mutable std::vector<grid_cell> box_at_;
  mutable std::vector<double> box_fraction_;
  mutable std::vector<char> box_has_mass_;
};

}  // namespace tacmap
