// tacmap: a minimal PGM (portable graymap) reader and writer for maps that travel with session
// logs. PGM opens everywhere without tacmap — Python (PIL, imageio), MATLAB (imread), image
// viewers — and needs no third-party code. Reads P5 (binary, 8 or 16 bit) and P2 (ASCII);
// writes 8-bit P5. Values are scaled to [0, 1] by the file's maxval.
#pragma once

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "tacmap/image.hpp"

namespace tacmap::detail {

/// Reads a PGM image into [0, 1]. Throws std::runtime_error naming the file and the problem.
inline image<float> read_pgm(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    fail<std::runtime_error>("read_pgm: cannot open ", path.string(),
                             "; check the path (a session's map is looked for next to the log)");
  const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)),
                                         std::istreambuf_iterator<char>());
  std::size_t pos = 0;
  const auto bad = [&](const char* what) {
    fail<std::runtime_error>("read_pgm: ", path.string(), ": ", what, " at byte ", pos,
                             "; expected a PGM image (P2 or P5)");
  };
  const auto skip_space_and_comments = [&] {
    for (;;) {
      while (pos < bytes.size() && std::isspace(bytes[pos]) != 0) ++pos;
      if (pos < bytes.size() && bytes[pos] == '#') {
        while (pos < bytes.size() && bytes[pos] != '\n') ++pos;
        continue;
      }
      return;
    }
  };
  const auto integer = [&](long long max, const char* what) {
    skip_space_and_comments();
    if (pos >= bytes.size() || std::isdigit(bytes[pos]) == 0) bad(what);
    long long v = 0;
    while (pos < bytes.size() && std::isdigit(bytes[pos]) != 0) {
      v = v * 10 + (bytes[pos] - '0');
      if (v > max) bad(what);
      ++pos;
    }
    return v;
  };
  if (bytes.size() < 2 || bytes[0] != 'P' || (bytes[1] != '5' && bytes[1] != '2'))
    bad("no P5/P2 magic number");
  const bool binary = bytes[1] == '5';
  pos = 2;
  const auto width = static_cast<Eigen::Index>(integer(1 << 16, "bad width"));
  const auto height = static_cast<Eigen::Index>(integer(1 << 16, "bad height"));
  const long long maxval = integer(65535, "bad maxval");
  if (width == 0 || height == 0 || maxval == 0) bad("empty image or zero maxval");
  image<float> out(height, width);
  const auto scale = static_cast<float>(1.0 / static_cast<double>(maxval));
  if (binary) {
    if (pos >= bytes.size() || std::isspace(bytes[pos]) == 0) bad("no whitespace after maxval");
    ++pos;
    const std::size_t sample = maxval > 255 ? 2 : 1;
    const auto needed = static_cast<std::size_t>(width * height) * sample;
    if (bytes.size() - pos < needed) bad("pixel data ends early");
    for (Eigen::Index r = 0; r < height; ++r)
      for (Eigen::Index c = 0; c < width; ++c) {
        long long v = bytes[pos++];
        if (sample == 2) v = (v << 8) | bytes[pos++];  // 16-bit samples are big-endian
        if (v > maxval) bad("sample above maxval");
        out(r, c) = static_cast<float>(v) * scale;
      }
  } else {
    for (Eigen::Index r = 0; r < height; ++r)
      for (Eigen::Index c = 0; c < width; ++c)
        out(r, c) = static_cast<float>(integer(maxval, "bad or missing sample")) * scale;
  }
  return out;
}

/// Writes `img` (values in [0, 1], clamped) as an 8-bit binary PGM.
inline void write_pgm(const std::filesystem::path& path, const image<float>& img) {
  if (img.size() == 0 || !all_finite(img))
    fail("write_pgm: ", path.string(),
         ": the image is empty or not finite; expected values in "
         "[0, 1]");
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << "P5\n" << img.cols() << ' ' << img.rows() << "\n255\n";
  for (Eigen::Index r = 0; r < img.rows(); ++r)
    for (Eigen::Index c = 0; c < img.cols(); ++c) {
      const float v = std::min(1.0F, std::max(0.0F, img(r, c)));
      out.put(static_cast<char>(static_cast<unsigned char>(std::lround(v * 255.0F))));
    }
  if (!out.flush())
    fail<std::runtime_error>("write_pgm: cannot write ", path.string(),
                             "; check that the folder exists and is writable");
}

}  // namespace tacmap::detail
