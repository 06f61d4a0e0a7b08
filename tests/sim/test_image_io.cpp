// PGM and PNG: round trips, error messages, and the PNG checked by an independent decoder
// (stb_image, whose implementation lives in this one test translation unit).
#include <doctest/doctest.h>

#include "tacmap/io/image_io.hpp"
#include "test_support.hpp"

#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#include <stb/stb_image.h>

#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

namespace test_image_io {

using tacmap::image;

using tacmap_test::message_of;

namespace {

// A non-square gradient with a marker, so that transposes and flips would show.
image<float> test_image(Eigen::Index rows, Eigen::Index cols) {
  image<float> img(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c)
      img(r, c) = static_cast<float>((r * 7 + c * 3) % 256) / 255.0F;
  if (rows > 1 && cols > 2) img(1, 2) = 1.0F;
  return img;
}

}  // namespace

TEST_CASE("PGM round trip keeps 8-bit levels exactly and rounds others") {
  const image<float> img = test_image(13, 29);
  const std::string bytes = tacmap::encode_pgm(img, "a comment");
  CHECK(bytes.rfind("P5\n# a comment\n29 13\n255\n", 0) == 0);
  const image<float> back = tacmap::decode_pgm(bytes);
  REQUIRE(back.rows() == 13);
  REQUIRE(back.cols() == 29);
  CHECK((back == img).all());
  const image<float> odd = image<float>::Constant(2, 3, 0.3F);
  CHECK((tacmap::decode_pgm(tacmap::encode_pgm(odd)) == 77.0F / 255.0F).all());  // 76.5 -> 77
  CHECK(tacmap::decode_pgm(tacmap::encode_pgm(image<float>::Constant(1, 1, 7.0F)))(0, 0) == 1.0F);
}

TEST_CASE("PGM decoding: 16-bit samples, comments anywhere in the header") {
  std::string bytes = "P5 # magic\n# size next\n2 # width\n1\n# max\n1000\n";
  bytes += std::string("\x01\xF4\x03\xE8", 4);  // 500, 1000 big-endian
  const image<float> img = tacmap::decode_pgm(bytes);
  REQUIRE(img.rows() == 1);
  REQUIRE(img.cols() == 2);
  CHECK(img(0, 0) == doctest::Approx(0.5F));
  CHECK(img(0, 1) == 1.0F);
}

TEST_CASE("PGM errors name the source and the problem") {
  CHECK(message_of([] {
          (void)tacmap::decode_pgm("P2\n1 1\n255\n0", "m.pgm");
        }).find("'m.pgm' does not start with the binary PGM magic 'P5'") != std::string::npos);
  CHECK(message_of([] {
          (void)tacmap::decode_pgm("P5\n4 4\n255\nabc", "t.pgm");
        }).find("'t.pgm' has 3 bytes of pixels but a 4 x 4 image") != std::string::npos);
  CHECK(message_of([] { (void)tacmap::decode_pgm("P5\nfour 4\n255\n", "w.pgm"); }).find("width") !=
        std::string::npos);
  CHECK(message_of([] {
          (void)tacmap::decode_pgm("P5\n0 4\n255\n", "z.pgm");
        }).find("is 0 x 4 px") != std::string::npos);
  CHECK(message_of([] {
          (void)tacmap::decode_pgm("P5\n1 1\n70000\n", "x.pgm");
        }).find("maxval 70000") != std::string::npos);
  CHECK(message_of([] {
          (void)tacmap::decode_pgm(std::string("P5\n1 1\n10\n\x0b", 11), "v.pgm");
        }).find("above maxval 10") != std::string::npos);
  CHECK(message_of([] {
          (void)tacmap::read_pgm("/nonexistent/dir/map.pgm");
        }).find("cannot open '/nonexistent/dir/map.pgm'") != std::string::npos);
  image<float> nan_img = image<float>::Zero(2, 2);
  nan_img(1, 0) = std::numeric_limits<float>::quiet_NaN();
  CHECK(message_of([&] { (void)tacmap::encode_pgm(nan_img); }).find("(row 1, col 0)") !=
        std::string::npos);
  CHECK(message_of([&] { (void)tacmap::encode_png(image<float>()); }).find("non-empty") !=
        std::string::npos);
}

TEST_CASE("PNG output decodes with stb_image to the same pixels") {
  for (const auto& size : {std::pair<Eigen::Index, Eigen::Index>{1, 1}, {13, 29}, {300, 250}}) {
    const Eigen::Index rows = size.first, cols = size.second;
    CAPTURE(rows);
    CAPTURE(cols);  // 300 x 251 bytes of scanlines: more than one 65535-byte stored block
    const image<float> img = test_image(rows, cols);
    const std::string png = tacmap::encode_png(img);
    int w = 0, h = 0, channels = 0;
    const std::unique_ptr<unsigned char, void (*)(void*)> pixels(
        stbi_load_from_memory(reinterpret_cast<const unsigned char*>(png.data()),
                              static_cast<int>(png.size()), &w, &h, &channels, 0),
        stbi_image_free);
    REQUIRE_MESSAGE(pixels != nullptr, stbi_failure_reason());
    CHECK(w == cols);
    CHECK(h == rows);
    CHECK(channels == 1);
    bool same = true;
    for (Eigen::Index r = 0; r < rows; ++r)
      for (Eigen::Index c = 0; c < cols; ++c)
        same = same && pixels.get()[r * cols + c] ==
                           static_cast<unsigned char>(std::lround(img(r, c) * 255.0F));
    CHECK(same);
  }
}

}  // namespace test_image_io
