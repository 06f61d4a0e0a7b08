// Helpers shared by the pose tests: rendering a tactile image from the map at a pose.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "tacmap/grid/pose_grid.hpp"
#include "tacmap/image.hpp"

namespace pose_test {

/// A deterministic textured map in [0, 1]: smooth blobs of random sizes and signs plus bars with
/// sharp edges, no periodic pattern (a plane wave looks the same turned by 180 degrees, which
/// would blur the heading tests). xorshift, not <random>: the same image on every platform.
inline tacmap::image<float> textured_map(Eigen::Index rows, Eigen::Index cols, std::uint32_t seed) {
  std::uint32_t state = seed * 2654435761U + 12345U;
  const auto next = [&state] {
    state ^= state << 13U;
    state ^= state >> 17U;
    state ^= state << 5U;
    return state;
  };
  const auto uniform = [&next](double lo, double hi) {
    return lo + (hi - lo) * static_cast<double>(next() % 10000U) / 10000.0;
  };
  tacmap::image<double> img = tacmap::image<double>::Zero(rows, cols);
  const auto blobs = rows * cols / 200;
  for (Eigen::Index k = 0; k < blobs; ++k) {
    const double cx = uniform(0, static_cast<double>(cols));
    const double cy = uniform(0, static_cast<double>(rows));
    const double sx = uniform(1.5, 5.0);
    const double sy = uniform(1.5, 5.0);
    const double amp = uniform(-1.0, 1.0);
    for (Eigen::Index r = 0; r < rows; ++r)
      for (Eigen::Index c = 0; c < cols; ++c) {
        const double dx = (static_cast<double>(c) + 0.5 - cx) / sx;
        const double dy = (static_cast<double>(r) + 0.5 - cy) / sy;
        img(r, c) += amp * std::exp(-0.5 * (dx * dx + dy * dy));
      }
  }
  const auto bars = rows * cols / 800;
  for (Eigen::Index k = 0; k < bars; ++k) {
    const auto r0 = static_cast<Eigen::Index>(next() % static_cast<std::uint32_t>(rows));
    const auto c0 = static_cast<Eigen::Index>(next() % static_cast<std::uint32_t>(cols));
    const Eigen::Index h = std::min<Eigen::Index>(rows - r0, 2 + next() % 10U);
    const Eigen::Index w = std::min<Eigen::Index>(cols - c0, 2 + next() % 10U);
    img.block(r0, c0, h, w) += uniform(0.5, 1.0);
  }
  img -= img.minCoeff();
  return (img / img.maxCoeff()).cast<float>();
}

/// The map bilinearly sampled at continuous map-pixel coordinates (x right, y down; pixel (r, c)
/// covers [c, c + 1) x [r, r + 1), its centre at (c + 0.5, r + 0.5)), edges clamped.
inline float sample(const tacmap::image<float>& map, double x, double y) {
  const double fx = std::clamp(x - 0.5, 0.0, static_cast<double>(map.cols() - 1));
  const double fy = std::clamp(y - 0.5, 0.0, static_cast<double>(map.rows() - 1));
  const auto c0 = static_cast<Eigen::Index>(std::floor(fx));
  const auto r0 = static_cast<Eigen::Index>(std::floor(fy));
  const Eigen::Index c1 = std::min<Eigen::Index>(c0 + 1, map.cols() - 1);
  const Eigen::Index r1 = std::min<Eigen::Index>(r0 + 1, map.rows() - 1);
  const double ax = fx - static_cast<double>(c0);
  const double ay = fy - static_cast<double>(r0);
  return static_cast<float>((1 - ax) * (1 - ay) * map(r0, c0) + ax * (1 - ay) * map(r0, c1) +
                            (1 - ax) * ay * map(r1, c0) + ax * ay * map(r1, c1));
}

/// The tactile image (height x width, in the sensor's own frame) a sensor centred at
/// (cx, cy) map px with heading theta sees: tactile pixel (r, c) has sensor-frame offset
/// (u, v) = (c + 0.5 - W/2, r + 0.5 - H/2) and lies at map point centre + R(theta) (u, v),
/// R = [cos -sin; sin cos] (pose_grid.hpp's convention, written out independently here).
inline tacmap::image<float> render(const tacmap::image<float>& map, double cx, double cy,
                                   double theta, tacmap::pixel_size window) {
  tacmap::image<float> z(window.height, window.width);
  const double c = std::cos(theta);
  const double s = std::sin(theta);
  for (Eigen::Index r = 0; r < window.height; ++r)
    for (Eigen::Index k = 0; k < window.width; ++k) {
      const double u = static_cast<double>(k) + 0.5 - 0.5 * static_cast<double>(window.width);
      const double v = static_cast<double>(r) + 0.5 - 0.5 * static_cast<double>(window.height);
      z(r, k) = sample(map, cx + c * u - s * v, cy + s * u + c * v);
    }
  return z;
}

/// The tactile image of pose-grid state `index` (its centre and heading).
template <class T>
tacmap::image<float> render_state(const tacmap::image<float>& map, const tacmap::pose_grid<T>& g,
                                  Eigen::Index index) {
  const auto s = g.state_mm(index);
  return render(map, g.mm_to_px(s.x()), g.mm_to_px(s.y()), s.z(), g.window_size());
}

/// Number of entries strictly better (larger) than entry `i`: 0 is the best.
template <class Array>
Eigen::Index rank_of(const Array& ll, Eigen::Index i) {
  return static_cast<Eigen::Index>((ll > ll(i)).count());
}

}  // namespace pose_test

namespace pose_test {

/// The tactile image z (height x width) turned by `quarter_turns` * 90 degrees into the map frame
/// on a canvas of `canvas` px centred on the sensor centre, edge pixels repeated: canvas pixel
/// centre offset (x, y) from the canvas centre shows tactile offset (u, v) = R(-theta) (x, y).
/// Exact trigonometry (0, +-1), so no interpolation: an independent reference for quarter turns.
inline tacmap::image<float> turn_quarter(const tacmap::image<float>& z, int quarter_turns,
                                         tacmap::pixel_size canvas) {
  const int q = ((quarter_turns % 4) + 4) % 4;
  const double c = q == 0 ? 1.0 : q == 2 ? -1.0 : 0.0;
  const double s = q == 1 ? 1.0 : q == 3 ? -1.0 : 0.0;
  tacmap::image<float> out(canvas.height, canvas.width);
  for (Eigen::Index r = 0; r < canvas.height; ++r)
    for (Eigen::Index k = 0; k < canvas.width; ++k) {
      const double x = static_cast<double>(k) + 0.5 - 0.5 * static_cast<double>(canvas.width);
      const double y = static_cast<double>(r) + 0.5 - 0.5 * static_cast<double>(canvas.height);
      const double u = c * x + s * y;
      const double v = -s * x + c * y;
      const auto col = std::clamp<Eigen::Index>(
          std::lround(u + 0.5 * static_cast<double>(z.cols()) - 0.5), 0, z.cols() - 1);
      const auto row = std::clamp<Eigen::Index>(
          std::lround(v + 0.5 * static_cast<double>(z.rows()) - 0.5), 0, z.rows() - 1);
      out(r, k) = z(row, col);
    }
  return out;
}

}  // namespace pose_test
