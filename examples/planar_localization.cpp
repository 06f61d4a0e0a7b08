// planar_localization — where on the object is the finger touching?
//
// The problem (Luo et al., ICRA 2015): a camera saw the object before the grasp; that image is
// the *map* (120 x 120 px at 3.4/3 mm per px). The finger's tactile array covers a 42 x 18 px
// window of it. During the exploration vision is occluded: the arm reports how far the finger
// moved (odometry, with noise), and each touch gives a tactile image of the part under it.
//
// Noise model of this example: the odometry is off by a Gaussian error of 0.8 mm per axis and
// the tactile image is the map window plus strong pixel noise (sigma 1.0 on a [0, 1] image), so
// one touch alone is ambiguous. The measurement model here is a plain Gaussian pixel-noise
// likelihood over every window (a stand-in until the SIFT-lite model of the paper is used).
// The filter starts uniform (no prior knowledge) and must lock on within a few touches.
//
// Run: planar_localization            Exit status 0 when the final error is below 3 mm (the paper
// counts 5 mm as localized).
#include <cmath>
#include <cstdio>
#include <random>

#include "tacmap/tacmap.hpp"

namespace {

using grid_t = tacmap::planar_grid<float>;

// A synthetic object: smooth blobs and raised bars, values in [0, 1].
tacmap::image<float> make_map(std::mt19937& rng) {
  tacmap::image<float> map = tacmap::image<float>::Zero(120, 120);
  std::uniform_real_distribution<float> pos(0.0F, 120.0F);
  std::uniform_real_distribution<float> size(4.0F, 12.0F);
  for (int blob = 0; blob < 14; ++blob) {
    const float cx = pos(rng), cy = pos(rng), s = size(rng);
    for (Eigen::Index r = 0; r < map.rows(); ++r)
      for (Eigen::Index c = 0; c < map.cols(); ++c) {
        const float dx = static_cast<float>(c) - cx, dy = static_cast<float>(r) - cy;
        map(r, c) += std::exp(-(dx * dx + dy * dy) / (2 * s * s));
      }
  }
  // Raised bars with sharp edges, like the protruding parts of a 3D-printed model.
  std::uniform_int_distribution<Eigen::Index> corner(0, 100), extent(3, 20);
  for (int bar = 0; bar < 10; ++bar)
    map.block(corner(rng), corner(rng), extent(rng), extent(rng)) += 1.0F;
  return map / map.maxCoeff();
}

// log p(z | x) for Gaussian pixel noise: -|z - window(x)|^2 / (2 sigma^2), whole grid.
struct pixel_noise_likelihood {
  using measurement_type = tacmap::image<float>;
  const tacmap::image<float>* map;
  float sigma;
  void log_likelihood(const grid_t& g, const measurement_type& z, Eigen::ArrayXf& out) const {
    const auto w = g.window_size();
    for (Eigen::Index r = 0; r < g.rows(); ++r)
      for (Eigen::Index c = 0; c < g.cols(); ++c)
        out(r * g.cols() + c) =
            -(map->block(r, c, w.height, w.width) - z).square().sum() / (2 * sigma * sigma);
  }
};

}  // namespace

int main() {
  std::mt19937 rng(2015);
  const tacmap::image<float> map = make_map(rng);
  const grid_t grid = grid_t::paper();
  const float pixel_sigma = 1.0F;
  tacmap::bayes_filter filter(grid, tacmap::odometry_gaussian({.sigma_mm = 1.0, .k = 8}),
                              pixel_noise_likelihood{&map, pixel_sigma});

  std::normal_distribution<float> pixel_noise(0.0F, pixel_sigma);
  std::normal_distribution<double> odo_noise(0.0, 0.8);
  tacmap::grid_cell truth{30, 20};  // stays inside the 79 x 103 grid
  const int path[][2] = {{0, 0}, {8, -6}, {10, 5}, {-4, 12}, {9, 3}, {-12, 8}, {6, -9}};
  double error_mm = 0.0;
  std::printf("touch  true (mm)        MAP (mm)         error (mm)  entropy (nats)\n");
  for (int touch = 0; touch < 7; ++touch) {
    truth.col += path[touch][0];
    truth.row += path[touch][1];
    if (touch > 0) {
      // Odometry in mm, with noise: what the arm reports about the move just made.
      filter.predict({.dx_mm = grid.px_to_mm(path[touch][0]) + odo_noise(rng),
                      .dy_mm = grid.px_to_mm(path[touch][1]) + odo_noise(rng)});
    }
    const auto w = grid.window_size();
    tacmap::image<float> tactile = map.block(truth.row, truth.col, w.height, w.width);
    for (float& v : tactile.reshaped()) v += pixel_noise(rng);
    filter.update(tactile);

    const auto e = filter.estimate();
    const auto true_mm = grid.state_mm(grid.index(truth));
    error_mm = (e.map_mm - true_mm).norm();
    std::printf("%5d  (%6.1f, %6.1f)  (%6.1f, %6.1f)  %9.2f  %14.2f\n", touch + 1, true_mm.x(),
                true_mm.y(), e.map_mm.x(), e.map_mm.y(), error_mm, e.entropy_nats);
  }
  if (error_mm >= 3.0) {
    std::printf("FAILED: final error %.2f mm, expected below 3 mm\n", error_mm);
    return 1;
  }
  std::printf("localized: final error %.2f mm\n", error_mm);
  return 0;
}
