// Drawing for the examples' figures (gecko_demo, library_demo): text (stb's quad font,
// stb_easy_font), boxes, rings and crosses for the truth and the estimate, the belief on one log10
// probability scale with its colour bar, and the check that a written figure decodes and stays
// small. One place, so that every demo figure reads the same way: green = the truth, cyan = the
// estimate, inferno = the belief from 1e-5 (black) to 1.
//
// Needs stb (Debian libstb-dev: stb_easy_font.h here, stb_image/stb_image_write through
// tacmap::image_file). Header-only, for examples only: not installed with the library.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "tacmap/image.hpp"
#include "tacmap/io/image_file.hpp"  // load_image, to check a written figure
#include "tacmap/io/png_rgb.hpp"

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

namespace tacmap_examples {

using tacmap::rgb_image;
using index_t = Eigen::Index;

struct colour {
  float r, g, b;
};
inline constexpr colour black{0.0F, 0.0F, 0.0F}, grey{0.35F, 0.35F, 0.35F};
// Truth and estimate: green and cyan, apart from each other and from the belief's colour map
// (inferno: black, purple, red, orange, yellow); their shapes differ too (solid box and ring
// for the truth, dashed box and cross for the estimate), for readers who do not tell them apart.
inline constexpr colour truth_colour{0.15F, 0.95F, 0.15F}, estimate_colour{0.0F, 0.85F, 1.0F};

inline void put(rgb_image& img, index_t row, index_t col, colour c) {
  img.set(row, col, c.r, c.g, c.b);
}

inline void fill(rgb_image& img, index_t top, index_t left, index_t h, index_t w, colour c) {
  for (index_t r = top; r < top + h; ++r)
    for (index_t x = left; x < left + w; ++x) put(img, r, x, c);
}

// Text through stb_easy_font (stb's quad font: ASCII, 12 px per line at scale 1), each quad
// filled as a `scale` x `scale` px block per font pixel.
struct easy_font_vertex {
  float x, y, z;
  unsigned char rgba[4];
};

inline index_t text_width(const std::string& s, int scale) {
  std::vector<char> text(s.begin(), s.end());
  text.push_back('\0');
  return static_cast<index_t>(stb_easy_font_width(text.data())) * scale;
}

// Draws `s` with its top-left corner at (top, left); returns the x just after it.
inline index_t draw_text(rgb_image& img, index_t top, index_t left, const std::string& s, int scale,
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
inline index_t draw_lines(rgb_image& img, index_t top, index_t left,
                          const std::vector<std::string>& lines, int scale, index_t line_h,
                          colour c = black) {
  for (const auto& line : lines) {
    draw_text(img, top, left, line, scale, c);
    top += line_h;
  }
  return top;
}

// `text` split at spaces into lines at most `max_w` px wide at `scale`.
inline std::vector<std::string> wrap(const std::string& text, int scale, index_t max_w) {
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
inline void blit_grey(rgb_image& img, const tacmap::image<float>& src, index_t top, index_t left,
                      int s) {
  for (index_t r = 0; r < src.rows() * s; ++r)
    for (index_t c = 0; c < src.cols() * s; ++c) {
      const float v = src(r / s, c / s);
      img.set(top + r, left + c, v, v, v);
    }
}

// Outline of a rectangle in screen px, 2 px thick, with a 1 px black edge outside and inside so
// that it shows on any background; `dashed`: 6 px on, 4 px off.
inline void draw_box(rgb_image& img, index_t r0, index_t c0, index_t r1, index_t c1, colour c,
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
inline void frame(rgb_image& img, index_t r0, index_t c0, index_t r1, index_t c1) {
  fill(img, r0 - 1, c0 - 1, 1, c1 - c0 + 3, black);
  fill(img, r1 + 1, c0 - 1, 1, c1 - c0 + 3, black);
  fill(img, r0 - 1, c0 - 1, r1 - r0 + 3, 1, black);
  fill(img, r0 - 1, c1 + 1, r1 - r0 + 3, 1, black);
}

// The truth's marker: a ring of radius `radius` px (the 5 mm success radius: an estimate inside
// it is "localized"), 2 px thick, with black edges; hollow, so the belief shows inside it.
inline void draw_ring(rgb_image& img, index_t row, index_t col, double radius) {
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
inline void draw_cross(rgb_image& img, index_t row, index_t col, index_t inner, index_t outer,
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
inline void draw_scale_bar(rgb_image& img, index_t top, index_t left, double length_mm,
                           double px_per_mm, const std::string& label) {
  const auto w = static_cast<index_t>(std::lround(length_mm * px_per_mm));
  fill(img, top, left, 6, w, black);
  fill(img, top - 4, left, 14, 2, black);
  fill(img, top - 4, left + w - 2, 14, 2, black);
  draw_text(img, top - 5, left + w + 8, label, 2);
}

// inferno (matplotlib's perceptually uniform map, sampled at 9 points): dark = improbable.
inline colour colour_map(double t) {
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

// The belief's colour scale, the same for every panel of every demo figure: log10 of the
// probability of a grid cell, from 1e-5 (and below, and outside the grid: black) to 1.
inline constexpr double log_p_min = -5.0, log_p_max = 0.0;
inline double scale_position(double p) {
  if (!(p > 0.0)) return 0.0;
  return (std::log10(p) - log_p_min) / (log_p_max - log_p_min);
}

// The belief over a panel of `h` x `w` screen px at `zoom` screen px per map px, whose top-left
// corner shows map px (origin_row, origin_col): the state with top-left (br, bc) is drawn at its
// window's centre; places no window centre can reach have probability 0 (black); the map's
// outline in white.
inline void draw_belief(rgb_image& img, index_t top, index_t left, index_t h, index_t w,
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
inline tacmap::image<std::uint8_t> outline(const tacmap::image<float>& map) {
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

inline std::string fixed(double v, int decimals) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// A vertical colour bar of the belief scale, `height` px from 1 (top) to 1e-5 (bottom) with its
// top-left at (top, left): one tick per decade labelled to its right (about 70 px), and, when
// `flat` > 0, a green mark at that probability — the level of a uniform belief (no information
// yet), so that a flat belief is read as such.
inline void draw_colour_bar(rgb_image& img, index_t top, index_t left, index_t height,
                            double flat) {
  constexpr index_t w = 16;
  for (index_t r = 0; r < height; ++r) {
    const double t = 1.0 - static_cast<double>(r) / static_cast<double>(height - 1);
    fill(img, top + r, left, 1, w, colour_map(t));
  }
  frame(img, top, left, top + height - 1, left + w - 1);
  const std::array<const char*, 6> ticks = {"1", "0.1", "0.01", "1e-3", "1e-4", "1e-5"};
  for (std::size_t k = 0; k < ticks.size(); ++k) {
    const index_t y = top + static_cast<index_t>(k) * (height - 1) / 5;
    fill(img, y, left + w, 1, 5, black);
    draw_text(img, y - 8, left + w + 8, ticks[k], 2);
  }
  if (flat > 0.0) {
    const auto flat_y = top + static_cast<index_t>(std::lround((1.0 - scale_position(flat)) *
                                                               static_cast<double>(height - 1)));
    fill(img, flat_y - 1, left - 10, 3, w + 10, truth_colour);
  }
}

// The figure is checked as CTest runs the demo: it decodes (stb_image) to the size drawn, and
// stays under 500 KB, small enough to attach, commit or open anywhere. `who`: the demo's name,
// for the message.
inline void check_figure(const char* who, const std::filesystem::path& png,
                         const rgb_image& drawn) {
  const auto bytes = std::filesystem::file_size(png);
  if (bytes >= 500U * 1024U)
    tacmap::detail::fail(who, ": ", png, " is ", bytes / 1024U,
                         " KB; expected a compressed figure under 500 KB");
  const tacmap::image<float> back = tacmap::load_image(png);
  if (back.rows() != drawn.rows() || back.cols() != drawn.cols())
    tacmap::detail::fail(who, ": ", png, " decodes to ", back.rows(), " x ", back.cols(),
                         " px; expected the ", drawn.rows(), " x ", drawn.cols(), " px drawn");
}

}  // namespace tacmap_examples
