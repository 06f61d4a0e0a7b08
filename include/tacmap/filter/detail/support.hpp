// tacmap: the support of a concentrated belief, for the filter's tracking mode
// (`bayes_filter::set_tracking`): states with p >= t for a threshold t below which the belief
// holds at most epsilon of its mass, found with passes over the grid or over the region the
// mass can be in (no sort of 300,000 states).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <span>
#include <vector>
#include <xsimd/xsimd.hpp>

#include "tacmap/measurement/concept.hpp"
#include "tacmap/motion/concept.hpp"
#include "tacmap/simd.hpp"

namespace tacmap::detail {

/// Candidate thresholds tried in one pass: geometric between epsilon / n (below which the mass
/// is < n * epsilon / n = epsilon whatever the belief) and the belief's maximum.
inline constexpr std::size_t support_candidates = 16;

/// mass[k] = sum of the p(i) < t[k] over the states of `ranges` (sorted, disjoint): one pass,
/// every candidate at once. Float lanes summed over blocks of 1024 states, then in double: the
/// sums of small masses keep ~1e-6 relative error. The lanes carry on from one range to the
/// next (a region's ranges are box rows of a few dozen states: reducing every
/// candidate's lanes per range cost more than the comparisons), flushed to double every 1024
/// states.
template <class T>
std::array<double, support_candidates> mass_below_on(const T* p,
                                                     std::span<const state_range> ranges,
                                                     const std::array<T, support_candidates>& t) {
  using batch = xsimd::batch<T, kernel_arch<T>>;
  constexpr auto width = static_cast<Eigen::Index>(batch::size);
  constexpr std::size_t K = support_candidates;
  std::array<double, K> out{};
  std::array<batch, K> tb;
  for (std::size_t k = 0; k < K; ++k) tb[k] = batch(t[k]);
  std::array<batch, K> acc;
  acc.fill(batch(T(0)));
  batch everywhere(T(0));
  Eigen::Index since = 0;
  const auto flush = [&] {
    const auto common = static_cast<double>(xsimd::hadd(everywhere));
    for (std::size_t k = 0; k < K; ++k) {
      out[k] += common + static_cast<double>(xsimd::hadd(acc[k]));
      acc[k] = batch(T(0));
    }
    everywhere = batch(T(0));
    since = 0;
  };
  for (const state_range& r : ranges) {
    Eigen::Index i = r.begin;
    for (; i + width <= r.end; i += width) {
      const batch v = batch::load_unaligned(p + i);
      if (xsimd::none(v >= tb[0])) {
        everywhere += v;
      } else {
        for (std::size_t k = 0; k < K; ++k) acc[k] += xsimd::select(v < tb[k], v, batch(T(0)));
      }
      if ((since += width) >= 1024) flush();
    }
    for (; i < r.end; ++i)
      for (std::size_t k = 0; k < K; ++k)
        if (p[i] < t[k]) out[k] += static_cast<double>(p[i]);
  }
  flush();
  return out;
}

/// `mass_below_on` over the states [0, n).
template <class T>
std::array<double, support_candidates> mass_below(const T* p, Eigen::Index n,
                                                  const std::array<T, support_candidates>& t) {
  const state_range all{0, n};
  return mass_below_on(p, std::span<const state_range>(&all, 1), t);
}

/// The geometric candidate thresholds between epsilon / n and 1 (see `support_threshold`).
template <class T>
std::array<T, support_candidates> support_candidate_thresholds(Eigen::Index n, double epsilon) {
  constexpr std::size_t K = support_candidates;
  const double lo = epsilon / static_cast<double>(std::max<Eigen::Index>(n, 1));
  const double hi = std::max(1.0, lo);
  const double ratio = std::pow(hi / lo, 1.0 / static_cast<double>(K - 1));
  std::array<T, K> t{};
  for (std::size_t k = 0; k < K; ++k)
    t[k] = static_cast<T>(lo * std::pow(ratio, static_cast<double>(k)));
  return t;
}

/// The largest candidate threshold whose mass below is <= epsilon.
template <class T>
T best_threshold(const std::array<T, support_candidates>& t,
                 const std::array<double, support_candidates>& below, double epsilon) {
  T best = t[0];
  for (std::size_t k = 1; k < support_candidates; ++k)
    if (below[k] <= epsilon) best = t[k];
  return best;
}

/// The largest candidate threshold t whose mass below is <= epsilon (see `mass_below`); the
/// support {p >= t} then holds >= 1 - epsilon of the mass. Candidates are geometric between
/// epsilon / n and 1: within a factor (n / epsilon)^(1/15) (5.8 for 547,000 states and 1e-6)
/// of the exact threshold of the smallest such set.
template <class T>
T support_threshold(const T* p, Eigen::Index n, double epsilon) {
  const auto t = support_candidate_thresholds<T>(n, epsilon);
  return best_threshold(t, mass_below(p, n, t), epsilon);
}

/// `support_threshold` over the states of `ranges` only (sorted, disjoint): the largest
/// candidate whose mass below, among those states, is <= epsilon.
template <class T>
T support_threshold_on(const T* p, std::span<const state_range> ranges, double epsilon) {
  Eigen::Index n = 0;
  for (const state_range& r : ranges) n += r.end - r.begin;
  const auto t = support_candidate_thresholds<T>(n, epsilon);
  return best_threshold(t, mass_below_on(p, ranges, t), epsilon);
}

/// What `support_ranges` found.
struct support_summary {
  Eigen::Index states = 0;  ///< states with p >= t
  double outside = 0.0;     ///< the mass of the others
  bool too_wide = false;    ///< stopped: more than the allowed states
};

/// The ranges of consecutive states in [begin, end) with p >= t, appended to `out` (a range
/// that continues the last one extends it), their count and the others' mass added to `s`.
/// Stops (too_wide) as soon as more than `max_states` states are in.
template <class T>
void append_support(const T* p, Eigen::Index begin, Eigen::Index end, T t, Eigen::Index max_states,
                    std::vector<state_range>& out, support_summary& s) {
  using batch = xsimd::batch<T, kernel_arch<T>>;
  constexpr auto width = static_cast<Eigen::Index>(batch::size);
  const batch tb(t);
  Eigen::Index open = -1;  // first state of the range being built, or -1
  batch outside(T(0));
  Eigen::Index since_flush = 0;
  const auto close = [&](Eigen::Index at) {
    if (!out.empty() && out.back().end == open)
      out.back().end = at;
    else
      out.push_back({open, at});
    open = -1;
  };
  const auto flush = [&] {
    s.outside += static_cast<double>(xsimd::hadd(outside));
    outside = batch(T(0));
    since_flush = 0;
  };
  const auto lane = [&](Eigen::Index i) {
    if (p[i] >= t) {
      if (open < 0) open = i;
      ++s.states;
    } else {
      s.outside += static_cast<double>(p[i]);
      if (open >= 0) close(i);
    }
  };
  const Eigen::Index vec_end = begin + (end - begin) - (end - begin) % width;
  for (Eigen::Index i = begin; i < vec_end; i += width) {
    const batch v = batch::load_unaligned(p + i);
    const auto in = v >= tb;
    if (xsimd::none(in)) {
      outside += v;
      if (open >= 0) close(i);
      if (++since_flush == 128) flush();
    } else if (xsimd::all(in)) {
      if (open < 0) open = i;
      s.states += width;
    } else {
      for (Eigen::Index l = 0; l < width; ++l) lane(i + l);
    }
    if (s.states > max_states) {
      s.too_wide = true;
      flush();
      return;
    }
  }
  for (Eigen::Index i = vec_end; i < end; ++i) lane(i);
  flush();
  if (open >= 0) close(end);
  s.too_wide = s.states > max_states;
}

/// The ranges of consecutive states with p >= t, into `out`, and the mass outside them. Stops
/// (too_wide) as soon as more than `max_states` states are in: the caller takes the whole grid.
template <class T>
support_summary support_ranges(const T* p, Eigen::Index n, T t, Eigen::Index max_states,
                               std::vector<state_range>& out) {
  out.clear();
  support_summary s;
  append_support(p, 0, n, t, max_states, out, s);
  return s;
}

/// `support_ranges` over the states of `ranges` only (sorted, disjoint): `outside` is then the
/// mass of their states below t.
template <class T>
support_summary support_ranges_on(const T* p, std::span<const state_range> ranges, T t,
                                  Eigen::Index max_states, std::vector<state_range>& out) {
  out.clear();
  support_summary s;
  for (const state_range& r : ranges) {
    append_support(p, r.begin, r.end, t, max_states, out, s);
    if (s.too_wide) break;
  }
  return s;
}

// --- The sample of the whole grid a tracked update checks its doubt against ---

/// Every `every`-th row of the belief image from row `offset` (mod `every`), in every one of its
/// `layers`: whole rows, so that a model that streams tiles of a row pays for the sampled states
/// only. Sorted, disjoint, into `out`.
///
/// `max_layers` > 0 caps the sample at that many layers' worth of rows: with more layers (the
/// headings of an (x, y, theta) grid, times its appearance blocks) k = ceil(layers / max_layers)
/// > 1, and the sample is every `every`-th row of the layers a = c (mod k) only: one heading of
/// every appearance block, so that the model describes the touch at one more heading, not at
/// all of them. Consecutive offsets take the next c; every k offsets, the next row. Every row
/// of every layer is sampled once in k every touches. k = 1 is the rule above.
inline void sample_rows(Eigen::Index rows, Eigen::Index cols, Eigen::Index layers,
                        Eigen::Index every, Eigen::Index offset, std::vector<state_range>& out,
                        Eigen::Index max_layers = 0) {
  out.clear();
  if (every <= 0 || rows <= 0 || cols <= 0 || layers <= 0) return;
  const Eigen::Index k = max_layers > 0 ? (layers + max_layers - 1) / max_layers : 1;
  // Layers a = phase (mod k): one heading of every appearance block, the next touch the next
  // (k = 1: phase 0, every layer, the rows from offset mod every).
  const Eigen::Index o = ((offset % (k * every)) + k * every) % (k * every);
  const Eigen::Index phase = o % k, first = o / k;
  for (Eigen::Index a = phase; a < layers; a += k)
    for (Eigen::Index r = first; r < rows; r += every) {
      const Eigen::Index begin = (a * rows + r) * cols;
      out.push_back({begin, begin + cols});
    }
}

/// The states of `a` not in `b` (both sorted and disjoint), sorted and disjoint, into `out`.
inline void ranges_minus(std::span<const state_range> a, std::span<const state_range> b,
                         std::vector<state_range>& out) {
  out.clear();
  std::size_t j = 0;
  for (state_range r : a) {
    while (j < b.size() && b[j].end <= r.begin) ++j;
    Eigen::Index at = r.begin;
    for (std::size_t k = j; k < b.size() && b[k].begin < r.end; ++k) {
      if (b[k].begin > at) out.push_back({at, b[k].begin});
      at = std::max(at, b[k].end);
    }
    if (at < r.end) out.push_back({at, r.end});
  }
}

/// The union of two disjoint sets of sorted, disjoint ranges (touching ranges joined), into
/// `out`.
inline void ranges_union(std::span<const state_range> a, std::span<const state_range> b,
                         std::vector<state_range>& out) {
  out.clear();
  std::size_t i = 0, j = 0;
  while (i < a.size() || j < b.size()) {
    const state_range r =
        j == b.size() || (i < a.size() && a[i].begin < b[j].begin) ? a[i++] : b[j++];
    if (!out.empty() && out.back().end >= r.begin)
      out.back().end = std::max(out.back().end, r.end);
    else
      out.push_back(r);
  }
}

// --- The region a tracked belief's mass is in (boxes on the belief image, every layer) ---

/// Boxes `a` and `b` overlap once each is grown by `gap` cells on every side.
inline bool boxes_meet(const grid_box& a, const grid_box& b, Eigen::Index gap) {
  return a.row - gap < b.row + b.rows && b.row - gap < a.row + a.rows &&
         a.col - gap < b.col + b.cols && b.col - gap < a.col + a.cols;
}

/// The smallest box holding `a` and `b`.
inline grid_box box_union(const grid_box& a, const grid_box& b) {
  const Eigen::Index r0 = std::min(a.row, b.row), c0 = std::min(a.col, b.col);
  const Eigen::Index r1 = std::max(a.row + a.rows, b.row + b.rows);
  const Eigen::Index c1 = std::max(a.col + a.cols, b.col + b.cols);
  return {r0, c0, r1 - r0, c1 - c0};
}

/// Merges boxes that come within `gap` cells of each other into their union, until none do:
/// the result's boxes are pairwise disjoint (more than `gap` cells apart) and cover the input.
inline void merge_boxes(std::vector<grid_box>& boxes, Eigen::Index gap) {
  for (bool merged = true; merged;) {
    merged = false;
    for (std::size_t i = 0; i < boxes.size() && !merged; ++i)
      for (std::size_t j = i + 1; j < boxes.size(); ++j)
        if (boxes_meet(boxes[i], boxes[j], gap)) {
          boxes[i] = box_union(boxes[i], boxes[j]);
          boxes.erase(boxes.begin() + static_cast<std::ptrdiff_t>(j));
          merged = true;
          break;
        }
  }
}

/// Boxes on a `rows x cols` belief image covering every state of `ranges` (of a grid of layers
/// of rows * cols states, layers united), states within `gap` cells of each other in one box.
/// More than `max_boxes` boxes become their bounding box. Empty for empty ranges.
inline std::vector<grid_box> cluster_boxes(std::span<const state_range> ranges, Eigen::Index rows,
                                           Eigen::Index cols, Eigen::Index gap,
                                           std::size_t max_boxes) {
  std::vector<grid_box> boxes;
  const Eigen::Index plane = rows * cols;
  const auto add = [&](const grid_box& b) {
    for (grid_box& c : boxes)
      if (boxes_meet(c, b, gap)) {
        c = box_union(c, b);
        return;
      }
    boxes.push_back(b);
  };
  for (const state_range& r : ranges) {
    // Layer by layer, then as rows: a partial first row, whole rows, a partial last row.
    for (Eigen::Index b = r.begin; b < r.end;) {
      const Eigen::Index layer_end = (b / plane + 1) * plane;
      const Eigen::Index e = std::min(r.end, layer_end);
      const Eigen::Index lb = b % plane, le = lb + (e - b);  // [lb, le) in the layer
      const Eigen::Index first = lb / cols, last = (le - 1) / cols;
      if (first == last) {
        add({first, lb % cols, 1, le - lb});
      } else {
        add({first, lb % cols, 1, cols - lb % cols});
        if (last > first + 1) add({first + 1, 0, last - first - 1, cols});
        add({last, 0, 1, le - last * cols});
      }
      b = e;
    }
  }
  merge_boxes(boxes, gap);
  if (boxes.size() > max_boxes) {
    grid_box all = boxes.front();
    for (const grid_box& b : boxes) all = box_union(all, b);
    boxes.assign(1, all);
  }
  return boxes;
}

/// The states of `boxes` (pairwise disjoint) in each of `layers` layers of rows * cols states,
/// as sorted state ranges (one per box row and layer, adjacent ones joined).
inline void box_ranges(std::span<const grid_box> boxes, Eigen::Index rows, Eigen::Index cols,
                       Eigen::Index layers, std::vector<state_range>& out) {
  struct segment {
    Eigen::Index row, col, cols;
  };
  std::vector<segment> seg;
  for (const grid_box& b : boxes)
    for (Eigen::Index r = b.row; r < b.row + b.rows; ++r) seg.push_back({r, b.col, b.cols});
  std::sort(seg.begin(), seg.end(), [](const segment& x, const segment& y) {
    return x.row != y.row ? x.row < y.row : x.col < y.col;
  });
  out.clear();
  for (Eigen::Index a = 0; a < layers; ++a)
    for (const segment& s : seg) {
      const Eigen::Index begin = a * rows * cols + s.row * cols + s.col;
      if (!out.empty() && out.back().end == begin)
        out.back().end = begin + s.cols;
      else
        out.push_back({begin, begin + s.cols});
    }
}

/// Sum of p over the states of `a` that are not in `b` (both sorted, disjoint), in double.
template <class T>
double mass_outside_of(const T* p, std::span<const state_range> a, std::span<const state_range> b) {
  double sum = 0.0;
  std::size_t j = 0;
  for (const state_range& r : a) {
    Eigen::Index at = r.begin;
    while (at < r.end) {
      while (j < b.size() && b[j].end <= at) ++j;
      const Eigen::Index stop = j < b.size() ? std::min(r.end, std::max(at, b[j].begin)) : r.end;
      for (Eigen::Index i = at; i < stop; ++i) sum += static_cast<double>(p[i]);
      at = stop;
      if (j < b.size() && at < r.end && at >= b[j].begin) at = std::min(r.end, b[j].end);
    }
  }
  return sum;
}

/// Sum of p over the states of `boxes` in every layer, in double.
template <class T>
double mass_in(const T* p, std::span<const grid_box> boxes, Eigen::Index rows, Eigen::Index cols,
               Eigen::Index layers) {
  double sum = 0.0;
  for (Eigen::Index a = 0; a < layers; ++a)
    for (const grid_box& b : boxes)
      for (Eigen::Index r = b.row; r < b.row + b.rows; ++r)
        sum += Eigen::Map<const Eigen::Array<T, Eigen::Dynamic, 1>>(
                   p + a * rows * cols + r * cols + b.col, b.cols)
                   .template cast<double>()
                   .sum();
  return sum;
}

}  // namespace tacmap::detail
