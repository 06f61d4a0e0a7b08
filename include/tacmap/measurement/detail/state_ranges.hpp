// tacmap: ranges of states for the tracking hook (`log_likelihood_on`, measurement/concept.hpp):
// what a model's tiles or a latent grid's blocks make of the filter's list of states.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <span>
#include <vector>

#include "tacmap/measurement/concept.hpp"
#include "tacmap/measurement/detail/distance_kernel.hpp"

namespace tacmap::detail {

/// The tiles of `width` positions that cover `states` (sorted, disjoint ranges of [0, n)), as
/// few ranges of whole tiles as possible (touching or overlapping ones merged), into `out`.
inline void covering_tiles(std::span<const state_range> states, Eigen::Index width, Eigen::Index n,
                           std::vector<tile_range>& out) {
  out.clear();
  for (const state_range& r : states) {
    const Eigen::Index b = std::max<Eigen::Index>(r.begin, 0);
    const Eigen::Index e = std::min(r.end, n);
    if (b >= e) continue;
    const Eigen::Index tb = b / width, te = (e + width - 1) / width;
    if (!out.empty() && tb <= out.back().end)
      out.back().end = std::max(out.back().end, te);
    else
      out.push_back({tb, te});
  }
}

/// The positions of tile range `t` (of `width`) that exist in [0, n).
inline state_range tile_positions(const tile_range& t, Eigen::Index width, Eigen::Index n) {
  return {t.begin * width, std::min(t.end * width, n)};
}

/// Sorts half-open ranges (anything with `begin` and `end`: state_range, tile_range) by their
/// start and merges those that overlap or touch, in place.
template <class Range>
void sort_and_merge(std::vector<Range>& ranges) {
  std::sort(ranges.begin(), ranges.end(),
            [](const Range& a, const Range& c) { return a.begin < c.begin; });
  std::size_t kept = 0;
  for (std::size_t i = 0; i < ranges.size(); ++i) {
    if (kept > 0 && ranges[i].begin <= ranges[kept - 1].end)
      ranges[kept - 1].end = std::max(ranges[kept - 1].end, ranges[i].end);
    else
      ranges[kept++] = ranges[i];
  }
  ranges.resize(kept);
}

/// The union over `blocks` blocks of `size` states of `states` (ranges of the whole latent
/// grid, sorted, disjoint) taken modulo `size`: the base grid's states any block needs, sorted
/// and merged, into `out` (the latent models compute every hypothesis on them in one pass).
inline void project_to_block(std::span<const state_range> states, Eigen::Index size,
                             std::vector<state_range>& out) {
  out.clear();
  for (const state_range& r : states) {
    Eigen::Index b = r.begin;
    while (b < r.end) {
      const Eigen::Index block = b / size;
      const Eigen::Index e = std::min(r.end, (block + 1) * size);
      out.push_back({b - block * size, e - block * size});
      b = e;
    }
  }
  sort_and_merge(out);
}

/// The states of block `h` (of `size`) in `states`, shifted to the block's own indices.
inline void block_ranges(std::span<const state_range> states, Eigen::Index h, Eigen::Index size,
                         std::vector<state_range>& out) {
  out.clear();
  const Eigen::Index lo = h * size, hi = lo + size;
  for (const state_range& r : states) {
    const Eigen::Index b = std::max(r.begin, lo), e = std::min(r.end, hi);
    if (b < e) out.push_back({b - lo, e - lo});
  }
}

}  // namespace tacmap::detail
