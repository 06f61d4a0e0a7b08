// Fuzz target: the map image loaders — `load_image` (io/image_file.hpp: PNG and JPEG through
// stb_image, binary PGM through tacmap's own reader) and `decode_pgm` (io/image_io.hpp) — on
// arbitrary bytes, as a map file a user points tacmap at.
//
// Besides "no crash, no sanitizer report", it checks:
//  * only std::invalid_argument escapes, with a message that names the loader;
//  * a decoded image is non-empty and every intensity is finite and in [0, 1];
//  * PGM bytes decode to the same image through load_image and decode_pgm;
//  * a decoded image written back (encode_pgm, encode_png, encode_png_compressed) reads back to
//    itself within the 8-bit writers' rounding, half a grey level.
#include <climits>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

#include "fuzz_check.hpp"
#include "tacmap/io/image_file.hpp"
#include "tacmap/io/image_io.hpp"

namespace {

std::span<const std::uint8_t> as_bytes(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

void check_image(const tacmap::image<float>& img) {
  TACMAP_FUZZ_CHECK(img.rows() > 0 && img.cols() > 0);
  TACMAP_FUZZ_CHECK(img.allFinite());
  TACMAP_FUZZ_CHECK((img >= 0.0F).all() && (img <= 1.0F).all());
}

/// `back` is `img` written at 8 bits and read again: within half a grey level.
void check_round_trip(const tacmap::image<float>& img, const tacmap::image<float>& back) {
  TACMAP_FUZZ_CHECK(back.rows() == img.rows() && back.cols() == img.cols());
  const float worst = (back - img).abs().maxCoeff();
  TACMAP_FUZZ_CHECK_MSG(worst <= 0.5F / 255.0F + 1e-6F, "round trip off by %g", worst);
}

template <class Call>
bool refused(Call&& call, std::string_view who) {
  try {
    std::forward<Call>(call)();
  } catch (const std::invalid_argument& e) {
    const std::string_view what = e.what();
    TACMAP_FUZZ_CHECK_MSG(what.find(who) != std::string_view::npos && what.size() > 40,
                          "message: %s", e.what());
    return true;
  }
  return false;
}

/// Whether the first IDAT chunk of a PNG is empty. stb_image 2.27 then calls
/// memcpy(NULL, ..., 0) (stbi__getn into a buffer it has not allocated yet): undefined behaviour
/// by the letter of the C standard (nonnull), harmless with every C library we know (nothing is
/// copied), and legal PNG. Skipped so that the run goes on; reported in README.md.
bool empty_first_idat(std::span<const std::uint8_t> bytes) {
  for (std::size_t at = 8; at + 8 <= bytes.size();) {
    const std::size_t length = (static_cast<std::size_t>(bytes[at]) << 24U) |
                               (static_cast<std::size_t>(bytes[at + 1]) << 16U) |
                               (static_cast<std::size_t>(bytes[at + 2]) << 8U) | bytes[at + 3];
    if (std::string_view(reinterpret_cast<const char*>(bytes.data() + at + 4), 4) == "IDAT")
      return length == 0;
    at += 12 + length;
  }
  return false;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> bytes(data, size);
  const std::string_view text(reinterpret_cast<const char*>(data), size);

  const bool pgm = size >= 2 && data[0] == 'P' && data[1] == '5';
  if (empty_first_idat(bytes)) return 0;
  // Speed: a header of a few bytes can declare 2^24 x 2^24 px, and stb (leniently) decodes a
  // truncated JPEG's missing blocks as flat, so large declared sizes cost time and memory in
  // proportion to their pixels, through the same code paths as small ones: inputs declaring
  // more than 2^18 px (512 x 512) are skipped. PGM declares its size too (decode_pgm refuses
  // it unless the file holds every pixel, so it stays cheap).
  // (stbi_info parses a JPEG's tables too: not before load_image's guard against stb 2.27's
  // Huffman table overflow would refuse them.)
  if (!pgm && size <= static_cast<std::size_t>(INT_MAX) &&
      !tacmap::detail::image_file::find_oversized_huffman_table(bytes)) {
    int width = 0;
    int height = 0;
    int channels = 0;
    if (stbi_info_from_memory(data, static_cast<int>(size), &width, &height, &channels) != 0 &&
        static_cast<long long>(width) * height > (1LL << 18))
      return 0;
  }
  tacmap::image<float> img;
  // PGM goes through decode_pgm, whose messages name it.
  if (refused([&] { img = tacmap::load_image(bytes, "fuzz"); },
              pgm ? "decode_pgm" : "load_image")) {
    if (pgm)
      TACMAP_FUZZ_CHECK(refused([&] { (void)tacmap::decode_pgm(text, "fuzz"); }, "decode_pgm"));
    return 0;
  }
  check_image(img);
  if (pgm) {
    const tacmap::image<float> direct = tacmap::decode_pgm(text, "fuzz");
    TACMAP_FUZZ_CHECK(direct.rows() == img.rows() && direct.cols() == img.cols() &&
                      (direct == img).all());
  }
  // Writing back costs time in proportion to the pixels: big images are checked above only.
  if (img.size() > (1 << 12)) return 0;
  check_round_trip(img, tacmap::decode_pgm(tacmap::encode_pgm(img)));
  check_round_trip(img, tacmap::load_image(as_bytes(tacmap::encode_png(img))));
  check_round_trip(img, tacmap::load_image(as_bytes(tacmap::encode_png_compressed(img))));
  return 0;
}
