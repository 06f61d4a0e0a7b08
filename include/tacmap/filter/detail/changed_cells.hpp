// tacmap: which cells of a layered belief image may have changed since some point — what
// `bayes_filter::save_state` copies and what the position statistics recompute, so that a
// tracked touch (which changes a few boxes of the belief image) costs neither a copy of the
// whole belief nor a pass over it.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <vector>

#include "tacmap/measurement/concept.hpp"
#include "tacmap/motion/concept.hpp"

namespace tacmap::detail {

/// The cells of a `rows x cols` belief image that may have changed, the same cells in every
/// layer of a layered belief (a pose grid's headings, a latent grid's hypotheses): per row one
/// span of columns [lo, hi) (what was marked in that row, widened to one span), or everything.
/// Marks only ever grow the set until `clear()`: an over-estimate is always safe, a cell left
/// out is not (it would be neither copied nor recomputed).
class changed_cells {
 public:
  changed_cells() = default;
  changed_cells(Eigen::Index rows, Eigen::Index cols)
      : cols_(cols),
        lo_(static_cast<std::size_t>(rows), cols),
        hi_(static_cast<std::size_t>(rows), 0) {}

  [[nodiscard]] Eigen::Index rows() const { return static_cast<Eigen::Index>(lo_.size()); }
  [[nodiscard]] Eigen::Index cols() const { return cols_; }
  /// Everything may have changed (the initial state: nothing is known yet).
  [[nodiscard]] bool all() const { return all_; }
  void mark_all() { all_ = true; }
  /// Nothing changed since now.
  void clear() {
    all_ = false;
    for (const Eigen::Index r : touched_) {
      lo_[static_cast<std::size_t>(r)] = cols_;
      hi_[static_cast<std::size_t>(r)] = 0;
    }
    touched_.clear();
  }

  /// Row r's changed columns [lo, hi) (lo >= hi: none); meaningful when !all().
  [[nodiscard]] Eigen::Index lo(Eigen::Index r) const { return lo_[static_cast<std::size_t>(r)]; }
  [[nodiscard]] Eigen::Index hi(Eigen::Index r) const { return hi_[static_cast<std::size_t>(r)]; }
  /// The rows with a changed cell, each once, in the order first marked.
  [[nodiscard]] const std::vector<Eigen::Index>& touched_rows() const { return touched_; }

  /// Columns [c0, c1) of row r (clipped to the image).
  void mark(Eigen::Index r, Eigen::Index c0, Eigen::Index c1) {
    if (all_) return;
    c0 = std::max<Eigen::Index>(c0, 0);
    c1 = std::min(c1, cols_);
    if (r < 0 || r >= rows() || c0 >= c1) return;
    const auto ru = static_cast<std::size_t>(r);
    if (lo_[ru] >= hi_[ru]) touched_.push_back(r);
    lo_[ru] = std::min(lo_[ru], c0);
    hi_[ru] = std::max(hi_[ru], c1);
  }
  /// A box of the image (clipped), in every layer.
  void mark(const grid_box& b) {
    for (Eigen::Index r = b.row; r < b.row + b.rows; ++r) mark(r, b.col, b.col + b.cols);
  }
  /// States [begin, end) of a layered belief (layer after layer of rows * cols states), as
  /// cells of the image (in every layer).
  void mark(const state_range& s) {
    if (all_ || s.end <= s.begin) return;
    const Eigen::Index plane = rows() * cols_;
    if (s.end - s.begin >= plane) {
      all_ = true;
      return;
    }
    const Eigen::Index from = s.begin % plane, to = from + (s.end - s.begin);
    if (to <= plane) {
      mark_plane(from, to);
    } else {  // wraps into the next layer
      mark_plane(from, plane);
      mark_plane(0, to - plane);
    }
  }

 private:
  // Cells [from, to) of one layer (0 <= from < to <= rows * cols).
  void mark_plane(Eigen::Index from, Eigen::Index to) {
    const Eigen::Index r0 = from / cols_, r1 = (to - 1) / cols_;
    if (r0 == r1) {
      mark(r0, from % cols_, (to - 1) % cols_ + 1);
      return;
    }
    mark(r0, from % cols_, cols_);
    for (Eigen::Index r = r0 + 1; r < r1; ++r) mark(r, 0, cols_);
    mark(r1, 0, (to - 1) % cols_ + 1);
  }

  Eigen::Index cols_ = 0;
  std::vector<Eigen::Index> lo_, hi_, touched_;
  bool all_ = true;
};

/// A link between a `bayes_filter` and the saved state it last saved into, that copies (and
/// moves) as no link: a copy of either side is a different object, whose saved copy must be
/// taken whole again.
struct save_link {
  const void* other = nullptr;
  save_link() = default;
  save_link(const save_link&) noexcept {}
  save_link& operator=(const save_link&) noexcept {
    other = nullptr;
    return *this;
  }
  ~save_link() = default;
};

}  // namespace tacmap::detail
