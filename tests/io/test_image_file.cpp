// Maps from ordinary images (io/image_file.hpp): PNG (grey, colour, 16-bit), JPEG and PGM decoded
// to the intensities that went in, broken files refused with their name; and the core's
// resize_area and rescale (image.hpp). Test images are written in memory: PNG by tacmap's own
// writers or stb_image_write (colour with alpha), JPEG by stb_image_write, 16-bit PNG by hand. And
// the compressed PNG writer (encode_png_compressed): stb_image decodes its output to the very
// bytes that went in, in a fraction of the uncompressed encoder's size.
#include <doctest/doctest.h>

#include "tacmap/io/image_file.hpp"
#include "tacmap/io/png_rgb.hpp"
#include "test_support.hpp"

// stb_image_write (test images: colour with alpha, JPEG) is the private copy that image_file.hpp
// compiles into this translation unit for its compressed writer.

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <vector>

// Defined in test_image_file_second_tu.cpp, which includes image_file.hpp too: the two
// translation units' private stb copies must link into one program.
tacmap::image<float> load_image_in_second_translation_unit(std::span<const std::uint8_t> bytes,
                                                           std::string_view name);

namespace {

namespace fs = std::filesystem;
using tacmap::image;
using tacmap_test::message_of;

std::span<const std::uint8_t> as_bytes(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// stb_image_write's output, collected in a string.
void append(void* context, void* data, int size) {
  static_cast<std::string*>(context)->append(static_cast<const char*>(data),
                                             static_cast<std::size_t>(size));
}

std::string stb_png(int width, int height, int channels, const std::vector<std::uint8_t>& px) {
  std::string out;
  REQUIRE(stbi_write_png_to_func(append, &out, width, height, channels, px.data(),
                                 width * channels) != 0);
  return out;
}

std::string stb_jpeg(int width, int height, int channels, const std::vector<std::uint8_t>& px) {
  std::string out;
  REQUIRE(stbi_write_jpg_to_func(append, &out, width, height, channels, px.data(), 100) != 0);
  return out;
}

// A 16-bit grey PNG: tacmap's 8-bit container with the bit depth in IHDR set to 16 (and its CRC
// recomputed), around scanlines of big-endian 16-bit samples.
std::string png16(const std::vector<std::vector<std::uint16_t>>& rows) {
  std::string raw;
  for (const auto& row : rows) {
    raw.push_back('\0');
    for (const std::uint16_t v : row) {
      raw.push_back(static_cast<char>(v >> 8U));
      raw.push_back(static_cast<char>(v & 0xFFU));
    }
  }
  std::string png = tacmap::detail::image_io::png_container(
      static_cast<Eigen::Index>(rows[0].size()), static_cast<Eigen::Index>(rows.size()), 0, raw);
  // Signature (8), length (4), then "IHDR" + 13 bytes of data, bit depth at data offset 8.
  constexpr std::size_t ihdr = 12;
  png[ihdr + 4 + 8] = '\x10';
  std::string crc;
  tacmap::detail::image_io::put_be32(
      crc, tacmap::detail::image_io::crc32(std::string_view(png).substr(ihdr, 4 + 13)));
  png.replace(ihdr + 4 + 13, 4, crc);
  return png;
}

/// A fresh temporary folder, removed with its contents at scope exit.
struct temp_dir {
  fs::path path;
  temp_dir() {
    std::random_device random;
    path = fs::temp_directory_path() / ("tacmap-image-" + std::to_string(random()));
    REQUIRE(fs::create_directory(path));
  }
  ~temp_dir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  temp_dir(const temp_dir&) = delete;
  temp_dir& operator=(const temp_dir&) = delete;
};

void write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  REQUIRE(out.good());
}

}  // namespace

TEST_CASE("image_file: a grey PNG reads back exactly, from memory and from a file") {
  image<float> img(3, 4);
  for (Eigen::Index i = 0; i < img.size(); ++i)
    img.data()[i] = static_cast<float>(i * 20) / 255.0F;  // exact 8-bit levels
  const std::string png = tacmap::encode_png(img);
  const image<float> back = tacmap::load_image(as_bytes(png), "grey.png");
  REQUIRE(back.rows() == 3);
  REQUIRE(back.cols() == 4);
  CHECK((back == img).all());

  temp_dir dir;
  write_bytes(dir.path / "grey.png", png);
  CHECK((tacmap::load_image(dir.path / "grey.png") == img).all());
}

TEST_CASE("image_file: colour becomes grey with BT.601 weights (stb's 77, 150, 29 / 256)") {
  auto rgb = tacmap::rgb_image::filled(1, 5, 0.0F, 0.0F, 0.0F);
  rgb.set(0, 0, 1.0F, 0.0F, 0.0F);  // red
  rgb.set(0, 1, 0.0F, 1.0F, 0.0F);  // green
  rgb.set(0, 2, 0.0F, 0.0F, 1.0F);  // blue
  rgb.set(0, 3, 1.0F, 1.0F, 1.0F);  // white; (0, 4) stays black
  const image<float> grey = tacmap::load_image(as_bytes(tacmap::encode_png_rgb(rgb)), "rgb.png");
  REQUIRE(grey.rows() == 1);
  REQUIRE(grey.cols() == 5);
  CHECK(grey(0, 0) == 76.0F / 255.0F);   // 255 * 77 >> 8
  CHECK(grey(0, 1) == 149.0F / 255.0F);  // 255 * 150 >> 8
  CHECK(grey(0, 2) == 28.0F / 255.0F);   // 255 * 29 >> 8
  CHECK(grey(0, 3) == 1.0F);
  CHECK(grey(0, 4) == 0.0F);

  // Alpha is ignored: a fully transparent pixel reads as its colour.
  const std::vector<std::uint8_t> rgba{255, 0, 0, 0, 0, 255, 0, 255};
  const image<float> from_rgba = tacmap::load_image(as_bytes(stb_png(2, 1, 4, rgba)), "rgba.png");
  CHECK(from_rgba(0, 0) == 76.0F / 255.0F);
  CHECK(from_rgba(0, 1) == 149.0F / 255.0F);
}

TEST_CASE("image_file: a compressed colour PNG decodes to the same pixels, much smaller") {
  // A figure-like image: flat background, a gradient panel, a few lines and a noisy corner.
  const Eigen::Index rows = 90, cols = 130;
  tacmap::rgb_image img = tacmap::rgb_image::filled(rows, cols, 1.0F, 1.0F, 1.0F);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(0.0F, 1.0F);
  for (Eigen::Index r = 10; r < 60; ++r)
    for (Eigen::Index c = 10; c < 70; ++c)
      img.set(r, c, static_cast<float>(r) / 60.0F, static_cast<float>(c) / 70.0F, 0.3F);
  for (Eigen::Index c = 0; c < cols; ++c) img.set(75, c, 0.9F, 0.1F, 0.1F);
  for (Eigen::Index r = 70; r < rows; ++r)
    for (Eigen::Index c = 110; c < cols; ++c) img.set(r, c, unit(rng), unit(rng), unit(rng));
  const std::string png = tacmap::encode_png_compressed(img);
  const std::string stored = tacmap::encode_png_rgb(img);
  CHECK(png.size() * 3 < stored.size());
  int width = 0, height = 0, channels = 0;
  std::unique_ptr<stbi_uc, void (*)(void*)> px(
      stbi_load_from_memory(as_bytes(png).data(), static_cast<int>(png.size()), &width, &height,
                            &channels, 3),
      stbi_image_free);
  REQUIRE(px != nullptr);
  REQUIRE(width == cols);
  REQUIRE(height == rows);
  CHECK(channels == 3);
  int wrong = 0;
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c) {
      const std::size_t i = static_cast<std::size_t>(3 * (r * cols + c));
      const auto byte = [](float v) { return tacmap::detail::image_io::to_byte(v); };
      wrong += px.get()[i] != byte(img.r(r, c)) || px.get()[i + 1] != byte(img.g(r, c)) ||
               px.get()[i + 2] != byte(img.b(r, c));
    }
  CHECK(wrong == 0);
  // And through a file, as the demo writes its figures.
  const fs::path file = fs::temp_directory_path() / "tacmap_test_compressed_rgb.png";
  tacmap::write_png_compressed(file, img);
  CHECK(fs::file_size(file) == png.size());
  fs::remove(file);
}

TEST_CASE("image_file: a compressed grey PNG reads back exactly; bad images are refused") {
  image<float> img(33, 47);
  for (Eigen::Index r = 0; r < img.rows(); ++r)
    for (Eigen::Index c = 0; c < img.cols(); ++c)
      img(r, c) = static_cast<float>((r * 7 + c * 3) % 256) / 255.0F;
  const std::string png = tacmap::encode_png_compressed(img);
  CHECK(png.size() < tacmap::encode_png(img).size());
  const image<float> back = tacmap::load_image(as_bytes(png), "grey.png");
  REQUIRE(back.rows() == img.rows());
  REQUIRE(back.cols() == img.cols());
  CHECK((back - img).abs().maxCoeff() < 1e-6F);

  tacmap::rgb_image bad = tacmap::rgb_image::filled(4, 4, 0.5F, 0.5F, 0.5F);
  bad.g = image<float>::Constant(4, 5, 0.5F);
  CHECK(contains(message_of([&] { (void)tacmap::encode_png_compressed(bad); }),
                 "encode_png_compressed: channel sizes differ"));
  img(2, 3) = std::nanf("");
  CHECK(contains(message_of([&] { (void)tacmap::encode_png_compressed(img); }),
                 "pixel (row 2, col 3) is nan"));
  CHECK(contains(message_of([&] { (void)tacmap::encode_png_compressed(image<float>()); }),
                 "expected a non-empty image"));
}

TEST_CASE("image_file: a 16-bit PNG keeps its 16 bits") {
  const image<float> img =
      tacmap::load_image(as_bytes(png16({{0, 1000, 32768}, {65535, 257, 1}})), "deep.png");
  REQUIRE(img.rows() == 2);
  REQUIRE(img.cols() == 3);
  CHECK(img(0, 0) == 0.0F);
  CHECK(img(0, 1) == 1000.0F / 65535.0F);  // 8 bits would give 4 / 255 (0.0157, not 0.0153)
  CHECK(img(0, 2) == 32768.0F / 65535.0F);
  CHECK(img(1, 0) == 1.0F);
  CHECK(img(1, 1) == 257.0F / 65535.0F);
  CHECK(img(1, 2) == 1.0F / 65535.0F);  // below one 8-bit step, yet not zero
}

TEST_CASE("image_file: JPEG, grey and colour, within the codec's error") {
  // A smooth ramp (JPEG's quantisation is gentle on it) at quality 100.
  constexpr int w = 16;
  constexpr int h = 8;
  std::vector<std::uint8_t> ramp(w * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      ramp[static_cast<std::size_t>(y * w + x)] = static_cast<std::uint8_t>(40 + 10 * x);
  const image<float> grey = tacmap::load_image(as_bytes(stb_jpeg(w, h, 1, ramp)), "ramp.jpg");
  REQUIRE(grey.rows() == h);
  REQUIRE(grey.cols() == w);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      CHECK(std::abs(grey(y, x) - static_cast<float>(40 + 10 * x) / 255.0F) <= 3.0F / 255.0F);

  // Uniform red: the JPEG's own luma, 0.299 of full scale.
  std::vector<std::uint8_t> red;
  for (int i = 0; i < w * h; ++i) red.insert(red.end(), {255, 0, 0});
  const image<float> from_red = tacmap::load_image(as_bytes(stb_jpeg(w, h, 3, red)), "red.jpg");
  CHECK(std::abs(from_red.mean() - 0.299F) < 0.01F);
  CHECK(from_red.maxCoeff() - from_red.minCoeff() < 0.01F);
}

TEST_CASE("image_file: a JPEG Huffman table of more than 256 codes is refused before stb") {
  // stb_image 2.27 overflows its tables on such a file (fuzz/image_loaders.cpp found it; the
  // regression input is fuzz/corpus/image_loaders/dht_oversized.jpg).
  std::vector<std::uint8_t> ramp(16 * 8);
  for (std::size_t i = 0; i < ramp.size(); ++i) ramp[i] = static_cast<std::uint8_t>(i * 2);
  const std::string good = stb_jpeg(16, 8, 1, ramp);
  const std::size_t dht = good.find("\xFF\xC4");
  REQUIRE(dht != std::string::npos);
  const std::size_t eoi = good.rfind("\xFF\xD9");
  REQUIRE(eoi != std::string::npos);
  using tacmap::detail::image_file::find_oversized_huffman_table;
  CHECK_FALSE(find_oversized_huffman_table(as_bytes(good)).has_value());

  // The first table's 16 counts (after the marker, the length and the class/id byte) made to
  // declare 16 x 32 = 512 codes.
  std::string bad = good;
  for (std::size_t k = 0; k < 16; ++k) bad[dht + 5 + k] = '\x20';
  const auto found = find_oversized_huffman_table(as_bytes(bad));
  REQUIRE(found.has_value());
  CHECK(found->offset == dht + 4);
  CHECK(found->codes == 512);
  const std::string message =
      message_of([&] { (void)tacmap::load_image(as_bytes(bad), "crafted.jpg"); });
  CHECK(contains(message,
                 "load_image: cannot decode 'crafted.jpg' as JPEG: the Huffman table at "
                 "byte " +
                     std::to_string(dht + 4) +
                     " declares 512 codes; a table "
                     "holds at most 256"));

  // Exactly 256 codes is the most a table holds: not refused by the guard (stb then judges it).
  // (A segment of one table: 16 counts of 16, its 256 symbols; then one of 257.)
  std::string full = std::string("\xFF\xD8\xFF\xC4\x01\x13\x00", 7) + std::string(16, '\x10') +
                     std::string(256, 'x') + "\xFF\xD9";
  CHECK_FALSE(find_oversized_huffman_table(as_bytes(full)).has_value());
  full[7 + 15] = '\x11';
  REQUIRE(find_oversized_huffman_table(as_bytes(full)).has_value());
  CHECK(find_oversized_huffman_table(as_bytes(full))->codes == 257);

  // A DHT segment after the scan (as progressive files have) is found too ...
  const std::string bad_table =
      std::string("\xFF\xC4\x00\x13\x00", 5) + std::string(16, '\x20') + "ab";
  std::string late = good;
  late.insert(eoi, bad_table);
  REQUIRE(find_oversized_huffman_table(as_bytes(late)).has_value());
  CHECK(find_oversized_huffman_table(as_bytes(late))->offset == eoi + 4);
  CHECK_THROWS_AS((void)tacmap::load_image(as_bytes(late), "late.jpg"), std::invalid_argument);
  // ... but the same bytes inside an application segment's payload (skipped by its length,
  // as stb does) or after the end of the image are data, and the file still decodes.
  std::string in_app = good;
  const std::string app =
      std::string("\xFF\xE1\x00", 3) + static_cast<char>(2 + bad_table.size()) + bad_table;
  in_app.insert(2, app);
  CHECK_FALSE(find_oversized_huffman_table(as_bytes(in_app)).has_value());
  CHECK(tacmap::load_image(as_bytes(in_app), "exif.jpg")
            .isApprox(tacmap::load_image(as_bytes(good), "good.jpg")));
  const std::string trailer = good + bad_table;
  CHECK_FALSE(find_oversized_huffman_table(as_bytes(trailer)).has_value());
  CHECK(tacmap::load_image(as_bytes(trailer), "motion.jpg").rows() == 8);
}

TEST_CASE("image_file: binary PGM goes through decode_pgm (maxval honoured, truncation refused)") {
  image<float> img(2, 2);
  img << 0.0F, 51.0F / 255.0F, 1.0F, 204.0F / 255.0F;
  CHECK((tacmap::load_image(as_bytes(tacmap::encode_pgm(img)), "m.pgm") == img).all());
  // maxval 1000, 16-bit samples: 500 is half of full scale (stb's PNM reader would give 0.0076).
  const std::string deep("P5\n1 1\n1000\n\x01\xF4", 14);
  CHECK(tacmap::load_image(as_bytes(deep), "deep.pgm")(0, 0) == 0.5F);
  const std::string cut = "P5\n4 4\n255\nabc";
  const std::string message =
      message_of([&] { (void)tacmap::load_image(as_bytes(cut), "cut.pgm"); });
  CHECK(contains(message, "'cut.pgm' has 3 bytes of pixels but a 4 x 4 image"));
  CHECK(contains(message, "truncated"));
}

TEST_CASE("image_file: truncated, corrupt, foreign and missing files are refused by name") {
  image<float> img(20, 30);
  for (Eigen::Index i = 0; i < img.size(); ++i) img.data()[i] = static_cast<float>(i % 97) / 96.0F;
  const std::string png = tacmap::encode_png(img);

  const std::string cut_png = png.substr(0, png.size() / 2);
  std::string message = message_of([&] { (void)tacmap::load_image(as_bytes(cut_png), "cut.png"); });
  CHECK(contains(message, "load_image: cannot decode 'cut.png' as PNG"));
  CHECK(contains(message, "stb_image: "));
  CHECK(contains(message, "truncated or corrupt"));

  std::vector<std::uint8_t> noise(static_cast<std::size_t>(img.size()));
  for (std::size_t i = 0; i < noise.size(); ++i)
    noise[i] = static_cast<std::uint8_t>((i * 37U) % 251U);
  const std::string jpeg = stb_jpeg(30, 20, 1, noise);
  const std::string cut_jpeg = jpeg.substr(0, jpeg.size() / 2);
  message = message_of([&] { (void)tacmap::load_image(as_bytes(cut_jpeg), "cut.jpg"); });
  CHECK(contains(message, "load_image: cannot decode 'cut.jpg' as JPEG"));

  // Garbage behind a valid signature. (stb does not check PNG's CRCs, so a flipped pixel byte
  // inside a stored block would read as a changed pixel: structure is what it refuses.)
  std::string junk_png = png.substr(0, 8);
  std::string junk_jpeg = jpeg.substr(0, 3);
  for (int i = 0; i < 200; ++i) {
    junk_png.push_back(static_cast<char>((i * 73 + 11) % 256));
    junk_jpeg.push_back(static_cast<char>((i * 73 + 11) % 256));
  }
  message = message_of([&] { (void)tacmap::load_image(as_bytes(junk_png), "junk.png"); });
  CHECK(contains(message, "cannot decode 'junk.png' as PNG (208 bytes; stb_image: "));
  message = message_of([&] { (void)tacmap::load_image(as_bytes(junk_jpeg), "junk.jpg"); });
  CHECK(contains(message, "cannot decode 'junk.jpg' as JPEG (203 bytes; stb_image: "));

  message = message_of([] { (void)tacmap::load_image(as_bytes("just some text"), "notes.txt"); });
  CHECK(contains(message, "'notes.txt' is an unknown format (first bytes 6A 75 73 74 )"));
  CHECK(contains(message, "not a PNG, JPEG or binary PGM (P5) image; convert it"));
  message = message_of([] { (void)tacmap::load_image(as_bytes("GIF89a\x01"), "anim.gif"); });
  CHECK(contains(message, "'anim.gif' is a GIF, not a PNG, JPEG or binary PGM"));
  message = message_of([] { (void)tacmap::load_image(as_bytes("P6\n1 1\n255\nabc"), "c.ppm"); });
  CHECK(contains(message, "'c.ppm' is a colour PPM"));
  message = message_of([] { (void)tacmap::load_image(std::span<const std::uint8_t>{}, "e.png"); });
  CHECK(contains(message, "'e.png' is empty (0 bytes)"));

  // From files: the path in the message.
  temp_dir dir;
  write_bytes(dir.path / "cut.png", cut_png);
  const fs::path cut_path = dir.path / "cut.png";
  message = message_of([&] { (void)tacmap::load_image(cut_path); });
  CHECK(contains(message, "cannot decode '" + cut_path.string() + "' as PNG"));
  message = message_of([] { (void)tacmap::load_image(fs::path("/nonexistent/dir/map.png")); });
  CHECK(contains(message, "load_image: cannot open '/nonexistent/dir/map.png' for reading"));
}

TEST_CASE("image_file: two translation units that include the header link and agree") {
  image<float> img(2, 3);
  img << 0.0F, 0.2F, 0.4F, 0.6F, 0.8F, 1.0F;
  const std::string png = tacmap::encode_png(img);
  const image<float> here = tacmap::load_image(as_bytes(png), "a.png");
  const image<float> there = load_image_in_second_translation_unit(as_bytes(png), "a.png");
  CHECK((here == there).all());
  const std::string message =
      message_of([] { (void)load_image_in_second_translation_unit(as_bytes("xx"), "second.png"); });
  CHECK(contains(message, "'second.png' is an unknown format"));
}

TEST_CASE("resize_area: block means, fractional overlaps, mean kept, constants exact") {
  image<float> src(4, 4);
  for (Eigen::Index i = 0; i < 16; ++i) src.data()[i] = static_cast<float>(i);
  const image<float> half = tacmap::resize_area(src, 2, 2);
  CHECK(half(0, 0) == doctest::Approx(2.5));  // mean of 0, 1, 4, 5
  CHECK(half(0, 1) == doctest::Approx(4.5));
  CHECK(half(1, 0) == doctest::Approx(10.5));
  CHECK(half(1, 1) == doctest::Approx(12.5));

  // 3 x 3 -> 2 x 2: output (0, 0) covers 1.5 x 1.5 source pixels, weights 2/3 and 1/3 per axis;
  // with src(r, c) = 3 r + c that is 3 x 1/3 + 1/3.
  image<float> three(3, 3);
  for (Eigen::Index i = 0; i < 9; ++i) three.data()[i] = static_cast<float>(i);
  const image<float> two = tacmap::resize_area(three, 2, 2);
  CHECK(two(0, 0) == doctest::Approx(4.0 / 3.0));
  CHECK(two(1, 1) == doctest::Approx(8.0 - 4.0 / 3.0));

  image<float> odd(7, 5);
  for (Eigen::Index i = 0; i < odd.size(); ++i)
    odd.data()[i] = static_cast<float>((i * 7919) % 101) / 100.0F;
  for (const auto& [rows, cols] :
       {std::pair<Eigen::Index, Eigen::Index>{3, 4}, {2, 2}, {1, 1}, {7, 5}, {11, 13}}) {
    CAPTURE(rows);
    CAPTURE(cols);
    const image<float> out = tacmap::resize_area(odd, rows, cols);
    REQUIRE(out.rows() == rows);
    REQUIRE(out.cols() == cols);
    CHECK(out.mean() == doctest::Approx(odd.mean()).epsilon(1e-5));
  }
  CHECK((tacmap::resize_area(odd, 7, 5) == odd).all());  // same size: unchanged
  const image<float> constant = image<float>::Constant(13, 11, 0.37F);
  CHECK((tacmap::resize_area(constant, 5, 4) - 0.37F).abs().maxCoeff() <= 1e-7F);
  CHECK((tacmap::resize_area(constant, 29, 17) - 0.37F).abs().maxCoeff() <= 1e-7F);

  CHECK(contains(message_of([&] { (void)tacmap::resize_area(src, 0, 4); }),
                 "resize_area: the requested size is 0 x 4 px (rows x cols); expected both >= 1"));
  CHECK(contains(message_of([] { (void)tacmap::resize_area(image<float>(0, 3), 2, 2); }),
                 "the source image is 0 x 3 px"));
}

TEST_CASE("rescale: the same extent at another scale; area when shrinking, bilinear enlarging") {
  image<float> src(6, 6);
  for (Eigen::Index i = 0; i < src.size(); ++i) src.data()[i] = static_cast<float>(i % 7);
  CHECK((tacmap::rescale(src, 1.5, 1.5) == src).all());
  const image<float> shrunk = tacmap::rescale(src, 1.0, 2.0);  // 6 mm at 2 mm per px: 3 px
  REQUIRE(shrunk.rows() == 3);
  REQUIRE(shrunk.cols() == 3);
  CHECK((shrunk == tacmap::resize_area(src, 3, 3)).all());
  CHECK(shrunk.mean() == doctest::Approx(src.mean()).epsilon(1e-6));

  // A 146 x 120 px photo at 1 mm per px on the paper's 3.4 / 3 mm per px map: 129 x 106 px
  // (146 x 0.882 = 128.8, 120 x 0.882 = 105.9).
  const image<float> photo = image<float>::Constant(120, 146, 0.5F);
  const image<float> map = tacmap::rescale(photo, 1.0, 3.4 / 3.0);
  CHECK(map.rows() == 106);
  CHECK(map.cols() == 129);

  // Enlarging interpolates between pixel centres; the border pixels are extended.
  image<float> pair(1, 2);
  pair << 0.0F, 1.0F;
  const image<float> wide = tacmap::rescale(pair, 2.0, 1.0);
  REQUIRE(wide.rows() == 2);
  REQUIRE(wide.cols() == 4);
  for (Eigen::Index r = 0; r < 2; ++r) {
    CHECK(wide(r, 0) == 0.0F);
    CHECK(wide(r, 1) == doctest::Approx(0.25));
    CHECK(wide(r, 2) == doctest::Approx(0.75));
    CHECK(wide(r, 3) == 1.0F);
  }
  const image<float> big = tacmap::rescale(image<float>::Constant(3, 5, 0.6F), 1.0, 0.3);
  CHECK(big.rows() == 10);
  CHECK(big.cols() == 17);
  CHECK((big - 0.6F).abs().maxCoeff() <= 1e-6F);

  CHECK(contains(message_of([&] { (void)tacmap::rescale(src, 0.0, 1.0); }),
                 "rescale: from 0 to 1 mm per px; expected two finite scales > 0"));
  CHECK(contains(message_of([&] { (void)tacmap::rescale(src, 1.0, std::nan("")); }),
                 "expected two finite scales > 0"));
  CHECK(contains(message_of([&] { (void)tacmap::rescale(src, 1.0, 100.0); }),
                 "a 6 x 6 px image from 1 to 100 mm per px would be 0 x 0 px; expected 1 px to "
                 "2^28 px"));
  CHECK(contains(message_of([&] { (void)tacmap::rescale(src, 1000.0, 0.001); }),
                 "would be 6000000 x 6000000 px"));
}
