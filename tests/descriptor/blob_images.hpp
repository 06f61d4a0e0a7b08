// Test images for the descriptor tests: soft Gaussian blobs of random size, position and height
// on zero, like a tactile image (weak, unnormalised descriptors next to strong ones).
#pragma once

#include <cmath>
#include <random>

#include "tacmap/image.hpp"

namespace tacmap_test {

/// Adds `blobs` blobs to `img`: centre uniform over the image, sigma in [1, 1 + sigma_spread] px,
/// height in [0.2, 1.2], drawn from `gen` in that order, blob after blob.
template <class T>
void add_blobs(tacmap::image<T>& img, std::mt19937& gen, int blobs, double sigma_spread) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::Index rows = img.rows();
  const Eigen::Index cols = img.cols();
  for (int blob = 0; blob < blobs; ++blob) {
    const double cy = u(gen) * static_cast<double>(rows);
    const double cx = u(gen) * static_cast<double>(cols);
    const double s = 1.0 + sigma_spread * u(gen);
    const double a = 0.2 + u(gen);
    for (Eigen::Index r = 0; r < rows; ++r) {
      for (Eigen::Index c = 0; c < cols; ++c) {
        const double dy = static_cast<double>(r) - cy;
        const double dx = static_cast<double>(c) - cx;
        img(r, c) += static_cast<T>(a * std::exp(-(dx * dx + dy * dy) / (2.0 * s * s)));
      }
    }
  }
}

}  // namespace tacmap_test
