// custom_descriptor — plugging your own descriptor into tacmap's filter.
//
// The problem: the paper matches tactile and visual images with SIFT-like descriptors. Suppose
// you want to try something else — here the simplest thing that could work: a patch's raw
// pixels, made zero-mean and unit-norm so that contact pressure and camera exposure cancel out.
// Anything that models `tacmap::descriptor` (a scalar type, dimension(), patch_size(), a dense
// compute() and a distance()) plugs into `descriptor_likelihood`, and from there into the same
// `bayes_filter` as the shipped descriptors.
//
// Noise model of this run: the tactile image is the map window with a different gain and offset
// (pressure vs. exposure) plus pixel noise (sigma 0.15); the odometry has 0.5 mm noise per axis.
// Exit status 0 when the final error is below 5 mm (the paper's "localized").
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

#include "tacmap/tacmap.hpp"

namespace {

// A user's descriptor: the zero-mean, unit-norm pixels of a 9 x 9 patch (81-D).
struct normalised_patch {
  using scalar_type = float;
  using column = Eigen::Ref<const Eigen::Array<float, Eigen::Dynamic, 1>>;
  static constexpr bool euclidean_distance = true;  // opt into the matrix-product fast path
  static constexpr Eigen::Index side = 9;

  Eigen::Index dimension() const { return side * side; }
  Eigen::Index patch_size() const { return side; }

  tacmap::descriptor_field<float> compute(const tacmap::image<float>& img) const {
    if (img.rows() < side || img.cols() < side)
      throw std::invalid_argument("normalised_patch: image smaller than a 9 x 9 patch");
    if (!img.allFinite())  // the concept's requirement 4: NaN is refused, not described
      throw std::invalid_argument("normalised_patch: the image holds NaN or infinity");
    tacmap::descriptor_field<float> f;
    f.rows = img.rows() - side + 1;
    f.cols = img.cols() - side + 1;
    f.values.resize(dimension(), f.rows * f.cols);
    for (Eigen::Index r = 0; r < f.rows; ++r)
      for (Eigen::Index c = 0; c < f.cols; ++c) {
        auto v = f.values.col(r * f.cols + c);
        v = img.block(r, c, side, side).reshaped<Eigen::RowMajor>();
        v -= v.mean();
        const float norm = std::sqrt(v.square().sum());
        if (norm > 1e-6F) v /= norm;  // a flat patch stays all-zero
      }
    return f;
  }
  float distance(column a, column b) const { return std::sqrt((a - b).square().sum()); }
};
static_assert(tacmap::descriptor<normalised_patch>);

tacmap::image<float> make_object(std::mt19937& rng) {
  tacmap::image<float> map = tacmap::image<float>::Zero(120, 120);
  std::uniform_int_distribution<Eigen::Index> corner(0, 105), extent(4, 16);
  for (int bar = 0; bar < 18; ++bar)
    map.block(corner(rng), corner(rng), extent(rng), extent(rng)) += 1.0F;
  for (Eigen::Index r = 0; r < 120; ++r)
    for (Eigen::Index c = 0; c < 120; ++c)
      map(r, c) +=
          0.3F * std::sin(0.21F * static_cast<float>(r)) * std::cos(0.13F * static_cast<float>(c));
  map -= map.minCoeff();
  return map / map.maxCoeff();
}

}  // namespace

int main() {
  std::mt19937 rng(7);
  const tacmap::image<float> map = make_object(rng);
  const auto grid = tacmap::planar_grid<float>::paper();
  tacmap::descriptor_likelihood<normalised_patch> model(
      normalised_patch{}, map, grid.window_size(),
      {.spacing = 9,
       .features = tacmap::window_features::shared_dense,
       .pairs = tacmap::pairing::aligned,
       .shape = tacmap::likelihood_shape::exponential,
       .tau = 0.5});
  tacmap::bayes_filter filter(grid, tacmap::odometry_gaussian({.sigma_mm = 1.0, .k = 8}), model);

  std::normal_distribution<float> pixel_noise(0.0F, 0.15F);
  std::normal_distribution<double> odo_noise(0.0, 0.5);
  tacmap::grid_cell truth{20, 70};
  const int path[][2] = {{0, 0}, {-9, 6}, {-7, 8}, {-10, 4}, {-6, 9}, {-8, 7}};
  double error = 0.0;
  for (const auto& step : path) {
    if (step[0] != 0 || step[1] != 0) {
      truth.col += step[0];
      truth.row += step[1];
      filter.predict(
          {grid.px_to_mm(step[0]) + odo_noise(rng), grid.px_to_mm(step[1]) + odo_noise(rng)});
    }
    tacmap::image<float> touch = 0.6F * map.block(truth.row, truth.col, 42, 18) + 0.2F;
    for (float& v : touch.reshaped()) v += pixel_noise(rng);
    filter.update(touch);
    const auto e = filter.estimate();
    error = (e.map_mm - grid.state_mm(grid.index(truth))).norm();
    std::printf("touch: error %6.2f mm, entropy %5.2f nats\n", error, e.entropy_nats);
  }
  std::printf("%s: final error %.2f mm\n", error < 5.0 ? "localized" : "FAILED", error);
  return error < 5.0 ? 0 : 1;
}
