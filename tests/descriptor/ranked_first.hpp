// Shared by the descriptor tests: how often a measurement model ranks a touch's true window first.
#pragma once

#include <utility>

#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/image.hpp"

namespace tacmap_test {

/// Touches cut from `touch_map` (42 x 18 px) at every 6th state row and 8th column of `grid`;
/// returns {touches whose true state has the highest log-likelihood, touches tried}.
template <class Model>
std::pair<int, int> ranked_first(const Model& model, const tacmap::planar_grid<float>& grid,
                                 const tacmap::image<float>& touch_map) {
  Eigen::ArrayXf ll(grid.size());
  int first = 0;
  int tried = 0;
  for (Eigen::Index row = 1; row < grid.rows(); row += 6)
    for (Eigen::Index col = 2; col < grid.cols(); col += 8) {
      model.log_likelihood(grid, touch_map.block(row, col, 42, 18), ll);
      Eigen::Index best = 0;
      ll.maxCoeff(&best);
      first += best == grid.index({row, col}) ? 1 : 0;
      ++tried;
    }
  return {first, tried};
}

}  // namespace tacmap_test
