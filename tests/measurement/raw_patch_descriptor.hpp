// A small descriptor for tests: the raw pixels of a p x p patch (dimension p^2), Euclidean.
#pragma once

#include <cmath>

#include "tacmap/descriptor/concept.hpp"

namespace tacmap_test {

template <bool Euclidean>
struct raw_patch_t {
  using scalar_type = float;
  using column = Eigen::Ref<const Eigen::Array<float, Eigen::Dynamic, 1>>;
  static constexpr bool euclidean_distance = Euclidean;
  Eigen::Index patch = 6;
  Eigen::Index dimension() const { return patch * patch; }
  Eigen::Index patch_size() const { return patch; }
  tacmap::descriptor_field<float> compute(const tacmap::image<float>& img) const {
    if (img.rows() < patch || img.cols() < patch)
      tacmap::detail::fail("raw_patch: image ", img.rows(), " x ", img.cols(),
                           " is smaller than the patch ", patch);
    if (!img.allFinite())
      tacmap::detail::fail("raw_patch: the image holds NaN or infinity; expected finite pixels");
    tacmap::descriptor_field<float> f;
    f.rows = img.rows() - patch + 1;
    f.cols = img.cols() - patch + 1;
    f.values.resize(dimension(), f.rows * f.cols);
    for (Eigen::Index r = 0; r < f.rows; ++r)
      for (Eigen::Index c = 0; c < f.cols; ++c)
        for (Eigen::Index i = 0; i < patch; ++i)
          for (Eigen::Index j = 0; j < patch; ++j)
            f.values(i * patch + j, r * f.cols + c) = img(r + i, c + j);
    return f;
  }
  float distance(column a, column b) const { return std::sqrt((a - b).square().sum()); }
};
using raw_patch = raw_patch_t<true>;
using raw_patch_generic = raw_patch_t<false>;  // same maths through the generic distance path

}  // namespace tacmap_test
