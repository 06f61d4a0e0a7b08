// tacmap: colour PNG output for figures (demo, evaluation): `rgb_image` and `write_png_rgb`.
//
// Same encoder as io/image_io.hpp's grey `encode_png` (stored deflate blocks, no compression,
// no dependency), with three 8-bit channels (PNG colour type 2): a figure of W x H px takes
// 3 W H bytes. Compressed PNG (typically 10-50x smaller for figures) is in the optional
// tacmap/io/image_file.hpp (`encode_png_compressed`, `write_png_compressed`, through
// stb_image_write; CMake target tacmap::image_file), so that this header stays dependency-free.
#pragma once

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "tacmap/image.hpp"
#include "tacmap/io/image_io.hpp"

namespace tacmap {

/// A colour image: three channels of the same size, intensities in [0, 1].
struct rgb_image {
  image<float> r, g, b;

  /// A `rows` x `cols` image filled with one colour.
  [[nodiscard]] static rgb_image filled(Eigen::Index rows, Eigen::Index cols, float red,
                                        float green, float blue) {
    return {image<float>::Constant(rows, cols, red), image<float>::Constant(rows, cols, green),
            image<float>::Constant(rows, cols, blue)};
  }
  [[nodiscard]] Eigen::Index rows() const { return r.rows(); }
  [[nodiscard]] Eigen::Index cols() const { return r.cols(); }
  /// Sets pixel (row, col) when it lies inside the image; ignores it otherwise (drawing helpers
  /// may clip at the border).
  void set(Eigen::Index row, Eigen::Index col, float red, float green, float blue) {
    if (row < 0 || col < 0 || row >= rows() || col >= cols()) return;
    r(row, col) = red;
    g(row, col) = green;
    b(row, col) = blue;
  }
};

namespace detail::image_io {

/// Refuses an `rgb_image` that cannot be written (channels of different sizes, empty, or holding
/// non-finite values); `who` names the caller in the message.
inline void check_writable_rgb(const rgb_image& img, const char* who) {
  if (img.g.rows() != img.r.rows() || img.g.cols() != img.r.cols() ||
      img.b.rows() != img.r.rows() || img.b.cols() != img.r.cols())
    detail::fail(who, ": channel sizes differ (red ", img.r.rows(), " x ", img.r.cols(), ", green ",
                 img.g.rows(), " x ", img.g.cols(), ", blue ", img.b.rows(), " x ", img.b.cols(),
                 "); expected three channels of the same size");
  check_writable(img.r, (std::string(who) + " (red)").c_str());
  check_writable(img.g, (std::string(who) + " (green)").c_str());
  check_writable(img.b, (std::string(who) + " (blue)").c_str());
}

}  // namespace detail::image_io

/// 8-bit RGB PNG bytes of `img`. Throws std::invalid_argument when the channels differ in size,
/// are empty or hold non-finite values (values outside [0, 1] are clamped).
[[nodiscard]] inline std::string encode_png_rgb(const rgb_image& img) {
  using detail::image_io::to_byte;
  detail::image_io::check_writable_rgb(img, "encode_png_rgb");
  std::string raw;
  raw.reserve(static_cast<std::size_t>(img.rows() * (3 * img.cols() + 1)));
  for (Eigen::Index row = 0; row < img.rows(); ++row) {
    raw.push_back('\0');  // filter type 0 (none)
    for (Eigen::Index col = 0; col < img.cols(); ++col) {
      raw.push_back(static_cast<char>(to_byte(img.r(row, col))));
      raw.push_back(static_cast<char>(to_byte(img.g(row, col))));
      raw.push_back(static_cast<char>(to_byte(img.b(row, col))));
    }
  }
  return detail::image_io::png_container(img.cols(), img.rows(), 2, raw);
}

/// Writes `img` as an 8-bit RGB PNG (see `encode_png_rgb`); std::runtime_error when the file
/// cannot be written.
inline void write_png_rgb(const std::filesystem::path& path, const rgb_image& img) {
  detail::image_io::write_file(path, encode_png_rgb(img), "write_png_rgb");
}

}  // namespace tacmap
