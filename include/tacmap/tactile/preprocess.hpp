// tacmap: tactile preprocessing (paper, Sec. IV-A) — from raw taxel counts to a map-scale image.
//
// 1. Reject frames "collected unintentionally": the maximum below a threshold, or the sum of all
//    taxels below a decision value. Also reject frames without a pattern: (max - min) / max
//    below a contrast threshold (a saturated frame, every taxel at full scale, is the usual
//    case); the descriptors would take their noise for a pattern and match the map anywhere. A
//    rejected frame is reported to the caller (it is never silently used, nor silently
//    dropped).
// 2. Normalise by the frame's maximum, so the image falls into [0, 1].
// 3. Resize from taxels to map pixels using the cell pitch and the map's scale: the paper's
//    14 x 6 array at 3.4 mm on a 3.4/3 mm-per-px map becomes 42 x 18 px. The geometry comes with
//    the frame; nothing here assumes 14 x 6.
#pragma once

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "tacmap/detail/setting_ranges.hpp"
#include "tacmap/image.hpp"
#include "tacmap/tactile/frame.hpp"

namespace tacmap {

/// How taxel values are spread over map pixels.
enum class resize_method {
  bilinear,  ///< interpolate between taxel centres (smooth, like an image resize)
  nearest,   ///< each taxel fills the pixels whose centres fall in its cell (blocky)
};

/// Configuration of `preprocess`. Thresholds are in raw counts (Weiss arrays: 12 bit, 0..4095).
struct preprocess_params {
  float min_peak = 200.0F;   ///< reject when the largest taxel is below this
  float min_total = 600.0F;  ///< reject when the sum of all taxels is below this (decision value)
  /// Reject when (max - min) / max, the range the normalised image spans, is below this
  /// fraction (not counts): the frame is flat, at whatever level. A saturated frame (every taxel
  /// at full scale, 4095 for Weiss arrays) is flat; so is a press that loads every taxel alike.
  /// Relative, so it holds for any read-out range and needs no change when min_peak does: a
  /// frame with one unloaded taxel spans 1. 0.05 is 200 counts at full scale, 20 sigma of a
  /// Weiss read-out's noise (about 10 counts). 0 turns the check off; a one-taxel array skips it.
  float min_contrast = 0.05F;
  double mm_per_px = 3.4 / 3.0;  ///< the map's scale
  resize_method resize = resize_method::bilinear;

  void validate() const {
    if (!(std::isfinite(min_peak) && min_peak >= 0.0F))
      detail::fail("preprocess_params: min_peak = ", min_peak, "; expected a finite count >= 0");
    if (!(std::isfinite(min_total) && min_total >= 0.0F))
      detail::fail("preprocess_params: min_total = ", min_total, "; expected a finite count >= 0");
    if (!(min_contrast >= 0.0F && min_contrast <= 1.0F))
      detail::fail("preprocess_params: min_contrast = ", min_contrast,
                   "; expected a fraction of the peak in [0, 1] (0.05: 5 %; 0 turns the "
                   "flat-frame check off)");
    if (!(std::isfinite(mm_per_px) && mm_per_px > 0.0))
      detail::fail("preprocess_params: mm_per_px = ", mm_per_px,
                   "; expected the map's scale, a finite value > 0 millimetres per pixel");
  }
};

/// Why a frame was not used.
enum class frame_rejection {
  none,        ///< accepted
  weak_peak,   ///< max < min_peak: no deliberate contact
  weak_total,  ///< sum < min_total: too little contact area or force
  flat,        ///< (max - min) / max < min_contrast: no pattern (e.g. saturated: all at full scale)
};

/// The outcome of preprocessing one frame. `pixels` is valid only when `accepted()`.
struct preprocessed_frame {
  frame_rejection rejection = frame_rejection::none;
  float peak = 0.0F;      ///< the frame's maximum (raw counts)
  float total = 0.0F;     ///< the frame's sum (raw counts)
  float contrast = 0.0F;  ///< (max - min) / max: the range the normalised image spans, 0..1
  image<float> pixels;    ///< map-scale tactile image in [0, 1] (rows x cols in map pixels)

  [[nodiscard]] bool accepted() const { return rejection == frame_rejection::none; }
  /// A sentence for logs: why the frame was rejected (empty when accepted).
  [[nodiscard]] std::string reason() const {
    switch (rejection) {
      case frame_rejection::weak_peak:
        return "rejected: peak " + std::to_string(peak) + " counts is below min_peak";
      case frame_rejection::weak_total:
        return "rejected: total " + std::to_string(total) + " counts is below min_total";
      case frame_rejection::flat:
        return "rejected: contrast (max - min) / max " + std::to_string(contrast) +
               " is below min_contrast: no pattern (saturated, or every taxel loaded alike)";
      case frame_rejection::none:
        break;
    }
    return {};
  }
};

/// The most map pixels a side of the sensor's window may span (a 65,536 px side is a 16 GB
/// float image): beyond it a scale is a unit mistake, not a map.
inline constexpr double max_tactile_window_px = 65536.0;

/// The size in map pixels of a tactile array of `geometry` on a map of `mm_per_px`: each side's
/// physical length (taxels x pitch) divided by the scale, rounded to whole pixels. Throws
/// std::invalid_argument when mm_per_px is not finite and > 0, or when a side would span more
/// than `max_tactile_window_px` (the scale range is named in the message).
[[nodiscard]] inline pixel_size tactile_window(const taxel_geometry& geometry, double mm_per_px) {
  geometry.validate();
  if (!(std::isfinite(mm_per_px) && mm_per_px > 0.0))
    detail::fail("tactile_window: mm_per_px = ", mm_per_px,
                 "; expected the map's scale, a finite value > 0 millimetres per pixel");
  const double longest =
      static_cast<double>(std::max(geometry.rows, geometry.cols)) * geometry.pitch_mm;
  // Checked before rounding: std::lround of a side beyond the long range (mm_per_px 1e-300) is
  // undefined, and gave "covers less than one pixel".
  if (!(longest / mm_per_px <= max_tactile_window_px))
    detail::fail("tactile_window: mm_per_px = ", mm_per_px, " makes the ", geometry.rows, " x ",
                 geometry.cols, " array at ", geometry.pitch_mm, " mm span ", longest / mm_per_px,
                 " px; expected a scale in [", longest / max_tactile_window_px,
                 ", infinity) mm per px (at most ", max_tactile_window_px,
                 " px per side) — check the units: millimetres per pixel, not pixels per mm");
  const auto side = [&](Eigen::Index taxels) {
    return static_cast<Eigen::Index>(
        std::lround(static_cast<double>(taxels) * geometry.pitch_mm / mm_per_px));
  };
  return {.width = side(geometry.cols), .height = side(geometry.rows)};
}

namespace detail {
/// A map's scale against the range in which the models stay finite ([min_mm_per_px,
/// max_mm_per_px]), refused naming the value and the range (messages start with `who`).
inline void check_map_scale(const char* who, double mm_per_px) {
  check_range(who, "mm_per_px", mm_per_px, min_mm_per_px, max_mm_per_px, " mm per px",
              "the map's scale", "give the photograph's scale in millimetres per pixel (e.g. 0.2)");
}
}  // namespace detail

/// `tactile_window`, checked against the map it must fit on: throws std::invalid_argument
/// (messages start with `who`) when the array covers less than a pixel or the map is smaller
/// than the sensor's footprint.
[[nodiscard]] inline pixel_size checked_tactile_window(const taxel_geometry& geometry,
                                                       double mm_per_px, pixel_size map,
                                                       const char* who) {
  detail::check_map_scale(who, mm_per_px);
  const pixel_size w = tactile_window(geometry, mm_per_px);
  if (w.width < 1 || w.height < 1)
    detail::fail(who, ": a ", geometry.rows, " x ", geometry.cols, " array at ", geometry.pitch_mm,
                 " mm covers less than one pixel at ", mm_per_px,
                 " mm per px; expected a map scale finer than the array's pitch");
  if (map.width < w.width || map.height < w.height)
    detail::fail(who, ": the map is ", map.width, " x ", map.height,
                 " px (width x height) but the sensor covers ", w.width, " x ", w.height, " px at ",
                 mm_per_px, " mm per px; expected a map at least the sensor's size");
  return w;
}

namespace detail {

// Resamples `src` (taxels) to `out_rows x out_cols` pixels. Pixel centres and taxel centres are
// aligned on the physical extent of the array, so the image is neither shifted nor stretched.
inline image<float> resize_taxels(const image<float>& src, Eigen::Index out_rows,
                                  Eigen::Index out_cols, resize_method method) {
  if (method == resize_method::bilinear) return resize_bilinear(src, out_rows, out_cols);
  image<float> out(out_rows, out_cols);
  const double sy = static_cast<double>(src.rows()) / static_cast<double>(out_rows);
  const double sx = static_cast<double>(src.cols()) / static_cast<double>(out_cols);
  for (Eigen::Index r = 0; r < out_rows; ++r) {
    const double v = (static_cast<double>(r) + 0.5) * sy - 0.5;  // taxel row coordinate
    const auto tr =
        std::clamp<Eigen::Index>(static_cast<Eigen::Index>(std::lround(v)), 0, src.rows() - 1);
    for (Eigen::Index c = 0; c < out_cols; ++c) {
      const double u = (static_cast<double>(c) + 0.5) * sx - 0.5;
      const auto tc =
          std::clamp<Eigen::Index>(static_cast<Eigen::Index>(std::lround(u)), 0, src.cols() - 1);
      out(r, c) = src(tr, tc);
    }
  }
  return out;
}

}  // namespace detail

/// Preprocesses one frame (Sec.\ IV-A). Throws std::invalid_argument for a malformed frame
/// (counts that disagree with the geometry, NaN or negative counts) or bad parameters; a weak or
/// flat frame is not an error but a rejection, reported in the result.
[[nodiscard]] inline preprocessed_frame preprocess(const tactile_frame& frame,
                                                   const preprocess_params& params = {}) {
  params.validate();
  frame.validate();
  preprocessed_frame result;
  result.peak = frame.counts.maxCoeff();
  result.total = frame.counts.sum();
  if (result.peak < params.min_peak || !(result.peak > 0.0F)) {
    result.rejection = frame_rejection::weak_peak;
    return result;
  }
  result.contrast = (result.peak - frame.counts.minCoeff()) / result.peak;
  if (result.total < params.min_total) {
    result.rejection = frame_rejection::weak_total;
    return result;
  }
  // A one-taxel array is flat by construction: only min_peak and min_total judge its frames.
  if (frame.counts.size() > 1 && result.contrast < params.min_contrast) {
    result.rejection = frame_rejection::flat;
    return result;
  }
  const pixel_size window = tactile_window(frame.geometry, params.mm_per_px);
  if (window.width < 1 || window.height < 1)
    detail::fail("preprocess: a ", frame.geometry.rows, " x ", frame.geometry.cols, " array at ",
                 frame.geometry.pitch_mm,
                 " mm covers less than one pixel of a map "
                 "at ",
                 params.mm_per_px, " mm per px; expected a map scale finer than the array");
  result.pixels =
      detail::resize_taxels(frame.counts / result.peak, window.height, window.width, params.resize);
  return result;
}

}  // namespace tacmap
