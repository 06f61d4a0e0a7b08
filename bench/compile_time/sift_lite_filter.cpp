// Compile-time measurement (README, "Compile time"): a translation unit that runs a SIFT-lite
// planar filter (predict, update, estimate), compiled header-only or with
// -DTACMAP_PRECOMPILED=1 (what linking tacmap::precompiled defines).
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/tacmap.hpp"

int main() {
  tacmap::image<float> map(120, 120);
  for (Eigen::Index r = 0; r < 120; ++r)
    for (Eigen::Index c = 0; c < 120; ++c) map(r, c) = static_cast<float>((r * 7 + c * 3) % 17);
  const auto grid = tacmap::planar_grid<float>::paper();
  tacmap::bayes_filter filter(
      grid, tacmap::odometry_gaussian{},
      tacmap::descriptor_likelihood<tacmap::sift_lite>({}, map, grid.window_size()));
  filter.predict({.dx_mm = 1.0, .dy_mm = 0.0});
  filter.update(map.block(30, 40, 42, 18));
  return filter.estimate().map_index > 0 ? 0 : 1;
}
