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
// A second run shows what the paper's gecko cannot: a photograph of a DARK object on a light
// background (data/horse/: scikit-image's horse silhouette, CC0), whose raised parts look darker
// in the photo than around them while the touch feels them as high pressure. The default model
// does not need to be told: the relation is a latent hypothesis of the filter, and its posterior
// ("raised parts look dark") is printed per touch and drawn as a bar under each column of
// horse_demo.png.
//
// Run: gecko_demo [--ideal] [output-folder]     (default: ./tacmap-demo-output)
// Exit status 0 when both final errors are below 5 mm (the paper's "localized").
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "tacmap/io/image_io.hpp"
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

// The figure: one column per touch, rows = tactile image, map with the true window (green) and
// the MAP window (red), the belief over the map with the true centre, the error; with
// `appearance_row`, a bar per touch: the posterior that the object's raised parts look dark
// (orange share) against bright (blue share).
void write_figure(const std::filesystem::path& png, const tacmap::sequence_result& run,
                  const tacmap::image<float>& map, tacmap::pixel_size win, double mm,
                  bool appearance_row) {
  constexpr int s = 2;   // map panels: 2 screen px per map px
  constexpr int ts = 4;  // tactile panel: 4 screen px per map px
  constexpr Eigen::Index margin = 10, gap = 12, bar_h = 16;
  const Eigen::Index panel_w = map.cols() * s, panel_h = map.rows() * s;
  const Eigen::Index tact_h = win.height * ts;
  const Eigen::Index n = static_cast<Eigen::Index>(run.touches.size());
  const Eigen::Index y_header = margin, y_tact = y_header + 25, y_map = y_tact + tact_h + gap,
                     y_bel = y_map + panel_h + gap, y_err = y_bel + panel_h + gap,
                     y_app = y_err + 20 + gap;
  const Eigen::Index height = (appearance_row ? y_app + bar_h + 20 : y_err + 20) + margin;
  tacmap::rgb_image fig = tacmap::rgb_image::filled(height, margin + n * (panel_w + gap), 1, 1, 1);
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
    // Map with the true window (green) and the estimate's window (red).
    blit_grey(fig, map, y_map, x, s, 0.8F);
    const double ww = static_cast<double>(win.width), wh = static_cast<double>(win.height);
    draw_rect(fig, y_map, x, s, t.estimate_x_mm / mm - ww / 2, t.estimate_y_mm / mm - wh / 2, ww,
              wh, 0.9F, 0.1F, 0.1F);
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
    if (appearance_row && t.appearance_probability.size() == 2) {
      // P(raised parts look dark) as the orange share of the bar, its value under it.
      const double dark = t.appearance_probability[1];
      const auto split =
          static_cast<Eigen::Index>(std::lround(dark * static_cast<double>(panel_w)));
      for (Eigen::Index r = 0; r < bar_h; ++r)
        for (Eigen::Index c = 0; c < panel_w; ++c) {
          if (c < split)
            fig.set(y_app + r, x + c, 0.95F, 0.55F, 0.1F);
          else
            fig.set(y_app + r, x + c, 0.25F, 0.45F, 0.85F);
        }
      char text[16];
      std::snprintf(text, sizeof text, "%.2f", dark);
      draw_text(fig, y_app + bar_h + 3, x + 4, text, 3, 0.0F);
    }
  }
  tacmap::write_png_rgb(png, fig);
}

void print_run(const tacmap::sequence_result& run) {
  std::printf("%5s %9s %20s %20s %9s %13s %14s %16s\n", "touch", "location", "true (x, y) mm",
              "estimate (x, y) mm", "error mm", "entropy nats", "P(raised dark)",
              "P(error <= 5 mm)");
  for (const auto& t : run.touches) {
    char dark[16] = "-";
    if (t.appearance_probability.size() == 2)
      std::snprintf(dark, sizeof dark, "%.3f", t.appearance_probability[1]);
    std::printf("%5zu %9zu %9.1f, %8.1f  %9.1f, %8.1f  %9.2f %13.3f %14s %8.3f %-11s%s\n",
                t.step + 1, t.location, t.true_x_mm, t.true_y_mm, t.estimate_x_mm, t.estimate_y_mm,
                t.error_mm, t.entropy_nats, dark, t.probability_within,
                tacmap::to_string(t.verdict), t.accepted ? "" : "   (frame rejected)");
  }
  const auto ttl = tacmap::touches_to_localize(run.touches);
  if (ttl)
    std::printf("error below 5 mm from touch %zu on\n", *ttl);
  else
    std::printf("not localized: the final error is not below 5 mm\n");
}

// The horse: a photograph of a dark silhouette on white, pressed as a 4 mm relief where the photo
// is dark; 7 touch locations whose windows hold both horse and background (fixed seed), visited
// in one order with the gecko protocol's odometry noise (0.5 mm per axis).
tacmap::touch_protocol horse_protocol() {
  tacmap::touch_protocol p;
  p.map_file = std::filesystem::path(TACMAP_DATA_DIR) / "horse" / "horse.pgm";
  p.map = tacmap::read_pgm(p.map_file);
  p.mm_per_px = 3.4 / 3.0;
  p.relief = {.kind = tacmap::relief_kind::binary,
              .threshold = 0.5F,
              .height_mm = 4.0,
              .edge_smoothing_px = 0.7};
  p.odometry_sigma_mm = 0.5;
  p.seed = 5;
  const tacmap::pixel_size window = tacmap::tactile_window({}, p.mm_per_px);
  const tacmap::planar_grid<float> grid(p.map_size(), p.mm_per_px, window);
  tacmap::sim_rng rng(p.seed);
  for (int attempt = 0; p.locations.size() < 7; ++attempt) {
    if (attempt > 100000)
      tacmap::detail::fail("gecko_demo: ", p.map_file,
                           " has too few windows over the "
                           "horse's edge; expected a silhouette filling part of the image");
    const auto i = static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(grid.size())));
    const tacmap::grid_cell cell = grid.cell(i);
    const float dark_share =
        (p.map.block(cell.row, cell.col, window.height, window.width) < 0.5F).cast<float>().mean();
    const auto s = grid.state_mm(i);
    const tacmap::touch_location loc{s(0), s(1)};
    if (dark_share > 0.25F && dark_share < 0.75F &&
        std::find(p.locations.begin(), p.locations.end(), loc) == p.locations.end())
      p.locations.push_back(loc);
  }
  std::vector<std::size_t> order(p.locations.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  p.sequences.push_back(tacmap::sequence_visiting(p.locations, order, p.odometry_sigma_mm, rng));
  return p;
}

}  // namespace

int main(int argc, char** argv) try {
  std::filesystem::path out_dir = "tacmap-demo-output";
  bool ideal = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::printf(
          "usage: gecko_demo [--ideal] [output-folder]\n"
          "  Localizes a simulated touch sequence on the bundled gecko (the paper's Fig. 5) and\n"
          "  on a photograph of a dark horse on white, with the library's default model, and\n"
          "  writes gecko_demo.png and horse_demo.png into output-folder\n"
          "  (default: ./tacmap-demo-output).\n"
          "  --ideal  press the map's own image with a new sensor instead of the realistic\n"
          "           scenario (camera map, misregistration, press jitter, worn sensor)\n");
      return 0;
    }
    if (arg == "--ideal")
      ideal = true;
    else if (arg.starts_with("-"))
      tacmap::detail::fail("gecko_demo: unknown option '", arg,
                           "'; expected [--ideal] [output-folder] (--help for details)");
    else
      out_dir = arg;
  }
  tacmap::localization_config config{};  // the library's default configuration
  if (!ideal) {
    config.scenario = tacmap::scenario_params::realistic();
    config.simulator = tacmap::realistic_sensor(config.simulator);
  }
  std::filesystem::create_directories(out_dir);

  // 1. The gecko: a light print on a dark base, raised parts bright.
  const tacmap::touch_protocol protocol =
      tacmap::load_protocol(std::filesystem::path(TACMAP_DATA_DIR) / "gecko" / "protocol.txt");
  tacmap::localization_experiment experiment(protocol, config);
  constexpr std::size_t sequence = 0;  // the paper's Fig. 5 path
  const tacmap::sequence_result run = experiment.run(sequence, true);
  std::printf("tacmap gecko demo: sequence %zu of the bundled gecko protocol, %zu touches\n",
              sequence, run.touches.size());
  std::printf("measurement model: %s; motion: sigma %.1f mm, k = %d; scenario: %s\n",
              config.name().c_str(), config.motion_sigma_mm, config.motion_k,
              ideal ? "ideal" : "realistic (camera map, misregistration, press jitter)");
  print_run(run);
  const std::filesystem::path gecko_png = std::filesystem::absolute(out_dir / "gecko_demo.png");
  write_figure(gecko_png, run, experiment.visual_map(),
               experiment.filter().grid().base().window_size(), protocol.mm_per_px, false);
  std::printf(
      "figure (like the paper's Fig. 5; columns = touches; rows = tactile image, map with true "
      "window green / estimate red, belief heat map with true centre, error):\n  %s\n\n",
      gecko_png.string().c_str());

  // 2. The horse: a dark object on a light background — the same default model, not told.
  const tacmap::touch_protocol horse = horse_protocol();
  tacmap::localization_config dark = config;
  dark.scenario.polarity = tacmap::relief_polarity::dark_raised;
  tacmap::localization_experiment horse_experiment(horse, dark);
  const tacmap::sequence_result horse_run = horse_experiment.run(0, true);
  std::printf(
      "a photograph of a dark horse on white (data/horse), its raised parts dark: %zu "
      "touches\n",
      horse_run.touches.size());
  print_run(horse_run);
  const std::filesystem::path horse_png = std::filesystem::absolute(out_dir / "horse_demo.png");
  write_figure(horse_png, horse_run, horse_experiment.visual_map(),
               horse_experiment.filter().grid().base().window_size(), horse.mm_per_px, true);
  std::printf(
      "figure (as above, plus a bar per touch: orange share = P(raised parts look dark), "
      "blue = P(bright)):\n  %s\n",
      horse_png.string().c_str());
  const auto final_error = [](const tacmap::sequence_result& r) {
    return r.touches.empty() ? INFINITY : r.touches.back().error_mm;
  };
  return final_error(run) < 5.0 && final_error(horse_run) < 5.0 ? 0 : 1;
} catch (const std::exception& e) {
  std::fprintf(stderr, "gecko_demo: %s\n", e.what());
  return 2;
}
