// Compile-time measurement (README, "Compile time"; issue 33): a translation unit that runs the
// generic front door with a user's descriptor, tacmap::descriptor_localizer<D> (its planar
// filter: latent appearance, robust motion, descriptor_likelihood<D>; the (x, y, theta) filter
// only with heading_support::localized, descriptor_localizer_headings_touch.cpp), against
// localizer_touch.cpp (the default instantiation).
#include <cmath>
#include <stdexcept>

#include "tacmap/localizer.hpp"

struct normalised_patch {
  using scalar_type = float;
  static constexpr bool euclidean_distance = true;
  Eigen::Index dimension() const { return 81; }
  Eigen::Index patch_size() const { return 9; }
  tacmap::descriptor_field<float> compute(const tacmap::image<float>& img) const {
    if (img.rows() < 9 || img.cols() < 9 || !img.allFinite())
      throw std::invalid_argument("normalised_patch: a finite image of at least 9 x 9 px");
    tacmap::descriptor_field<float> f{{}, img.rows() - 8, img.cols() - 8};
    f.values.resize(81, f.rows * f.cols);
    for (Eigen::Index r = 0; r < f.rows; ++r)
      for (Eigen::Index c = 0; c < f.cols; ++c) {
        auto v = f.values.col(r * f.cols + c);
        v = img.block(r, c, 9, 9).reshaped<Eigen::RowMajor>();
        v -= v.mean();
        if (const float norm = std::sqrt(v.square().sum()); norm > 1e-6F) v /= norm;
      }
    return f;
  }
  using column = Eigen::Ref<const Eigen::ArrayXf>;
  float distance(column a, column b) const { return std::sqrt((a - b).square().sum()); }
};

int main() {
  tacmap::image<float> map = tacmap::image<float>::Zero(120, 120);
  tacmap::descriptor_localizer<normalised_patch> loc(map, 3.4 / 3.0);
  tacmap::tactile_frame f;
  const auto r = loc.touch(f);
  return r.position_mm(0) > 0 ? 0 : 1;
}
