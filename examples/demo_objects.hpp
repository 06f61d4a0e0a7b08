// The demos' simulated objects beyond the gecko's own protocol: touch protocols over any map
// whose sensor windows hold an object's edge, and the horse photograph's (data/horse/), which
// gecko_demo and library_demo both touch. Header-only, for the examples only: not installed.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <utility>
#include <vector>

#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/io/image_io.hpp"
#include "tacmap/sim/protocol.hpp"
#include "tacmap/sim/random.hpp"
#include "tacmap/tactile/preprocess.hpp"

namespace tacmap_examples {

// A protocol on `map` (intensities in [0, 1] at `mm_per_px`, pressed as `relief`): `count`
// distinct touch locations on pixel-aligned states whose sensor windows are between a quarter
// and three quarters dark (< 0.5) — object and background both, so that every touch feels an
// edge — drawn from `seed`. Sequence 0 visits them in the order drawn, sequences 1 ..
// `sequences` - 1 in random orders; every move's measured odometry is the truth plus N(0,
// 0.5 mm) per axis (the gecko protocol's noise). Throws std::invalid_argument for a map with
// too few such windows.
inline tacmap::touch_protocol edge_protocol(std::filesystem::path map_file,
                                            tacmap::image<float> map, double mm_per_px,
                                            tacmap::relief_params relief, std::uint64_t seed,
                                            std::size_t count = 7, std::size_t sequences = 1) {
  tacmap::touch_protocol p;
  p.map_file = std::move(map_file);
  p.map = std::move(map);
  p.mm_per_px = mm_per_px;
  p.relief = relief;
  p.odometry_sigma_mm = 0.5;
  p.seed = seed;
  const tacmap::pixel_size window = tacmap::tactile_window({}, p.mm_per_px);
  const tacmap::planar_grid<float> grid(p.map_size(), p.mm_per_px, window);
  tacmap::sim_rng rng(p.seed);
  for (int attempt = 0; p.locations.size() < count; ++attempt) {
    if (attempt > 100000)
      tacmap::detail::fail("edge_protocol: ", p.map_file, " has fewer than ", count,
                           " sensor windows over an object's edge (25-75 % of the window dark); "
                           "expected an object filling part of the image");
    const auto i = static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(grid.size())));
    const tacmap::grid_cell cell = grid.cell(i);
    const float dark_share =
        (p.map.block(cell.row, cell.col, window.height, window.width) < 0.5F).cast<float>().mean();
    const auto s = grid.state_mm(i);
    const tacmap::touch_location loc{s(0), s(1)};
    if (dark_share > 0.25F && dark_share < 0.75F &&
        std::find(p.locations.begin(), p.locations.end(), loc) == p.locations.end())
      p.locations.push_back(loc);
  }
  std::vector<std::size_t> order(p.locations.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  for (std::size_t q = 0; q < sequences; ++q) {
    if (q > 0)
      for (std::size_t k = order.size() - 1; k > 0; --k)
        std::swap(order[k], order[rng.below(k + 1)]);
    p.sequences.push_back(tacmap::sequence_visiting(p.locations, order, p.odometry_sigma_mm, rng));
  }
  return p;
}

// The horse (data/horse/: scikit-image's horse silhouette, CC0): a photograph of a dark
// silhouette on white, pressed as a 4 mm relief where the photo is dark (the experiment's
// polarity: dark_raised); 7 locations over its edge (seed 5), visited in order in sequence 0.
inline tacmap::touch_protocol horse_protocol(const std::filesystem::path& data_dir,
                                             std::size_t sequences = 1) {
  const std::filesystem::path file = data_dir / "horse" / "horse.pgm";
  return edge_protocol(file, tacmap::read_pgm(file), 3.4 / 3.0,
                       {.kind = tacmap::relief_kind::binary,
                        .threshold = 0.5F,
                        .height_mm = 4.0,
                        .edge_smoothing_px = 0.7},
                       5, 7, sequences);
}

}  // namespace tacmap_examples
