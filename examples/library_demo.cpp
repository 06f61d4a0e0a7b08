// library_demo — which object, and where (issue 15): a robot has photographed five objects on a
// table and closes its hand on one of them without being told which. `tacmap::library_localizer`
// holds every photograph and answers both questions from the same touches: after each touch it
// reports every object's posterior, the most probable ("leading") object and the sensor's
// position on that object's map.
//
// The library: the bundled gecko (data/gecko/), the horse photograph (data/horse/, a dark
// silhouette whose raised parts look dark), the replay demo's object of smooth bumps and raised
// bars (data/sessions/replay_demo_map.pgm), and two objects generated here: an embossed
// nameplate and a gear. Every object is simulated in the realistic scenario (sim/scenario.hpp):
// the library holds what a webcam makes of each object (lighting, texture, blur, noise, gamma),
// the object lies ~1 mm / 1 degree off its photograph, every press turns, tilts and presses a
// little differently, and the sensor is a used one. Each object has its own photograph and
// noise (its own seed). The touches are the gecko protocol's sequence 0 (the path of the
// paper's Fig. 5), with the arm's noisy odometry between them; the localizer is not told that it
// touches the gecko.
//
// Per touch it prints each object's posterior, the leading object, the error on the touched
// object (when it leads), the joint claim P(right object and within 5 mm) and the verdict, and
// the same touches localized knowing the object (the object's own filter) for comparison. It
// writes library_demo.png: one row per touch — what the sensor felt, the object posteriors as a
// bar chart (the touched object green, the 0.9 recognition threshold), and the belief on the
// leading object's map on gecko_demo's log10 probability scale.
//
// Run: library_demo [--object NAME] [--seed N] [output-folder]  (default: ./tacmap-demo-output)
//      library_demo --sweep N   (touch every object, seeds 1 .. N; count how often it passes)
// Exit status 0 when, at the last touch, the touched object leads with a posterior above 0.9 and
// the error on it is below 5 mm (recognized and localized); --sweep: when every run does.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "demo_objects.hpp"  // the horse's protocol, protocols over an object's edges
#include "figure.hpp"        // the demo figures' drawing (stb_easy_font text, belief colour scale)
#include "tacmap/io/image_file.hpp"  // write_png_compressed (stb_image_write; tacmap::image_file)
#include "tacmap/io/image_io.hpp"
#include "tacmap/io/png_rgb.hpp"
#include "tacmap/library_localizer.hpp"
#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/protocol.hpp"
#include "tacmap/sim/scenario.hpp"

#ifndef TACMAP_DATA_DIR
#error "TACMAP_DATA_DIR must name tacmap's data/ folder"
#endif

namespace {

using namespace tacmap_examples;  // the figures' drawing (figure.hpp), the objects
using tacmap::image;

constexpr double recognized_above = 0.9;    // the object counts as recognized above this posterior
constexpr double localized_below_mm = 5.0;  // and the contact as localized within this error
// Bars of objects other than the touched one (the touched one is green, as the truth everywhere).
constexpr colour other_colour{0.55F, 0.6F, 0.7F}, track_colour{0.92F, 0.92F, 0.92F};
constexpr colour threshold_colour{0.85F, 0.1F, 0.1F}, rule_colour{0.8F, 0.8F, 0.8F};

// One object of the library: its name, its touch protocol (photograph, scale, relief, touch
// locations and sequences) and whether its raised parts look dark in the photograph.
struct demo_object {
  std::string name;
  tacmap::touch_protocol protocol;
  tacmap::relief_polarity polarity = tacmap::relief_polarity::bright_raised;
};

// A light object (0.85) on a dark base (0.1), anti-aliased with 4 x 4 samples per pixel:
// `inside(x, y)` in map pixels (x along columns).
template <class Inside>
image<float> render(index_t rows, index_t cols, Inside inside) {
  image<float> map(rows, cols);
  for (index_t r = 0; r < rows; ++r)
    for (index_t c = 0; c < cols; ++c) {
      int hits = 0;
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
          hits += inside(static_cast<double>(c) + (j + 0.5) / 4.0,
                         static_cast<double>(r) + (i + 0.5) / 4.0)
                      ? 1
                      : 0;
      map(r, c) = 0.1F + 0.75F * static_cast<float>(hits) / 16.0F;
    }
  return map;
}

// A spur gear seen from above, 120 x 120 px: 10 teeth, a bore with a keyway and four lightening
// holes. Much of it repeats (teeth, holes): windows on it look alike, as on a real gear.
image<float> make_gear() {
  constexpr double cx = 60.0, cy = 60.0, tip = 54.0, root = 45.0, teeth = 10.0;
  return render(120, 120, [&](double x, double y) {
    const double dx = x - cx, dy = y - cy, r = std::hypot(dx, dy);
    const double turns = (std::atan2(dy, dx) / (2.0 * std::numbers::pi) + 1.0) * teeth;
    const double phase = turns - std::floor(turns);  // 0 .. 1 across one tooth and one gap
    // Trapezoidal teeth: full height over 40 % of the pitch, flanks over 10 % each.
    const double rise = std::clamp(std::min(phase, 0.6 - phase) / 0.1, 0.0, 1.0);
    if (r > root + (tip - root) * rise) return false;
    if (r < 11.0) return false;                                      // the bore
    if (std::abs(dx) < 3.0 && dy < 0.0 && dy > -14.0) return false;  // its keyway
    for (int k = 0; k < 4; ++k) {                                    // lightening holes
      const double a = std::numbers::pi / 4.0 + k * std::numbers::pi / 2.0;
      if (std::hypot(x - (cx + 28.0 * std::cos(a)), y - (cy + 28.0 * std::sin(a))) < 8.0)
        return false;
    }
    return true;
  });
}

// An embossed nameplate, 120 x 120 px: raised letters "TAC", "MAP", "15" (stb's quad font,
// 4 px strokes: 4.5 mm) on a dark plate.
image<float> make_nameplate() {
  rgb_image plate = rgb_image::filled(120, 120, 0.1F, 0.1F, 0.1F);
  const colour letters{0.85F, 0.85F, 0.85F};
  const std::vector<std::string> lines = {"TAC", "MAP", "15"};
  for (std::size_t k = 0; k < lines.size(); ++k)
    draw_text(plate, 8 + static_cast<index_t>(k) * 38, (120 - text_width(lines[k], 4)) / 2,
              lines[k], 4, letters);
  return plate.r;
}

// The library (see the file comment); each object's sequence 0 is the one touched.
std::vector<demo_object> make_objects() {
  const std::filesystem::path data = TACMAP_DATA_DIR;
  const tacmap::relief_params binary{.kind = tacmap::relief_kind::binary,
                                     .threshold = 0.5F,
                                     .height_mm = 4.0,
                                     .edge_smoothing_px = 0.7};
  constexpr double mm = 3.4 / 3.0;  // the paper's map scale: 3 px per 3.4 mm taxel
  std::vector<demo_object> objects;
  objects.push_back({"gecko", tacmap::load_protocol(data / "gecko" / "protocol.txt"),
                     tacmap::relief_polarity::bright_raised});
  objects.push_back({"horse", horse_protocol(data), tacmap::relief_polarity::dark_raised});
  // A height field stored as an image: the height is 4 mm x the intensity.
  const std::filesystem::path bumps = data / "sessions" / "replay_demo_map.pgm";
  objects.push_back({"bumps",
                     edge_protocol(bumps, tacmap::read_pgm(bumps), mm,
                                   {.kind = tacmap::relief_kind::continuous, .height_mm = 4.0}, 7),
                     tacmap::relief_polarity::bright_raised});
  objects.push_back({"nameplate",
                     edge_protocol("nameplate (generated)", make_nameplate(), mm, binary, 11),
                     tacmap::relief_polarity::bright_raised});
  objects.push_back({"gear", edge_protocol("gear (generated)", make_gear(), mm, binary, 13),
                     tacmap::relief_polarity::bright_raised});
  return objects;
}

// The library's default model (README, "The photo is not the touch": the appearance is a
// latent hypothesis, nobody tells the filter which) in the realistic scenario, or in the ideal
// one (`ideal`: the sensor, new, presses each map's own image).
tacmap::localization_config demo_config(std::uint64_t seed, bool ideal) {
  tacmap::localization_config config{};
  if (!ideal) {
    config.scenario = tacmap::scenario_params::realistic();
    config.simulator = tacmap::realistic_sensor(config.simulator);
  }
  config.simulator_seed = seed;
  return config;
}

std::string scenario_words(bool ideal) {
  return ideal ? "ideal scenario (the sensor presses each map's own image)"
               : "realistic scenario (camera maps, misregistration, press jitter, worn sensor)";
}

// Every object's simulation (its camera map, its relief, its own filter: the object known) and
// the localizer over all their camera maps: what the robot photographed.
struct library {
  std::vector<std::unique_ptr<tacmap::localization_experiment>> experiments;
  std::optional<tacmap::library_localizer> localizer;
  std::vector<image<float>> maps;  // at the library's scale, as the localizer holds them
};

library build_library(const std::vector<demo_object>& objects,
                      const tacmap::localization_config& config) {
  library lib;
  std::vector<tacmap::library_map> maps;
  for (std::size_t k = 0; k < objects.size(); ++k) {
    tacmap::localization_config c = config;
    c.scenario.polarity = objects[k].polarity;
    // Each object its own photograph (camera texture and noise) and its own presses.
    c.simulator_seed = config.simulator_seed + 1000 * k;
    lib.experiments.push_back(
        std::make_unique<tacmap::localization_experiment>(objects[k].protocol, c));
    maps.push_back(
        {objects[k].name, lib.experiments.back()->visual_map(), objects[k].protocol.mm_per_px});
  }
  lib.localizer.emplace(maps, static_cast<const tacmap::localizer_config&>(config),
                        config.simulator.geometry);
  for (const auto& m : maps)
    lib.maps.push_back(tacmap::rescale(m.map, m.mm_per_px, lib.localizer->mm_per_px()));
  return lib;
}

// One touch of a run.
struct touch_outcome {
  tacmap::library_touch_result result;
  double true_x_mm = 0.0, true_y_mm = 0.0;  // the touched object's map frame
  // The estimate's distance to the truth when the touched object leads; +infinity when another
  // object leads (a position on the wrong object is no position).
  double error_mm = std::numeric_limits<double>::infinity();
  double known_error_mm = 0.0;  // the same touches, the object known (its own filter)
  image<float> tactile;         // what the sensor felt (map scale; empty when rejected)
  image<float> belief;          // the position belief on the leading object's map, given it
};

struct run_result {
  std::size_t object = 0;  // the touched object
  std::vector<touch_outcome> touches;
  // Recognized and localized at the last touch (the demo's claim).
  [[nodiscard]] bool passed() const {
    if (touches.empty()) return false;
    const touch_outcome& t = touches.back();
    return static_cast<std::size_t>(t.result.object) == object &&
           t.result.object_probability[object] > recognized_above &&
           t.error_mm < localized_below_mm;
  }
};

// Touches object `object` along sequence `sequence` of its protocol (simulated frames at the true
// places, the arm's measured odometry between them) and localizes them over the whole library.
run_result touch_object(library& lib, std::size_t object, std::size_t sequence, bool keep_images) {
  // The raw frames come with the images only.
  const tacmap::sequence_result sim = lib.experiments.at(object)->run(sequence, true);
  tacmap::library_localizer& loc = *lib.localizer;
  loc.reset();
  run_result run;
  run.object = object;
  for (std::size_t t = 0; t < sim.touches.size(); ++t) {
    const tacmap::touch_record& rec = sim.touches[t];
    touch_outcome out;
    out.result = t == 0 ? loc.touch(sim.frames[t])
                        : loc.touch(sim.frames[t], tacmap::odometry{.dx_mm = rec.reported_dx_mm,
                                                                    .dy_mm = rec.reported_dy_mm});
    out.true_x_mm = rec.true_x_mm;
    out.true_y_mm = rec.true_y_mm;
    if (static_cast<std::size_t>(out.result.object) == object)
      out.error_mm = std::hypot(out.result.position_mm(0) - rec.true_x_mm,
                                out.result.position_mm(1) - rec.true_y_mm);
    out.known_error_mm = rec.error_mm;
    if (keep_images) {
      out.tactile = sim.tactile_images[t];
      out.belief = loc.object_belief_image(out.result.object);
    }
    run.touches.push_back(std::move(out));
  }
  return run;
}

std::string probability_text(double p) { return p < 0.001 ? "<0.001" : fixed(p, 3); }

void print_run(const run_result& run, const std::vector<demo_object>& objects) {
  std::printf("%5s", "touch");
  for (const auto& o : objects) std::printf(" %10s", ("P(" + o.name.substr(0, 7) + ")").c_str());
  std::printf(" %10s", "P(unknown)");  // none of these (filter/open_set.hpp)
  std::printf(" %10s %9s %16s %-13s %12s\n", "leading", "error mm", "P(right, <=5mm)", "verdict",
              "known: error");
  for (std::size_t t = 0; t < run.touches.size(); ++t) {
    const touch_outcome& o = run.touches[t];
    std::printf("%5zu", t + 1);
    for (const double p : o.result.object_probability)
      std::printf(" %10s", probability_text(p).c_str());
    std::printf(" %10s", probability_text(o.result.probability_unknown).c_str());
    const std::string error = std::isfinite(o.error_mm) ? fixed(o.error_mm, 2) : "-";
    std::printf(" %10s %9s %16.3f %-13s %9.2f mm%s\n", o.result.object_name.c_str(), error.c_str(),
                o.result.probability_within, tacmap::to_string(o.result.verdict), o.known_error_mm,
                o.result.accepted() ? "" : "   (frame rejected)");
  }
}

struct figure_text {
  std::string title;     // what was localized
  std::string subtitle;  // how (model, scenario, seed)
};

// The figure: the library's photographs on top, then one row per touch — what the sensor felt
// and the numbers, the object posteriors as a bar chart (touched object green, the 0.9
// recognition threshold red and dashed), and the belief on the leading object's map (truth ring
// when that object is the touched one, the estimate's cross) on gecko_demo's log colour scale.
void write_figure(const std::filesystem::path& png, const run_result& run, const library& lib,
                  const std::vector<demo_object>& objects, const figure_text& words) {
  constexpr int s = 2;   // belief panels: 2 screen px per map px
  constexpr int ts = 4;  // tactile panels: 4 screen px per map px
  constexpr index_t margin = 16, line = 24, pitch = 34, bar_h = 24, bar_len = 340;
  const tacmap::library_localizer& loc = *lib.localizer;
  const double mm = loc.mm_per_px();
  const auto n_objects = static_cast<index_t>(objects.size());
  const auto window = [&](std::size_t k) {
    return loc.filter().grid().object(static_cast<index_t>(k)).base().window_size();
  };
  const tacmap::pixel_size touched_window = window(run.object);
  index_t panel_w = 0, panel_h = 0, names_w = 0;
  for (std::size_t k = 0; k < objects.size(); ++k) {
    panel_w = std::max(panel_w, lib.maps[k].cols() * s);
    panel_h = std::max(panel_h, lib.maps[k].rows() * s);
    names_w = std::max(names_w, text_width(objects[k].name, 2));
  }
  // Columns: labels and numbers, the tactile image, the bar chart, the belief, the colour bar.
  const index_t label_w = 300;
  const index_t x_tact = margin + label_w, tact_w = touched_window.width * ts;
  const index_t x_bars = x_tact + tact_w + 40 + names_w + 12;  // the bars' 0
  const index_t x_bel = x_bars + bar_len + 110;
  const index_t x_cb = x_bel + panel_w + 30;
  const index_t width = x_cb + 16 + 70 + margin;
  // Rows: title, the library's photographs, the column heads, one row per touch, the key.
  const std::vector<std::string> title_lines = wrap(words.title, 3, width - 2 * margin);
  const std::vector<std::string> subtitle_lines = wrap(words.subtitle, 2, width - 2 * margin);
  const index_t y_title = margin;
  const index_t y_lib = y_title + static_cast<index_t>(title_lines.size()) * (3 * 12 + 4) +
                        static_cast<index_t>(subtitle_lines.size()) * line + 16;
  index_t thumbs_h = 0;
  for (const auto& m : lib.maps) thumbs_h = std::max(thumbs_h, m.rows());
  const index_t y_thumbs = y_lib + line + 6, y_head = y_thumbs + thumbs_h + 2 * line + 16;
  const index_t row_h =
      line + std::max({panel_h, touched_window.height * ts, n_objects * pitch + 2 * line}) + 24;
  const index_t y_rows = y_head + 3 * line + 12;
  const auto n = static_cast<index_t>(run.touches.size());
  const index_t y_key = y_rows + n * row_h + 8;
  const std::string touched = objects[run.object].name;
  const auto cells = static_cast<double>(
      loc.filter().grid().object(static_cast<index_t>(run.object)).base().size());
  const std::string key =
      "How to read: one row per touch, in order; between touches the arm moved by its noisy "
      "odometry. The localizer holds the " +
      std::to_string(objects.size()) +
      " photographs above and is not told which object it "
      "touches. Bars: each object's posterior P(object | the touches so far), on a 0..1 axis; "
      "green = the object actually touched (the " +
      touched +
      "), grey = the others; the red dashed line is 0.9, above which the object counts "
      "as recognized. Right: the belief over positions on the leading (most probable) "
      "object's map, given that object: P(sensor centre in a 1-px cell | object), on "
      "gecko_demo's log colour scale (black = below 1e-5; green tick on the colour bar: "
      "a flat belief, 1/" +
      std::to_string(static_cast<long>(cells)) + " per cell on the " + touched +
      "'s map). Green ring: 5 mm around the true centre, drawn when the leading object is the "
      "touched one; cyan +: the estimate; white: the map's outline. Left: the error of the "
      "estimate on the touched object, and P(right object, err<=5mm): the belief's own claim "
      "that the leading object is right AND the estimate within 5 mm; the verdict follows from "
      "it.";
  const std::vector<std::string> key_lines = wrap(key, 2, width - 2 * margin);
  const index_t height = y_key + static_cast<index_t>(key_lines.size()) * line + margin;
  rgb_image fig = rgb_image::filled(height, width, 1, 1, 1);

  const index_t y_sub = draw_lines(fig, y_title, margin, title_lines, 3, 3 * 12 + 4);
  draw_lines(fig, y_sub, margin, subtitle_lines, 2, line, grey);

  // The library: each object's photograph at the library's scale (1 screen px per map px).
  draw_text(fig, y_lib, margin,
            "the library: the robot's photographs of " + std::to_string(objects.size()) +
                " objects (camera images, as the localizer holds them)",
            2);
  index_t x = margin;
  for (std::size_t k = 0; k < objects.size(); ++k) {
    const image<float>& m = lib.maps[k];
    blit_grey(fig, m, y_thumbs, x, 1);
    frame(fig, y_thumbs, x, y_thumbs + m.rows() - 1, x + m.cols() - 1);
    const bool is_touched = k == run.object;
    if (is_touched)
      draw_box(fig, y_thumbs - 4, x - 4, y_thumbs + m.rows() + 3, x + m.cols() + 3, truth_colour,
               false);
    draw_text(fig, y_thumbs + m.rows() + 10, x, objects[k].name, 2, is_touched ? black : grey);
    if (is_touched) draw_text(fig, y_thumbs + m.rows() + 10 + line, x, "(touched)", 2);
    x += m.cols() + 40;
  }
  draw_scale_bar(fig, y_thumbs + thumbs_h / 2, x + 10, 20.0, 1.0 / mm, "20 mm");

  // Column heads.
  draw_lines(fig, y_head, margin, {"after each touch:", "the numbers"}, 2, line);
  draw_lines(fig, y_head, x_tact - 20, {"what the", "sensor felt"}, 2, line);
  draw_lines(fig, y_head, x_bars - names_w - 12,
             {"which object? P(object | touches so far)", "(not told; green = touched)"}, 2, line);
  draw_lines(fig, y_head, x_bel,
             {"where? belief on the leading map:", "P(sensor centre in a cell |",
              "object), log scale (colour bar)"},
             2, line);

  const double ring_radius = std::max(8.0, 5.0 / mm * s);  // 5 mm, the success radius
  const auto screen = [&](double v_mm) { return static_cast<index_t>(std::lround(v_mm / mm * s)); };
  for (index_t i = 0; i < n; ++i) {
    const touch_outcome& t = run.touches[static_cast<std::size_t>(i)];
    const index_t y = y_rows + i * row_h, y_panel = y + line;
    if (i > 0) fill(fig, y - 14, margin, 1, width - 2 * margin, rule_colour);
    // Left: the touch and the numbers after it.
    draw_text(fig, y, margin,
              "touch " + std::to_string(i + 1) + (t.result.accepted() ? "" : " (rejected)"), 3);
    const bool right = static_cast<std::size_t>(t.result.object) == run.object;
    draw_lines(fig, y_panel + 20, margin,
               {"leading: " + t.result.object_name,
                right ? "error " + fixed(t.error_mm, 1) + " mm" : "error: wrong object",
                "P(right object,", "  err<=5mm) " + fixed(t.result.probability_within, 2),
                "-> " + std::string(tacmap::to_string(t.result.verdict))},
               2, line);
    // What the sensor felt; a rejected frame leaves a grey box.
    blit_grey(fig,
              t.tactile.size() > 0
                  ? t.tactile
                  : image<float>::Constant(touched_window.height, touched_window.width, 0.5F),
              y_panel, x_tact, ts);
    // The bar chart: a track per object (0..1), its posterior filled, the value after it.
    const index_t y_bars = y_panel + 8;
    for (index_t k = 0; k < n_objects; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      const double p = t.result.object_probability[kk];
      const index_t top = y_bars + k * pitch;
      const std::string& name = objects[kk].name;
      draw_text(fig, top + 2, x_bars - 12 - text_width(name, 2), name, 2,
                kk == run.object ? black : grey);
      fill(fig, top, x_bars, bar_h, bar_len, track_colour);
      fill(fig, top, x_bars, bar_h, std::lround(p * static_cast<double>(bar_len)),
           kk == run.object ? truth_colour : other_colour);
      draw_text(fig, top + 2, x_bars + bar_len + 10, probability_text(p), 2);
    }
    // The axis: 0, 0.5 and 1 below, the threshold (0.9) dashed over the bars, labelled above.
    const index_t y_axis = y_bars + n_objects * pitch;
    fill(fig, y_axis, x_bars, 2, bar_len, black);
    for (const double v : {0.0, 0.5, 1.0}) {
      const index_t tx = x_bars + std::lround(v * static_cast<double>(bar_len));
      fill(fig, y_axis, tx - 1, 8, 2, black);
      const std::string label = v == 0.0 ? "0" : v == 1.0 ? "1" : "0.5";
      draw_text(fig, y_axis + 12, tx - text_width(label, 2) / 2, label, 2);
    }
    const index_t x_thr = x_bars + std::lround(recognized_above * static_cast<double>(bar_len));
    for (index_t r = y_bars - 6; r < y_axis + 8; ++r)
      if ((r - y_bars) % 8 < 5) fill(fig, r, x_thr - 1, 1, 2, threshold_colour);
    // Its label ends over the line, clear of the belief column's title.
    const std::string threshold_label = "recognized above 0.9";
    draw_text(fig, y_bars - 30, x_thr + text_width("0.9", 2) / 2 - text_width(threshold_label, 2),
              threshold_label, 2, threshold_colour);
    // The belief on the leading object's map, given it; the truth where it is that map.
    const auto lead = static_cast<std::size_t>(t.result.object);
    const image<float>& map = lib.maps[lead];
    const index_t w = map.cols() * s, h = map.rows() * s;
    draw_text(fig, y, x_bel,
              "on the " + t.result.object_name + (right ? " (touched)" : " (NOT the touched one)"),
              2, right ? black : threshold_colour);
    draw_belief(fig, y_panel, x_bel, h, w, t.belief, outline(map), window(lead), s, 0.0, 0.0);
    if (right)
      draw_ring(fig, y_panel + screen(t.true_y_mm), x_bel + screen(t.true_x_mm), ring_radius);
    draw_cross(fig, y_panel + screen(t.result.position_mm(1)),
               x_bel + screen(t.result.position_mm(0)), 3, 7, 1);
    if (i == 0) draw_colour_bar(fig, y_panel, x_cb, panel_h, 1.0 / cells);
  }
  draw_lines(fig, y_key, margin, key_lines, 2, line);
  tacmap::write_png_compressed(png, fig);
  check_figure("library_demo", png, fig);
}

std::size_t object_index(const std::vector<demo_object>& objects, const std::string& name) {
  for (std::size_t k = 0; k < objects.size(); ++k)
    if (objects[k].name == name) return k;
  std::string names;
  for (const auto& o : objects) names += (names.empty() ? "" : ", ") + o.name;
  tacmap::detail::fail("library_demo: --object '", name,
                       "' is not in the library; expected one of ", names);
}

std::uint64_t parse_count(const std::string& option, const std::string& value) {
  std::size_t used = 0;
  unsigned long long v = 0;
  try {
    v = std::stoull(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != value.size() || value.empty() || v == 0)
    tacmap::detail::fail("library_demo: ", option, " '", value,
                         "' is not a count; expected a whole number >= 1");
  return v;
}

// Touches every object along its sequence 0, for seeds 1 .. `seeds`; prints one line per run and
// the passes per object. Returns the number of runs that failed.
std::size_t sweep(std::uint64_t seeds, bool ideal) {
  const std::vector<demo_object> objects = make_objects();
  std::vector<std::size_t> passed(objects.size(), 0);
  std::printf("%4s %-10s %12s %12s %10s %9s %-11s %6s %15s\n", "seed", "touched", "recognized",
              "P(touched)", "leading", "error mm", "verdict", "pass", "known: error mm");
  for (std::uint64_t seed = 1; seed <= seeds; ++seed) {
    library lib = build_library(objects, demo_config(seed, ideal));
    for (std::size_t k = 0; k < objects.size(); ++k) {
      const run_result run = touch_object(lib, k, 0, false);
      // The first touch (1-based) from which the touched object stays recognized (leading with
      // P > 0.9); 0 when it is not at the last touch.
      std::size_t from = 0;
      for (std::size_t t = 0; t < run.touches.size(); ++t) {
        const auto& r = run.touches[t].result;
        const bool ok =
            static_cast<std::size_t>(r.object) == k && r.object_probability[k] > recognized_above;
        from = !ok ? 0 : from == 0 ? t + 1 : from;
      }
      const touch_outcome& last = run.touches.back();
      const std::string error = std::isfinite(last.error_mm) ? fixed(last.error_mm, 2) : "-";
      std::printf("%4llu %-10s %12s %12s %10s %9s %-11s %6s %15.2f\n",
                  static_cast<unsigned long long>(seed), objects[k].name.c_str(),
                  from > 0 ? ("touch " + std::to_string(from)).c_str() : "no",
                  probability_text(last.result.object_probability[k]).c_str(),
                  last.result.object_name.c_str(), error.c_str(),
                  tacmap::to_string(last.result.verdict), run.passed() ? "yes" : "NO",
                  last.known_error_mm);
      passed[k] += run.passed() ? 1U : 0U;
    }
  }
  std::size_t total = 0;
  std::printf("passed (the touched object leads with P > 0.9 and error < 5 mm at touch 7):\n");
  for (std::size_t k = 0; k < objects.size(); ++k) {
    std::printf("  %-10s %zu of %llu seeds\n", objects[k].name.c_str(), passed[k],
                static_cast<unsigned long long>(seeds));
    total += passed[k];
  }
  const std::size_t runs = objects.size() * static_cast<std::size_t>(seeds);
  std::printf("  all        %zu of %zu runs\n", total, runs);
  return runs - total;
}

}  // namespace

int main(int argc, char** argv) try {
  std::filesystem::path out_dir = "tacmap-demo-output";
  std::string touched = "gecko";
  std::uint64_t seed = 1;
  std::optional<std::uint64_t> sweep_seeds;
  bool ideal = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) tacmap::detail::fail("library_demo: ", arg, " needs a value");
      return argv[++i];
    };
    if (arg == "--help" || arg == "-h") {
      std::printf(
          "usage: library_demo [--object NAME] [--seed N] [--ideal] [output-folder]\n"
          "       library_demo --sweep N [--ideal]\n"
          "  Touches one object of a library of five (gecko, horse, bumps, nameplate, gear) in\n"
          "  the realistic scenario and localizes the touches over the whole library with\n"
          "  tacmap::library_localizer: which object, and where. Prints every object's posterior\n"
          "  per touch and writes library_demo.png into output-folder\n"
          "  (default: ./tacmap-demo-output).\n"
          "  --object NAME  the object touched (default: gecko, its protocol's sequence 0)\n"
          "  --seed N       the simulation's seed (default: 1)\n"
          "  --ideal        press each map's own image with a new sensor instead of the\n"
          "                 realistic scenario (camera maps, misregistration, press jitter,\n"
          "                 worn sensor)\n"
          "  --sweep N      touch every object for seeds 1 .. N and count the passes (no figure)\n"
          "  Exit status 0 when the touched object leads with P > 0.9 and the error on it is\n"
          "  below 5 mm at the last touch (--sweep: in every run).\n");
      return 0;
    }
    if (arg == "--object")
      touched = value();
    else if (arg == "--seed")
      seed = parse_count(arg, value());
    else if (arg == "--ideal")
      ideal = true;
    else if (arg == "--sweep")
      sweep_seeds = parse_count(arg, value());
    else if (arg.starts_with("-"))
      tacmap::detail::fail("library_demo: unknown option '", arg,
                           "'; expected [--object NAME] [--seed N] [--ideal] [--sweep N] "
                           "[output-folder] "
                           "(--help for details)");
    else
      out_dir = arg;
  }
  if (sweep_seeds) return sweep(*sweep_seeds, ideal) == 0 ? 0 : 1;

  const std::vector<demo_object> objects = make_objects();
  const std::size_t object = object_index(objects, touched);
  const tacmap::localization_config config = demo_config(seed, ideal);
  library lib = build_library(objects, config);
  const run_result run = touch_object(lib, object, 0, true);
  std::printf(
      "tacmap library demo: %zu touches on the %s (its protocol's sequence 0), localized over a "
      "library of %zu objects by tacmap::library_localizer, which is not told the object\n",
      run.touches.size(), objects[object].name.c_str(), objects.size());
  std::printf(
      "model: %s (the library's default); %s; seed %llu; known: the same touches, the object "
      "known\n",
      config.name().c_str(), scenario_words(ideal).c_str(), static_cast<unsigned long long>(seed));
  print_run(run, objects);
  std::filesystem::create_directories(out_dir);
  const std::filesystem::path png = std::filesystem::absolute(out_dir / "library_demo.png");
  write_figure(png, run, lib, objects,
               {"library_demo: which object, and where? " + std::to_string(run.touches.size()) +
                    " touches on the " + objects[object].name + ", localized over a library of " +
                    std::to_string(objects.size()) + " objects",
                "model: " + config.name() + " (the library's default), every object; " +
                    scenario_words(ideal) + "; seed " + std::to_string(seed)});
  const bool ok = run.passed();
  std::printf("%s at the last touch: the %s %s\n",
              ok ? "recognized and localized" : "NOT recognized and localized",
              objects[object].name.c_str(),
              ok ? "leads with P > 0.9 and the error is below 5 mm"
                 : "does not lead with P > 0.9 within 5 mm");
  std::printf(
      "figure (one row per touch: the tactile image, the object posteriors as bars, the belief "
      "on the leading object's map; its key inside):\n  %s\n",
      png.string().c_str());
  return ok ? 0 : 1;
} catch (const std::exception& e) {
  std::fprintf(stderr, "library_demo: %s\n", e.what());
  return 2;
}
