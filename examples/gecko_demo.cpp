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

#include "tacmap/io/image_file.hpp"  // write_png_compressed (stb_image_write; tacmap::image_file)
#include "tacmap/io/image_io.hpp"
#include "tacmap/io/png_rgb.hpp"
#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/protocol.hpp"

// stb's quad font for the figure's text (ASCII, from libstb-dev like image_file.hpp's stb):
// all its functions are static, and its warnings are stb's.
#if defined(__clang__)
#pragma clang diagnostic push
#pragma clang diagnostic ignored "-Weverything"
#elif defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wold-style-cast"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#pragma GCC diagnostic ignored "-Wuseless-cast"
#endif
#if __has_include(<stb/stb_easy_font.h>)
#include <stb/stb_easy_font.h>
#else
#include <stb_easy_font.h>
#endif
#if defined(__clang__)
#pragma clang diagnostic pop
#elif defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

#ifndef TACMAP_DATA_DIR
#error "TACMAP_DATA_DIR must name tacmap's data/ folder"
#endif

namespace {

using tacmap::rgb_image;
using index_t = Eigen::Index;

struct colour {
  float r, g, b;
};
constexpr colour black{0.0F, 0.0F, 0.0F}, grey{0.35F, 0.35F, 0.35F};
// Truth and estimate: green and cyan, apart from each other and from the belief's colour map
// (inferno: black, purple, red, orange, yellow); their shapes differ too (solid box and ring
// for the truth, dashed box and cross for the estimate), for readers who do not tell them apart.
constexpr colour truth_colour{0.15F, 0.95F, 0.15F}, estimate_colour{0.0F, 0.85F, 1.0F};
constexpr colour dark_colour{0.95F, 0.55F, 0.1F}, bright_colour{0.25F, 0.45F, 0.85F};

void put(rgb_image& img, index_t row, index_t col, colour c) { img.set(row, col, c.r, c.g, c.b); }

void fill(rgb_image& img, index_t top, index_t left, index_t h, index_t w, colour c) {
  for (index_t r = top; r < top + h; ++r)
    for (index_t x = left; x < left + w; ++x) put(img, r, x, c);
}

// Text through stb_easy_font (stb's quad font: ASCII, 12 px per line at scale 1), each quad
// filled as a `scale` x `scale` px block per font pixel.
struct easy_font_vertex {
  float x, y, z;
  unsigned char rgba[4];
};

index_t text_width(const std::string& s, int scale) {
  std::vector<char> text(s.begin(), s.end());
  text.push_back('\0');
  return static_cast<index_t>(stb_easy_font_width(text.data())) * scale;
}

// Draws `s` with its top-left corner at (top, left); returns the x just after it.
index_t draw_text(rgb_image& img, index_t top, index_t left, const std::string& s, int scale,
                  colour c = black) {
  std::vector<char> text(s.begin(), s.end());
  text.push_back('\0');
  std::vector<easy_font_vertex> quads(s.size() * 4 * 24 + 64);
  const int n = stb_easy_font_print(0.0F, 0.0F, text.data(), nullptr, quads.data(),
                                    static_cast<int>(quads.size() * sizeof(easy_font_vertex)));
  for (int q = 0; q < n; ++q) {
    const easy_font_vertex& a = quads[static_cast<std::size_t>(4 * q)];
    const easy_font_vertex& b = quads[static_cast<std::size_t>(4 * q + 2)];
    const auto at = [scale](float v) {
      return static_cast<index_t>(std::lround(v * static_cast<float>(scale)));
    };
    fill(img, top + at(a.y), left + at(a.x), at(b.y) - at(a.y), at(b.x) - at(a.x), c);
  }
  return left + text_width(s, scale);
}

// Several lines, `line_h` px apart; returns the y below the last.
index_t draw_lines(rgb_image& img, index_t top, index_t left, const std::vector<std::string>& lines,
                   int scale, index_t line_h, colour c = black) {
  for (const auto& line : lines) {
    draw_text(img, top, left, line, scale, c);
    top += line_h;
  }
  return top;
}

// `text` split at spaces into lines at most `max_w` px wide at `scale`.
std::vector<std::string> wrap(const std::string& text, int scale, index_t max_w) {
  std::vector<std::string> lines;
  std::string current;
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find(' ', start);
    if (end == std::string::npos) end = text.size();
    const std::string word = text.substr(start, end - start);
    const std::string longer = current.empty() ? word : current + " " + word;
    if (!current.empty() && text_width(longer, scale) > max_w) {
      lines.push_back(current);
      current = word;
    } else {
      current = longer;
    }
    start = end + 1;
  }
  if (!current.empty()) lines.push_back(current);
  return lines;
}

// A grey image scaled up by `s` (nearest neighbour) with its top-left at (top, left).
void blit_grey(rgb_image& img, const tacmap::image<float>& src, index_t top, index_t left, int s) {
  for (index_t r = 0; r < src.rows() * s; ++r)
    for (index_t c = 0; c < src.cols() * s; ++c) {
      const float v = src(r / s, c / s);
      img.set(top + r, left + c, v, v, v);
    }
}

// Outline of a rectangle in screen px, 2 px thick, with a 1 px black edge outside and inside so
// that it shows on any background; `dashed`: 6 px on, 4 px off.
void draw_box(rgb_image& img, index_t r0, index_t c0, index_t r1, index_t c1, colour c,
              bool dashed) {
  const auto on = [dashed](index_t k) { return !dashed || (k % 10) < 6; };
  const auto ring = [&](index_t inset, colour col, bool dash) {
    for (index_t x = c0 + inset; x <= c1 - inset; ++x)
      if (!dash || on(x - c0)) {
        put(img, r0 + inset, x, col);
        put(img, r1 - inset, x, col);
      }
    for (index_t y = r0 + inset; y <= r1 - inset; ++y)
      if (!dash || on(y - r0)) {
        put(img, y, c0 + inset, col);
        put(img, y, c1 - inset, col);
      }
  };
  if (!dashed) {  // the dashed (estimate) box keeps the truth's box visible through its gaps
    ring(-1, black, false);
    ring(2, black, false);
  }
  ring(0, c, dashed);
  ring(1, c, dashed);
}

// A 1 px black frame just outside the rectangle (r0, c0)-(r1, c1).
void frame(rgb_image& img, index_t r0, index_t c0, index_t r1, index_t c1) {
  fill(img, r0 - 1, c0 - 1, 1, c1 - c0 + 3, black);
  fill(img, r1 + 1, c0 - 1, 1, c1 - c0 + 3, black);
  fill(img, r0 - 1, c0 - 1, r1 - r0 + 3, 1, black);
  fill(img, r0 - 1, c1 + 1, r1 - r0 + 3, 1, black);
}

// The truth's marker: a ring of radius `radius` px (the 5 mm success radius: an estimate inside
// it is "localized"), 2 px thick, with black edges; hollow, so the belief shows inside it.
void draw_ring(rgb_image& img, index_t row, index_t col, double radius) {
  const auto reach = static_cast<index_t>(radius) + 3;
  for (index_t dy = -reach; dy <= reach; ++dy)
    for (index_t dx = -reach; dx <= reach; ++dx) {
      const double d = std::hypot(static_cast<double>(dy), static_cast<double>(dx)) - radius;
      if (d >= -2.0 && d <= 2.0) put(img, row + dy, col + dx, black);
      if (d >= -1.0 && d <= 1.0) put(img, row + dy, col + dx, truth_colour);
    }
}

// The estimate's marker, drawn after (over) the truth's: a "+" reticle with black edges whose
// arms (from `inner` to `outer` px from the centre) leave the centre open, so that the belief's
// peak shows, and fit inside the ring, so that both show when the error is 0.
void draw_cross(rgb_image& img, index_t row, index_t col, index_t inner, index_t outer,
                index_t half_width) {
  for (int pass = 0; pass < 2; ++pass) {
    const colour c = pass == 0 ? black : estimate_colour;
    const index_t edge = pass == 0 ? 1 : 0;
    for (index_t d = inner - edge; d <= outer + edge; ++d)
      for (index_t t = -half_width - edge; t <= half_width - 1 + edge; ++t)
        for (const index_t sign : {-1, 1}) {
          put(img, row + sign * d, col + t, c);
          put(img, row + t, col + sign * d, c);
        }
  }
}

// Horizontal scale bar of `length_mm` at `px_per_mm`, its label to the right.
void draw_scale_bar(rgb_image& img, index_t top, index_t left, double length_mm, double px_per_mm,
                    const std::string& label) {
  const auto w = static_cast<index_t>(std::lround(length_mm * px_per_mm));
  fill(img, top, left, 6, w, black);
  fill(img, top - 4, left, 14, 2, black);
  fill(img, top - 4, left + w - 2, 14, 2, black);
  draw_text(img, top - 5, left + w + 8, label, 2);
}

// inferno (matplotlib's perceptually uniform map, sampled at 9 points): dark = improbable.
colour colour_map(double t) {
  static const std::array<colour, 9> anchors = {{{0.001F, 0.000F, 0.014F},
                                                 {0.129F, 0.047F, 0.291F},
                                                 {0.342F, 0.062F, 0.429F},
                                                 {0.541F, 0.135F, 0.415F},
                                                 {0.736F, 0.216F, 0.330F},
                                                 {0.894F, 0.353F, 0.194F},
                                                 {0.978F, 0.558F, 0.035F},
                                                 {0.975F, 0.798F, 0.206F},
                                                 {0.988F, 0.998F, 0.645F}}};
  const double x = std::clamp(t, 0.0, 1.0) * 8.0;
  const auto i = std::min<std::size_t>(7, static_cast<std::size_t>(x));
  const auto f = static_cast<float>(x - static_cast<double>(i));
  const colour a = anchors[i], b = anchors[i + 1];
  return {a.r + f * (b.r - a.r), a.g + f * (b.g - a.g), a.b + f * (b.b - a.b)};
}

// The belief's colour scale, the same for every panel of both figures: log10 of the
// probability of a grid cell, from 1e-5 (and below, and outside the grid: black) to 1.
constexpr double log_p_min = -5.0, log_p_max = 0.0;
double scale_position(double p) {
  if (!(p > 0.0)) return 0.0;
  return (std::log10(p) - log_p_min) / (log_p_max - log_p_min);
}

// The belief over a panel of `h` x `w` screen px at `zoom` screen px per map px, whose top-left
// corner shows map px (origin_row, origin_col): the state with top-left (br, bc) is drawn at its
// window's centre; places no window centre can reach have probability 0 (black); the map's
// outline in white.
void draw_belief(rgb_image& img, index_t top, index_t left, index_t h, index_t w,
                 const tacmap::image<float>& bel, const tacmap::image<std::uint8_t>& edges,
                 tacmap::pixel_size win, int zoom, double origin_row, double origin_col) {
  for (index_t r = 0; r < h; ++r)
    for (index_t c = 0; c < w; ++c) {
      const auto mr = static_cast<index_t>(std::floor(origin_row + static_cast<double>(r) / zoom));
      const auto mc = static_cast<index_t>(std::floor(origin_col + static_cast<double>(c) / zoom));
      const index_t br = mr - win.height / 2, bc = mc - win.width / 2;
      double p = 0.0;
      if (br >= 0 && bc >= 0 && br < bel.rows() && bc < bel.cols())
        p = static_cast<double>(bel(br, bc));
      colour col = colour_map(scale_position(p));
      if (mr >= 0 && mc >= 0 && mr < edges.rows() && mc < edges.cols() && edges(mr, mc) != 0) {
        constexpr float a = 0.45F;
        col = {(1 - a) * col.r + a, (1 - a) * col.g + a, (1 - a) * col.b + a};
      }
      put(img, top + r, left + c, col);
    }
}

// The map's outline for the belief panels: where a 3 x 3 box-blurred map crosses its mean.
tacmap::image<std::uint8_t> outline(const tacmap::image<float>& map) {
  tacmap::image<float> blur = map;
  for (index_t r = 0; r < map.rows(); ++r)
    for (index_t c = 0; c < map.cols(); ++c) {
      float sum = 0.0F;
      int n = 0;
      for (index_t dr = -1; dr <= 1; ++dr)
        for (index_t dc = -1; dc <= 1; ++dc)
          if (r + dr >= 0 && c + dc >= 0 && r + dr < map.rows() && c + dc < map.cols()) {
            sum += map(r + dr, c + dc);
            ++n;
          }
      blur(r, c) = sum / static_cast<float>(n);
    }
  const float level = blur.mean();
  tacmap::image<std::uint8_t> edge = tacmap::image<std::uint8_t>::Zero(map.rows(), map.cols());
  for (index_t r = 0; r + 1 < map.rows(); ++r)
    for (index_t c = 0; c + 1 < map.cols(); ++c) {
      const bool above = blur(r, c) > level;
      if (above != (blur(r + 1, c) > level) || above != (blur(r, c + 1) > level)) edge(r, c) = 1;
    }
  return edge;
}

std::string fixed(double v, int decimals) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// The figure is checked as CTest runs the demo: it decodes (stb_image) to the size drawn, and
// stays under 500 KB, small enough to attach, commit or open anywhere.
void check_figure(const std::filesystem::path& png, const rgb_image& drawn) {
  const auto bytes = std::filesystem::file_size(png);
  if (bytes >= 500U * 1024U)
    tacmap::detail::fail("gecko_demo: ", png, " is ", bytes / 1024U,
                         " KB; expected a compressed figure under 500 KB");
  const tacmap::image<float> back = tacmap::load_image(png);
  if (back.rows() != drawn.rows() || back.cols() != drawn.cols())
    tacmap::detail::fail("gecko_demo: ", png, " decodes to ", back.rows(), " x ", back.cols(),
                         " px; expected the ", drawn.rows(), " x ", drawn.cols(), " px drawn");
}

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
  // Colour bar beside the belief labels: 1e-5 (black) to 1, one tick per decade, and the
  // level of a uniform belief (no information yet), so that a flat belief is read as such.
  const index_t cb_x = margin + label_w - 86, cb_w = 16;
  for (index_t r = 0; r < panel_h; ++r) {
    const double t = 1.0 - static_cast<double>(r) / static_cast<double>(panel_h - 1);
    fill(fig, y_bel + r, cb_x, 1, cb_w, colour_map(t));
  }
  frame(fig, y_bel, cb_x, y_bel + panel_h - 1, cb_x + cb_w - 1);
  const std::array<const char*, 6> ticks = {"1", "0.1", "0.01", "1e-3", "1e-4", "1e-5"};
  for (std::size_t k = 0; k < ticks.size(); ++k) {
    const index_t y = y_bel + static_cast<index_t>(k) * (panel_h - 1) / 5;
    fill(fig, y, cb_x + cb_w, 1, 5, black);
    draw_text(fig, y - 8, cb_x + cb_w + 8, ticks[k], 2);
  }
  const auto uniform_y =
      y_bel + static_cast<index_t>(std::lround((1.0 - scale_position(1.0 / cells)) *
                                               static_cast<double>(panel_h - 1)));
  fill(fig, uniform_y - 1, cb_x - 10, 3, cb_w + 10, truth_colour);

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
  check_figure(png, fig);
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
  const std::string scenario_words =
      ideal ? "ideal scenario (the sensor presses the map's own image)"
            : "realistic scenario (camera map, misregistration, press jitter, worn sensor)";
  const std::string model_words =
      "model: " + config.name() + " (the library's default); " + scenario_words;
  write_figure(gecko_png, run, experiment.visual_map(),
               experiment.filter().grid().base().window_size(), protocol.mm_per_px, false,
               {"gecko_demo: " + std::to_string(run.touches.size()) +
                    " touches on the bundled gecko (sequence 0, the path of the paper's Fig. 5)",
                model_words});
  std::printf(
      "figure (like the paper's Fig. 5, its key inside; columns = touches; rows = tactile "
      "image, map with the true window green / estimate cyan, belief on a log scale, zoomed "
      "belief, numbers):\n  %s\n\n",
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
               horse_experiment.filter().grid().base().window_size(), horse.mm_per_px, true,
               {"gecko_demo: " + std::to_string(horse_run.touches.size()) +
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
