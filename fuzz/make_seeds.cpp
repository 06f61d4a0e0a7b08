// Writes the fuzz targets' seed corpus: valid and damaged inputs that lead the fuzzer to the
// interesting code paths quickly (a random byte string almost never carries a valid CRC).
//
//   make_fuzz_seeds fuzz/corpus     (writes fuzz/corpus/weiss_parser/*, .../session_reader/*,
//                                     .../image_loaders/*)
//
// The first two bytes of a weiss_parser input select the family, the chunk size and the cell
// count (see weiss_parser.cpp); the seeds use 84 cells, the paper's 14 x 6 array.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tacmap/devices/weiss/codec.hpp"
#include "tacmap/io/image_file.hpp"
#include "tacmap/io/image_io.hpp"
#include "tacmap/io/session_log.hpp"

namespace {

namespace fs = std::filesystem;
namespace w = tacmap::weiss;
using bytes = std::vector<std::uint8_t>;

constexpr std::uint8_t cells_84 = 83;  // cells = 1 + byte % 200

std::uint8_t selector(w::protocol_family family, std::size_t chunk) {
  return static_cast<std::uint8_t>(((chunk - 1) << 1U) |
                                   (family == w::protocol_family::dsacon32m ? 1U : 0U));
}

void write(const fs::path& path, const bytes& b) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

void write(const fs::path& path, const std::string& s) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << s;
}

bytes input(w::protocol_family family, std::size_t chunk, const std::vector<bytes>& parts) {
  bytes out{selector(family, chunk), cells_84};
  for (const bytes& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

std::vector<std::uint16_t> blob() {
  std::vector<std::uint16_t> cells(84, 0);
  for (std::size_t i = 30; i < 50; ++i) cells[i] = static_cast<std::uint16_t>(100 * (i - 29));
  return cells;
}

bytes reply(w::protocol_family family, std::uint8_t id, const bytes& data,
            std::uint16_t status = 0) {
  bytes payload{static_cast<std::uint8_t>(status & 0xFFU), static_cast<std::uint8_t>(status >> 8U)};
  payload.insert(payload.end(), data.begin(), data.end());
  return w::encode_packet(family, id, payload);
}

void weiss_seeds(const fs::path& dir) {
  fs::create_directories(dir);
  const auto wts = w::protocol_family::wts;
  const auto dsa = w::protocol_family::dsacon32m;
  const bytes frame =
      w::encode_packet(wts, w::frame_id, w::encode_frame_payload(1234, blob(), false));
  const bytes rle = w::encode_packet(wts, w::frame_id, w::encode_frame_payload(1250, blob(), true));
  const bytes dsa_frame =
      w::encode_packet(dsa, w::frame_id, w::encode_frame_payload(9, blob(), true));
  write(dir / "wts_frame.bin", input(wts, 64, {frame}));
  write(dir / "wts_rle_frame.bin", input(wts, 64, {rle}));
  write(dir / "dsacon32m_frame.bin", input(dsa, 64, {dsa_frame}));
  write(dir / "wts_replies.bin",
        input(wts, 7,
              {reply(wts, w::wts_command::matrix_info,
                     w::encode_wts_matrix_info({6, 14, 3.4, 3.4, 4095.0})),
               reply(wts, w::wts_command::system_info,
                     w::encode_wts_system_info({2, 1, 0x1234, 20240001U})),
               reply(wts, w::wts_command::sensor_type, bytes{'W', 'T', 'S'}),
               reply(wts, w::wts_command::start_periodic, {}, 4)}));
  w::dsacon32m_matrix_info m;
  m.matrix = {6, 14, 3.4, 3.4, 0.0};
  m.full_scale_raw = 4095;
  w::dsacon32m_controller_info c;
  c.serial = 7;
  c.can_id = 3;
  write(dir / "dsacon32m_replies.bin",
        input(dsa, 5,
              {w::encode_packet(dsa, w::dsacon32m_command::configure_acquisition, {}),
               reply(dsa, w::dsacon32m_command::matrix_info, w::encode_dsacon32m_matrix_info(m)),
               reply(dsa, w::dsacon32m_command::controller_info,
                     w::encode_dsacon32m_controller_info(c)),
               reply(dsa, w::dsacon32m_command::sensor_info,
                     w::encode_dsacon32m_sensor_info({1, 0, 1, 8, 0}))}));
  // Line noise, a truncated frame, a frame with a bad CRC, then good frames: resynchronisation.
  bytes truncated(frame.begin(), frame.begin() + static_cast<std::ptrdiff_t>(frame.size() / 2));
  bytes bad_crc = frame;
  bad_crc.back() ^= 0x5AU;
  write(dir / "wts_resync.bin",
        input(wts, 1, {bytes{0x00, 0xAA, 0x13, 0xAA, 0xAA}, truncated, bad_crc, frame, rle}));
  write(dir / "dsacon32m_banner.bin",
        input(dsa, 3,
              {bytes(w::dsacon32m_banner.begin(), w::dsacon32m_banner.end()),
               bytes(w::dsacon32m_banner.begin(), w::dsacon32m_banner.end()), dsa_frame}));
  // A header announcing more than max_payload bytes, followed by a good packet.
  write(dir / "wts_oversize.bin",
        input(wts, 16, {bytes{0xAA, 0xAA, 0xAA, 0x00, 0xFF, 0xFF}, frame}));
}

std::string session(const tacmap::session_header& h,
                    const std::vector<tacmap::session_record>& records) {
  std::string text = tacmap::detail::format_session_header(h);
  for (const auto& r : records) {
    if (const auto* f = std::get_if<tacmap::tactile_frame>(&r))
      tacmap::detail::format_session_frame(text, *f);
    else
      tacmap::detail::format_session_pose(text, std::get<tacmap::sensor_pose>(r));
  }
  return text;
}

void session_seeds(const fs::path& dir) {
  fs::create_directories(dir);
  tacmap::session_header h;
  h.geometry = tacmap::taxel_geometry{3, 2, 3.4};
  h.map_file = "map.pgm";
  h.mm_per_px = 3.4 / 3.0;
  h.calibration = tacmap::map_calibration::horizontal(0.3, {60.0, 70.0});
  h.extra = {{"source", "make_fuzz_seeds"}};
  tacmap::tactile_frame f;
  f.geometry = *h.geometry;
  f.counts.resize(3, 2);
  f.counts << 0.0F, 12.5F, 4095.0F, 1e-3F, 7.0F, 300.0F;
  f.sequence = 3;
  f.timestamp = tacmap::detail::session_time_point(5'000'000'000'000);
  const tacmap::sensor_pose p{tacmap::detail::session_time_point(5'000'010'000'000), -29.25, 0.032,
                              3.315, 0.00144};
  const std::string good = session(h, {p, f, p, f});
  write(dir / "full.session", good);
  write(dir / "header_only.session", std::string("tacmap-session 1\n"));
  tacmap::session_header paper;
  paper.geometry = tacmap::taxel_geometry{};  // 14 x 6 at 3.4 mm
  write(dir / "paper_geometry.session", session(paper, {tacmap::tactile_frame{}, p}));
  std::string crlf;
  for (const char ch : good) {
    if (ch == '\n') crlf += '\r';
    crlf += ch;
  }
  write(dir / "crlf.session", crlf);
  write(dir / "truncated.session", good.substr(0, good.size() - 5));
  write(dir / "corrupt.session",
        "tacmap-session 1\ngeometry 3 2 3.4\n"
        "pose 1 2 nan 4 5\n"
        "frame 1 2 1 2 3 -4 5 6\n"
        "frame 1 2 1 2 3\n"
        "poser 1 2\n"
        "map late.pgm\n"
        "\n"
        "pose +1 +2 1E3 -0 4\n");
  write(dir / "bad_header.session", "tacmap-session 1\ncalibration 1 0 0 1 0 0 0 0 0 1\n");
  write(dir / "version2.session", "tacmap-session 2\n");
  write(dir / "empty.session", std::string());
}

// Small images in every format load_image reads: a gradient with a bright square, so that the
// decoders' filters and predictors see both smooth and sharp changes.
tacmap::image<float> test_image(Eigen::Index rows, Eigen::Index cols) {
  tacmap::image<float> img(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index c = 0; c < cols; ++c)
      img(r, c) = (r >= 2 && r < 5 && c >= 3 && c < 7)
                      ? 1.0F
                      : static_cast<float>(r * cols + c) / static_cast<float>(rows * cols);
  return img;
}

std::string jpeg(const std::vector<std::uint8_t>& pixels, int width, int height, int channels) {
  std::string out;
  const auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data),
                                               static_cast<std::size_t>(size));
  };
  stbi_write_jpg_to_func(append, &out, width, height, channels, pixels.data(), 90);
  return out;
}

void image_seeds(const fs::path& dir) {
  fs::create_directories(dir);
  const tacmap::image<float> img = test_image(9, 11);
  write(dir / "grey.pgm", tacmap::encode_pgm(img, "make_fuzz_seeds"));
  // 16-bit samples (maxval 1023: a 10-bit camera).
  std::string deep = "P5\n# ten bits\n11 9\n1023\n";
  for (Eigen::Index i = 0; i < img.size(); ++i) {
    const auto v = static_cast<unsigned>(std::lround(img.data()[i] * 1023.0F));
    deep.push_back(static_cast<char>(v >> 8U));
    deep.push_back(static_cast<char>(v & 0xFFU));
  }
  write(dir / "deep.pgm", deep);
  const std::string png = tacmap::encode_png(img);
  write(dir / "stored.png", png);
  write(dir / "compressed.png", tacmap::encode_png_compressed(img));
  tacmap::rgb_image rgb{img, img.reverse(), 1.0F - img};
  write(dir / "rgb.png", tacmap::encode_png_compressed(rgb));
  std::vector<std::uint8_t> grey_pixels;
  std::vector<std::uint8_t> rgb_pixels;
  for (Eigen::Index r = 0; r < img.rows(); ++r)
    for (Eigen::Index c = 0; c < img.cols(); ++c) {
      grey_pixels.push_back(tacmap::detail::image_io::to_byte(img(r, c)));
      rgb_pixels.push_back(tacmap::detail::image_io::to_byte(rgb.r(r, c)));
      rgb_pixels.push_back(tacmap::detail::image_io::to_byte(rgb.g(r, c)));
      rgb_pixels.push_back(tacmap::detail::image_io::to_byte(rgb.b(r, c)));
    }
  const auto w = static_cast<int>(img.cols());
  const auto h = static_cast<int>(img.rows());
  write(dir / "grey.jpg", jpeg(grey_pixels, w, h, 1));
  const std::string colour = jpeg(rgb_pixels, w, h, 3);
  write(dir / "rgb.jpg", colour);
  // Damaged files: cut off, and a header that promises more than the file holds.
  write(dir / "truncated.png", png.substr(0, png.size() / 2));
  write(dir / "truncated.jpg", colour.substr(0, colour.size() / 2));
  write(dir / "truncated.pgm", std::string("P5 11 9 255\n") + std::string(20, '\x40'));
  write(dir / "not_an_image.gif", std::string("GIF89a\x01\x00\x01\x00"));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_fuzz_seeds <corpus folder, e.g. fuzz/corpus>\n");
    return 2;
  }
  weiss_seeds(fs::path(argv[1]) / "weiss_parser");
  session_seeds(fs::path(argv[1]) / "session_reader");
  image_seeds(fs::path(argv[1]) / "image_loaders");
  std::printf("seeds written under %s\n", argv[1]);
  return 0;
}
