// tacmap: maps from ordinary image files — PNG and JPEG (grey or colour) through stb_image, and
// binary PGM through tacmap's own reader (io/image_io.hpp); compressed PNG output for figures
// (`encode_png_compressed`, `write_png_compressed`) through stb_image_write.
//
// Optional: the one tacmap header with an image-format dependency, stb_image (Debian
// libstb-dev). tacmap/tacmap.hpp does not include it; link the CMake target tacmap::image_file
// (created where stb_image.h is found) or have <stb/stb_image.h> or <stb_image.h> on the include
// path.
//
// How stb_image is compiled. stb wants its implementation (STB_IMAGE_IMPLEMENTATION) in exactly
// one translation unit of a program, which a header-only library cannot choose. So by default
// this header compiles a private copy into each translation unit that includes it
// (STB_IMAGE_STATIC: every stb function has internal linkage, so any number of translation
// units link together), restricted to the PNG and JPEG decoders. The cost is code size: each
// translation unit that calls load_image carries its own decoders (unused ones are dropped).
// Escape hatch: define TACMAP_STB_IMAGE_EXTERNAL before including this header when your program
// compiles stb_image itself (one .c/.cpp with STB_IMAGE_IMPLEMENTATION, PNG and JPEG enabled);
// this header then only declares stb's API and calls yours. Without that macro, including
// stb_image.h before this header is refused at compile time (the two would clash), and
// compiling stb's implementation again after it in the same translation unit fails.
//
// stb_image_write (the compressed PNG writer) is compiled the same way: a private copy per
// translation unit (STB_IMAGE_WRITE_STATIC), or yours when TACMAP_STB_IMAGE_WRITE_EXTERNAL is
// defined (one .c/.cpp of your program with STB_IMAGE_WRITE_IMPLEMENTATION); including
// stb_image_write.h before this header without that macro is refused at compile time. Why not
// in io/png_rgb.hpp: that header is dependency-free by design (stored, uncompressed deflate);
// the compressed writer lives where stb already is.
//
// Why PGM does not go through stb: stb's PNM reader ignores maxval (a 10-bit PGM reads as dark)
// and reads a truncated file as if whole; decode_pgm scales by maxval and refuses truncation.
#pragma once

#if !defined(TACMAP_STB_IMAGE_EXTERNAL) && defined(STBI_INCLUDE_STB_IMAGE_H)
#error \
    "tacmap/io/image_file.hpp: stb_image.h was included before it. Define TACMAP_STB_IMAGE_EXTERNAL before including tacmap/io/image_file.hpp to use your own stb_image (compiled once in your program), or include tacmap's header first and do not compile stb_image yourself."
#endif

#if !defined(TACMAP_STB_IMAGE_WRITE_EXTERNAL) && defined(INCLUDE_STB_IMAGE_WRITE_H)
#error \
    "tacmap/io/image_file.hpp: stb_image_write.h was included before it. Define TACMAP_STB_IMAGE_WRITE_EXTERNAL before including tacmap/io/image_file.hpp to use your own stb_image_write (compiled once in your program), or include tacmap's header first and use its copy."
#endif

#if !defined(TACMAP_STB_IMAGE_EXTERNAL)
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STBI_NO_HDR
#define STBI_NO_LINEAR
#endif
#if !defined(TACMAP_STB_IMAGE_WRITE_EXTERNAL)
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#endif
// stb is C written for brevity: its warnings are not ours to fix, and must not reach the
// consumer's build (whose flags we do not know), so they are silenced for the include only.
#if defined(__clang__)
#pragma clang diagnostic push
#pragma clang diagnostic ignored "-Weverything"
#elif defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wold-style-cast"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-but-set-variable"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#pragma GCC diagnostic ignored "-Wcast-qual"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wuseless-cast"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wpedantic"
#elif defined(_MSC_VER)
#pragma warning(push, 0)
#endif
#if defined(STBI_INCLUDE_STB_IMAGE_H)
// TACMAP_STB_IMAGE_EXTERNAL, stb already included: including it again would compile its
// implementation a second time when the including file defined STB_IMAGE_IMPLEMENTATION.
#elif __has_include(<stb/stb_image.h>)
#include <stb/stb_image.h>  // Debian, Ubuntu, Homebrew: stb's headers in a folder of their own
#elif __has_include(<stb_image.h>)
#include <stb_image.h>  // vcpkg, Conan, a copy next to the sources
#else
#error \
    "tacmap/io/image_file.hpp needs stb_image.h (Debian: apt install libstb-dev); link the CMake target tacmap::image_file or add stb's folder to the include path."
#endif
#if defined(INCLUDE_STB_IMAGE_WRITE_H)
// TACMAP_STB_IMAGE_WRITE_EXTERNAL, stb_image_write already included (see above).
#elif __has_include(<stb/stb_image_write.h>)
#include <stb/stb_image_write.h>
#elif __has_include(<stb_image_write.h>)
#include <stb_image_write.h>
#else
#error \
    "tacmap/io/image_file.hpp needs stb_image_write.h (Debian: apt install libstb-dev); link the CMake target tacmap::image_file or add stb's folder to the include path."
#endif
#if defined(__clang__)
#pragma clang diagnostic pop
#elif defined(__GNUC__)
#pragma GCC diagnostic pop
#elif defined(_MSC_VER)
#pragma warning(pop)
#endif
#if !defined(TACMAP_STB_IMAGE_EXTERNAL)
// Configuration for the implementation above only; the consumer's own macros stay theirs.
#undef STB_IMAGE_STATIC
#undef STB_IMAGE_IMPLEMENTATION
#undef STBI_ONLY_PNG
#undef STBI_ONLY_JPEG
#undef STBI_NO_HDR
#undef STBI_NO_LINEAR
#endif
#if !defined(TACMAP_STB_IMAGE_WRITE_EXTERNAL)
#undef STB_IMAGE_WRITE_STATIC
#undef STB_IMAGE_WRITE_IMPLEMENTATION
#endif

#include <climits>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "tacmap/image.hpp"
#include "tacmap/io/image_io.hpp"
#include "tacmap/io/png_rgb.hpp"

namespace tacmap {

namespace detail::image_file {

/// What the first bytes say the file is, for the decoder's choice and the error message.
enum class format { png, jpeg, pgm, unknown };

inline bool starts_with(std::span<const std::uint8_t> bytes, std::string_view magic) {
  if (bytes.size() < magic.size()) return false;
  for (std::size_t i = 0; i < magic.size(); ++i)
    if (bytes[i] != static_cast<std::uint8_t>(magic[i])) return false;
  return true;
}

inline format sniff(std::span<const std::uint8_t> bytes) {
  if (starts_with(bytes, "\x89PNG\r\n\x1a\n")) return format::png;
  if (starts_with(bytes, "\xFF\xD8\xFF")) return format::jpeg;
  if (starts_with(bytes, "P5")) return format::pgm;
  return format::unknown;
}

/// A name for a format we do not read, so that the message says what the file is.
inline std::string other_format(std::span<const std::uint8_t> bytes) {
  if (starts_with(bytes, "GIF8")) return "a GIF";
  if (starts_with(bytes, "BM")) return "a BMP";
  if (starts_with(bytes, "II*") || starts_with(bytes, "MM\x00*")) return "a TIFF";
  if (starts_with(bytes, "RIFF") && bytes.size() >= 12 && starts_with(bytes.subspan(8), "WEBP"))
    return "a WebP";
  if (starts_with(bytes, "P2")) return "an ASCII PGM (P2)";
  if (starts_with(bytes, "P3") || starts_with(bytes, "P6")) return "a colour PPM";
  std::string hex;
  for (std::size_t i = 0; i < bytes.size() && i < 4; ++i) {
    char byte[4];
    std::snprintf(byte, sizeof byte, "%02X ", static_cast<unsigned>(bytes[i]));
    hex += byte;
  }
  return "an unknown format (first bytes " + (hex.empty() ? std::string("none ") : hex) + ")";
}

inline const char* name_of(format f) { return f == format::png ? "PNG" : "JPEG"; }

/// A JPEG Huffman table (DHT) declaring more codes than a table can hold: where it starts
/// (byte offset of its class/id byte) and the codes its 16 counts add up to.
struct oversized_huffman_table {
  std::size_t offset = 0;
  unsigned codes = 0;
};

/// The first DHT table of a JPEG whose counts add up to more than 256 codes, or nothing.
///
/// Why: stb_image before 2.28 (Debian 12's libstb-dev is 2.27) builds each table into arrays of
/// 257 sizes and 256 values without checking the counts, so such a table writes up to 3.8 KB
/// past them (a heap overflow; found by fuzz/image_loaders.cpp). A valid table holds at most 256
/// codes (one per 8-bit symbol), so refusing more loses no valid file. The walk finds every DHT
/// stb could process: it skips each length-prefixed segment as stb does (stb consumes exactly
/// a segment's length or fails), and between segments, in entropy-coded data and in padding, it
/// takes every 0xFF followed by a marker byte as a marker, as stb's bit reader does. It stops at
/// the first end-of-image marker, after which stb reads nothing (data appended to a JPEG, such as
/// a motion photo's video, is not looked at).
inline std::optional<oversized_huffman_table> find_oversized_huffman_table(
    std::span<const std::uint8_t> bytes) {
  // stb reads 0 past the end of the data.
  const auto at = [&](std::size_t i) -> unsigned { return i < bytes.size() ? bytes[i] : 0U; };
  std::size_t i = 2;  // after the start-of-image marker
  while (i + 1 < bytes.size()) {
    if (bytes[i] != 0xFFU || bytes[i + 1] == 0xFFU) {  // data, padding or a fill byte
      ++i;
      continue;
    }
    const unsigned marker = bytes[i + 1];
    if (marker == 0xD9U) break;  // end of image
    // No length: byte stuffing (0xFF00), restart markers, start of image, TEM.
    if (marker == 0x00U || (marker >= 0xD0U && marker <= 0xD8U) || marker == 0x01U) {
      i += 2;
      continue;
    }
    const std::size_t length = (at(i + 2) << 8U) | at(i + 3);  // includes its own two bytes
    if (marker == 0xC4U) {
      // The segment's tables, each a class/id byte, 16 counts and as many symbols.
      for (std::size_t table = i + 4; table < i + 2 + length && table < bytes.size();) {
        unsigned codes = 0;
        for (std::size_t k = 1; k <= 16; ++k) codes += at(table + k);
        if (codes > 256U) return oversized_huffman_table{table, codes};
        table += 17 + codes;
      }
    }
    i += 2 + length;
  }
  return std::nullopt;
}

/// stb's reason, never null (stb leaves it unset on some paths).
inline const char* stb_reason() {
  const char* reason = stbi_failure_reason();
  return reason != nullptr ? reason : "no reason given";
}

/// PNG bytes of `channels`-interleaved 8-bit `pixels` through stb_image_write (zlib-style
/// deflate at stb's level 8 with per-row filters).
inline std::string encode_png_stb(const std::vector<std::uint8_t>& pixels, Eigen::Index width,
                                  Eigen::Index height, int channels, const char* who) {
  if (width > INT_MAX / channels || height > INT_MAX)
    detail::fail(who, ": the image is ", height, " x ", width,
                 " px (rows x cols); stb_image_write writes at most ", INT_MAX / channels,
                 " px per row — write it with tacmap's uncompressed encode_png / encode_png_rgb");
  std::string out;
  const auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data),
                                               static_cast<std::size_t>(size));
  };
  if (stbi_write_png_to_func(append, &out, static_cast<int>(width), static_cast<int>(height),
                             channels, pixels.data(), static_cast<int>(width) * channels) == 0)
    detail::fail(who, ": stb_image_write could not encode the ", height, " x ", width,
                 " px image (out of memory?)");
  return out;
}

}  // namespace detail::image_file

/// Decodes an image file's bytes into grey intensities in [0, 1] (0 = black). `name` (usually
/// the file's path) is used in error messages.
///
/// - PNG (8 or 16 bits per sample; 16-bit files are read at 16 bits, value / 65535) and
///   baseline or progressive JPEG, through stb_image; binary PGM (P5, any maxval, value / maxval)
///   through decode_pgm.
/// - Colour becomes grey with stb's luma, ITU-R BT.601 weights 0.299 R + 0.587 G + 0.114 B (as
///   77, 150 and 29 / 256) on the stored, gamma-encoded values; a colour JPEG's own luma
///   channel is used as is. Alpha is ignored, and so are colour profiles and PNG gamma: samples
///   are taken as stored.
///
/// Throws std::invalid_argument, naming `name`, when the bytes are empty, not PNG, JPEG or
/// binary PGM (GIF, BMP, TIFF, colour PPM...: convert them), or a file that stb cannot decode
/// (truncated or corrupt; stb's reason is quoted). A JPEG Huffman table of more than 256 codes
/// is refused before stb sees it (`find_oversized_huffman_table`: stb 2.27 overflows on it).
[[nodiscard]] inline image<float> load_image(std::span<const std::uint8_t> bytes,
                                             std::string_view name = "image") {
  namespace file = detail::image_file;
  if (bytes.empty())
    detail::fail("load_image: '", name,
                 "' is empty (0 bytes); expected a PNG, JPEG or binary PGM image");
  const file::format format = file::sniff(bytes);
  if (format == file::format::pgm)
    return decode_pgm(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()),
                      name);
  if (format == file::format::unknown)
    detail::fail("load_image: '", name, "' is ", file::other_format(bytes),
                 ", not a PNG, JPEG or binary PGM (P5) image; convert it, e.g. with "
                 "'convert in.gif out.png' (ImageMagick)");
  if (bytes.size() > static_cast<std::size_t>(INT_MAX))
    detail::fail("load_image: '", name, "' is ", bytes.size(), " bytes; stb_image reads at most ",
                 INT_MAX, " bytes — shrink the image first");
  if (format == file::format::jpeg)
    if (const auto bad = file::find_oversized_huffman_table(bytes))
      detail::fail("load_image: cannot decode '", name, "' as JPEG: the Huffman table at byte ",
                   bad->offset, " declares ", bad->codes,
                   " codes; a table holds at most 256 — the file is corrupt (or crafted): "
                   "re-export or re-download it");
  const auto* data = bytes.data();
  const auto size = static_cast<int>(bytes.size());
  int width = 0;
  int height = 0;
  int channels = 0;
  const bool sixteen = stbi_is_16_bit_from_memory(data, size) != 0;
  // One grey channel requested: stb converts colour with its luma weights (see above).
  std::unique_ptr<void, void (*)(void*)> pixels(
      sixteen
          ? static_cast<void*>(stbi_load_16_from_memory(data, size, &width, &height, &channels, 1))
          : static_cast<void*>(stbi_load_from_memory(data, size, &width, &height, &channels, 1)),
      stbi_image_free);
  if (!pixels)
    detail::fail("load_image: cannot decode '", name, "' as ", file::name_of(format), " (",
                 bytes.size(), " bytes; stb_image: ", file::stb_reason(),
                 "); expected a complete, valid file — it may be truncated or corrupt: "
                 "re-export or re-download it");
  if (width < 1 || height < 1)
    detail::fail("load_image: '", name, "' is ", width, " x ", height,
                 " px; expected a non-empty image");
  image<float> out(height, width);
  if (sixteen) {
    const auto* grey = static_cast<const std::uint16_t*>(pixels.get());
    for (Eigen::Index i = 0; i < out.size(); ++i)
      out.data()[i] = static_cast<float>(grey[i]) / 65535.0F;
  } else {
    const auto* grey = static_cast<const std::uint8_t*>(pixels.get());
    for (Eigen::Index i = 0; i < out.size(); ++i)
      out.data()[i] = static_cast<float>(grey[i]) / 255.0F;
  }
  return out;
}

/// Reads an image file (PNG, JPEG or binary PGM; see the overload above) into grey intensities in
/// [0, 1]. Throws std::invalid_argument naming the path when the file cannot be opened or
/// decoded. The map's scale (mm per px) is not in the file: give it to the grid, or `rescale`.
[[nodiscard]] inline image<float> load_image(const std::filesystem::path& path) {
  const std::string bytes = detail::image_io::read_file(path, "load_image");
  return load_image(std::span<const std::uint8_t>(
                        reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()),
                    path.string());
}

/// Compressed 8-bit RGB PNG bytes of `img` (deflate through stb_image_write; the same pixels as
/// the dependency-free `encode_png_rgb` of io/png_rgb.hpp, a fraction of its size: figures with
/// flat areas shrink 10-50x). Throws std::invalid_argument when the channels differ in size, are
/// empty or hold non-finite values (values outside [0, 1] are clamped).
[[nodiscard]] inline std::string encode_png_compressed(const rgb_image& img) {
  detail::image_io::check_writable_rgb(img, "encode_png_compressed");
  std::vector<std::uint8_t> pixels;
  pixels.reserve(static_cast<std::size_t>(3 * img.rows() * img.cols()));
  for (Eigen::Index row = 0; row < img.rows(); ++row)
    for (Eigen::Index col = 0; col < img.cols(); ++col) {
      pixels.push_back(detail::image_io::to_byte(img.r(row, col)));
      pixels.push_back(detail::image_io::to_byte(img.g(row, col)));
      pixels.push_back(detail::image_io::to_byte(img.b(row, col)));
    }
  return detail::image_file::encode_png_stb(pixels, img.cols(), img.rows(), 3,
                                            "encode_png_compressed");
}

/// Compressed 8-bit grey PNG bytes of `img` (intensities in [0, 1]; as `encode_png` of
/// io/image_io.hpp, compressed). Throws std::invalid_argument when `img` is empty or holds
/// non-finite values.
[[nodiscard]] inline std::string encode_png_compressed(const image<float>& img) {
  detail::image_io::check_writable(img, "encode_png_compressed");
  std::vector<std::uint8_t> pixels;
  pixels.reserve(static_cast<std::size_t>(img.size()));
  for (Eigen::Index row = 0; row < img.rows(); ++row)
    for (Eigen::Index col = 0; col < img.cols(); ++col)
      pixels.push_back(detail::image_io::to_byte(img(row, col)));
  return detail::image_file::encode_png_stb(pixels, img.cols(), img.rows(), 1,
                                            "encode_png_compressed");
}

/// Writes `img` as a compressed PNG (see `encode_png_compressed`); std::runtime_error when the
/// file cannot be written.
inline void write_png_compressed(const std::filesystem::path& path, const rgb_image& img) {
  detail::image_io::write_file(path, encode_png_compressed(img), "write_png_compressed");
}

/// Writes the grey `img` as a compressed PNG (see `encode_png_compressed`).
inline void write_png_compressed(const std::filesystem::path& path, const image<float>& img) {
  detail::image_io::write_file(path, encode_png_compressed(img), "write_png_compressed");
}

}  // namespace tacmap
