// tacmap tools: photographs as maps — loading (stb_image), area resizing and the generated
// touch protocol that tacmap-evaluate and tacmap-calibrate share. Include in ONE translation
// unit per program (it defines stb_image's implementation).
#pragma once

#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STBI_ONLY_PNM
#define STBI_NO_HDR
#define STBI_NO_LINEAR
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wold-style-cast"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#pragma GCC diagnostic ignored "-Wcast-qual"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wuseless-cast"
#pragma GCC diagnostic ignored "-Wpedantic"
#endif
#include <stb/stb_image.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/sim/protocol.hpp"
#include "tacmap/sim/random.hpp"
#include "tacmap/tactile/preprocess.hpp"

namespace tacmap_tools {

using tacmap::image;

// A photograph as grey intensities in [0, 1] (stb_image's own grey conversion).
inline image<float> load_photo(const std::string& path) {
  int w = 0, h = 0, channels = 0;
  std::unique_ptr<unsigned char, void (*)(void*)> pixels(
      stbi_load(path.c_str(), &w, &h, &channels, 1), stbi_image_free);
  if (!pixels)
    tacmap::detail::fail("cannot read the photograph '", path, "' (", stbi_failure_reason(),
                         "); expected a readable PNG, JPEG or PGM file — check the path");
  image<float> out(h, w);
  for (Eigen::Index r = 0; r < h; ++r)
    for (Eigen::Index c = 0; c < w; ++c)
      out(r, c) = static_cast<float>(pixels.get()[r * w + c]) / 255.0F;
  return out;
}

// Area-average resize: each output pixel is the mean of the source area it covers (fractional
// overlaps weighted), so shrinking a photograph does not alias.
inline image<float> resize_area(const image<float>& src, Eigen::Index rows, Eigen::Index cols) {
  const double sy = static_cast<double>(src.rows()) / static_cast<double>(rows);
  const double sx = static_cast<double>(src.cols()) / static_cast<double>(cols);
  // Weights of the source indices each output index covers, per axis.
  const auto weights = [](Eigen::Index n_out, double scale, Eigen::Index n_src) {
    std::vector<std::vector<std::pair<Eigen::Index, double>>> w(static_cast<std::size_t>(n_out));
    for (Eigen::Index o = 0; o < n_out; ++o) {
      const double a = static_cast<double>(o) * scale, b = a + scale;
      for (auto s = static_cast<Eigen::Index>(std::floor(a));
           s < n_src && static_cast<double>(s) < b; ++s) {
        const double overlap =
            std::min(b, static_cast<double>(s + 1)) - std::max(a, static_cast<double>(s));
        if (overlap > 0) w[static_cast<std::size_t>(o)].push_back({s, overlap / scale});
      }
    }
    return w;
  };
  const auto wy = weights(rows, sy, src.rows());
  const auto wx = weights(cols, sx, src.cols());
  image<float> out(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c) {
      double sum = 0, total = 0;
      for (const auto& [y, a] : wy[static_cast<std::size_t>(r)])
        for (const auto& [x, b] : wx[static_cast<std::size_t>(c)]) {
          sum += a * b * src(y, x);
          total += a * b;
        }
      out(r, c) = static_cast<float>(sum / total);
    }
  return out;
}

// A photograph's protocol: `touches` touch locations on pixel-aligned states, 22 random orders,
// measured odometry = true motion + N(0, 0.5 mm) per axis (the gecko protocol's noise), from
// `seed`.
inline tacmap::touch_protocol photo_protocol(const std::string& path, std::uint64_t seed,
                                             std::size_t touches = 7) {
  tacmap::touch_protocol p;
  p.map_file = path;
  p.map = resize_area(load_photo(path), 120, 120);
  p.mm_per_px = 3.4 / 3.0;
  p.relief = {.kind = tacmap::relief_kind::continuous,
              .threshold = 0.5F,
              .height_mm = 4.0,
              .edge_smoothing_px = 0.0};
  p.odometry_sigma_mm = 0.5;
  p.seed = seed;
  const tacmap::planar_grid<float> grid(p.map_size(), p.mm_per_px,
                                        tacmap::tactile_window({}, p.mm_per_px));
  tacmap::sim_rng rng(seed);
  while (p.locations.size() < touches) {  // distinct states
    const auto s = grid.state_mm(
        static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(grid.size()))));
    const tacmap::touch_location loc{s(0), s(1)};
    if (std::find(p.locations.begin(), p.locations.end(), loc) == p.locations.end())
      p.locations.push_back(loc);
  }
  const std::size_t n = p.locations.size();
  for (int q = 0; q < 22; ++q) {
    std::vector<std::size_t> order(n);
    for (std::size_t k = 0; k < n; ++k) order[k] = k;
    for (std::size_t k = n - 1; k > 0; --k) std::swap(order[k], order[rng.below(k + 1)]);
    p.sequences.push_back(tacmap::sequence_visiting(p.locations, order, p.odometry_sigma_mm, rng));
  }
  return p;
}

}  // namespace tacmap_tools
