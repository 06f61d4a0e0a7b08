// tacmap: the control update of a belief made of blocks — one per hypothesis of a
// `latent_grid`, one per object of a `library_grid` — each block moved by its own motion model,
// the blocks keeping their relative masses.
#pragma once

#include <algorithm>
#include <cmath>
#include <exception>
#include <stdexcept>
#include <utility>
#include <vector>

#include "tacmap/config.hpp"
#include "tacmap/detail/mass_sum.hpp"
#include "tacmap/image.hpp"
#include "tacmap/motion/concept.hpp"

namespace tacmap::detail {

/// What `predict_blocks` leaves for the caller: the total mass before and the mass the blocks
/// kept on their grids.
struct block_masses {
  double before = 0.0;
  double kept = 0.0;
};

/// Moves each of `blocks` blocks of `in` into the same block of `out`: block k is
/// in.segment(span(k).first, span(k).second), handed to `predict(k, block_in, block_out)` (a
/// motion model's predict on that block's grid, returning its `prediction_report`) through the
/// scratch arrays `buffers(k)` returns (a pair of references, resized here).
///
/// Base motion models normalise their own output, so each block goes in normalised and comes
/// out scaled back to the mass it kept (its mass before, times one minus the fraction it lost
/// off its grid), relative to the largest kept mass: blocks keep their relative weights
/// through a prediction, however unlikely one has become, and the result is not normalised
/// (the caller mixes or normalises it). A block whose motion leaves no mass on its grid keeps
/// none (others may still hold some); only when every block loses everything does this throw,
/// as a base model would (std::domain_error; `who` and `blocks_are`, e.g. "hypotheses", name
/// them in the message). `kept` receives each block's kept mass.
template <class T, class Span, class Buffers, class Predict>
block_masses predict_blocks(Eigen::Index blocks, Span span, Buffers buffers, Predict predict,
                            const Eigen::Array<T, Eigen::Dynamic, 1>& in,
                            Eigen::Array<T, Eigen::Dynamic, 1>& out, std::vector<double>& kept,
                            const char* who, const char* blocks_are) {
  kept.assign(static_cast<std::size_t>(blocks), 0.0);
  block_masses m;
  std::exception_ptr lost_everything;
  for (Eigen::Index k = 0; k < blocks; ++k) {
    const auto [at, n] = span(k);
    const double mass = mass_sum(in.data() + at, n);
    m.before += mass;
    if (!(mass > 0.0)) {
      out.segment(at, n).setZero();
      continue;
    }
    auto&& [block_in, block_out] = buffers(k);
    block_in.resize(n);
    block_out.resize(n);
    // The base model sees a normalised belief: a block whose hypothesis has become very
    // unlikely (mass 1e-40, say) would otherwise overflow the base model's own 1 / sum.
    if (const auto scale = static_cast<T>(1.0 / mass); std::isfinite(scale))
      block_in = in.segment(at, n) * scale;
    else  // 1 / mass overflows T (a denormal mass): scale in double
      block_in = (in.segment(at, n).template cast<double>() * (1.0 / mass)).template cast<T>();
    double block_kept = 0.0;
    try {
      const prediction_report r = predict(k, std::as_const(block_in), block_out);
      block_kept = mass * (1.0 - r.mass_lost);
    } catch (const std::domain_error&) {
      // This block's mass all left its grid; other blocks may still hold some.
      lost_everything = std::current_exception();
    }
    if (block_kept > 0.0)
      out.segment(at, n) = block_out;  // normalised; weighted below
    else
      out.segment(at, n).setZero();
    kept[static_cast<std::size_t>(k)] = block_kept;
    m.kept += block_kept;
  }
  if (!(m.kept > 0.0)) {
    if (lost_everything) std::rethrow_exception(lost_everything);
    fail<std::domain_error>(who, ": the motion left no belief mass in any of ", blocks, " ",
                            blocks_are);
  }
  // Each block back to its kept mass, relative to the largest (in double, so that a belief
  // that almost entirely left the grid cannot underflow every block to 0 in float).
  const double largest = *std::max_element(kept.begin(), kept.end());
  for (Eigen::Index k = 0; k < blocks; ++k) {
    const auto [at, n] = span(k);
    out.segment(at, n) *= static_cast<T>(kept[static_cast<std::size_t>(k)] / largest);
  }
  return m;
}

}  // namespace tacmap::detail
