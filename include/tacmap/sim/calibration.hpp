// tacmap: is the belief's confidence right, and the likelihood scale that makes it so.
//
// Two pieces (README, "Confidence"):
//  * `reliability`: probabilities a belief claimed (e.g. P(error <= 5 mm), `assess`) against
//    what happened, in bins — the reliability diagram — and the expected calibration error
//    ECE = sum_b (n_b / N) |mean claimed probability_b - observed frequency_b|.
//  * `likelihood_calibration`: the temperature tau of an exponential likelihood
//    p(z | x) = exp(-d(x, z) / tau) fitted by maximum likelihood. The filter is replayed over
//    recorded (or simulated) sequences whose truth is known, with the touches' log-likelihoods
//    recorded once at a reference tau and rescaled (log p is linear in 1 / tau), and tau is
//    chosen to maximise the mean log probability the filter gives the truth after each touch:
//        tau* = argmax_tau  (1/T) sum_t log bel_t^tau(truth_t)
//    — the log score, a proper scoring rule, so the maximiser is the scale at which the
//    belief's probabilities are, on average, what they claim to be. The truth is the set of
//    states within `truth_radius_mm` of the true position (and, for latent grids, in the true
//    hypothesis's block when it is known): both the per-state likelihood and the evidence that
//    compares hypotheses are scored, through the one tau they share.
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <iterator>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "tacmap/config.hpp"
#include "tacmap/filter/bayes_filter.hpp"
#include "tacmap/filter/confidence.hpp"
#include "tacmap/grid/latent_grid.hpp"
#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/protocol.hpp"

namespace tacmap {

/// One bin of a reliability diagram: claims in [lower, upper).
struct reliability_bin {
  double lower = 0.0;
  double upper = 0.0;
  std::size_t count = 0;          ///< claims in the bin
  double mean_probability = 0.0;  ///< their mean (NaN when empty)
  double frequency = 0.0;         ///< fraction that came true (NaN when empty)
};

/// Claimed probabilities against outcomes.
struct reliability_report {
  std::vector<reliability_bin> bins;
  std::size_t count = 0;
  /// sum_b (n_b / N) |mean_probability_b - frequency_b|, in [0, 1] (x 100: "points").
  double expected_calibration_error = 0.0;
  double brier_score = 0.0;  ///< mean (p - outcome)^2
};

/// The reliability of `probability[i]` as a claim that `outcome[i]` is true, over `bins` equal
/// bins of [0, 1] (the last closed). Throws std::invalid_argument for spans of different
/// lengths, no claims, zero bins or a probability outside [0, 1].
[[nodiscard]] inline reliability_report reliability(std::span<const double> probability,
                                                    std::span<const char> outcome,
                                                    std::size_t bins = 10) {
  if (probability.size() != outcome.size())
    detail::fail("reliability: ", probability.size(), " probabilities but ", outcome.size(),
                 " outcomes; expected one outcome per claim");
  if (probability.empty()) detail::fail("reliability: no claims; expected at least one");
  if (bins == 0) detail::fail("reliability: 0 bins; expected at least 1 (e.g. 10)");
  reliability_report r;
  r.bins.resize(bins);
  std::vector<double> sum_p(bins, 0.0), sum_o(bins, 0.0);
  for (std::size_t i = 0; i < probability.size(); ++i) {
    // Sums of float probabilities may exceed 1 by rounding: a claim within 1e-4 counts as 1.
    if (!(probability[i] >= -1e-4 && probability[i] <= 1.0 + 1e-4))
      detail::fail("reliability: probability ", probability[i], " at claim ", i,
                   "; expected [0, 1]");
    const double p = std::clamp(probability[i], 0.0, 1.0);
    const auto b = std::min(bins - 1, static_cast<std::size_t>(p * static_cast<double>(bins)));
    const double o = outcome[i] ? 1.0 : 0.0;
    ++r.bins[b].count;
    sum_p[b] += p;
    sum_o[b] += o;
    r.brier_score += (p - o) * (p - o);
  }
  r.count = probability.size();
  const auto n = static_cast<double>(r.count);
  r.brier_score /= n;
  for (std::size_t b = 0; b < bins; ++b) {
    reliability_bin& bin = r.bins[b];
    bin.lower = static_cast<double>(b) / static_cast<double>(bins);
    bin.upper = static_cast<double>(b + 1) / static_cast<double>(bins);
    if (bin.count == 0) {
      bin.mean_probability = bin.frequency = std::numeric_limits<double>::quiet_NaN();
      continue;
    }
    const auto c = static_cast<double>(bin.count);
    bin.mean_probability = sum_p[b] / c;
    bin.frequency = sum_o[b] / c;
    r.expected_calibration_error += c / n * std::abs(bin.mean_probability - bin.frequency);
  }
  return r;
}

/// How `likelihood_calibration::fit` searches and what it accepts.
struct tau_fit_params {
  /// The search range of tau; a maximum on either end is reported as outside the sane range.
  double tau_min = 0.01;
  double tau_max = 10.0;
  /// The truth scored after each touch: the states within this distance of the true position
  /// (mm; the nearest state when none is). 0: the nearest state only.
  double truth_radius_mm = 2.0;
  std::size_t min_touches = 30;   ///< accepted touches needed
  std::size_t min_sequences = 3;  ///< sequences needed

  void validate() const {
    if (!(std::isfinite(tau_min) && std::isfinite(tau_max) && tau_min > 0.0 && tau_max > tau_min))
      detail::fail("tau_fit_params: tau range [", tau_min, ", ", tau_max,
                   "]; expected 0 < tau_min < tau_max, finite");
    if (!(std::isfinite(truth_radius_mm) && truth_radius_mm >= 0.0))
      detail::fail("tau_fit_params: truth_radius_mm = ", truth_radius_mm,
                   "; expected a finite distance >= 0");
  }
};

/// The result of a fit.
struct tau_fit {
  double tau = 0.0;                          ///< the maximiser (usable only when `sane`)
  double reference_tau = 0.0;                ///< the tau the log-likelihoods were recorded at
  double mean_log_score = 0.0;               ///< (1/T) sum_t log bel_t(truth_t) at `tau`
  double mean_log_score_at_reference = 0.0;  ///< the same at `reference_tau`
  std::size_t touches = 0;
  std::size_t sequences = 0;
  /// (tau, mean log score) at every tau the search tried, by tau.
  std::vector<std::pair<double, double>> curve;
  /// False when the maximum lies on an end of the search range: the data want a scale outside
  /// [tau_min, tau_max], which is not a temperature to ship (see `message`).
  bool sane = true;
  std::string message;  ///< why `sane` is false; empty otherwise
};

/// Recorded sequences replayed through copies of their filters at other likelihood scales.
/// `Filter`: a `bayes_filter` over a planar grid (optionally a `latent_grid` of one), whose
/// control is `odometry`; its measurement model is not called (the log-likelihoods are given).
template <class Filter>
class likelihood_calibration {
 public:
  /// `reference_tau`: the temperature of the exponential likelihood the log-likelihoods given to
  /// `add` were computed at (log p = -d / reference_tau). Throws std::invalid_argument unless it
  /// is finite and > 0.
  explicit likelihood_calibration(double reference_tau) : reference_tau_(reference_tau) {
    if (!(std::isfinite(reference_tau) && reference_tau > 0.0))
      detail::fail("likelihood_calibration: reference tau ", reference_tau,
                   "; expected the finite tau > 0 the log-likelihoods were computed at");
  }

  /// Adds one recorded sequence: `filter` (its grid and motion model; copied once per distinct
  /// filter address), the protocol's `steps` (odometry before each touch after the first), and
  /// the run with its log-likelihoods (`localization_experiment::run(i, false, true)`).
  /// `truth_hypothesis`: the true latent hypothesis when known (scored jointly with the
  /// position), else empty (the position marginal is scored). Throws std::invalid_argument when
  /// the run has no log-likelihoods, its length differs from the steps', or a true position lies
  /// off the grid's states by more than a window (a map scale that does not fit the data).
  void add(const Filter& filter, const touch_sequence& steps, const sequence_result& run,
           std::optional<Eigen::Index> truth_hypothesis = std::nullopt) {
    if (run.log_likelihoods.size() != run.touches.size() || run.touches.size() != steps.size())
      detail::fail("likelihood_calibration::add: sequence ", run.sequence, " has ",
                   run.touches.size(), " touches, ", run.log_likelihoods.size(),
                   " recorded log-likelihoods and ", steps.size(),
                   " protocol steps; expected the same number of each (run it with "
                   "keep_log_likelihoods = true)");
    const Filter* key = &filter;
    auto it = std::find_if(filters_.begin(), filters_.end(),
                           [&](const auto& f) { return f.first == key; });
    if (it == filters_.end()) {
      filters_.emplace_back(key, std::make_shared<Filter>(filter));
      it = std::prev(filters_.end());
    }
    recorded rec{.filter = it->second, .steps = {}};
    const auto& grid = it->second->grid();
    for (std::size_t t = 0; t < steps.size(); ++t) {
      const touch_record& tr = run.touches[t];
      recorded_touch touch{.control = steps[t].measured_motion,
                           .log_likelihood = run.log_likelihoods[t],
                           .truth = {},
                           .x_mm = tr.true_x_mm,
                           .y_mm = tr.true_y_mm};
      if (touch.log_likelihood.size() != 0 && touch.log_likelihood.size() != grid.size())
        detail::fail("likelihood_calibration::add: touch ", t + 1, " of sequence ", run.sequence,
                     " has ", touch.log_likelihood.size(), " log-likelihoods; expected ",
                     grid.size(), " (one per state of the filter's grid)");
      touch.truth = truth_states(grid, tr.true_x_mm, tr.true_y_mm, truth_hypothesis, run.sequence);
      rec.steps.push_back(std::move(touch));
    }
    sequences_.push_back(std::move(rec));
  }

  /// What the replayed beliefs claimed at `tau` and what happened, after every accepted touch:
  /// `assess`'s P(error <= radius) with whether the estimate was that close, and the verdicts.
  struct claims {
    std::vector<double> probability;
    std::vector<char> outcome;
    std::size_t said = 0, right = 0, said_and_right = 0;  // "localized", right, both
  };
  [[nodiscard]] claims confidence_claims(double tau, const confidence_params& params = {}) const {
    claims out;
    replay(tau, [&](const Filter& f, const recorded_touch& touch) {
      const confidence c = assess(f, params);
      const bool right =
          std::hypot(c.centre_mm(0) - touch.x_mm, c.centre_mm(1) - touch.y_mm) <= params.radius_mm;
      const bool said = c.verdict == verdict::localized;
      out.probability.push_back(c.probability_within);
      out.outcome.push_back(right ? 1 : 0);
      out.said += said ? 1U : 0U;
      out.right += right ? 1U : 0U;
      out.said_and_right += said && right ? 1U : 0U;
    });
    return out;
  }

  /// The mean log score (1/T) sum_t log bel_t(truth_t) of every accepted touch at `tau`.
  [[nodiscard]] double mean_log_score(double tau, double truth_radius_mm) const {
    double total = 0.0;
    std::size_t n = 0;
    replay(tau, [&](const Filter& f, const recorded_touch& touch) {
      total += std::log(std::max(truth_mass(f, touch, truth_radius_mm), 1e-300));
      ++n;
    });
    return n == 0 ? 0.0 : total / static_cast<double>(n);
  }

  /// Fits tau (see the file's comment): a coarse scan of log tau over the range, then golden
  /// section around the best. Throws std::invalid_argument for too few sequences or touches,
  /// or degenerate data (every touch's log-likelihood the same, or none that varies over the
  /// states); returns `sane = false` with a message when the maximum is on the range's end.
  [[nodiscard]] tau_fit fit(const tau_fit_params& params = {}) const {
    params.validate();
    check_data(params);
    tau_fit out;
    out.reference_tau = reference_tau_;
    out.sequences = sequences_.size();
    out.touches = accepted_touches();
    const auto score = [&](double log_tau) {
      const double tau = std::exp(log_tau);
      const double v = mean_log_score(tau, params.truth_radius_mm);
      out.curve.emplace_back(tau, v);
      return v;
    };
    const double lo = std::log(params.tau_min), hi = std::log(params.tau_max);
    constexpr int coarse = 16;
    std::vector<double> values(coarse + 1);
    int best = 0;
    for (int k = 0; k <= coarse; ++k) {
      values[static_cast<std::size_t>(k)] = score(lo + (hi - lo) * k / coarse);
      if (values[static_cast<std::size_t>(k)] > values[static_cast<std::size_t>(best)]) best = k;
    }
    double a = lo + (hi - lo) * std::max(best - 1, 0) / coarse;
    double b = lo + (hi - lo) * std::min(best + 1, coarse) / coarse;
    const double g = 0.5 * (std::sqrt(5.0) - 1.0);
    double c = b - g * (b - a), d = a + g * (b - a);
    double fc = score(c), fd = score(d);
    for (int it = 0; it < 20; ++it) {
      if (fc > fd) {
        b = d;
        d = c;
        fd = fc;
        c = b - g * (b - a);
        fc = score(c);
      } else {
        a = c;
        c = d;
        fc = fd;
        d = a + g * (b - a);
        fd = score(d);
      }
    }
    const double best_log = fc > fd ? c : d;
    out.tau = std::exp(best_log);
    out.mean_log_score = std::max(fc, fd);
    if (values[static_cast<std::size_t>(best)] >
        out.mean_log_score) {  // a flat top: keep the scan's
      out.tau = std::exp(lo + (hi - lo) * best / coarse);
      out.mean_log_score = values[static_cast<std::size_t>(best)];
    }
    out.mean_log_score_at_reference = mean_log_score(reference_tau_, params.truth_radius_mm);
    std::sort(out.curve.begin(), out.curve.end());
    if (best == 0 || best == coarse) {
      out.sane = false;
      std::ostringstream m;
      m << "the log score is highest at the end of the search range (tau = " << out.tau
        << ", range [" << params.tau_min << ", " << params.tau_max
        << "]): the data do not pin a temperature down (too few informative touches, or a "
           "likelihood that is not exp(-d / tau)); not used — check the data or widen the range";
      out.message = m.str();
    }
    return out;
  }

  [[nodiscard]] std::size_t sequences() const { return sequences_.size(); }
  [[nodiscard]] std::size_t accepted_touches() const {
    std::size_t n = 0;
    for (const auto& s : sequences_)
      for (const auto& t : s.steps) n += t.log_likelihood.size() != 0 ? 1U : 0U;
    return n;
  }

 private:
  struct recorded_touch {
    odometry control;
    Eigen::Array<float, Eigen::Dynamic, 1> log_likelihood;  // at reference_tau_; empty: rejected
    std::vector<std::pair<double, Eigen::Index>> truth;     // (distance mm, state), nearest first
    double x_mm = 0.0, y_mm = 0.0;                          // the true position
  };
  struct recorded {
    std::shared_ptr<Filter> filter;
    std::vector<recorded_touch> steps;
  };

  // Runs every recorded sequence through its filter at `tau`, calling visit(filter, touch)
  // after each accepted touch's update.
  template <class Visit>
  void replay(double tau, Visit visit) const {
    const auto scale = static_cast<float>(reference_tau_ / tau);
    for (const auto& s : sequences_) {
      Filter& f = *s.filter;
      f.reset();
      for (std::size_t t = 0; t < s.steps.size(); ++t) {
        const recorded_touch& touch = s.steps[t];
        // A scale so sharp that the belief collapses onto states the next motion carries off
        // the map, or a touch leaves no predicted state any probability: the filter refuses;
        // start again from a uniform belief, as a user would (the score then shows it).
        if (t > 0) {
          try {
            f.predict(touch.control);
          } catch (const std::exception&) {
            f.reset();
          }
        }
        if (touch.log_likelihood.size() == 0) continue;
        scaled_ = touch.log_likelihood * scale;
        try {
          f.update_log_likelihood(scaled_);
        } catch (const std::domain_error&) {
          f.reset();
        }
        visit(static_cast<const Filter&>(f), touch);
      }
    }
  }

  // The states scored as the truth with their positions' distances to it, nearest first: in
  // the true hypothesis's block when it is known, in every block otherwise.
  static std::vector<std::pair<double, Eigen::Index>> truth_states(
      const typename Filter::grid_type& grid, double x, double y,
      std::optional<Eigen::Index> hypothesis, std::size_t sequence) {
    Eigen::Index blocks = 1, block_size = grid.size();
    if constexpr (latent_state_grid<typename Filter::grid_type>) {
      blocks = grid.hypotheses();
      block_size = grid.hypothesis_size();
      if (hypothesis && (*hypothesis < 0 || *hypothesis >= blocks))
        detail::fail("likelihood_calibration::add: true hypothesis ", *hypothesis, " of sequence ",
                     sequence, "; expected 0 .. ", blocks - 1);
    }
    std::vector<std::pair<double, Eigen::Index>> by_distance;  // over the first block
    by_distance.reserve(static_cast<std::size_t>(block_size));
    for (Eigen::Index i = 0; i < block_size; ++i) {
      const auto s = grid.state_mm(i);
      by_distance.emplace_back(std::hypot(s(0) - x, s(1) - y), i);
    }
    std::sort(by_distance.begin(), by_distance.end());
    if (!(std::isfinite(x) && std::isfinite(y)) || by_distance.front().first > off_map_mm)
      detail::fail("likelihood_calibration::add: the true position (", x, ", ", y,
                   ") mm of sequence ", sequence, " is ", by_distance.front().first,
                   " mm from the nearest state of the map; expected a position the sensor's "
                   "centre can take on the map (within ",
                   off_map_mm,
                   " mm) — is the map's scale (mm per px) the one the data were recorded at?");
    std::vector<std::pair<double, Eigen::Index>> out;
    for (std::size_t k = 0; k < by_distance.size(); ++k) {
      const auto [dist, i] = by_distance[k];
      if (k > 0 && dist > max_truth_radius_mm) break;
      for (Eigen::Index h = 0; h < blocks; ++h)
        if (!hypothesis || h == *hypothesis) out.emplace_back(dist, h * block_size + i);
    }
    return out;
  }

  // Mass of the truth's states within `radius` (the nearest position's when none is).
  static double truth_mass(const Filter& f, const recorded_touch& touch, double radius) {
    const double nearest = touch.truth.front().first;
    double mass = 0.0;
    for (const auto& [dist, i] : touch.truth) {
      if (dist > radius && dist > nearest) break;
      mass += static_cast<double>(f.belief()(i));
    }
    return mass;
  }

  void check_data(const tau_fit_params& params) const {
    const std::size_t touches = accepted_touches();
    if (sequences_.size() < params.min_sequences || touches < params.min_touches)
      detail::fail("likelihood_calibration::fit: ", touches, " accepted touches in ",
                   sequences_.size(), " sequences; expected at least ", params.min_touches,
                   " touches in ", params.min_sequences,
                   " sequences — add sequences or maps (too little data gives a scale that fits "
                   "the noise)");
    if (params.truth_radius_mm > max_truth_radius_mm)
      detail::fail("likelihood_calibration::fit: truth_radius_mm = ", params.truth_radius_mm,
                   "; expected at most ", max_truth_radius_mm, " mm");
    const Eigen::Array<float, Eigen::Dynamic, 1>* first = nullptr;
    bool differ = false, informative = false;
    for (const auto& s : sequences_)
      for (const auto& t : s.steps) {
        if (t.log_likelihood.size() == 0) continue;
        const float hi = t.log_likelihood.maxCoeff(), lo = t.log_likelihood.minCoeff();
        if (hi - lo > 1e-6F * std::max(1.0F, std::abs(hi))) informative = true;
        if (first == nullptr)
          first = &t.log_likelihood;
        else if (first->size() != t.log_likelihood.size() ||
                 !first->isApprox(t.log_likelihood, 1e-6F))
          differ = true;
      }
    if (!informative)
      detail::fail(
          "likelihood_calibration::fit: every touch's log-likelihood is flat over the "
          "states; expected touches that prefer some states to others (is the map "
          "blank, or every frame empty?)");
    if (!differ)
      detail::fail(
          "likelihood_calibration::fit: every touch has the same log-likelihood (the "
          "same frame at the same place); expected touches at different places");
  }

  static constexpr double max_truth_radius_mm = 10.0;
  // A true position farther than this from every state is not on the map.
  static constexpr double off_map_mm = 5.0;
  double reference_tau_;
  std::vector<std::pair<const Filter*, std::shared_ptr<Filter>>> filters_;
  std::vector<recorded> sequences_;
  mutable Eigen::Array<float, Eigen::Dynamic, 1> scaled_;
};

/// A protocol for calibrating on a photograph of the user's own: `photo` (intensities, row 0 at
/// the top) at `mm_per_px`, `touches` distinct touch locations on the grid's states drawn from
/// `seed`, 22 random orders of them, odometry = true motion + N(0, 0.5 mm) per axis (the gecko
/// protocol's noise), a continuous 4 mm relief (height = intensity). What `tacmap-calibrate
/// --photo` builds (after resizing the photograph to its `--map-px`). Throws
/// std::invalid_argument for a photograph with fewer sensor positions than `touches`.
[[nodiscard]] inline touch_protocol photo_touch_protocol(image<float> photo, double mm_per_px,
                                                         std::uint64_t seed,
                                                         std::size_t touches = 7) {
  touch_protocol p;
  p.map = std::move(photo);
  p.mm_per_px = mm_per_px;
  p.relief = {.kind = relief_kind::continuous,
              .threshold = 0.5F,
              .height_mm = 4.0,
              .edge_smoothing_px = 0.0};
  p.odometry_sigma_mm = 0.5;
  p.seed = seed;
  const planar_grid<float> grid(
      p.map_size(), p.mm_per_px,
      checked_tactile_window({}, mm_per_px, p.map_size(), "photo_touch_protocol"));
  // Distinct locations are drawn until there are enough: a small map may not have that many.
  if (static_cast<std::size_t>(grid.size()) < touches)
    detail::fail("photo_touch_protocol: a ", p.map.cols(), " x ", p.map.rows(), " px map has ",
                 grid.size(), " sensor positions, fewer than the ", touches,
                 " distinct touches asked for; expected a larger map or fewer touches");
  sim_rng rng(seed);
  while (p.locations.size() < touches) {  // distinct states
    const auto s = grid.state_mm(
        static_cast<Eigen::Index>(rng.below(static_cast<std::uint64_t>(grid.size()))));
    const touch_location loc{s(0), s(1)};
    if (std::find(p.locations.begin(), p.locations.end(), loc) == p.locations.end())
      p.locations.push_back(loc);
  }
  const std::size_t n = p.locations.size();
  for (int q = 0; q < 22; ++q) {
    std::vector<std::size_t> order(n);
    for (std::size_t k = 0; k < n; ++k) order[k] = k;
    for (std::size_t k = n - 1; k > 0; --k) std::swap(order[k], order[rng.below(k + 1)]);
    p.sequences.push_back(sequence_visiting(p.locations, order, p.odometry_sigma_mm, rng));
  }
  return p;
}

/// Fits the temperature tau of the planar model of the measurement policy `measurement`
/// (localizer.hpp: `configured_models`, or `descriptor_measurement<D>` for a descriptor of your
/// own) on `maps` (your photographs as protocols, `photo_touch_protocol`, or recorded ones,
/// `load_protocol`): every sequence (the first `sequences` of each map when > 0) is simulated
/// under `config` (its scenario, simulator and seed; `localization_config`, sim/experiment.hpp),
/// its log-likelihoods recorded at the reference tau (`config.tau`, else the model's default)
/// and the log score maximised (`likelihood_calibration`). Three lines for your descriptor:
///
///     std::vector<tacmap::touch_protocol> maps{tacmap::photo_touch_protocol(photo, 0.5, 1)};
///     const tacmap::tau_fit fit = tacmap::fit_tau(maps, {},
///     tacmap::descriptor_measurement<my_descriptor>{}); if (fit.sane) config.tau = fit.tau;  //
///     tacmap::localizer_config, for descriptor_localizer
///
/// Throws std::invalid_argument for headings > 0 (the fit is planar), no maps, or too few
/// touches (`tau_fit_params`).
template <localizer_measurement M = configured_models>
[[nodiscard]] tau_fit fit_tau(const std::vector<touch_protocol>& maps,
                              localization_config config = {}, M measurement = M{},
                              const tau_fit_params& params = {}, std::size_t sequences = 0) {
  if (config.headings != 0)
    detail::fail("fit_tau: headings = ", config.headings,
                 "; the fit is made on the planar model (headings = 0), whose tau the pose "
                 "model shares");
  if (maps.empty()) detail::fail("fit_tau: no maps; expected at least one protocol");
  // The temperature the model runs at by default: the log-likelihoods are recorded there.
  double reference = descriptor_likelihood_params{}.tau;
  if (config.tau)
    reference = *config.tau;
  else if constexpr (std::same_as<M, configured_models>)
    reference = config.planar_tau().value_or(reference);
  config.tau = reference;
  likelihood_calibration<planar_filter_for<M>> calibration(reference);
  // Alive until the fit: the calibration keys its copies of the filters by address.
  std::vector<std::unique_ptr<basic_localization_experiment<M>>> experiments;
  for (const touch_protocol& p : maps) {
    experiments.push_back(
        std::make_unique<basic_localization_experiment<M>>(p, config, measurement));
    auto& experiment = *experiments.back();
    const std::size_t n =
        sequences == 0 ? p.sequences.size() : std::min(p.sequences.size(), sequences);
    for (std::size_t q = 0; q < n; ++q) {
      const auto run = experiment.run(q, false, true);
      calibration.add(experiment.filter(), p.sequences[q], run,
                      static_cast<Eigen::Index>(run.raised_dark ? 1 : 0));
    }
  }
  return calibration.fit(params);
}

}  // namespace tacmap
