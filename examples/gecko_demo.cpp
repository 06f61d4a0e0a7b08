// gecko_demo — the paper's Fig. 5, reproduced on the bundled gecko (data/gecko/).
//
// A tactile array (14 x 6 taxels, 3.4 mm pitch) touches a 3-D printed gecko at 7 places, in the
// order of the protocol's sequence 0 (the path of the paper's Fig. 5). Each touch is a simulated,
// noisy tactile frame; between touches the filter predicts with the arm's measured (noisy)
// odometry and then updates with the tactile image, using the library's default measurement model
// configuration (`tacmap::localization_config{}`). After every touch it prints the MAP error in mm
// and the belief's entropy, and at the end writes a figure like Fig. 5: one column per touch —
// the tactile image (upsampled), the map with the true sensor window (green) and the MAP
// estimate (red), the belief as a heat map over the map (true centre: green cross).
//
// The touches are simulated in the realistic scenario (sim/scenario.hpp): the map is what a
// webcam makes of the print, the print is misregistered by ~1 mm / 1 degree, every press turns,
// tilts and presses a little differently, and the sensor is a used one — the gap between seeing
// and touching the paper had to bridge. `--ideal` presses the map's own image instead.
//
// Run: gecko_demo [--ideal] [output-folder]     (default: ./tacmap-demo-output)
// Exit status 0 when the final error is below 5 mm (the paper's "localized").
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>

#include "tacmap/io/png_rgb.hpp"
#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/protocol.hpp"

#ifndef TACMAP_DATA_DIR
#error "TACMAP_DATA_DIR must name tacmap's data/ folder"
#endif

namespace {

// A 3 x 5 pixel font for the figure's numbers: digits, '.', 'm' and ' '.
const std::array<const char*, 5>* glyph(char ch) {
  static const std::array<std::array<const char*, 5>, 13> font = {{
      {"111", "101", "101", "101", "111"},
      {"010", "110", "010", "010", "111"},
      {"111", "001", "111", "100", "111"},
      {"111", "001", "111", "001", "111"},
      {"101", "101", "111", "001", "001"},
      {"111", "100", "111", "001", "111"},
      {"111", "100", "111", "101", "111"},
      {"111", "001", "001", "001", "001"},
      {"111", "101", "111", "101", "111"},
      {"111", "101", "111", "001", "111"},
      {"000", "000", "000", "000", "010"},
      {"000", "000", "111", "111", "101"},
      {"000", "000", "000", "000", "000"},
  }};
  if (ch >= '0' && ch <= '9') return &font[static_cast<std::size_t>(ch - '0')];
  if (ch == '.') return &font[10];
  if (ch == 'm') return &font[11];
  if (ch == ' ') return &font[12];
  return nullptr;
}

void draw_text(tacmap::rgb_image& img, Eigen::Index top, Eigen::Index left, const std::string& s,
               int scale, float grey) {
  Eigen::Index x = left;
  for (const char ch : s) {
    if (const auto* g = glyph(ch)) {
      for (Eigen::Index r = 0; r < 5; ++r)
        for (Eigen::Index c = 0; c < 3; ++c)
          if ((*g)[static_cast<std::size_t>(r)][c] == '1')
            for (int dy = 0; dy < scale; ++dy)
              for (int dx = 0; dx < scale; ++dx)
                img.set(top + r * scale + dy, x + c * scale + dx, grey, grey, grey);
    }
    x += 4 * scale;
  }
}

// A grey image scaled up by `s` (nearest neighbour) with its top-left at (top, left).
void blit_grey(tacmap::rgb_image& img, const tacmap::image<float>& src, Eigen::Index top,
               Eigen::Index left, int s, float gain = 1.0F) {
  for (Eigen::Index r = 0; r < src.rows() * s; ++r)
    for (Eigen::Index c = 0; c < src.cols() * s; ++c) {
      const float v = gain * src(r / s, c / s);
      img.set(top + r, left + c, v, v, v);
    }
}

// Outline of a map-pixel rectangle (x0, y0, w, h in map px) on a panel scaled by `s`.
void draw_rect(tacmap::rgb_image& img, Eigen::Index top, Eigen::Index left, int s, double x0,
               double y0, double w, double h, float red, float green, float blue) {
  const auto px = [&](double v) { return static_cast<Eigen::Index>(std::lround(v * s)); };
  const Eigen::Index c0 = left + px(x0), c1 = left + px(x0 + w) - 1;
  const Eigen::Index r0 = top + px(y0), r1 = top + px(y0 + h) - 1;
  for (int t = 0; t < 2; ++t) {  // 2 px thick lines
    for (Eigen::Index c = c0; c <= c1; ++c) {
      img.set(r0 + t, c, red, green, blue);
      img.set(r1 - t, c, red, green, blue);
    }
    for (Eigen::Index r = r0; r <= r1; ++r) {
      img.set(r, c0 + t, red, green, blue);
      img.set(r, c1 - t, red, green, blue);
    }
  }
}

void draw_cross(tacmap::rgb_image& img, Eigen::Index row, Eigen::Index col, float red, float green,
                float blue) {
  for (Eigen::Index d = -6; d <= 6; ++d)
    for (Eigen::Index t = -1; t <= 0; ++t) {
      img.set(row + d, col + t, red, green, blue);
      img.set(row + t, col + d, red, green, blue);
    }
}

std::string one_decimal(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

}  // namespace

int main(int argc, char** argv) try {
  std::filesystem::path out_dir = "tacmap-demo-output";
  bool ideal = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--ideal")
      ideal = true;
    else if (arg.starts_with("-"))
      tacmap::detail::fail("gecko_demo: unknown option '", arg,
                           "'; expected [--ideal] [output-folder]");
    else
      out_dir = arg;
  }
  const tacmap::touch_protocol protocol =
      tacmap::load_protocol(std::filesystem::path(TACMAP_DATA_DIR) / "gecko" / "protocol.txt");
  tacmap::localization_config config{};  // the library's default configuration
  if (!ideal) {
    config.scenario = tacmap::scenario_params::realistic();
    config.simulator = tacmap::realistic_sensor(config.simulator);
  }
  tacmap::localization_experiment experiment(protocol, config);
  constexpr std::size_t sequence = 0;  // the paper's Fig. 5 path
  const tacmap::sequence_result run = experiment.run(sequence, true);
  const auto& grid = experiment.filter().grid();

  std::printf("tacmap gecko demo: sequence %zu of the bundled gecko protocol, %zu touches\n",
              sequence, run.touches.size());
  std::printf("measurement model: %s; motion: sigma %.1f mm, k = %d; scenario: %s\n",
              config.name().c_str(), config.motion_sigma_mm, config.motion_k,
              ideal ? "ideal" : "realistic (camera map, misregistration, press jitter)");
  std::printf("%5s %9s %20s %20s %9s %13s\n", "touch", "location", "true (x, y) mm",
              "estimate (x, y) mm", "error mm", "entropy nats");
  for (const auto& t : run.touches)
    std::printf("%5zu %9zu %9.1f, %8.1f  %9.1f, %8.1f  %9.2f %13.3f%s\n", t.step + 1, t.location,
                t.true_x_mm, t.true_y_mm, t.map_x_mm, t.map_y_mm, t.error_mm, t.entropy_nats,
                t.accepted ? "" : "   (frame rejected)");
  const auto ttl = tacmap::touches_to_localize(run.touches);
  if (ttl)
    std::printf("localized (error < 5 mm from then on) at touch %zu\n", *ttl);
  else
    std::printf("not localized: the final error is not below 5 mm\n");

  // The figure: one column per touch, three panels per column.
  const tacmap::image<float>& map = experiment.visual_map();  // what the filter matched against
  constexpr int s = 2;                                        // map panels: 2 screen px per map px
  constexpr int ts = 4;  // tactile panel: 4 screen px per map px
  constexpr Eigen::Index margin = 10, gap = 12;
  const Eigen::Index panel_w = map.cols() * s, panel_h = map.rows() * s;
  const tacmap::pixel_size win = grid.window_size();
  const Eigen::Index tact_h = win.height * ts;
  const Eigen::Index n = static_cast<Eigen::Index>(run.touches.size());
  const Eigen::Index y_header = margin, y_tact = y_header + 25, y_map = y_tact + tact_h + gap,
                     y_bel = y_map + panel_h + gap, y_err = y_bel + panel_h + gap;
  tacmap::rgb_image fig =
      tacmap::rgb_image::filled(y_err + 20 + margin, margin + n * (panel_w + gap), 1, 1, 1);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& t = run.touches[static_cast<std::size_t>(i)];
    const Eigen::Index x = margin + i * (panel_w + gap);
    draw_text(fig, y_header, x + panel_w / 2 - 6, std::to_string(i + 1), 4, 0.0F);
    // Tactile image, centred in the column; a rejected frame leaves a grey box.
    const Eigen::Index tx = x + (panel_w - win.width * ts) / 2;
    const auto& tact = run.tactile_images[static_cast<std::size_t>(i)];
    if (tact.size() > 0)
      blit_grey(fig, tact, y_tact, tx, ts);
    else
      blit_grey(fig, tacmap::image<float>::Constant(win.height, win.width, 0.5F), y_tact, tx, ts);
    // Map with the true window (green) and the MAP window (red).
    blit_grey(fig, map, y_map, x, s, 0.8F);
    const double mm = protocol.mm_per_px;
    const double ww = static_cast<double>(win.width), wh = static_cast<double>(win.height);
    draw_rect(fig, y_map, x, s, t.map_x_mm / mm - ww / 2, t.map_y_mm / mm - wh / 2, ww, wh, 0.9F,
              0.1F, 0.1F);
    draw_rect(fig, y_map, x, s, t.true_x_mm / mm - ww / 2, t.true_y_mm / mm - wh / 2, ww, wh, 0.1F,
              0.8F, 0.1F);
    // Belief heat map over the (dimmed) map: state (r, c) is drawn at its window centre.
    const auto& bel = run.beliefs[static_cast<std::size_t>(i)];
    const float peak = std::max(bel.maxCoeff(), 1e-30F);
    for (Eigen::Index r = 0; r < panel_h; ++r)
      for (Eigen::Index c = 0; c < panel_w; ++c) {
        const float base = 0.35F * map(r / s, c / s);
        const Eigen::Index br = r / s - win.height / 2, bc = c / s - win.width / 2;
        float v = 0.0F;
        if (br >= 0 && bc >= 0 && br < bel.rows() && bc < bel.cols())
          v = std::sqrt(bel(br, bc) / peak);  // sqrt: keeps the weaker modes visible
        const float a = std::min(1.0F, 3.0F * v);
        const float red = std::clamp(3.0F * v, 0.0F, 1.0F);
        const float green = std::clamp(3.0F * v - 1.0F, 0.0F, 1.0F);
        const float blue = std::clamp(3.0F * v - 2.0F, 0.0F, 1.0F);
        fig.set(y_bel + r, x + c, (1 - a) * base + a * red, (1 - a) * base + a * green,
                (1 - a) * base + a * blue);
      }
    draw_cross(fig, y_bel + static_cast<Eigen::Index>(std::lround(t.true_y_mm / mm * s)),
               x + static_cast<Eigen::Index>(std::lround(t.true_x_mm / mm * s)), 0.1F, 0.9F, 0.1F);
    draw_text(fig, y_err, x + 4, one_decimal(t.error_mm) + " mm", 3, 0.0F);
  }
  std::filesystem::create_directories(out_dir);
  const std::filesystem::path png = std::filesystem::absolute(out_dir / "gecko_demo.png");
  tacmap::write_png_rgb(png, fig);
  std::printf(
      "figure (like the paper's Fig. 5; columns = touches; rows = tactile image, map with true "
      "window green / estimate red, belief heat map with true centre, error):\n  %s\n",
      png.string().c_str());
  const double final_error = run.touches.empty() ? INFINITY : run.touches.back().error_mm;
  return final_error < 5.0 ? 0 : 1;
} catch (const std::exception& e) {
  std::fprintf(stderr, "gecko_demo: %s\n", e.what());
  return 2;
}
