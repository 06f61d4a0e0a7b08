// Helpers shared by the tracking tests (test_tracking.cpp, test_default_tracking.cpp).
#pragma once

#include <cstdint>

#include "tacmap/grid/concept.hpp"
#include "tacmap/image.hpp"

namespace tacmap_test {

/// The window of `map` with top-left (row, col) plus a little deterministic noise (xorshift32,
/// +-0.015): a touch, not an exact cut.
inline tacmap::image<float> noisy_window(const tacmap::image<float>& map, Eigen::Index row,
                                         Eigen::Index col, tacmap::pixel_size window,
                                         unsigned seed) {
  tacmap::image<float> z = map.block(row, col, window.height, window.width);
  std::uint32_t state = seed * 2654435761U + 7U;
  for (float& v : z.reshaped()) {
    state ^= state << 13U;
    state ^= state >> 17U;
    state ^= state << 5U;
    v += 0.03F * (static_cast<float>(state % 1000U) / 1000.0F - 0.5F);
  }
  return z;
}

/// The total variation distance between two beliefs.
template <class A, class B>
double total_variation(const A& a, const B& b) {
  return 0.5 * (a.template cast<double>() - b.template cast<double>()).abs().sum();
}

}  // namespace tacmap_test
