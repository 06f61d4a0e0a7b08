// tacmap-evaluate --library: which object, and where (issue 15). Every map of the run is one
// object of one library; each sequence is a protocol sequence on a random object, localized by
// the filter over the whole library (`library_experiment`), and by the touched object's own
// filter on the same touches (the object known) for comparison.
#pragma once

#include <algorithm>
#include <cstdio>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "tacmap/sim/library_experiment.hpp"
#include "tacmap/sim/random.hpp"

namespace tacmap_tools {

struct library_tally {
  std::size_t sequences = 0;
  std::vector<std::size_t> recognized;  // per touch number: touched object decided, P > 0.9
  std::size_t recognized_by_4 = 0;      // recognized at touch 4
  std::size_t localized = 0;            // < 5 mm on the right object from touch 6 on
  std::size_t localized_known = 0;      // the same touches, the object known
  std::size_t wrong_at_end = 0;         // another object decided at the last touch
  std::vector<double> to_recognize;     // touches until recognized for good
  std::vector<double> evaluated;        // per touch number: objects evaluated, summed
  std::vector<std::size_t> touches_at;  // per touch number: how many sequences have one

  // Claims: "localized" that is false (another object, or 5 mm or more off; in the open-set and
  // wrong-object modes every one), at any touch and at the last, without and with the open set.
  std::size_t false_any = 0, false_last = 0, false_any_open = 0, false_last_open = 0;
  std::size_t right_last = 0, right_last_open = 0;  // a right "localized" at the last touch
  std::size_t recognized_by_4_open = 0;             // recognized at touch 4, with the open set
  std::vector<double> unknown_at_end;               // P(unknown) at the last touch

  void add(const tacmap::library_sequence_result& r) {
    ++sequences;
    const bool all_false = r.open_set || r.wrong_object;
    bool any = false, any_open = false, last = false, last_open = false;
    for (std::size_t t = 0; t < r.touches.size(); ++t) {
      const bool wrong = all_false || r.decided[t] != r.object || !(r.touches[t].error_mm < 5.0);
      const bool claim = r.touches[t].verdict == tacmap::verdict::localized;
      const bool claim_open = r.open_set_verdict[t] == tacmap::verdict::localized;
      any = any || (claim && wrong);
      any_open = any_open || (claim_open && wrong);
      if (t + 1 == r.touches.size()) {
        last = claim && wrong;
        last_open = claim_open && wrong;
        right_last += claim && !wrong ? 1U : 0U;
        right_last_open += claim_open && !wrong ? 1U : 0U;
      }
    }
    false_any += any ? 1U : 0U;
    false_last += last ? 1U : 0U;
    false_any_open += any_open ? 1U : 0U;
    false_last_open += last_open ? 1U : 0U;
    if (!r.probability_unknown.empty()) unknown_at_end.push_back(r.probability_unknown.back());
    recognized_by_4_open +=
        !all_false && r.recognized_with_unknown_at(std::min<std::size_t>(4, r.touches.size())) ? 1U
                                                                                               : 0U;
    const std::size_t n = r.touches.size();
    if (recognized.size() < n) {
      recognized.resize(n);
      evaluated.resize(n);
      touches_at.resize(n);
    }
    for (std::size_t t = 1; t <= n; ++t) {
      recognized[t - 1] += r.recognized_at(t) ? 1U : 0U;
      evaluated[t - 1] += static_cast<double>(r.evaluated_objects[t - 1]);
      ++touches_at[t - 1];
    }
    recognized_by_4 += r.recognized_at(std::min<std::size_t>(4, n)) ? 1U : 0U;
    localized += tacmap::localized(r.touches) ? 1U : 0U;
    localized_known += tacmap::localized(r.known_object) ? 1U : 0U;
    wrong_at_end += !r.decided.empty() && r.decided.back() != r.object ? 1U : 0U;
    if (const auto t = r.touches_to_recognize()) to_recognize.push_back(static_cast<double>(*t));
  }
};

// A configuration's name in the tables and the CSV: its filter's, and "/active" when the library
// filter chooses the touches (--touch-order active).
inline std::string library_label(const tacmap::localization_config& c) {
  return c.name() + (c.order == tacmap::touch_order::active ? "/active" : "") +
         (c.simulator.frames_per_press == 1
              ? std::string()
              : "/frames " + std::to_string(c.simulator.frames_per_press));
}

inline std::string library_percent(std::size_t k, std::size_t n) {
  if (n == 0) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", 100.0 * static_cast<double>(k) / static_cast<double>(n));
  return buf;
}

/// What a library evaluation runs each sequence through (tacmap-evaluate --library-mode).
enum class library_mode {
  closed,        ///< the whole library (the touched object is in it)
  left_out,      ///< the library without the touched object: open set
  wrong_object,  ///< the single map of the next object (a localizer of another photograph)
  own_map,       ///< the object's own single map (a localizer of its photograph)
};

inline const char* to_string(library_mode m) {
  switch (m) {
    case library_mode::closed:
      return "closed";
    case library_mode::left_out:
      return "left-out";
    case library_mode::wrong_object:
      return "wrong-object";
    case library_mode::own_map:
      return "own-map";
  }
  return "?";
}

/// Runs `sequences` library sequences per configuration over `objects` (each with its
/// protocol), printing the tables (Markdown) to stdout and one row per touch to `csv`. Returns
/// false when a localization rate is below `min_success` (a fraction; negative: no floor).
inline bool run_library_evaluation(const std::vector<tacmap::library_object>& objects,
                                   const std::vector<tacmap::localization_config>& configs,
                                   std::size_t sequences, std::size_t max_sequences,
                                   std::uint64_t seed, double min_success, bool quiet,
                                   std::ostream& csv,
                                   const tacmap::library_likelihood_params& params = {},
                                   library_mode mode = library_mode::closed) {
  csv << "config,mode,object,sequence,touch,decided,p_true_object,p_decided,error_mm,"
         "known_error_mm,probability_within,verdict,objects_evaluated,raised_dark,p_unknown,"
         "log_open_set_factor,open_set_verdict,log_likelihood_max,log_marginal_likelihood,"
         "log_prediction_support,entropy_nats,log_shadow_evidence,shadow_log_likelihood_max\n";
  bool below_floor = false;
  const std::size_t k_objects = objects.size();
  std::printf(
      "| configuration | objects | sequences | recognized %% (right object, P > 0.9) at touch 1, "
      "2, ... | recognized by touch 4 %% | localized %%: library / object known | median touches "
      "to recognize | wrong object at the last touch | objects evaluated per touch (of %zu) |\n"
      "|---|---|---|---|---|---|---|---|---|\n",
      k_objects);
  for (const auto& config : configs) {
    if (!quiet)
      std::fprintf(stderr, "%s: preparing %zu maps\n", library_label(config).c_str(), k_objects);
    tacmap::library_experiment experiment(objects, config);
    experiment.set_library_params(params);
    library_tally total;
    std::vector<library_tally> per_object(k_objects);
    std::vector<std::vector<std::size_t>> confusion(k_objects, std::vector<std::size_t>(k_objects));
    // Which object and which of its sequences: their own stream, fixed by the seed.
    std::uint64_t s = seed ^ 0x6A09E667F3BCC909ULL;
    tacmap::sim_rng rng(tacmap::splitmix64(s));
    for (std::size_t q = 0; q < sequences; ++q) {
      const auto object = std::min(
          k_objects - 1, static_cast<std::size_t>(rng.uniform() * static_cast<double>(k_objects)));
      std::size_t n = objects[object].protocol->sequences.size();
      if (max_sequences > 0) n = std::min(n, max_sequences);
      const auto index =
          std::min(n - 1, static_cast<std::size_t>(rng.uniform() * static_cast<double>(n)));
      const auto r =
          mode == library_mode::left_out       ? experiment.run_left_out(object, index)
          : mode == library_mode::wrong_object ? experiment.run_wrong_object(object, index)
          : mode == library_mode::own_map      ? experiment.run_single_map(object, index, object)
                                               : experiment.run(object, index);
      total.add(r);
      per_object[object].add(r);
      if (!r.decided.empty()) ++confusion[object][r.decided.back()];
      for (std::size_t t = 0; t < r.touches.size(); ++t) {
        char line[800];
        std::snprintf(
            line, sizeof line,
            "%s,%s,%s,%zu,%zu,%s,%.4f,%.4f,%.4f,%.4f,%.4f,%s,%zu,%d,%.6g,%.6g,%s,%.9g,%.9g,%.6g,"
            "%.6g,%.9g,%.9g\n",
            library_label(config).c_str(), to_string(mode), objects[object].name.c_str(), index,
            t + 1, objects[r.decided[t]].name.c_str(), r.object_probability[t][object],
            r.object_probability[t][r.decided[t]], r.touches[t].error_mm,
            r.known_object[t].error_mm, r.touches[t].probability_within,
            tacmap::to_string(r.touches[t].verdict), r.evaluated_objects[t], r.raised_dark ? 1 : 0,
            r.probability_unknown[t], r.log_open_set_factor[t],
            tacmap::to_string(r.open_set_verdict[t]), r.log_likelihood_max[t],
            r.touches[t].log_marginal_likelihood, r.touches[t].log_prediction_support,
            r.touches[t].entropy_nats,
            r.log_shadow_evidence.empty() ? 0.0 : r.log_shadow_evidence[t],
            r.shadow_log_likelihood_max.empty() ? 0.0 : r.shadow_log_likelihood_max[t]);
        csv << line;
      }
      if (!quiet) std::fprintf(stderr, "\r%zu/%zu sequences", q + 1, sequences);
    }
    if (!quiet) std::fprintf(stderr, "\r%*s\r", 40, "");
    std::string per_touch, evaluated;
    for (std::size_t t = 0; t < total.recognized.size(); ++t) {
      if (t > 0) per_touch += ", ";
      per_touch += library_percent(total.recognized[t], total.touches_at[t]);
      char buf[32];
      std::snprintf(
          buf, sizeof buf, "%.1f",
          total.evaluated[t] / static_cast<double>(std::max<std::size_t>(1, total.touches_at[t])));
      if (t > 0) evaluated += ", ";
      evaluated += buf;
    }
    char ttr[32] = "-";
    if (!total.to_recognize.empty())
      std::snprintf(ttr, sizeof ttr, "%.1f", tacmap::median(total.to_recognize));
    std::printf("| %s | %zu | %zu | %s | %s | %s / %s | %s | %zu | %s |\n",
                library_label(config).c_str(), k_objects, total.sequences, per_touch.c_str(),
                library_percent(total.recognized_by_4, total.sequences).c_str(),
                library_percent(total.localized, total.sequences).c_str(),
                library_percent(total.localized_known, total.sequences).c_str(), ttr,
                total.wrong_at_end, evaluated.c_str());
    // False claims and recognition, without and with the open-set hypothesis.
    char pu[32] = "-";
    if (!total.unknown_at_end.empty())
      std::snprintf(pu, sizeof pu, "%.3f", tacmap::median(total.unknown_at_end));
    std::printf(
        "\n| configuration (%s; prior P(unknown) %g) | sequences | false \"localized\" at any "
        "touch %%: without / with the unknown | at the last touch %% | right \"localized\" at the "
        "last touch %% | recognized by touch 4 %% | median P(unknown) at the last touch |\n"
        "|---|---|---|---|---|---|---|\n",
        to_string(mode), config.open_set.prior_unknown);
    std::printf("| %s | %zu | %s / %s | %s / %s | %s / %s | %s / %s | %s |\n\n",
                library_label(config).c_str(), total.sequences,
                library_percent(total.false_any, total.sequences).c_str(),
                library_percent(total.false_any_open, total.sequences).c_str(),
                library_percent(total.false_last, total.sequences).c_str(),
                library_percent(total.false_last_open, total.sequences).c_str(),
                library_percent(total.right_last, total.sequences).c_str(),
                library_percent(total.right_last_open, total.sequences).c_str(),
                library_percent(total.recognized_by_4, total.sequences).c_str(),
                library_percent(total.recognized_by_4_open, total.sequences).c_str(), pu);
    // Per object, and the confusion matrix at the last touch.
    std::printf(
        "\n| object (%s) | raised parts in the photo | sequences | recognized by touch 4 | "
        "localized: library / object known |\n|---|---|---|---|---|\n",
        library_label(config).c_str());
    for (std::size_t k = 0; k < k_objects; ++k) {
      const library_tally& t = per_object[k];
      std::printf("| %s | %s | %zu | %zu | %zu / %zu |\n", objects[k].name.c_str(),
                  experiment.raised_dark(k) ? "dark" : "bright", t.sequences, t.recognized_by_4,
                  t.localized, t.localized_known);
    }
    std::printf(
        "\nConfusion at the last touch (rows: touched object; columns: most probable):\n\n| |");
    for (std::size_t k = 0; k < k_objects; ++k) std::printf(" %s |", objects[k].name.c_str());
    std::printf("\n|---|");
    for (std::size_t k = 0; k < k_objects; ++k) std::printf("---|");
    std::printf("\n");
    for (std::size_t a = 0; a < k_objects; ++a) {
      std::printf("| %s |", objects[a].name.c_str());
      for (std::size_t b = 0; b < k_objects; ++b) std::printf(" %zu |", confusion[a][b]);
      std::printf("\n");
    }
    std::printf("\n");
    std::fflush(stdout);
    if (min_success >= 0.0 && total.sequences > 0 &&
        static_cast<double>(total.localized) < min_success * static_cast<double>(total.sequences))
      below_floor = true;
  }
  return !below_floor;
}

}  // namespace tacmap_tools
