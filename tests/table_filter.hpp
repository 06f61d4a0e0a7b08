// A planar filter whose measurement *is* a log-likelihood table: tests of what the filter does
// with a belief (confidence, calibration) without a descriptor model in the way.
#pragma once

#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/motion/odometry_gaussian.hpp"

namespace tacmap_test {

/// The measurement is the log-likelihood over the grid's states.
template <class G>
struct table_likelihood {
  using measurement_type = tacmap::belief_array<G>;
  void log_likelihood(const G&, const measurement_type& z, tacmap::belief_array<G>& out) const {
    out = z;
  }
};

using table_grid = tacmap::planar_grid<float>;
using table_filter =
    tacmap::bayes_filter<table_grid, tacmap::odometry_gaussian, table_likelihood<table_grid>>;

/// 20 x 10 positions, 1 mm apart (a 22 x 12 px map at 1 mm per px, a 3 x 3 px window); state
/// centres at (c + 1.5, r + 1.5) mm.
inline table_filter lattice_filter() {
  return table_filter(table_grid({.width = 22, .height = 12}, 1.0, {.width = 3, .height = 3}),
                      tacmap::odometry_gaussian({.sigma_mm = 1.0, .k = 8}), {});
}

}  // namespace tacmap_test
