// tacmap: `planar_grid` — candidate sensor-centre positions on the map (paper, Sec. III-A/C).
//
// Convention (documented once, used everywhere):
//  * Map frame: x to the right along columns, y downwards along rows, origin at the top-left
//    corner of the map image, millimetres. Pixel (row r, col c) covers
//    [c, c+1) x [r, r+1) pixels, i.e. [c*s, (c+1)*s) x [r*s, (r+1)*s) mm for scale s.
//  * A state is a placement of the sensor window (window.height rows x window.width cols of map
//    pixels) entirely inside the map. State (i, j) is the window whose top-left pixel is (i, j);
//    its coordinates are the window's *centre*: x = (j + width/2) s, y = (i + height/2) s.
//    The paper assigns the probability to the window's start pixel p(i,j) (Sec. IV-A); we report
//    the centre instead because that is where the sensor physically is, and it does not move
//    when the window size changes. `top_left_px` gives the paper's start pixel.
//  * The belief image has (map.height - window.height + 1) rows and
//    (map.width - window.width + 1) cols; state index = i * cols + j (row-major).
//    Paper's case: map 120 x 120, window 18 wide x 42 tall -> 79 x 103 = 8,137 states.
#pragma once

#include <cmath>
#include <optional>
#include <stdexcept>

#include "tacmap/grid/concept.hpp"
#include "tacmap/image.hpp"

namespace tacmap {

/// Row and column of a state on a 2-D grid.
struct grid_cell {
  Eigen::Index row = 0;
  Eigen::Index col = 0;
  friend bool operator==(const grid_cell&, const grid_cell&) = default;
};

/// The paper's state space: every position of the sensor window on the map, orientation known.
template <belief_scalar T = float>
class planar_grid {
 public:
  using scalar_type = T;
  static constexpr int dimension = 2;
  using state_type = Eigen::Matrix<double, 2, 1>;

  /// `map`: the map image's size in pixels; `mm_per_px`: its scale; `window`: the sensor's
  /// footprint on the map in pixels (for the paper: 18 wide x 42 tall at 3.4/3 mm per px).
  /// Throws std::invalid_argument when the window does not fit or the scale is not positive.
  planar_grid(pixel_size map, double mm_per_px, pixel_size window)
      : map_(map), window_(window), mm_per_px_(mm_per_px) {
    if (!(std::isfinite(mm_per_px) && mm_per_px > 0.0))
      detail::fail("planar_grid: mm_per_px = ", mm_per_px,
                   "; expected a finite scale > 0 millimetres per map pixel "
                   "(the paper's map: 3.4 / 3 = 1.1333 mm per px)");
    if (window.width <= 0 || window.height <= 0)
      detail::fail("planar_grid: window = ", window.width, " x ", window.height,
                   " px (width x height); expected both > 0");
    if (map.width < window.width || map.height < window.height)
      detail::fail("planar_grid: map = ", map.width, " x ", map.height, " px is smaller than the ",
                   "sensor window ", window.width, " x ", window.height,
                   " px (width x height); expected a map at least as large as the window — "
                   "check the map's scale or crop less");
  }

  [[nodiscard]] Eigen::Index rows() const { return map_.height - window_.height + 1; }
  [[nodiscard]] Eigen::Index cols() const { return map_.width - window_.width + 1; }
  [[nodiscard]] Eigen::Index size() const { return rows() * cols(); }
  [[nodiscard]] pixel_size map_size() const { return map_; }
  [[nodiscard]] pixel_size window_size() const { return window_; }
  [[nodiscard]] double mm_per_px() const { return mm_per_px_; }

  [[nodiscard]] Eigen::Index index(grid_cell cell) const {
    TACMAP_ASSERT(contains(cell), "grid cell out of range");
    return cell.row * cols() + cell.col;
  }
  [[nodiscard]] grid_cell cell(Eigen::Index index) const {
    TACMAP_ASSERT(index >= 0 && index < size(), "state index out of range");
    return {index / cols(), index % cols()};
  }
  [[nodiscard]] bool contains(grid_cell cell) const {
    return cell.row >= 0 && cell.row < rows() && cell.col >= 0 && cell.col < cols();
  }

  /// The paper's "start pixel" p(i,j): the window's top-left map pixel (equal to the cell).
  [[nodiscard]] grid_cell top_left_px(Eigen::Index index) const { return cell(index); }

  /// The window centre in map pixels (x along columns, y along rows; continuous coordinates).
  [[nodiscard]] state_type centre_px(Eigen::Index index) const {
    const grid_cell c = cell(index);
    return {static_cast<double>(c.col) + 0.5 * static_cast<double>(window_.width),
            static_cast<double>(c.row) + 0.5 * static_cast<double>(window_.height)};
  }

  /// The window centre in millimetres in the map frame: the state's coordinates.
  [[nodiscard]] state_type state_mm(Eigen::Index index) const {
    return centre_px(index) * mm_per_px_;
  }

  /// The state whose centre is nearest to (x_mm, y_mm), or nothing when that point is more than
  /// half a pixel outside the region the window centre can reach.
  [[nodiscard]] std::optional<Eigen::Index> nearest_state(double x_mm, double y_mm) const {
    if (!(std::isfinite(x_mm) && std::isfinite(y_mm))) return std::nullopt;
    const double col = x_mm / mm_per_px_ - 0.5 * static_cast<double>(window_.width);
    const double row = y_mm / mm_per_px_ - 0.5 * static_cast<double>(window_.height);
    const auto c = static_cast<Eigen::Index>(std::lround(col));
    const auto r = static_cast<Eigen::Index>(std::lround(row));
    if (!contains({r, c})) return std::nullopt;
    return index({r, c});
  }

  /// Converts a length in millimetres to map pixels.
  [[nodiscard]] double mm_to_px(double mm) const { return mm / mm_per_px_; }
  /// Converts a length in map pixels to millimetres.
  [[nodiscard]] double px_to_mm(double px) const { return px * mm_per_px_; }

  /// The paper's configuration: a 120 x 120 px map at 3.4/3 mm per px (3 px per 3.4 mm taxel)
  /// and the 14 x 6 Weiss array resized to 42 x 18 px.
  [[nodiscard]] static planar_grid paper() {
    return planar_grid({.width = 120, .height = 120}, 3.4 / 3.0, {.width = 18, .height = 42});
  }

 private:
  pixel_size map_;
  pixel_size window_;
  double mm_per_px_;
};

}  // namespace tacmap
