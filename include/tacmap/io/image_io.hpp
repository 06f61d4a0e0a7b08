// tacmap: reading and writing grey-level images — binary PGM (read and write) and PNG (write).
//
// Why self-written and not stb: these need no dependency at all, and the core needs only
// grey-level maps in and debug pictures out. Binary PGM (netpbm P5, 8 or 16 bit) is a ten-line
// format that any image tool reads (stb's reader ignores maxval and accepts truncated files);
// PNG output uses "stored" (uncompressed) deflate blocks, which every PNG reader accepts, so no
// zlib is needed. Colour photos and compressed PNG or JPEG maps: tacmap/io/image_file.hpp
// (`load_image`, through stb_image; the optional target tacmap::image_file).
//
// Intensities at the API are floats in [0, 1] (0 = black), like the map images tacmap works on.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>

#include "tacmap/image.hpp"

namespace tacmap {

namespace detail::image_io {

inline void check_writable(const image<float>& img, const char* what) {
  if (img.size() == 0)
    fail(what, ": the image is ", img.rows(), " x ", img.cols(),
         " px (rows x cols); expected a non-empty image");
  for (Eigen::Index r = 0; r < img.rows(); ++r)
    for (Eigen::Index c = 0; c < img.cols(); ++c)
      if (!std::isfinite(img(r, c)))
        fail(what, ": pixel (row ", r, ", col ", c, ") is ", img(r, c),
             "; expected finite intensities in [0, 1] (values outside are clamped)");
}

inline std::uint8_t to_byte(float v) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0F, 1.0F) * 255.0F));
}

inline std::string read_file(const std::filesystem::path& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    fail(what, ": cannot open '", path.string(),
         "' for reading; expected an existing, readable "
         "file — check the path (relative paths are resolved from the working directory '",
         std::filesystem::current_path().string(), "')");
  // A folder opens as a stream on Linux, and reading it then throws a bare
  // "basic_filebuf::underflow" (e.g. a session log's map line naming a folder): say what it is.
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    fail(what, ": '", path.string(),
         "' is a folder, not an image file; expected the path of a file — check the path (or "
         "the session log's 'map' line)");
  try {
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  } catch (const std::exception& e) {
    fail<std::runtime_error>(what, ": reading '", path.string(), "' failed (", e.what(),
                             "); expected a readable file");
  }
}

inline void write_file(const std::filesystem::path& path, const std::string& bytes,
                       const char* what) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out)
    fail<std::runtime_error>(what, ": cannot open '", path.string(),
                             "' for writing; check that "
                             "the folder exists and is writable");
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out)
    fail<std::runtime_error>(what, ": writing ", bytes.size(), " bytes to '", path.string(),
                             "' failed (disk full?)");
}

inline std::uint32_t crc32(std::string_view bytes) {
  std::uint32_t crc = 0xFFFFFFFFU;
  for (const char ch : bytes) {
    crc ^= static_cast<std::uint8_t>(ch);
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1U) ^ (0xEDB88320U & (0U - (crc & 1U)));
  }
  return ~crc;
}

inline void put_be32(std::string& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8)
    out.push_back(static_cast<char>((v >> static_cast<unsigned>(shift)) & 0xFFU));
}

/// A PNG file around `raw` scanlines (each prefixed with filter byte 0) of `width` x `height`
/// pixels, 8 bits per sample, `color_type` 0 (grey) or 2 (RGB); stored (uncompressed) deflate.
[[nodiscard]] inline std::string png_container(Eigen::Index width, Eigen::Index height,
                                               int color_type, const std::string& raw) {
  // zlib stream: header 0x78 0x01, stored blocks of up to 65535 bytes, Adler-32 trailer.
  std::string z = "\x78\x01";
  for (std::size_t pos = 0; pos < raw.size() || pos == 0;) {
    const std::size_t len = std::min<std::size_t>(65535, raw.size() - pos);
    const bool last = pos + len >= raw.size();
    z.push_back(last ? '\x01' : '\x00');
    const auto n = static_cast<std::uint16_t>(len);
    const auto nn = static_cast<std::uint16_t>(~n);
    z.push_back(static_cast<char>(n & 0xFFU));
    z.push_back(static_cast<char>(n >> 8U));
    z.push_back(static_cast<char>(nn & 0xFFU));
    z.push_back(static_cast<char>(nn >> 8U));
    z.append(raw, pos, len);
    pos += len;
    if (last) break;
  }
  std::uint32_t a = 1;
  std::uint32_t b = 0;
  for (const char ch : raw) {
    a = (a + static_cast<std::uint8_t>(ch)) % 65521U;
    b = (b + a) % 65521U;
  }
  put_be32(z, (b << 16U) | a);

  std::string out = "\x89PNG\r\n\x1a\n";
  const auto chunk = [&](std::string_view type, const std::string& data) {
    put_be32(out, static_cast<std::uint32_t>(data.size()));
    std::string body(type);
    body += data;
    out += body;
    put_be32(out, crc32(body));
  };
  std::string ihdr;
  put_be32(ihdr, static_cast<std::uint32_t>(width));
  put_be32(ihdr, static_cast<std::uint32_t>(height));
  ihdr.push_back('\x08');  // 8 bits per sample
  ihdr.push_back(static_cast<char>(color_type));
  ihdr += std::string("\x00\x00\x00", 3);  // deflate, filter 0, no interlace
  chunk("IHDR", ihdr);
  chunk("IDAT", z);
  chunk("IEND", {});
  return out;
}
}  // namespace detail::image_io

/// Binary PGM (P5, maxval 255) bytes of `img`, intensities in [0, 1] rounded to 8 bits.
/// `comment` (one line, optional) goes into the header, e.g. the image's origin and license.
[[nodiscard]] inline std::string encode_pgm(const image<float>& img,
                                            std::string_view comment = {}) {
  detail::image_io::check_writable(img, "encode_pgm");
  if (comment.find_first_of("\r\n") != std::string_view::npos)
    detail::fail("encode_pgm: the comment '", comment, "' spans several lines; expected one line");
  std::string out = "P5\n";
  if (!comment.empty()) out += "# " + std::string(comment) + "\n";
  out += std::to_string(img.cols()) + " " + std::to_string(img.rows()) + "\n255\n";
  for (Eigen::Index r = 0; r < img.rows(); ++r)
    for (Eigen::Index c = 0; c < img.cols(); ++c)
      out.push_back(static_cast<char>(detail::image_io::to_byte(img(r, c))));
  return out;
}

/// Decodes a binary PGM (P5, maxval 1..65535, '#' comments in the header) into intensities in
/// [0, 1] (value / maxval). `name` is used in error messages (usually the file's path).
[[nodiscard]] inline image<float> decode_pgm(std::string_view bytes,
                                             std::string_view name = "PGM") {
  std::size_t at = 0;
  const auto skip_space_and_comments = [&] {
    while (at < bytes.size()) {
      if (bytes[at] == '#') {
        while (at < bytes.size() && bytes[at] != '\n') ++at;
      } else if (bytes[at] == ' ' || bytes[at] == '\t' || bytes[at] == '\n' || bytes[at] == '\r') {
        ++at;
      } else {
        break;
      }
    }
  };
  const auto header_number = [&](const char* field) {
    skip_space_and_comments();
    long value = 0;
    std::size_t digits = 0;
    while (at < bytes.size() && bytes[at] >= '0' && bytes[at] <= '9' && digits < 9) {
      value = value * 10 + (bytes[at] - '0');
      ++at;
      ++digits;
    }
    if (digits == 0 || (at < bytes.size() && bytes[at] >= '0' && bytes[at] <= '9'))
      detail::fail("decode_pgm: '", name, "': the header's ", field, " at byte ", at,
                   " is not a number of up to 9 digits; expected a binary PGM header "
                   "'P5 <width> <height> <maxval>'");
    return value;
  };
  if (bytes.size() < 2 || bytes[0] != 'P' || bytes[1] != '5')
    detail::fail("decode_pgm: '", name, "' does not start with the binary PGM magic 'P5' (",
                 bytes.size(),
                 " bytes); expected a binary netpbm grey-level image — convert "
                 "it, e.g. with 'convert in.png out.pgm' or 'pnmtopnm'");
  at = 2;
  const long width = header_number("width");
  const long height = header_number("height");
  const long maxval = header_number("maxval");
  if (width < 1 || height < 1)
    detail::fail("decode_pgm: '", name, "' is ", width, " x ", height,
                 " px; expected a non-empty image");
  if (maxval < 1 || maxval > 65535)
    detail::fail("decode_pgm: '", name, "' has maxval ", maxval, "; expected 1 .. 65535");
  if (at >= bytes.size() ||
      !(bytes[at] == ' ' || bytes[at] == '\t' || bytes[at] == '\n' || bytes[at] == '\r'))
    detail::fail("decode_pgm: '", name, "': expected one whitespace byte after maxval at byte ",
                 at);
  ++at;
  const std::size_t sample_bytes = maxval > 255 ? 2 : 1;
  const std::size_t need =
      static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * sample_bytes;
  if (bytes.size() - at < need)
    detail::fail("decode_pgm: '", name, "' has ", bytes.size() - at, " bytes of pixels but a ",
                 width, " x ", height, " image with maxval ", maxval, " needs ", need,
                 "; the file is truncated");
  image<float> img(height, width);
  const auto byte = [&](std::size_t i) { return static_cast<std::uint8_t>(bytes[at + i]); };
  for (Eigen::Index i = 0; i < img.size(); ++i) {
    const auto k = static_cast<std::size_t>(i) * sample_bytes;
    const unsigned v =
        sample_bytes == 2 ? (static_cast<unsigned>(byte(k)) << 8U) | byte(k + 1) : byte(k);
    if (v > static_cast<unsigned>(maxval))
      detail::fail("decode_pgm: '", name, "': pixel ", i, " (row ", i / width, ", col ", i % width,
                   ") is ", v, ", above maxval ", maxval, "; the file is corrupt");
    img.data()[i] = static_cast<float>(v) / static_cast<float>(maxval);
  }
  return img;
}

/// Reads a binary PGM file into intensities in [0, 1]. Errors name the file.
[[nodiscard]] inline image<float> read_pgm(const std::filesystem::path& path) {
  return decode_pgm(detail::image_io::read_file(path, "read_pgm"), path.string());
}

/// Writes `img` (intensities in [0, 1]) as a binary 8-bit PGM.
inline void write_pgm(const std::filesystem::path& path, const image<float>& img,
                      std::string_view comment = {}) {
  detail::image_io::write_file(path, encode_pgm(img, comment), "write_pgm");
}

/// 8-bit grey-level PNG bytes of `img` (intensities in [0, 1]), uncompressed deflate.
[[nodiscard]] inline std::string encode_png(const image<float>& img) {
  detail::image_io::check_writable(img, "encode_png");
  // Raw scanlines, each prefixed with filter type 0 (none).
  std::string raw;
  raw.reserve(static_cast<std::size_t>(img.rows() * (img.cols() + 1)));
  for (Eigen::Index r = 0; r < img.rows(); ++r) {
    raw.push_back('\0');
    for (Eigen::Index c = 0; c < img.cols(); ++c)
      raw.push_back(static_cast<char>(detail::image_io::to_byte(img(r, c))));
  }
  return detail::image_io::png_container(img.cols(), img.rows(), 0, raw);
}

/// Writes `img` (intensities in [0, 1]) as an 8-bit grey-level PNG.
inline void write_png(const std::filesystem::path& path, const image<float>& img) {
  detail::image_io::write_file(path, encode_png(img), "write_png");
}

}  // namespace tacmap
