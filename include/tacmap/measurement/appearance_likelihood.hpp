// tacmap: `appearance_likelihood` — the relation between the photograph and the touch as a
// discrete latent state of the filter.
//
// A tactile image measures pressure, about the local height; the map is a photograph, albedo
// times illumination. Which way they relate is a property of the object: raised parts may be
// brighter than their surroundings (a light print on a dark base, the paper's gecko) or darker
// (black rubber letters on white card, a dark coin on a light tray). An inverted relation turns
// every gradient by 180 degrees: descriptors of the true window point the opposite way, NCC
// scores it near -1, and a model that assumes one relation never localizes the other
// (shared/reference/cross-modal-matching.md).
//
// This model makes the relation a hypothesis h of a `latent_grid` and gives each its own
// likelihood from any measurement model M of the base grid:
//
//   log p(z | x, h) = log p_M(a_h(z) | x),     a_as_photographed(z) = z,
//                                               a_inverted(z) = max(z) + min(z) - z
//
// i.e. under "inverted" the tactile image is matched as the photograph would show it: raised
// parts dark. The map is described once, for every hypothesis (for dense SIFT an inverted image's
// descriptors are its orientation channels turned by half a turn, so the map's description serves
// both). The filter multiplies these likelihoods into its belief over (h, x); after a few touches
// the evidence decides the relation and `estimate().hypothesis_probability` reports it. Nothing
// needs to be told about the object.
//
// Any measurement model works, including a user's own descriptor through descriptor_likelihood:
// a descriptor that is already invariant to the sign of contrast gains nothing from the second
// hypothesis (both blocks get the same likelihood, the posterior stays at its prior) and pays for
// it; one that is not gets the invariance from the filter. The cost is one likelihood of M per
// hypothesis per touch, less where M scores several at once: `descriptor_likelihood` streams its
// map descriptors once for all hypotheses (`log_likelihood_each`), and with a descriptor that
// declares its contrast permutation (dense_sift) and `both_signs` it scores a touch and its
// inverse with the multiply-adds of one (`log_likelihood_both_signs`).
//
// The likelihoods of different hypotheses are compared by their absolute values, so M must not
// normalise its output per call (none of the shipped models does: they return -d / tau,
// -log(d + eps) or ncc / tau).
#pragma once

#include <cstddef>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "tacmap/grid/latent_grid.hpp"
#include "tacmap/image.hpp"
#include "tacmap/measurement/concept.hpp"
#include "tacmap/measurement/detail/state_ranges.hpp"

namespace tacmap {

/// Measurement models that can score several measurements in one call, block k of `out` for
/// measurement k (`descriptor_likelihood::log_likelihood_each`: one pass over the map's
/// descriptors for all of them). `appearance_likelihood` then hands it every hypothesis's image
/// at once, straight into the latent belief's blocks.
template <class M, class G>
concept measures_each = requires(const M& m, const G& g,
                                 std::span<const typename M::measurement_type> zs,
                                 typename G::scalar_type* out) {
  m.log_likelihood_each(g, zs, out);
};

/// Measurement models that score a touch and its inverted contrast in one call, blocks 0 and 1
/// of `out` (`descriptor_likelihood::log_likelihood_both_signs`: with a contrast-symmetric
/// descriptor, both for the multiply-adds of one).
template <class M, class G>
concept measures_both_signs = requires(const M& m, const G& g,
                                       const typename M::measurement_type& z,
                                       typename G::scalar_type* out) {
  m.log_likelihood_both_signs(g, z, out);
};

/// How the photograph shows the object's height (a hypothesis of `appearance_likelihood`).
enum class appearance {
  as_photographed,  ///< raised parts look as the tactile image shows them: brighter
  inverted,         ///< raised parts look darker than their surroundings
};

[[nodiscard]] inline const char* to_string(appearance a) {
  return a == appearance::as_photographed ? "as photographed" : "inverted";
}

/// The tactile image `z` as hypothesis `a` expects the photograph to show it.
[[nodiscard]] inline image<float> appearance_transform(const image<float>& z, appearance a) {
  if (a == appearance::as_photographed) return z;
  // max + min - z maps [min, max] onto itself, reversed: the preprocessed range (peak 1) and
  // any contact-free taxels' level are kept, only the sign of every gradient flips.
  return detail::inverted_contrast(z);
}

/// The names a `latent_grid` gets for `hypotheses` (for `estimate()` and figures).
[[nodiscard]] inline std::vector<std::string> appearance_names(
    const std::vector<appearance>& hypotheses) {
  std::vector<std::string> names;
  for (const appearance a : hypotheses) names.emplace_back(to_string(a));
  return names;
}

/// Both relations: the default set of hypotheses.
[[nodiscard]] inline std::vector<appearance> both_appearances() {
  return {appearance::as_photographed, appearance::inverted};
}

/// Measurement model over `latent_grid<G>`: hypothesis h's block gets `Model`'s log-likelihood of
/// the tactile image under appearance h (see the file comment). Keeps per-touch workspaces, like
/// the shipped models: one object is not reentrant (one filter per thread).
template <class Model>
class appearance_likelihood {
 public:
  using measurement_type = image<float>;
  using base_model_type = Model;

  /// `hypotheses`: one appearance per hypothesis of the grid, in block order, all different.
  /// Throws std::invalid_argument for an empty or repeated list.
  explicit appearance_likelihood(Model model,
                                 std::vector<appearance> hypotheses = both_appearances())
      : model_(std::move(model)), hypotheses_(std::move(hypotheses)) {
    if (hypotheses_.empty())
      detail::fail(
          "appearance_likelihood: no appearance hypotheses; expected at least one "
          "(as_photographed and inverted by default)");
    for (std::size_t a = 0; a < hypotheses_.size(); ++a)
      for (std::size_t b = a + 1; b < hypotheses_.size(); ++b)
        if (hypotheses_[a] == hypotheses_[b])
          detail::fail("appearance_likelihood: hypotheses ", a, " and ", b, " are both '",
                       to_string(hypotheses_[a]),
                       "'; expected each appearance once (a repeated one only halves the "
                       "others' prior)");
  }

  [[nodiscard]] const Model& base() const { return model_; }
  [[nodiscard]] Model& base() { return model_; }
  [[nodiscard]] const std::vector<appearance>& hypotheses() const { return hypotheses_; }
  /// The grid's hypothesis names for this model's hypotheses.
  [[nodiscard]] std::vector<std::string> hypothesis_names() const {
    return appearance_names(hypotheses_);
  }

  template <latent_state_grid G>
  requires measurement_model<Model, typename G::base_type> &&
      std::same_as<typename Model::measurement_type, image<float>>
  void log_likelihood(const G& grid, const measurement_type& z, belief_array<G>& out) const {
    check_hypotheses(grid);
    const Eigen::Index n = grid.hypothesis_size();
    // One hypothesis as photographed: the model itself, straight into the belief's buffer.
    if (hypotheses_.size() == 1 && hypotheses_[0] == appearance::as_photographed) {
      model_.log_likelihood(grid.base(), z, out);
      return;
    }
    if constexpr (measures_both_signs<Model, typename G::base_type>) {
      if (both_signs_order()) {
        model_.log_likelihood_both_signs(grid.base(), z, out.data());
        return;
      }
    }
    if constexpr (measures_each<Model, typename G::base_type>) {
      auto& images = images_;
      images.resize(hypotheses_.size());
      for (std::size_t h = 0; h < hypotheses_.size(); ++h)
        images[h] = appearance_transform(z, hypotheses_[h]);
      model_.log_likelihood_each(grid.base(), std::span<const image<float>>(images), out.data());
      return;
    }
    auto& block = scratch<typename G::scalar_type>();
    block.resize(n);
    for (std::size_t h = 0; h < hypotheses_.size(); ++h) {
      const auto offset = static_cast<Eigen::Index>(h) * n;
      if (hypotheses_[h] == appearance::as_photographed) {
        model_.log_likelihood(grid.base(), z, block);
      } else {
        model_.log_likelihood(grid.base(), appearance_transform(z, hypotheses_[h]), block);
      }
      out.segment(offset, n) = block;
    }
  }

  /// Tracking hook (measurement/concept.hpp), when `Model` has one: its bound.
  [[nodiscard]] double log_likelihood_bound() const requires requires(const Model& m) {
    m.log_likelihood_bound();
  }
  { return static_cast<double>(model_.log_likelihood_bound()); }

  /// Tracking hook: `log_likelihood` at (at least) the latent states of `states`, bit for bit.
  /// Both signs in one pass (the localizer's default): the base states any hypothesis needs,
  /// scored for both at once; a model scoring several images in one pass otherwise: the whole
  /// grid (its shared pass is what `log_likelihood` runs, exact only whole); else each
  /// hypothesis's own states through the model's hook.
  template <latent_state_grid G>
  requires measures_on_states<Model, typename G::base_type> &&
      std::same_as<typename Model::measurement_type, image<float>>
  void log_likelihood_on(const G& grid, const measurement_type& z, belief_array<G>& out,
                         std::span<const state_range> states) const {
    check_hypotheses(grid);
    const Eigen::Index n = grid.hypothesis_size();
    if (hypotheses_.size() == 1 && hypotheses_[0] == appearance::as_photographed) {
      model_.log_likelihood_on(grid.base(), z, out, states);
      return;
    }
    if constexpr (measures_both_signs<Model, typename G::base_type>) {
      if (both_signs_order()) {
        if constexpr (requires(const Model& m, const typename G::base_type& b,
                               const measurement_type& zz, typename G::scalar_type* o,
                               std::span<const state_range> st) {
                        m.log_likelihood_both_signs_on(b, zz, o, st);
                      }) {
          detail::project_to_block(states, n, base_ranges_);
          model_.log_likelihood_both_signs_on(grid.base(), z, out.data(),
                                              std::span<const state_range>(base_ranges_));
        } else {
          model_.log_likelihood_both_signs(grid.base(), z, out.data());
        }
        return;
      }
    }
    if constexpr (measures_each<Model, typename G::base_type>) {
      log_likelihood(grid, z, out);
      return;
    }
    auto& block = scratch<typename G::scalar_type>();
    block.resize(n);
    for (std::size_t h = 0; h < hypotheses_.size(); ++h) {
      const auto offset = static_cast<Eigen::Index>(h) * n;
      detail::block_ranges(states, static_cast<Eigen::Index>(h), n, base_ranges_);
      if (base_ranges_.empty()) continue;
      const std::span<const state_range> mine(base_ranges_);
      if (hypotheses_[h] == appearance::as_photographed)
        model_.log_likelihood_on(grid.base(), z, block, mine);
      else
        model_.log_likelihood_on(grid.base(), appearance_transform(z, hypotheses_[h]), block, mine);
      for (const state_range& r : mine)
        out.segment(offset + r.begin, r.end - r.begin) = block.segment(r.begin, r.end - r.begin);
    }
  }

 private:
  // The two hypotheses in the order log_likelihood_both_signs fills them.
  [[nodiscard]] bool both_signs_order() const {
    return hypotheses_.size() == 2 && hypotheses_[0] == appearance::as_photographed &&
           hypotheses_[1] == appearance::inverted;
  }

  template <latent_state_grid G>
  void check_hypotheses(const G& grid) const {
    if (grid.hypotheses() != static_cast<Eigen::Index>(hypotheses_.size()))
      detail::fail("appearance_likelihood: the grid has ", grid.hypotheses(),
                   " hypotheses but the model ", hypotheses_.size(),
                   "; expected one grid hypothesis per appearance — build the latent_grid with "
                   "the model's hypothesis_names()");
    for (std::size_t h = 0; h < hypotheses_.size(); ++h)
      if (grid.hypothesis_name(static_cast<Eigen::Index>(h)) != to_string(hypotheses_[h]))
        detail::fail("appearance_likelihood: the grid's hypothesis ", h, " is named '",
                     grid.hypothesis_name(static_cast<Eigen::Index>(h)), "' but the model's is '",
                     to_string(hypotheses_[h]),
                     "'; expected the same order — build the latent_grid with the model's "
                     "hypothesis_names()");
  }

  template <class T>
  Eigen::Array<T, Eigen::Dynamic, 1>& scratch() const {
    if constexpr (std::is_same_v<T, float>)
      return scratch_f_;
    else
      return scratch_d_;
  }

  Model model_;
  std::vector<appearance> hypotheses_;
  // One block of log-likelihoods, kept between calls: one object is not reentrant.
  mutable Eigen::ArrayXf scratch_f_;
  mutable Eigen::ArrayXd scratch_d_;
  mutable std::vector<image<float>> images_;      // each hypothesis's view of the touch
  mutable std::vector<state_range> base_ranges_;  // log_likelihood_on: the base grid's states
};

}  // namespace tacmap
