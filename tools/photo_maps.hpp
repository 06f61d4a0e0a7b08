// tacmap tools: photographs as maps — loading (io/image_file.hpp), resizing to the map's size
// and the generated touch protocol that tacmap-evaluate and tacmap-calibrate share.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "tacmap/grid/planar_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/io/image_file.hpp"
#include "tacmap/sim/calibration.hpp"
#include "tacmap/sim/protocol.hpp"
#include "tacmap/sim/random.hpp"
#include "tacmap/tactile/preprocess.hpp"

namespace tacmap_tools {

using tacmap::image;

/// The photographs' map scale: the paper's, 3 map px per 3.4 mm taxel.
inline constexpr double photo_mm_per_px = 3.4 / 3.0;
/// The default map size, in px per side: the paper's 120 x 120 px maps.
inline constexpr long long default_map_px = 120;

/// Checks --map-px: a square map must hold the sensor's window at photo_mm_per_px (42 x 18 px for
/// the paper's array) and stay small enough to build its model (4096 px). Throws
/// std::invalid_argument naming the option, the value and the range.
inline void check_map_px(long long map_px) {
  const tacmap::pixel_size window = tacmap::tactile_window({}, photo_mm_per_px);
  const long long least = std::max(window.width, window.height);
  if (map_px < least || map_px > 4096)
    tacmap::detail::fail("--map-px: ", map_px, " is not a map size; expected ", least,
                         " .. 4096 px per side (at least the sensor's ", window.width, " x ",
                         window.height,
                         " px (width x height) window at 3.4/3 mm per px), or --native to keep the "
                         "photograph's own size");
}

/// A photograph as the map: grey intensities in [0, 1], resized by area to `map_px` x `map_px`
/// (the aspect ratio is not kept), or at its own size when `map_px` is 0. Says on stderr what it
/// did, so that nobody takes a resized map for the photograph's own.
inline image<float> load_photo(const std::string& path, long long map_px) {
  const image<float> photo = tacmap::load_image(std::filesystem::path(path));
  const auto mm = [](Eigen::Index px) { return static_cast<double>(px) * photo_mm_per_px; };
  if (map_px == 0) {
    const tacmap::pixel_size window = tacmap::tactile_window({}, photo_mm_per_px);
    if (photo.rows() < window.height || photo.cols() < window.width)
      tacmap::detail::fail("photo '", path, "' is ", photo.cols(), " x ", photo.rows(),
                           " px (width x height), smaller than the sensor's ", window.width, " x ",
                           window.height,
                           " px window at 3.4/3 mm per px; drop --native (or give --map-px N) "
                           "to enlarge it");
    std::fprintf(stderr,
                 "photo '%s' is %ld x %ld px (width x height); kept at that size (--native) at "
                 "%.4g mm per px: a %.0f x %.0f mm object\n",
                 path.c_str(), static_cast<long>(photo.cols()), static_cast<long>(photo.rows()),
                 photo_mm_per_px, mm(photo.cols()), mm(photo.rows()));
    return photo;
  }
  check_map_px(map_px);
  const auto side = static_cast<Eigen::Index>(map_px);
  std::fprintf(stderr,
               "photo '%s' is %ld x %ld px (width x height); %s to %ld x %ld px at %.4g mm per "
               "px: a %.0f x %.0f mm object%s (--map-px N sets the size, --native keeps the "
               "photograph's)\n",
               path.c_str(), static_cast<long>(photo.cols()), static_cast<long>(photo.rows()),
               photo.rows() == side && photo.cols() == side ? "used as is, already" : "resized",
               static_cast<long>(side), static_cast<long>(side), photo_mm_per_px, mm(side),
               mm(side), photo.rows() == photo.cols() ? "" : ", aspect ratio not kept");
  return tacmap::resize_area(photo, side, side);
}

// A photograph's protocol: the map from `load_photo(path, map_px)`, `touches` touch locations on
// pixel-aligned states, 22 random orders, measured odometry = true motion + N(0, 0.5 mm) per
// axis (the gecko protocol's noise), from `seed`.
inline tacmap::touch_protocol photo_protocol(const std::string& path, std::uint64_t seed,
                                             std::size_t touches = 7,
                                             long long map_px = default_map_px) {
  try {
    tacmap::touch_protocol p =
        tacmap::photo_touch_protocol(load_photo(path, map_px), photo_mm_per_px, seed, touches);
    p.map_file = path;
    return p;
  } catch (const std::invalid_argument& e) {
    tacmap::detail::fail("photo '", path, "': ", e.what(), " (--map-px, --touches)");
  }
}

}  // namespace tacmap_tools
