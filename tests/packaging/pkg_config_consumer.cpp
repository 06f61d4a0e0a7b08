// Compiled by the packaging tests with nothing but `pkg-config --cflags tacmap` (and
// -std=c++20): tacmap's headers and Eigen's come from the .pc files.
#include <cstdio>
#include <tacmap/config.hpp>
#include <tacmap/grid/planar_grid.hpp>

int main() {
  const auto grid = tacmap::planar_grid<float>::paper();
  std::printf("tacmap %d through pkg-config: the paper's grid has %ld states\n", TACMAP_VERSION,
              static_cast<long>(grid.size()));
  return grid.size() > 0 ? 0 : 1;
}
