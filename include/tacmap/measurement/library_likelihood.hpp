// tacmap: `library_likelihood` — the measurement model over a `library_grid`: each object's
// block gets the log-likelihood of the touch under that object's own map.
//
//   log p(z | x, k) = log p_{M_k}(z_k | x)
//
// where M_k is a measurement model built on object k's map (a `descriptor_likelihood` of its
// photograph, say, or an `appearance_likelihood` around one, so that each object has its own
// appearance hypotheses) and z_k the touch as that map sees it (the tactile image resampled to
// object k's scale; the same image when the maps share a scale). The filter compares objects by
// these values directly, so every M_k must give log-likelihoods on one scale: the same model
// type with the same settings (one descriptor, one tau; tacmap-calibrate calibrates it), and no
// per-call normalisation (none of the shipped models normalises).
//
// Cost: one likelihood per object, i.e. linear in the library's total number of states — less
// once the touches have decided: an object whose predicted posterior has fallen below
// `library_likelihood_params::prune_below` is not evaluated any more and drops out of the belief
// (its block gets -infinity). The update is then the exact update conditioned on "not one of
// the pruned objects", which held less than epsilon of the predicted belief each: the usual
// trade of beam pruning — an object dropped this way does not come back, so epsilon must be
// far below any posterior a real candidate reaches (the default 1e-9 is nine orders below).
// 0 turns pruning off.
//
// Evidence exponent. The object posterior is prior x evidence, E_k = sum_x p(z | x, k)
// bel_bar(x | k) per touch. Where the likelihood's scale is calibrated for positions but the
// objects' posteriors come out under- or over-confident, `evidence_exponent` beta turns each
// object's share into E_k^beta (adding (beta - 1) log E_k to its block: the position belief
// within each object is untouched). 1, the default, is the Bayes update; any other value is a
// calibration choice, to be fitted on data outside the evaluation (README, "Which object, and
// where").
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

#include "tacmap/config.hpp"
#include "tacmap/grid/library_grid.hpp"
#include "tacmap/measurement/concept.hpp"

namespace tacmap {

/// Configuration of `library_likelihood`.
struct library_likelihood_params {
  /// Objects whose predicted posterior is below this are no longer evaluated (see the file
  /// comment); in [0, 0.01]. 0: every object at every touch.
  double prune_below = 1e-9;
  /// Exponent beta on each object's evidence (see the file comment): the object posterior
  /// becomes prior x evidence^beta, the position belief within an object is unchanged. 1: the
  /// plain Bayes update. In [0.25, 8].
  double evidence_exponent = 1.0;
};

/// Measurement model over `library_grid<G>`: object k's block gets `models[k]`'s
/// log-likelihood (see the file comment). A measurement is one touch as each object's map sees
/// it: a vector of one `Model::measurement_type` per object, or of a single one that serves
/// every object (maps at one scale). Keeps per-object workspaces: not reentrant (one filter per
/// thread).
template <class Model>
class library_likelihood {
 public:
  using object_measurement_type = typename Model::measurement_type;
  using measurement_type = std::vector<object_measurement_type>;
  using object_model_type = Model;

  /// `models`: one per object, in the library's order, built on each object's map. Throws
  /// std::invalid_argument for an empty list or invalid parameters.
  explicit library_likelihood(std::vector<Model> models, library_likelihood_params params = {})
      : models_(std::move(models)), params_(params) {
    if (models_.empty())
      detail::fail(
          "library_likelihood: no models; expected one measurement model per object of the "
          "library");
    check(params_);
  }

  [[nodiscard]] Eigen::Index objects() const { return static_cast<Eigen::Index>(models_.size()); }
  [[nodiscard]] const Model& object_model(Eigen::Index k) const {
    return models_.at(static_cast<std::size_t>(k));
  }
  [[nodiscard]] const library_likelihood_params& params() const { return params_; }
  /// Replaces the parameters (e.g. pruning off for an exhaustive run); throws
  /// std::invalid_argument for invalid ones, parameters unchanged.
  void set_params(const library_likelihood_params& params) {
    check(params);
    params_ = params;
  }
  /// The objects the last update evaluated (false: pruned, see the file comment).
  [[nodiscard]] const std::vector<bool>& evaluated() const { return evaluated_; }

  /// Every object's log-likelihood (no pruning).
  template <library_state_grid G>
  requires measurement_model<Model, typename G::object_grid_type>
  void log_likelihood(const G& grid, const measurement_type& z, belief_array<G>& out) const {
    evaluate(grid, z, out, nullptr);
  }

  /// As above, skipping the objects the predicted belief `predicted` (the filter's belief
  /// before this update) gives less than `prune_below`: `bayes_filter::update` calls this one.
  template <library_state_grid G>
  requires measurement_model<Model, typename G::object_grid_type>
  void log_likelihood(const G& grid, const measurement_type& z, belief_array<G>& out,
                      const belief_array<G>& predicted) const {
    evaluate(grid, z, out, &predicted);
  }

 private:
  static void check(const library_likelihood_params& p) {
    if (!(std::isfinite(p.prune_below) && p.prune_below >= 0.0 && p.prune_below <= 0.01))
      detail::fail("library_likelihood: prune_below = ", p.prune_below,
                   "; expected a posterior in [0, 0.01] below which an object stops being "
                   "evaluated (0 = never)");
    if (!(std::isfinite(p.evidence_exponent) && p.evidence_exponent >= 0.25 &&
          p.evidence_exponent <= 8.0))
      detail::fail("library_likelihood: evidence_exponent = ", p.evidence_exponent,
                   "; expected an exponent in [0.25, 8] on each object's evidence (1 = Bayes)");
  }

  template <class G>
  void evaluate(const G& grid, const measurement_type& z, belief_array<G>& out,
                const belief_array<G>* predicted) const {
    const Eigen::Index objects = grid.objects();
    if (objects != this->objects())
      detail::fail("library_likelihood: the library has ", objects, " objects but the model ",
                   this->objects(), "; expected one measurement model per object, in order");
    if (z.size() != 1 && static_cast<Eigen::Index>(z.size()) != objects)
      detail::fail("library_likelihood: the touch comes in ", z.size(), " views for ", objects,
                   " objects; expected one view per object (each map's scale), or one for all");
    using T = typename G::scalar_type;
    auto& blocks = scratch<T>();
    blocks.resize(static_cast<std::size_t>(objects));
    evaluated_.assign(static_cast<std::size_t>(objects), true);
    for (Eigen::Index k = 0; k < objects; ++k) {
      const Eigen::Index at = grid.object_offset(k), n = grid.object_size(k);
      if (predicted && params_.prune_below > 0.0 &&
          static_cast<double>(predicted->segment(at, n).template cast<double>().sum()) <
              params_.prune_below) {
        out.segment(at, n).setConstant(-std::numeric_limits<T>::infinity());
        evaluated_[static_cast<std::size_t>(k)] = false;
        continue;
      }
      auto& block = blocks[static_cast<std::size_t>(k)];
      block.resize(n);
      models_[static_cast<std::size_t>(k)].log_likelihood(
          grid.object(k), z[z.size() == 1 ? 0 : static_cast<std::size_t>(k)], block);
      if (block.size() != n)
        detail::fail("library_likelihood: object ", k, "'s model resized its output to ",
                     block.size(), " values; expected ", n, " (one per state of its grid)");
      out.segment(at, n) = block;
      if (predicted && params_.evidence_exponent != 1.0) {
        // log E_k = log sum_x p(z | x, k) bel_bar(x | k), with the block's maximum taken out;
        // adding (beta - 1) log E_k to the whole block leaves p(x | k) as it is and turns the
        // object's share of the update into E_k^beta.
        const auto pred = predicted->segment(at, n).template cast<double>();
        const double mass = pred.sum();
        const double top = static_cast<double>(block.maxCoeff());
        if (mass > 0.0 && std::isfinite(top)) {
          const double e = ((block.template cast<double>() - top).exp() * pred).sum() / mass;
          if (e > 0.0)
            out.segment(at, n) +=
                static_cast<T>((params_.evidence_exponent - 1.0) * (top + std::log(e)));
        }
      }
    }
  }

  template <class T>
  std::vector<Eigen::Array<T, Eigen::Dynamic, 1>>& scratch() const {
    if constexpr (std::is_same_v<T, float>)
      return scratch_f_;
    else
      return scratch_d_;
  }

  std::vector<Model> models_;
  library_likelihood_params params_;
  // Per object: its block of log-likelihoods, kept between calls (no allocation per touch).
  mutable std::vector<Eigen::ArrayXf> scratch_f_;
  mutable std::vector<Eigen::ArrayXd> scratch_d_;
  mutable std::vector<bool> evaluated_;
};

}  // namespace tacmap
