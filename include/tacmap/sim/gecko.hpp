// tacmap: the bundled gecko — a synthetic stand-in for the paper's 3D-printed gecko (Sec. IV)
// and its touch protocol, generated in code so that data/gecko/ can be regenerated and checked.
//
// The map: a 120 x 120 px image at 3.4/3 mm per px (the paper's resolution: 3 px per 3.4 mm
// taxel) of a gecko seen from above — bright object on a dark base, drawn from simple shapes:
// an elliptical body with three dark spots (holes in the print), a neck, a head turned to the
// left with two eye holes, four legs in a walking pose (left fore and right hind reaching
// forward, the other two back) with five toes each ending in round pads, and a tail that curls
// to the right, with two holes along it. The pose makes it asymmetric, so that every part looks
// different through the 42 x 18 px sensor window. Edges are anti-aliased (4 x 4 samples per
// pixel); the relief is the paper's binary protrusion: 4 mm where the image is above 0.5.
//
// The protocol (the paper's experiment, Sec. IV-B): 7 touch locations on the gecko, chosen by
// hand so that each window holds object edges and features (head, both hands, a hind foot,
// body, tail, tail curl), visited in 22 sequences. Sequence 0 follows the paper's Fig. 5 path
// (from the right to the left, from the bottom to the top); sequences 1-21 are distinct random
// orders from the seed. Every move is recorded twice: the true displacement between the
// locations and the "measured" one of the arm, truth plus N(0, 0.5 mm) per axis.
//
// Everything here is deterministic (sim_rng, fixed shapes); the files in data/gecko/ are
// exactly `gecko_data_files()`, and a test checks that.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "tacmap/image.hpp"
#include "tacmap/io/image_io.hpp"
#include "tacmap/sim/protocol.hpp"
#include "tacmap/sim/random.hpp"

namespace tacmap {

/// How the gecko data is made; the defaults are what data/gecko/ holds.
struct gecko_params {
  std::uint64_t seed = 2015;       ///< orders of sequences 1.. and the odometry noise
  int sequences = 22;              ///< the paper's 22 exploration paths
  double odometry_sigma_mm = 0.5;  ///< per-axis noise of the measured moves
  int readings_per_location = 20;  ///< the paper's 20 readings per touch
};

namespace detail::gecko {

struct point {
  double x, y;
};

/// One drawing primitive with its bounding box (so most samples are rejected by four compares).
struct primitive {
  enum class kind { disc, capsule, ellipse };
  kind type = kind::disc;
  point a{}, b{};         // disc: centre a; capsule: ends a, b; ellipse: centre a
  double ra = 0, rb = 0;  // disc: radius ra; capsule: radii at a and b; ellipse: semi-axes
  double cs = 1, sn = 0;  // ellipse: rotation
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;

  [[nodiscard]] bool contains(point p) const {
    if (p.x < x0 || p.x > x1 || p.y < y0 || p.y > y1) return false;
    const double dx = p.x - a.x;
    const double dy = p.y - a.y;
    switch (type) {
      case kind::disc:
        return dx * dx + dy * dy <= ra * ra;
      case kind::ellipse: {
        const double u = (dx * cs + dy * sn) / ra;
        const double v = (-dx * sn + dy * cs) / rb;
        return u * u + v * v <= 1.0;
      }
      case kind::capsule: {
        // Distance to the segment; the radius goes linearly from ra to rb along it.
        const double ex = b.x - a.x;
        const double ey = b.y - a.y;
        const double len2 = ex * ex + ey * ey;
        const double t = len2 > 0.0 ? std::clamp((dx * ex + dy * ey) / len2, 0.0, 1.0) : 0.0;
        const double qx = dx - t * ex;
        const double qy = dy - t * ey;
        const double r = ra + t * (rb - ra);
        return qx * qx + qy * qy <= r * r;
      }
    }
    return false;
  }
};

inline primitive disc(point c, double r) {
  return {primitive::kind::disc, c, c, r, r, 1, 0, c.x - r, c.y - r, c.x + r, c.y + r};
}
inline primitive capsule(point a, point b, double ra, double rb) {
  const double r = std::max(ra, rb);
  return {primitive::kind::capsule,
          a,
          b,
          ra,
          rb,
          1,
          0,
          std::min(a.x, b.x) - r,
          std::min(a.y, b.y) - r,
          std::max(a.x, b.x) + r,
          std::max(a.y, b.y) + r};
}
inline primitive ellipse(point c, double ax, double ay, double angle_deg) {
  const double angle = angle_deg * std::numbers::pi / 180.0;
  const double r = std::max(ax, ay);
  return {primitive::kind::ellipse, c,       c,       ax,      ay,     std::cos(angle),
          std::sin(angle),          c.x - r, c.y - r, c.x + r, c.y + r};
}

/// A leg: upper and lower limb, a palm, five toes fanned around the forearm's direction (plus
/// `fan_deg`), each ending in a round pad (geckos' adhesive toe pads).
inline void add_leg(std::vector<primitive>& parts, point shoulder, point elbow, point hand,
                    double fan_deg) {
  parts.push_back(capsule(shoulder, elbow, 3.2, 2.6));
  parts.push_back(capsule(elbow, hand, 2.6, 2.2));
  parts.push_back(disc(hand, 2.8));
  const double base =
      std::atan2(hand.y - elbow.y, hand.x - elbow.x) + fan_deg * std::numbers::pi / 180.0;
  for (int toe = 0; toe < 5; ++toe) {
    const double angle = base + (toe - 2) * 0.55;  // ~31 degrees between toes
    const point tip{hand.x + 7.0 * std::cos(angle), hand.y + 7.0 * std::sin(angle)};
    parts.push_back(capsule(hand, tip, 1.1, 0.9));
    parts.push_back(disc(tip, 1.7));
  }
}

/// The gecko in map pixel coordinates (x along columns, y along rows): parts minus holes.
struct shape {
  std::vector<primitive> parts;
  std::vector<primitive> holes;

  [[nodiscard]] bool contains(point p) const {
    for (const primitive& h : holes)
      if (h.contains(p)) return false;
    for (const primitive& q : parts)
      if (q.contains(p)) return true;
    return false;
  }
};

inline shape gecko_shape() {
  shape g;
  // Spots on the back, eyes, holes along the tail.
  g.holes = {disc({55, 48}, 2.6),   disc({62, 58}, 2.2),     disc({54, 67}, 2.8),
             disc({48.5, 18}, 2.1), disc({58.5, 15.5}, 2.1), disc({60, 98}, 1.9),
             disc({80, 110}, 1.6)};
  // Body, neck, head turned to the left, snout.
  g.parts = {ellipse({58, 58}, 11, 23, 6), ellipse({56, 35}, 7, 8, 0),
             ellipse({54, 22}, 10, 12, -12), ellipse({51, 11}, 6, 6, 0)};
  add_leg(g.parts, {50, 42}, {36, 36}, {30, 24}, 0);    // left fore, reaching forward
  add_leg(g.parts, {66, 43}, {80, 47}, {92, 41}, 10);   // right fore, sideways
  add_leg(g.parts, {51, 74}, {37, 80}, {31, 94}, -10);  // left hind, pushing back
  add_leg(g.parts, {65, 72}, {80, 75}, {87, 63}, 0);    // right hind, reaching forward
  // The tail's centre line, tapering from the body to the curled tip.
  constexpr std::array<std::pair<point, double>, 11> tail{{{{58, 78}, 5.5},
                                                           {{57, 88}, 5.0},
                                                           {{60, 98}, 4.6},
                                                           {{68, 106}, 4.2},
                                                           {{80, 110}, 3.8},
                                                           {{92, 108}, 3.3},
                                                           {{101, 101}, 2.9},
                                                           {{105, 91}, 2.5},
                                                           {{103, 82}, 2.1},
                                                           {{97, 77}, 1.8},
                                                           {{92, 80}, 1.5}}};
  for (std::size_t k = 0; k + 1 < tail.size(); ++k)
    g.parts.push_back(
        capsule(tail[k].first, tail[k + 1].first, tail[k].second, tail[k + 1].second));
  return g;
}

}  // namespace detail::gecko

/// The gecko map: 120 x 120 px, intensities in [0, 1] on the 8-bit grid (what the PGM stores):
/// base 0.1, gecko 0.9, anti-aliased edges.
[[nodiscard]] inline image<float> make_gecko_map() {
  constexpr Eigen::Index size = 120;
  constexpr int sub = 4;
  const detail::gecko::shape gecko = detail::gecko::gecko_shape();
  image<float> map(size, size);
  for (Eigen::Index r = 0; r < size; ++r)
    for (Eigen::Index c = 0; c < size; ++c) {
      int inside = 0;
      for (int a = 0; a < sub; ++a)
        for (int b = 0; b < sub; ++b)
          inside += gecko.contains({static_cast<double>(c) + (b + 0.5) / sub,
                                    static_cast<double>(r) + (a + 0.5) / sub})
                        ? 1
                        : 0;
      const double coverage = static_cast<double>(inside) / (sub * sub);
      const long level = std::lround(255.0 * (0.1 + 0.8 * coverage));
      map(r, c) = static_cast<float>(level) / 255.0F;
    }
  return map;
}

/// The 7 touch locations on the gecko (sensor centres, mm), in the order of the paper's
/// Fig.\ 5 path: from the right to the left and from the bottom to the top. Each is the centre
/// of a planar_grid state of the paper's grid (window 18 x 42 px), rounded to 0.1 um.
[[nodiscard]] inline std::vector<touch_location> gecko_locations() {
  // Window top-left pixels (row i, col j); centre = ((j + 9) s, (i + 21) s).
  constexpr std::array<std::pair<int, int>, 7> top_left{{
      {66, 88},  // tail curl
      {60, 60},  // tail and right hind leg
      {40, 78},  // right hind foot and right hand
      {60, 20},  // left hind foot
      {24, 49},  // body with the back spots
      {2, 21},   // left hand
      {0, 45},   // head with the eyes
  }};
  const double s = 3.4 / 3.0;
  std::vector<touch_location> out;
  for (const auto& [i, j] : top_left)
    out.push_back({std::round((j + 9) * s * 1e4) / 1e4, std::round((i + 21) * s * 1e4) / 1e4});
  return out;
}

/// The gecko protocol (map, relief, locations, sequences) as `gecko_params` describes it.
[[nodiscard]] inline touch_protocol make_gecko_protocol(const gecko_params& params = {}) {
  if (params.sequences < 1)
    detail::fail("make_gecko_protocol: sequences = ", params.sequences, "; expected >= 1");
  if (!(std::isfinite(params.odometry_sigma_mm) && params.odometry_sigma_mm >= 0.0))
    detail::fail("make_gecko_protocol: odometry_sigma_mm = ", params.odometry_sigma_mm,
                 "; expected a finite standard deviation >= 0 in millimetres");
  if (params.readings_per_location < 1)
    detail::fail("make_gecko_protocol: readings_per_location = ", params.readings_per_location,
                 "; expected >= 1");
  touch_protocol p;
  p.map_file = "gecko_map.pgm";
  p.map = make_gecko_map();
  p.mm_per_px = 3.4 / 3.0;
  p.relief = {
      .kind = relief_kind::binary, .threshold = 0.5F, .height_mm = 4.0, .edge_smoothing_px = 0.0};
  p.locations = gecko_locations();
  p.readings_per_location = params.readings_per_location;
  p.odometry_sigma_mm = params.odometry_sigma_mm;
  p.seed = params.seed;

  const std::size_t n = p.locations.size();
  // 7! = 5040 orders; more sequences than that cannot all be distinct.
  std::size_t orders = 1;
  for (std::size_t k = 2; k <= n; ++k) orders *= k;
  if (static_cast<std::size_t>(params.sequences) > orders)
    detail::fail("make_gecko_protocol: sequences = ", params.sequences, "; expected at most ",
                 orders, " (the distinct orders of ", n, " locations)");

  sim_rng order_rng(params.seed);
  sim_rng noise_rng(params.seed ^ 0x6765636B6FULL);  // "gecko": a second, independent stream
  std::vector<std::vector<std::size_t>> visits;
  std::vector<std::size_t> paper_order(n);
  for (std::size_t k = 0; k < n; ++k) paper_order[k] = k;
  visits.push_back(paper_order);
  while (visits.size() < static_cast<std::size_t>(params.sequences)) {
    std::vector<std::size_t> order = paper_order;
    for (std::size_t k = n - 1; k > 0; --k) std::swap(order[k], order[order_rng.below(k + 1)]);
    if (std::find(visits.begin(), visits.end(), order) == visits.end()) visits.push_back(order);
  }
  const auto round4 = [](double v) { return std::round(v * 1e4) / 1e4; };
  for (const auto& order : visits)
    p.sequences.push_back(
        sequence_visiting(p.locations, order, params.odometry_sigma_mm, noise_rng, round4));
  return p;
}

/// One file of the bundled data: its name inside data/gecko/ and its exact bytes.
struct data_file {
  std::string name;
  std::string bytes;
};

/// The files of data/gecko/, byte for byte (tools/generate_gecko_data writes them).
[[nodiscard]] inline std::vector<data_file> gecko_data_files(const gecko_params& params = {}) {
  const touch_protocol p = make_gecko_protocol(params);
  const std::string origin =
      "generated by tacmap (include/tacmap/sim/gecko.hpp, tools/generate_gecko_data); CC0-1.0";
  return {
      {p.map_file,
       encode_pgm(p.map, "tacmap gecko map, 120 x 120 px at 3.4/3 mm per px; " + origin)},
      {"protocol.txt", format_manifest(p, "tacmap gecko protocol; " + origin)},
      {p.locations_file, format_locations(p.locations)},
      {p.sequences_file, format_sequences(p.sequences)},
  };
}

}  // namespace tacmap
