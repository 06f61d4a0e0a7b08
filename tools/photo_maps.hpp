// tacmap tools: photographs as maps — loading (io/image_file.hpp), resizing to the map's size
// and the generated touch protocol that tacmap-evaluate and tacmap-calibrate share.
#pragma once

#include <CLI/CLI.hpp>
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
/// The default map size: the paper's maps were 120 x 120 px; a photograph's longer side becomes
/// 120 px and its shorter side keeps the aspect ratio.
inline constexpr long long default_map_px = 120;

/// How a photograph becomes a map (the tools' --max-side, --map-px and --native).
struct map_sizing {
  enum class kind {
    max_side,  ///< the longer side resized to `px`, the aspect ratio kept (the default)
    square,    ///< resized to `px` x `px`, the aspect ratio not kept (--map-px)
    native     ///< the photograph's own size (--native)
  };
  kind how = kind::max_side;
  long long px = default_map_px;
};

/// Checks a map side given on the command line (`option`: --max-side or --map-px): it must hold
/// the sensor's window at photo_mm_per_px (42 x 18 px for the paper's array) and stay small
/// enough to build its model (4096 px). Throws std::invalid_argument naming the option, the value
/// and the range.
inline void check_map_px(long long map_px, const char* option = "--map-px") {
  const tacmap::pixel_size window = tacmap::tactile_window({}, photo_mm_per_px);
  const long long least = std::max(window.width, window.height);
  if (map_px < least || map_px > 4096)
    tacmap::detail::fail(option, ": ", map_px, " is not a map size; expected ", least,
                         " .. 4096 px per side (at least the sensor's ", window.width, " x ",
                         window.height,
                         " px (width x height) window at 3.4/3 mm per px), or --native to keep the "
                         "photograph's own size");
}

/// The options that size the photographs' maps, shared by both tools: --max-side (the
/// default: the longer side, the aspect ratio kept), --map-px (a square) or --native.
struct map_sizing_options {
  long long max_side = default_map_px;  // signed: a negative size is refused
  long long map_px = 0;
  bool native = false;
  CLI::Option* square = nullptr;

  void add_to(CLI::App& app) {
    auto* longer = app.add_option(
        "--max-side", max_side,
        "the photographs' maps: the longer side, px, the aspect ratio kept (120; resized by area)");
    square = app.add_option("--map-px", map_px,
                            "the photographs' maps: N x N px instead, the aspect ratio not kept")
                 ->excludes(longer);
    app.add_flag("--native", native, "keep each photograph's own size as its map")
        ->excludes(square)
        ->excludes(longer);
  }

  /// The sizing the options chose, its size checked against the sensor's window.
  [[nodiscard]] map_sizing chosen() const {
    if (native) return {map_sizing::kind::native, 0};
    const bool is_square = square != nullptr && square->count() > 0;
    const map_sizing sizing = is_square ? map_sizing{map_sizing::kind::square, map_px}
                                        : map_sizing{map_sizing::kind::max_side, max_side};
    check_map_px(sizing.px, is_square ? "--map-px" : "--max-side");
    return sizing;
  }
};

/// A photograph as the map: grey intensities in [0, 1], resized by area as `sizing` says (by
/// default its longer side to 120 px, the aspect ratio kept). Says on stderr what it did, so
/// that nobody takes a resized map for the photograph's own.
inline image<float> load_photo(const std::string& path, map_sizing sizing = {}) {
  const image<float> photo = tacmap::load_image(std::filesystem::path(path));
  const auto mm = [](Eigen::Index px) { return static_cast<double>(px) * photo_mm_per_px; };
  const tacmap::pixel_size window = tacmap::tactile_window({}, photo_mm_per_px);
  if (sizing.how == map_sizing::kind::native) {
    if (photo.rows() < window.height || photo.cols() < window.width)
      tacmap::detail::fail("photo '", path, "' is ", photo.cols(), " x ", photo.rows(),
                           " px (width x height), smaller than the sensor's ", window.width, " x ",
                           window.height,
                           " px window at 3.4/3 mm per px; drop --native (or give --max-side N) "
                           "to enlarge it");
    std::fprintf(stderr,
                 "photo '%s' is %ld x %ld px (width x height); kept at that size (--native) at "
                 "%.4g mm per px: a %.0f x %.0f mm object\n",
                 path.c_str(), static_cast<long>(photo.cols()), static_cast<long>(photo.rows()),
                 photo_mm_per_px, mm(photo.cols()), mm(photo.rows()));
    return photo;
  }
  const bool square = sizing.how == map_sizing::kind::square;
  check_map_px(sizing.px, square ? "--map-px" : "--max-side");
  const auto side = static_cast<Eigen::Index>(sizing.px);
  Eigen::Index cols = side, rows = side;
  if (!square) {  // the longer side to `side`, the shorter in proportion (rounded)
    const double scale =
        static_cast<double>(side) / static_cast<double>(std::max(photo.cols(), photo.rows()));
    cols = std::max<Eigen::Index>(
        1, static_cast<Eigen::Index>(std::lround(static_cast<double>(photo.cols()) * scale)));
    rows = std::max<Eigen::Index>(
        1, static_cast<Eigen::Index>(std::lround(static_cast<double>(photo.rows()) * scale)));
    if (rows < window.height || cols < window.width)
      tacmap::detail::fail("photo '", path, "' is ", photo.cols(), " x ", photo.rows(),
                           " px (width x height): with its longer side at --max-side ", side,
                           " px its map would be ", cols, " x ", rows,
                           " px, smaller than the sensor's ", window.width, " x ", window.height,
                           " px window; expected a larger --max-side, or --map-px N for a square "
                           "map");
  }
  const bool same = photo.rows() == rows && photo.cols() == cols;
  std::fprintf(stderr,
               "photo '%s' is %ld x %ld px (width x height); %s to %ld x %ld px at %.4g mm per "
               "px: a %.0f x %.0f mm object%s\n",
               path.c_str(), static_cast<long>(photo.cols()), static_cast<long>(photo.rows()),
               same ? "used as is, already" : "resized", static_cast<long>(cols),
               static_cast<long>(rows), photo_mm_per_px, mm(cols), mm(rows),
               square ? (photo.rows() == photo.cols() ? " (--map-px: a square map)"
                                                      : " (--map-px: aspect ratio not kept)")
                      : " (aspect ratio kept; --max-side N sets the longer side, --native keeps "
                        "the photograph's size)");
  return same ? photo : tacmap::resize_area(photo, rows, cols);
}

// A photograph's protocol: the map from `load_photo(path, sizing)`, `touches` touch locations on
// pixel-aligned states, 22 random orders, measured odometry = true motion + N(0, 0.5 mm) per
// axis (the gecko protocol's noise), from `seed`.
inline tacmap::touch_protocol photo_protocol(const std::string& path, std::uint64_t seed,
                                             std::size_t touches = 7, map_sizing sizing = {}) {
  try {
    tacmap::touch_protocol p =
        tacmap::photo_touch_protocol(load_photo(path, sizing), photo_mm_per_px, seed, touches);
    p.map_file = path;
    return p;
  } catch (const std::invalid_argument& e) {
    tacmap::detail::fail("photo '", path, "': ", e.what(), " (--max-side, --touches)");
  }
}

}  // namespace tacmap_tools
