// tacmap: `library_experiment` — which object, and where, in simulation: sequences of touches on
// one object of a library, localized by the filter over the whole library (issue 15).
//
// Each object is a protocol (its photograph, scale and touch sequences) simulated as
// `localization_experiment` simulates one map: the scenario's camera map, registration error,
// press variations and exploration faults. What differs from the world a single-object run
// assumes is that the filter is not told which object is touched: it holds every object's map
// (the camera map of each, as the robot photographed them) and must recognise the object from
// the touches while it localizes them. Each object has one appearance for all its sequences (a
// photograph is taken once): with a random polarity it is drawn per object, not per sequence.
// The same touches also run through the filter of the touched object alone (what a robot that
// knows the object gets), so every table can compare both on identical data. Maps at different
// scales are resampled to the library's one scale (`make_library_filter`), and the touches are
// preprocessed at it.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "tacmap/filter/open_set.hpp"
#include "tacmap/library_localizer.hpp"
#include "tacmap/sim/experiment.hpp"

namespace tacmap {

/// One object of a simulated library: its name and its protocol (photograph, scale, sequences).
struct library_object {
  std::string name;
  const touch_protocol* protocol = nullptr;  ///< must outlive the experiment
};

/// One sequence on one object of the library.
struct library_sequence_result {
  std::size_t object = 0;    ///< the object touched (index into the library)
  std::size_t sequence = 0;  ///< the sequence of its protocol
  bool raised_dark = false;  ///< the object's appearance: raised parts dark in its photograph
  /// The library filter's touches: `error_mm` is the estimate's distance to the truth when the
  /// most probable object is the touched one and +infinity otherwise (a position on the wrong
  /// object is no position), so `localized()` and `touches_to_localize()` mean "on the right
  /// object and within the radius"; `probability_within` and `verdict` are the joint ones.
  std::vector<touch_record> touches;
  /// The same touches through the filter of the touched object alone (the object known).
  std::vector<touch_record> known_object;
  /// After each touch: every object's posterior, and the most probable object.
  std::vector<std::vector<double>> object_probability;
  std::vector<std::size_t> decided;
  /// After each touch: the objects the library filter evaluated (pruning).
  std::vector<std::size_t> evaluated_objects;
  /// After each touch: P(none of the maps) with the configuration's prior
  /// (`localizer_config::open_set`, filter/open_set.hpp), the touch's log Bayes factor of the
  /// maps against the unknown (0 for a rejected frame), and the verdict with the open set
  /// (`with_open_set`; `touches[t].verdict` is the filter's own, without it). The object
  /// posteriors in `object_probability` are the filter's, given one of the maps.
  std::vector<double> probability_unknown;
  std::vector<double> log_open_set_factor;
  std::vector<tacmap::verdict> open_set_verdict;
  /// After each touch, with the shadow model (`unknown_model::shadow`): the touch's predictive
  /// log-evidence under the shadow filter over the mirrored maps (eq. 2 of filter/open_set.hpp;
  /// 0 for a rejected frame); empty with the support model.
  std::vector<double> log_shadow_evidence;
  /// The shadow filter's `update_report::log_likelihood_max` of the touch (0 for a rejected
  /// frame); empty with the support model.
  std::vector<double> shadow_log_likelihood_max;
  /// After each touch: the touch's largest log-likelihood over the states evaluated
  /// (`update_report::log_likelihood_max`, 0 for a rejected frame).
  std::vector<double> log_likelihood_max;
  bool open_set = false;      ///< `run_left_out`: the touched object was not in the library
  bool wrong_object = false;  ///< `run_wrong_object`: touches on another object's single map

  /// True when after touch `t` (1-based) the touched object is the most probable one with a
  /// posterior above `threshold`.
  [[nodiscard]] bool recognized_at(std::size_t t, double threshold = 0.9) const {
    return t >= 1 && t <= decided.size() && decided[t - 1] == object &&
           object_probability[t - 1][object] > threshold;
  }
  /// As `recognized_at`, with the open set: the object's posterior times P(one of the maps)
  /// (`probability_unknown`) above `threshold`.
  [[nodiscard]] bool recognized_with_unknown_at(std::size_t t, double threshold = 0.9) const {
    return recognized_at(t, 0.0) &&
           object_probability[t - 1][object] * (1.0 - probability_unknown[t - 1]) > threshold;
  }
  /// The first touch (1-based) from which the object stays recognized; empty when it is not at
  /// the last touch.
  [[nodiscard]] std::optional<std::size_t> touches_to_recognize(double threshold = 0.9) const {
    std::optional<std::size_t> first;
    for (std::size_t t = 1; t <= decided.size(); ++t) {
      if (recognized_at(t, threshold)) {
        if (!first) first = t;
      } else {
        first.reset();
      }
    }
    return first;
  }
};

/// A library of simulated objects and the filter over all of them (see the file comment).
class library_experiment {
 public:
  /// Throws std::invalid_argument for an empty library, a missing protocol, repeated names,
  /// an unknown heading (the library filter is planar) or anything `localization_experiment`
  /// and `make_library_filter` refuse.
  library_experiment(std::vector<library_object> objects, localization_config config)
      : objects_(std::move(objects)), config_(std::move(config)) {
    config_.validate();
    if (objects_.empty())
      detail::fail("library_experiment: no objects; expected at least one (two or more to ",
                   "recognise anything)");
    if (config_.headings != 0 || config_.random_orientation)
      detail::fail("library_experiment: headings = ", config_.headings, ", random orientation ",
                   config_.random_orientation ? "on" : "off",
                   "; the library filter localizes with a known heading: headings = 0 and no "
                   "random orientation");
    std::vector<library_map> maps;
    for (std::size_t k = 0; k < objects_.size(); ++k) {
      if (objects_[k].protocol == nullptr)
        detail::fail("library_experiment: object ", k, " ('", objects_[k].name,
                     "') has no protocol; expected its touch protocol");
      localization_config c = config_;
      if (c.scenario.polarity == relief_polarity::random) {
        // One photograph per object: its appearance is drawn once, from its own stream.
        std::uint64_t s = config_.simulator_seed ^ (0xC2B2AE3D27D4EB4FULL * (k + 1));
        sim_rng rng(splitmix64(s));
        c.scenario.polarity =
            rng.uniform() < 0.5 ? relief_polarity::bright_raised : relief_polarity::dark_raised;
      }
      dark_.push_back(c.scenario.polarity == relief_polarity::dark_raised ? 1 : 0);
      experiments_.push_back(std::make_unique<localization_experiment>(*objects_[k].protocol, c));
      maps.push_back(
          {objects_[k].name, experiments_.back()->visual_map(), objects_[k].protocol->mm_per_px});
    }
    filter_.emplace(make_library_filter(config_, maps, config_.simulator.geometry));
    // The touches as the library sees them: at its one scale (the coarsest map's, or the
    // working resolution where that is coarser).
    config_.preprocessing.mm_per_px = library_scale(maps, config_, config_.simulator.geometry);
    if (shadowed())
      shadow_.emplace(make_library_filter(config_, mirrored_maps(maps), config_.simulator.geometry,
                                          {}, config_.preprocessing.mm_per_px));
  }

  [[nodiscard]] std::size_t objects() const { return objects_.size(); }
  [[nodiscard]] const library_object& object(std::size_t k) const { return objects_.at(k); }
  [[nodiscard]] const localization_config& config() const { return config_; }
  [[nodiscard]] const library_localizer_filter& filter() const { return *filter_; }
  /// The library's measurement parameters (pruning, evidence exponent); throws
  /// std::invalid_argument for invalid ones.
  void set_library_params(const library_likelihood_params& params) {
    filter_->measurement_model().set_params(params);
    if (shadow_) shadow_->measurement_model().set_params(params);
  }
  /// Object k's appearance: raised parts dark in its photograph.
  [[nodiscard]] bool raised_dark(std::size_t k) const { return dark_.at(k) != 0; }
  /// The map the library holds for object k (its camera map).
  [[nodiscard]] const image<float>& visual_map(std::size_t k) const {
    return experiments_.at(k)->visual_map();
  }

  /// Replays sequence `sequence` of object `object`'s protocol through the library filter
  /// (from its prior) and through that object's own filter. Throws std::invalid_argument for an
  /// object or sequence out of range.
  [[nodiscard]] library_sequence_result run(std::size_t object, std::size_t sequence) {
    check_object(object);
    const auto same = [](Eigen::Index k) { return static_cast<std::size_t>(k); };
    if (config_.order == touch_order::active) {
      // The library filter chooses each next touch (`next_touch` over objects and positions,
      // among candidates drawn on the touched object: the arm knows where the object is, not
      // which it is), so it runs touch by touch beside the simulation; the object's own filter
      // sees the same touches.
      library_sequence_result out;
      out.object = object;
      out.sequence = sequence;
      out.raised_dark = raised_dark(object);
      library_localizer_filter& f = *filter_;
      f.reset();
      if (shadow_) shadow_->reset();
      open_set unknown(config_.open_set);
      touch_hooks hooks;
      hooks.rank = [&](std::span<const odometry> moves) {
        return detail::rank_library_touches(f, moves, config_.confidence.radius_mm,
                                            config_.next_touch,
                                            "library_experiment (active order)");
      };
      hooks.touched = [&](const touch_record& rec, const tactile_frame& frame) {
        replay_touch(f, shadow_ ? &*shadow_ : nullptr, unknown, rec, frame, config_.preprocessing,
                     out, same);
      };
      out.known_object = experiments_[object]->run(sequence, false, false, hooks).touches;
      return out;
    }
    // The touched object's simulation (frames, truth, odometry) and its own filter's run.
    sequence_result single = experiments_[object]->run(sequence, true);
    library_sequence_result out = start(object, sequence, single);
    replay(*filter_, shadow_ ? &*shadow_ : nullptr, single, config_.preprocessing, out, same);
    return out;
  }

  /// Open set: the same sequence through a library of every object but the touched one (its
  /// photograph left out), so that every "localized" is a false claim and `probability_unknown`
  /// should rise. Each left-out library is prepared on first use.
  [[nodiscard]] library_sequence_result run_left_out(std::size_t object, std::size_t sequence) {
    check_object(object);
    if (objects_.size() < 2)
      detail::fail("library_experiment::run_left_out: a library of ", objects_.size(),
                   " object; expected two or more (one is left out)");
    if (left_out_.size() != objects_.size()) {
      left_out_.resize(objects_.size());
      left_out_shadow_.resize(objects_.size());
    }
    if (!left_out_[object]) {
      std::vector<library_map> maps;
      for (std::size_t k = 0; k < objects_.size(); ++k)
        if (k != object) maps.push_back(map_of(k));
      // At the full library's scale: the same touches as `run` sees.
      left_out_[object].emplace(make_library_filter(config_, maps, config_.simulator.geometry, {},
                                                    config_.preprocessing.mm_per_px));
      left_out_[object]->measurement_model().set_params(filter_->measurement_model().params());
      if (shadowed()) {
        // The shadow of the library the robot holds: the mirrored maps of that library.
        left_out_shadow_[object].emplace(make_library_filter(config_, mirrored_maps(maps),
                                                             config_.simulator.geometry, {},
                                                             config_.preprocessing.mm_per_px));
        left_out_shadow_[object]->measurement_model().set_params(
            filter_->measurement_model().params());
      }
    }
    sequence_result single = experiments_[object]->run(sequence, true);
    library_sequence_result out = start(object, sequence, single);
    out.open_set = true;
    auto& shadow = left_out_shadow_[object];
    replay(*left_out_[object], shadow ? &*shadow : nullptr, single, config_.preprocessing, out,
           [object](Eigen::Index k) {
             return static_cast<std::size_t>(k) + (static_cast<std::size_t>(k) >= object ? 1 : 0);
           });
    return out;
  }

  /// Wrong object: the sequence's touches (object `object`) through the single-map filter of
  /// the next object's photograph ((object + 1) mod objects), as a `localizer` built for that
  /// photograph would run them; every "localized" is a false claim. `decided` holds the map's
  /// object, `object_probability` P(this map | ...) = 1 - P(not this object).
  [[nodiscard]] library_sequence_result run_wrong_object(std::size_t object, std::size_t sequence) {
    check_object(object);
    library_sequence_result out = run_single_map(object, sequence, (object + 1) % objects_.size());
    out.wrong_object = true;
    return out;
  }

  /// The sequence's touches (object `object`) through the single-map filter of object
  /// `other`'s photograph, as a `localizer` of that photograph runs them (`other` == `object`:
  /// the object's own map, the single-object case the open set must not spoil).
  [[nodiscard]] library_sequence_result run_single_map(std::size_t object, std::size_t sequence,
                                                       std::size_t other) {
    check_object(object);
    check_object(other);
    if (single_.size() != objects_.size()) {
      single_.resize(objects_.size());
      single_shadow_.resize(objects_.size());
    }
    const touch_protocol& p = *objects_[other].protocol;
    if (!single_[other]) {
      const pixel_size window = checked_tactile_window(config_.simulator.geometry, p.mm_per_px,
                                                       p.map_size(), "library_experiment");
      single_[other].emplace(make_planar_filter(config_, visual_map(other), p.mm_per_px, window,
                                                config_.simulator.geometry));
      if (shadowed())
        single_shadow_[other].emplace(
            make_planar_filter(config_, visual_map(other).rowwise().reverse().eval(), p.mm_per_px,
                               window, config_.simulator.geometry));
    }
    sequence_result single = experiments_[object]->run(sequence, true);
    library_sequence_result out = start(object, sequence, single);
    preprocess_params pp = config_.preprocessing;
    pp.mm_per_px = p.mm_per_px;  // what a localizer of that photograph is configured with
    auto& shadow = single_shadow_[other];
    replay(*single_[other], shadow ? &*shadow : nullptr, single, pp, out,
           [other](Eigen::Index) { return other; });
    return out;
  }

 private:
  [[nodiscard]] bool shadowed() const { return config_.open_set.model == unknown_model::shadow; }
  void check_object(std::size_t object) const {
    if (object >= objects_.size())
      detail::fail("library_experiment::run: object ", object, "; expected 0 .. ",
                   objects_.size() - 1);
  }
  [[nodiscard]] library_map map_of(std::size_t k) const {
    return {objects_[k].name, visual_map(k), objects_[k].protocol->mm_per_px};
  }
  library_sequence_result start(std::size_t object, std::size_t sequence,
                                const sequence_result& single) const {
    library_sequence_result out;
    out.object = object;
    out.sequence = sequence;
    out.raised_dark = raised_dark(object);
    out.known_object = single.touches;
    return out;
  }

  // The touches of `single` through `f` (from its prior), as `library_localizer` runs them:
  // predict, update, restart on the two documented causes, assess, and the open-set hypothesis
  // beside it (filter/open_set.hpp). `object_of` maps the filter's objects to the library's.
  template <class Filter, class ObjectOf>
  void replay(Filter& f, Filter* shadow, const sequence_result& single, const preprocess_params& pp,
              library_sequence_result& out, ObjectOf&& object_of) const {
    f.reset();
    if (shadow) shadow->reset();
    open_set unknown(config_.open_set);
    for (std::size_t t = 0; t < single.touches.size(); ++t)
      replay_touch(f, shadow, unknown, single.touches[t], single.frames[t], pp, out, object_of);
  }

  // One touch of `replay` (its record `touch` and frame), appended to `out`. `shadow`, where
  // given, is the open set's shadow filter (eq. 2 of filter/open_set.hpp): the same motions and
  // touches on the mirrored maps, restarted with `f`, and on its own when a touch contradicts
  // its prediction (its evidence is then the touch's under a uniform belief).
  template <class Filter, class ObjectOf>
  void replay_touch(Filter& f, Filter* shadow, open_set& unknown, const touch_record& touch,
                    const tactile_frame& frame, const preprocess_params& pp,
                    library_sequence_result& out, ObjectOf&& object_of) const {
    constexpr bool library = library_state_grid<typename Filter::grid_type>;
    const std::size_t object = out.object;
    const std::size_t t = touch.step;
    touch_record rec = touch;
    rec.lost_track = false;
    if (t > 0) {
      try {
        f.predict({.dx_mm = rec.reported_dx_mm, .dy_mm = rec.reported_dy_mm});
      } catch (const std::domain_error&) {
        f.reset();
        unknown.reset();
        rec.lost_track = true;
      }
    }
    const preprocessed_frame pre = preprocess(frame, pp);
    rec.accepted = pre.accepted();
    rec.rejection = pre.rejection;
    std::optional<update_report> report;
    const std::optional<odometry> moved =
        t > 0 ? std::optional<odometry>(
                    odometry{.dx_mm = rec.reported_dx_mm, .dy_mm = rec.reported_dy_mm})
              : std::nullopt;
    double log_factor = 0.0;
    double best = 0.0;
    double shadow_evidence = 0.0, shadow_best = 0.0;
    if (pre.accepted()) {
      const auto z = [&] {
        if constexpr (library)
          return std::vector<image<float>>{pre.pixels};
        else
          return pre.pixels;
      }();
      try {
        report = f.update(z);
      } catch (const std::domain_error&) {
        f.reset();
        unknown.reset();
        rec.lost_track = true;
        report = f.update(z);
        report->log_prediction_support = -std::numeric_limits<double>::infinity();
      }
      rec.log_marginal_likelihood = report->log_marginal_likelihood();
      best = report->log_likelihood_max;
      rec.log_prediction_support = report->log_prediction_support;
      rec.contradicted = report->log_prediction_support < config_.confidence.contradiction;
      std::optional<update_report> shadow_report;
      if (shadow) {
        shadow_report = detail::shadow_step(*shadow, moved, &z, rec.lost_track);
        shadow_evidence = shadow_report->log_marginal_likelihood();
        shadow_best = shadow_report->log_likelihood_max;
      }
      // As the front doors weigh it (detail::follow_touch): a restart restarts the question.
      const double before = unknown.log_odds();
      if (!rec.lost_track) {
        if (shadow_report)
          unknown.observe(*report, *shadow_report);
        else
          unknown.observe(*report);
      }
      log_factor = before - unknown.log_odds();
    } else if (shadow) {
      using measurement = std::conditional_t<library, std::vector<image<float>>, image<float>>;
      (void)detail::shadow_step(*shadow, moved, static_cast<const measurement*>(nullptr),
                                rec.lost_track);
    }
    const auto est = f.estimate();
    const confidence conf = assess(f, est, config_.confidence);
    std::size_t decided = object_of(0);
    std::vector<double> p(objects_.size(), 0.0);
    if constexpr (library) {
      decided = object_of(est.map_object);
      for (std::size_t k = 0; k < est.object_probability.size(); ++k)
        p[object_of(static_cast<Eigen::Index>(k))] = est.object_probability[k];
    } else {
      p[decided] = 1.0;
    }
    rec.probability_within = conf.probability_within;
    rec.verdict = conf.verdict;
    rec.estimate_x_mm = conf.centre_mm(0);
    rec.estimate_y_mm = conf.centre_mm(1);
    rec.map_x_mm = est.map_mm(0);
    rec.map_y_mm = est.map_mm(1);
    const double inf = std::numeric_limits<double>::infinity();
    rec.error_mm = decided == object ? std::hypot(rec.estimate_x_mm - rec.true_x_mm,
                                                  rec.estimate_y_mm - rec.true_y_mm)
                                     : inf;
    rec.map_error_mm = decided == object
                           ? std::hypot(rec.map_x_mm - rec.true_x_mm, rec.map_y_mm - rec.true_y_mm)
                           : inf;
    rec.entropy_nats = est.entropy_nats;
    rec.appearance_probability = est.hypothesis_probability;
    const double pu = unknown.probability_unknown();
    out.touches.push_back(rec);
    out.object_probability.push_back(p);
    out.decided.push_back(decided);
    out.probability_unknown.push_back(pu);
    out.log_open_set_factor.push_back(log_factor);
    out.log_likelihood_max.push_back(best);
    if (shadow) {
      out.log_shadow_evidence.push_back(shadow_evidence);
      out.shadow_log_likelihood_max.push_back(shadow_best);
    }
    out.open_set_verdict.push_back(with_open_set(conf, pu, config_.confidence).verdict);
    std::size_t evaluated = 1;
    if constexpr (library) {
      evaluated = 0;
      for (const bool e : f.measurement_model().evaluated()) evaluated += e ? 1U : 0U;
    }
    out.evaluated_objects.push_back(report ? evaluated : 0U);
  }

  std::vector<library_object> objects_;
  localization_config config_;
  std::vector<std::unique_ptr<localization_experiment>> experiments_;
  std::vector<char> dark_;
  std::optional<library_localizer_filter> filter_;
  std::vector<std::optional<library_localizer_filter>> left_out_;  // run_left_out, per object
  std::vector<std::optional<planar_localizer_filter>> single_;     // run_wrong_object, per map
  // The open set's shadow filters (unknown_model::shadow): of the library, of each left-out
  // library and of each single map.
  std::optional<library_localizer_filter> shadow_;
  std::vector<std::optional<library_localizer_filter>> left_out_shadow_;
  std::vector<std::optional<planar_localizer_filter>> single_shadow_;
};

}  // namespace tacmap
