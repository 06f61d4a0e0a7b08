// generate_gecko_data — writes the bundled gecko data (data/gecko/) and, optionally, preview
// pictures of the map and of simulated touches.
//
//   generate_gecko_data <out-dir>                   writes gecko_map.pgm, protocol.txt,
//                                                   locations.txt, sequences.txt into <out-dir>
//   generate_gecko_data <out-dir> --preview <dir>   also writes PNG previews into <dir>
//
// The bytes come from tacmap::gecko_data_files(); tests/sim checks that the committed files
// equal them, so after changing the generator, rerun this with data/gecko as <out-dir>.
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <string_view>

#include "tacmap/io/image_io.hpp"
#include "tacmap/sim/gecko.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "tacmap/tactile/preprocess.hpp"

namespace {

// Nearest-neighbour upsampling so that small images are visible.
tacmap::image<float> upsample(const tacmap::image<float>& in, Eigen::Index factor) {
  tacmap::image<float> out(in.rows() * factor, in.cols() * factor);
  for (Eigen::Index r = 0; r < out.rows(); ++r)
    for (Eigen::Index c = 0; c < out.cols(); ++c) out(r, c) = in(r / factor, c / factor);
  return out;
}

// Map with the 7 sensor footprints outlined, then one row per location: map window, relief
// window, raw frame (taxels, 3 px each), preprocessed frame.
void write_previews(const std::filesystem::path& dir) {
  const tacmap::touch_protocol p = tacmap::make_gecko_protocol();
  const tacmap::image<float> relief = p.relief_mm();
  tacmap::write_png(dir / "gecko_map.png", upsample(p.map, 4));

  tacmap::image<float> outlined = p.map;
  for (const auto& loc : p.locations) {
    const auto j = static_cast<Eigen::Index>(std::lround(loc.x_mm / p.mm_per_px - 9.0));
    const auto i = static_cast<Eigen::Index>(std::lround(loc.y_mm / p.mm_per_px - 21.0));
    for (Eigen::Index r = i; r < i + 42; ++r) outlined(r, j) = outlined(r, j + 17) = 0.55F;
    for (Eigen::Index c = j; c < j + 18; ++c) outlined(i, c) = outlined(i + 41, c) = 0.55F;
  }
  tacmap::write_png(dir / "gecko_locations.png", upsample(outlined, 4));

  tacmap::tactile_simulator sim(relief, p.map_size(), p.mm_per_px, {.seed = 7});
  const Eigen::Index gap = 2;
  tacmap::image<float> sheet = tacmap::image<float>::Constant(
      42, static_cast<Eigen::Index>(p.locations.size()) * (4 * 18 + 5 * gap), 0.3F);
  Eigen::Index x = 0;
  for (const auto& loc : p.locations) {
    const auto j = static_cast<Eigen::Index>(std::lround(loc.x_mm / p.mm_per_px - 9.0));
    const auto i = static_cast<Eigen::Index>(std::lround(loc.y_mm / p.mm_per_px - 21.0));
    const tacmap::tactile_frame frame = sim.render(loc.pose());
    const auto pre = tacmap::preprocess(frame);
    x += gap;
    sheet.block(0, x, 42, 18) = p.map.block(i, j, 42, 18);
    x += 18;
    sheet.block(0, x, 42, 18) = relief.block(i, j, 42, 18) / 4.0F;
    x += 18;
    sheet.block(0, x, 42, 18) = upsample(frame.counts / 4095.0F, 3);
    x += 18;
    if (pre.accepted()) sheet.block(0, x, 42, 18) = pre.pixels;
    x += 18 + 3 * gap;
    std::printf("location (%.2f, %.2f) mm: peak %.0f, total %.0f counts, %s\n", loc.x_mm, loc.y_mm,
                static_cast<double>(pre.peak), static_cast<double>(pre.total),
                pre.accepted() ? "accepted" : pre.reason().c_str());
  }
  tacmap::write_png(dir / "gecko_touches.png", upsample(sheet, 4));
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc != 2 && !(argc == 4 && std::string_view(argv[2]) == "--preview")) {
    std::fprintf(stderr, "usage: %s <out-dir> [--preview <dir>]\n", argv[0]);
    return 2;
  }
  const std::filesystem::path out = argv[1];
  std::filesystem::create_directories(out);
  for (const auto& file : tacmap::gecko_data_files()) {
    const std::filesystem::path path = out / file.name;
    std::FILE* f = std::fopen(path.string().c_str(), "wb");
    if (f == nullptr ||
        std::fwrite(file.bytes.data(), 1, file.bytes.size(), f) != file.bytes.size())
      throw std::runtime_error("cannot write " + path.string());
    std::fclose(f);
    std::printf("wrote %s (%zu bytes)\n", path.string().c_str(), file.bytes.size());
  }
  if (argc == 4) {
    std::filesystem::create_directories(argv[3]);
    write_previews(argv[3]);
  }
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "generate_gecko_data: %s\n", e.what());
  return 1;
}
