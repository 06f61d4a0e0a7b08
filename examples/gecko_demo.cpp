// gecko_demo — the paper's Fig. 5, reproduced on the bundled gecko (data/gecko/).
//
// A tactile array (14 x 6 taxels, 3.4 mm pitch) touches a 3-D printed gecko at 7 places, in the
// order of the protocol's sequence 0 (the path of the paper's Fig. 5). Each touch is a simulated,
// noisy tactile frame; between touches the filter predicts with the arm's measured (noisy)
// odometry and then updates with the tactile image, using the library's default measurement model
// configuration (`tacmap::localization_config{}`). After every touch it prints the error in mm
// and the belief's entropy, and at the end writes a figure like Fig. 5 that explains itself (row
// labels, colour bar, scale bars and the key are in the picture): one column per touch — the
// tactile image, the map with the true sensor window (green) and the estimate's (cyan, dashed,
// on top), the belief over the whole map and zoomed around the truth on one log probability
// scale shared by all panels (true centre: green ring of 5 mm; estimate: cyan cross over it),
// and the numbers. The PNGs are compressed (io/image_file.hpp, stb_image_write) and the text is
// stb's quad font (stb_easy_font): the demo needs stb (Debian libstb-dev, tacmap::image_file).
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
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "demo_objects.hpp"  // the horse's protocol
#include "figure.hpp"        // the demo figures' drawing (stb_easy_font text, belief colour scale)
#include "tacmap/io/image_file.hpp"  // write_png_compressed (stb_image_write; tacmap::image_file)
#include "tacmap/io/image_io.hpp"
#include "tacmap/io/png_rgb.hpp"
#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/protocol.hpp"

#ifndef TACMAP_DATA_DIR
#error "TACMAP_DATA_DIR must name tacmap's data/ folder"
#endif

namespace {

using namespace tacmap_examples;  // the figures' drawing (figure.hpp)

// The horse figure's appearance bar: P(raised parts look dark) against bright.
constexpr colour dark_colour{0.95F, 0.55F, 0.1F}, bright_colour{0.25F, 0.45F, 0.85F};

struct figure_text {
  std::string title;     // what was localized
  std::string subtitle;  // how (model, scenario)
};

// The figure (like the paper's Fig. 5): one column per touch; rows: the tactile image, the map
// with the true and the estimated sensor window, the belief over the map with the true and the
// estimated centre, the numbers; with `appearance_row`, a bar per touch: the posterior that the
// object's raised parts look dark (orange share) against bright (blue share). Row labels, the
// colour bar, scale bars and the key are drawn into the figure: it explains itself.
void write_figure(const std::filesystem::path& png, const tacmap::sequence_result& run,
                  const tacmap::image<float>& map, tacmap::pixel_size win, double mm,
                  bool appearance_row, const figure_text& words) {
  constexpr int s = 2;   // map panels: 2 screen px per map px
  constexpr int ts = 4;  // tactile panel: 4 screen px per map px (2x the map panels' scale)
  constexpr index_t margin = 16, gap = 16, label_w = 360, line = 24, bar_h = 18;
  const index_t panel_w = map.cols() * s, panel_h = map.rows() * s;
  const index_t tact_h = win.height * ts;
  const index_t n = static_cast<index_t>(run.touches.size());
  const index_t x0 = margin + label_w;  // first column
  const index_t y_title = margin, y_head = y_title + 2 * line + 16, y_tact = y_head + line + 6;
  const index_t y_map = y_tact + std::max<index_t>(tact_h, 5 * line) + gap;
  constexpr int zoom = 4 * s;  // the zoomed belief panels: 4x the map panels' scale
  const index_t y_bel = y_map + panel_h + gap, y_zoom = y_bel + panel_h + gap;
  const index_t y_num = y_zoom + panel_h + 10;
  const index_t y_app = y_num + 4 * line + 16;
  const index_t y_key = (appearance_row ? y_app + 3 * line : y_num + 4 * line) + 20;
  const index_t width = x0 + n * (panel_w + gap) - gap + margin;
  const double px_per_mm = s / mm;
  const double cells = static_cast<double>(run.beliefs.empty() ? 1 : run.beliefs[0].size());
  // The key: what a reader needs without the terminal, wrapped to the figure's width.
  const std::string n_cells = std::to_string(static_cast<long>(cells));
  std::string key =
      "How to read: the columns are the touches, in order; between touches the arm moved by its "
      "noisy odometry. Green = the truth, cyan = the filter's estimate after that touch, drawn on "
      "top; the ring is 5 mm around the true centre (an estimate inside it counts as localized). "
      "Belief: the probability that the sensor's centre is in each 1-px cell of the map (" +
      fixed(mm, 2) + " mm per px, " + n_cells +
      " cells), on one log colour scale for all panels: a flat belief (no information, 1/" +
      n_cells +
      " per cell, the green tick on the colour bar) looks dark, a small bright spot is a certain "
      "belief; black = below 1e-5 or out of reach. Entropy " +
      fixed(std::log(cells), 1) +
      " nats = flat. P(err<=5mm): the belief's own claim that the error is below 5 mm; the "
      "verdict follows from it.";
  if (appearance_row)
    key +=
        " Bar: the filter's posterior that the object's raised parts look DARK in the photo "
        "(orange share) rather than bright (blue); nobody told it which.";
  const std::vector<std::string> key_lines = wrap(key, 2, width - 2 * margin);
  const index_t height = y_key + static_cast<index_t>(key_lines.size()) * line + margin;
  rgb_image fig = rgb_image::filled(height, width, 1, 1, 1);

  // Title and row labels.
  draw_text(fig, y_title, margin, words.title, 3);
  draw_text(fig, y_title + 3 * 12 + 4, margin, words.subtitle, 2, grey);
  draw_lines(fig, y_tact, margin,
             {"what the sensor felt", "tactile image,", "14 x 6 taxels", "(white = pressed)"}, 2,
             line);
  draw_scale_bar(fig, y_tact + 4 * line + 8, margin, 10.0, ts / mm, "10 mm");
  draw_lines(fig, y_map, margin,
             {"where it was: the", "map (a photo)", "sensor window:", "truth: green box",
              "estimate: cyan box,", "dashed, on top"},
             2, line);
  draw_scale_bar(fig, y_map + 6 * line + 14, margin, 20.0, px_per_mm, "20 mm");
  draw_lines(fig, y_bel, margin,
             {"belief after the", "touch: P(sensor", "centre in a 1-px", "cell), log scale",
              "for all panels;", "green tick: flat", "ring: 5 mm around", "the true centre",
              "+: the estimate"},
             2, line);
  draw_lines(fig, y_zoom, margin,
             {"the same belief,", "zoomed 4x around", "the truth", "white: the map's", "outline"},
             2, line);
  draw_scale_bar(fig, y_zoom + 5 * line + 14, margin, 5.0, zoom / mm, "5 mm");
  // Colour bar beside the belief labels, with the level of a uniform belief.
  draw_colour_bar(fig, y_bel, margin + label_w - 86, panel_h, 1.0 / cells);

  const tacmap::image<std::uint8_t> edges = outline(map);
  const double ring_radius = std::max(8.0, 5.0 * px_per_mm);  // 5 mm, the success radius
  const double ww = static_cast<double>(win.width), wh = static_cast<double>(win.height);
  const auto screen = [&](double v_mm) { return static_cast<index_t>(std::lround(v_mm / mm * s)); };
  for (index_t i = 0; i < n; ++i) {
    const auto& t = run.touches[static_cast<std::size_t>(i)];
    const index_t x = x0 + i * (panel_w + gap);
    const std::string head = "touch " + std::to_string(i + 1) + (t.accepted ? "" : " (rejected)");
    draw_text(fig, y_head, x + (panel_w - text_width(head, 2)) / 2, head, 2);
    // Tactile image, centred in the column; a rejected frame leaves a grey box.
    const index_t tx = x + (panel_w - win.width * ts) / 2;
    const auto& tact = run.tactile_images[static_cast<std::size_t>(i)];
    blit_grey(fig,
              tact.size() > 0 ? tact : tacmap::image<float>::Constant(win.height, win.width, 0.5F),
              y_tact, tx, ts);
    // Map with the true window (green, solid) and the estimate's (cyan, dashed, drawn last).
    blit_grey(fig, map, y_map, x, s);
    const auto window_box = [&](double cx_mm, double cy_mm, colour c, bool dashed) {
      const double left = cx_mm / mm - ww / 2, top = cy_mm / mm - wh / 2;
      draw_box(fig, y_map + std::lround(top * s), x + std::lround(left * s),
               y_map + std::lround((top + wh) * s) - 1, x + std::lround((left + ww) * s) - 1, c,
               dashed);
    };
    window_box(t.true_x_mm, t.true_y_mm, truth_colour, false);
    window_box(t.estimate_x_mm, t.estimate_y_mm, estimate_colour, true);
    // Belief over the whole map, then zoomed around the truth; truth first, estimate on top.
    const auto& bel = run.beliefs[static_cast<std::size_t>(i)];
    draw_belief(fig, y_bel, x, panel_h, panel_w, bel, edges, win, s, 0.0, 0.0);
    draw_ring(fig, y_bel + screen(t.true_y_mm), x + screen(t.true_x_mm), ring_radius);
    draw_cross(fig, y_bel + screen(t.estimate_y_mm), x + screen(t.estimate_x_mm), 3, 7, 1);
    const double zr0 = t.true_y_mm / mm - static_cast<double>(panel_h) / (2.0 * zoom);
    const double zc0 = t.true_x_mm / mm - static_cast<double>(panel_w) / (2.0 * zoom);
    draw_belief(fig, y_zoom, x, panel_h, panel_w, bel, edges, win, zoom, zr0, zc0);
    const auto zoomed = [&](double v_mm, double origin) {
      return static_cast<index_t>(std::lround((v_mm / mm - origin) * zoom));
    };
    draw_ring(fig, y_zoom + zoomed(t.true_y_mm, zr0), x + zoomed(t.true_x_mm, zc0),
              5.0 / mm * zoom);
    const index_t er = zoomed(t.estimate_y_mm, zr0), ec = zoomed(t.estimate_x_mm, zc0);
    if (er >= 16 && ec >= 16 && er < panel_h - 16 && ec < panel_w - 16)
      draw_cross(fig, y_zoom + er, x + ec, 5, 18, 2);
    else
      draw_text(fig, y_zoom + panel_h - 22, x + 6, "+ off this view", 2, estimate_colour);
    // The numbers: the error, the belief's entropy, its claim and verdict.
    draw_lines(
        fig, y_num, x,
        {"error " + fixed(t.error_mm, 1) + " mm", "entropy " + fixed(t.entropy_nats, 2) + " nats",
         "P(err<=5mm) " + fixed(t.probability_within, 2),
         "-> " + std::string(tacmap::to_string(t.verdict))},
        2, line);
    if (appearance_row && t.appearance_probability.size() == 2) {
      // P(raised parts look dark) as the orange share of the bar, its value under it.
      const double dark = t.appearance_probability[1];
      const auto split = static_cast<index_t>(std::lround(dark * static_cast<double>(panel_w)));
      fill(fig, y_app, x, bar_h, split, dark_colour);
      fill(fig, y_app, x + split, bar_h, panel_w - split, bright_colour);
      draw_text(fig, y_app + bar_h + 4, x, "P(dark) " + fixed(dark, 2), 2);
    }
  }
  if (appearance_row) {  // the posterior of the photo-versus-touch relation
    draw_lines(fig, y_app - 4, margin, {"photo vs touch: do", "raised parts look"}, 2, line);
    const index_t after = draw_text(fig, y_app + 2 * line - 4, margin, "dark", 2, dark_colour);
    const index_t after_or = draw_text(fig, y_app + 2 * line - 4, after, " or ", 2);
    draw_text(fig, y_app + 2 * line - 4, after_or, "bright?", 2, bright_colour);
  }
  draw_lines(
      fig, y_num, margin,
      {"after the touch:", "the estimate's error,", "the belief's entropy,", "claim and verdict"},
      2, line, grey);

  draw_lines(fig, y_key, margin, key_lines, 2, line);
  tacmap::write_png_compressed(png, fig);
  check_figure("gecko_demo", png, fig);
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
  const std::string scenario_words =
      ideal ? "ideal scenario (the sensor presses the map's own image)"
            : "realistic scenario (camera map, misregistration, press jitter, worn sensor)";
  const std::string model_words =
      "model: " + config.name() + " (the library's default); " + scenario_words;
  write_figure(gecko_png, run, experiment.visual_map(),
               experiment.filter().grid().base().window_size(), protocol.mm_per_px, false,
               {"tacmap: " + std::to_string(run.touches.size()) +
                    " touches on the bundled gecko (sequence 0, the path of the paper's Fig. 5)",
                model_words});
  std::printf(
      "figure (like the paper's Fig. 5, its key inside; columns = touches; rows = tactile "
      "image, map with the true window green / estimate cyan, belief on a log scale, zoomed "
      "belief, numbers):\n  %s\n\n",
      gecko_png.string().c_str());

  // 2. The horse: a dark object on a light background — the same default model, not told.
  const tacmap::touch_protocol horse = horse_protocol(TACMAP_DATA_DIR);
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
               horse_experiment.filter().grid().base().window_size(), horse.mm_per_px, true,
               {"tacmap: " + std::to_string(horse_run.touches.size()) +
                    " touches on a photo of a dark horse on white (data/horse): raised parts "
                    "look dark",
                model_words});
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
