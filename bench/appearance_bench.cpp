// The cost of not knowing how the photograph shows the object's height: one touch (predict then
// update) of the default model with the map's appearance fixed (raised = bright, the filter
// before appearance hypotheses) against the same model with both appearances as a latent state
// of the filter (appearance_likelihood over a latent_grid). Issue target: the latent default at
// most 2 x the fixed one per touch, same run. Planar: classic_sift per window, aligned,
// exponential (the default); pose: sift_lite rotated model, 36 headings.
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "bench_maps.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/library_localizer.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/tacmap.hpp"

namespace {

using tacmap_bench::bench_map;
using tacmap_bench::frame_at;
using tacmap_bench::time_localizer_touches;
using tacmap_bench::time_touches;
using planar = tacmap::planar_grid<float>;
using pose = tacmap::pose_grid<float>;

void planar_touch_fixed(benchmark::State& state) {
  const auto map = bench_map();
  const auto grid = planar::paper();
  tacmap::bayes_filter filter(
      grid, tacmap::odometry_gaussian{},
      tacmap::descriptor_likelihood<tacmap::classic_sift>({}, map, grid.window_size()));
  time_touches(state, filter, map, {.dx_mm = 4.5, .dy_mm = 0.0}, {.dx_mm = -4.5, .dy_mm = 0.0});
}
BENCHMARK(planar_touch_fixed)->Unit(benchmark::kMicrosecond);

// `both_signs`: the map stored in the contrast basis, both hypotheses from one pass (the
// default through localization_config); without it, one pass per hypothesis's image over the
// map's descriptors (`log_likelihood_each`).
void planar_touch_latent(benchmark::State& state, bool both_signs) {
  const auto map = bench_map();
  const auto grid = planar::paper();
  using model_t = tacmap::descriptor_likelihood<tacmap::classic_sift>;
  const tacmap::appearance_likelihood<model_t> model(
      model_t({}, map, grid.window_size(), {.both_signs = both_signs}));
  tacmap::bayes_filter filter(
      tacmap::latent_grid<planar>(grid, model.hypothesis_names()),
      tacmap::latent_motion<tacmap::odometry_gaussian>(tacmap::odometry_gaussian{}), model);
  time_touches(state, filter, map, {.dx_mm = 4.5, .dy_mm = 0.0}, {.dx_mm = -4.5, .dy_mm = 0.0});
}
BENCHMARK_CAPTURE(planar_touch_latent, one_pass, true)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(planar_touch_latent, pass_per_hypothesis, false)->Unit(benchmark::kMicrosecond);

// `config`'s planar filter on the bench map, touches alternating between two places.
void time_planar_filter(benchmark::State& state, const tacmap::localizer_config& config) {
  const auto map = bench_map();
  auto filter = tacmap::make_planar_filter(config, map, 3.4 / 3.0, {.width = 18, .height = 42});
  time_touches(state, filter, map, {.dx_mm = 4.5, .dy_mm = 0.0}, {.dx_mm = -4.5, .dy_mm = 0.0});
}

// The localizer's filter alone (make_planar_filter with the defaults: the model above behind
// appearance_likelihood, and robust_motion's floor and wide component): predict + update, as
// planar_touch_latent/one_pass; against planar_touch_default_filter_no_robust (below), the same
// filter without robust motion, it is robust motion's cost per touch.
void planar_touch_default_filter(benchmark::State& state) { time_planar_filter(state, {}); }
BENCHMARK(planar_touch_default_filter)->Unit(benchmark::kMicrosecond);

// The same filter with robust motion switched off (no floor, no wide or broad component): the
// issue's "per-touch cost at most 1.2 x" is planar_touch_default_filter against this, same run.
void planar_touch_default_filter_no_robust(benchmark::State& state) {
  tacmap::localizer_config config;
  config.lost_probability = 0.0;
  config.wide_probability = 0.0;
  config.broad_probability = 0.0;
  time_planar_filter(state, config);
}
BENCHMARK(planar_touch_default_filter_no_robust)->Unit(benchmark::kMicrosecond);

// The localizer's filter with the optional broad component (0.05 of 10 mm, off by default):
// its cost per touch against planar_touch_default_filter.
void planar_touch_default_filter_broad(benchmark::State& state) {
  tacmap::localizer_config config;
  config.broad_probability = 0.05;
  time_planar_filter(state, config);
}
BENCHMARK(planar_touch_default_filter_broad)->Unit(benchmark::kMicrosecond);

// The front door: one `localizer::touch` with its defaults (the model above, one pass, plus the
// motion floor, preprocessing a raw 14 x 6 frame, the estimate and `assess`'s verdict) against
// planar_touch_latent/one_pass, the bare filter's predict + update.
void planar_touch_localizer(benchmark::State& state) {
  const auto map = bench_map();
  tacmap::localizer loc(map, 3.4 / 3.0);
  time_localizer_touches(state, loc, map);
}
BENCHMARK(planar_touch_localizer)->Unit(benchmark::kMicrosecond);

// What the open-set hypothesis (filter/open_set.hpp) adds to a localizer's touch: following the
// update's report and the verdict against P(unknown) — the whole of its per-touch work (its
// evidence is the update's own `log_prediction_support`, eq. 1 of open_set.hpp). Compare with
// planar_touch_localizer in the same run.
void open_set_step(benchmark::State& state) {
  tacmap::open_set unknown;
  tacmap::update_report report;
  tacmap::confidence c;
  c.probability_within = 0.95;
  c.verdict = tacmap::verdict::localized;
  const double margin = unknown.params().support_margin;
  double support = 0.5;
  for (auto _ : state) {
    report.log_prediction_support = margin + support;
    support = -support;  // alternate around the margin, so that the odds stay finite
    tacmap::detail::follow_touch(unknown, false, report);
    const auto v = tacmap::with_open_set(c, unknown.probability_unknown(), {});
    benchmark::DoNotOptimize(v);
  }
}
BENCHMARK(open_set_step)->Unit(benchmark::kMicrosecond);

// What makes a touch all or nothing (detail::localizer_step): the localizer's filter state
// saved before each touch, a whole belief copy into reused storage (what a touch that changed
// every state pays; after a tracked touch only the changed cells are copied), against
// planar_touch_localizer, which includes it. Two saved states in turn: a save into the one the
// filter did not save into last copies the whole belief.
void planar_touch_localizer_save_state(benchmark::State& state) {
  const auto map = bench_map();
  tacmap::localizer loc(map, 3.4 / 3.0);
  loc.touch(frame_at(map, 30, 40));
  auto filter = *loc.planar_filter();
  tacmap::planar_localizer_filter::saved_state saved[2];
  int which = 0;
  for (auto _ : state) {
    filter.save_state(saved[which]);
    which = 1 - which;
    benchmark::ClobberMemory();
  }
}
BENCHMARK(planar_touch_localizer_save_state)->Unit(benchmark::kMicrosecond);

void pose_touch_fixed(benchmark::State& state) {
  const auto map = bench_map();
  const auto grid = pose::paper(36);
  tacmap::bayes_filter filter(
      grid, tacmap::pose_odometry_gaussian{},
      tacmap::rotated_descriptor_likelihood<tacmap::sift_lite>({}, map, grid));
  time_touches(state, filter, map, {.du_mm = 4.5, .dv_mm = 0.0, .dtheta_rad = 0.0},
               {.du_mm = -4.5, .dv_mm = 0.0, .dtheta_rad = 0.0});
}
BENCHMARK(pose_touch_fixed)->Unit(benchmark::kMillisecond);

void pose_touch_latent(benchmark::State& state) {
  const auto map = bench_map();
  const auto grid = pose::paper(36);
  using model_t = tacmap::rotated_descriptor_likelihood<tacmap::sift_lite>;
  const tacmap::appearance_likelihood<model_t> model(model_t({}, map, grid));
  tacmap::bayes_filter filter(
      tacmap::latent_grid<pose>(grid, model.hypothesis_names()),
      tacmap::latent_motion<tacmap::pose_odometry_gaussian>(tacmap::pose_odometry_gaussian{}),
      model);
  time_touches(state, filter, map, {.du_mm = 4.5, .dv_mm = 0.0, .dtheta_rad = 0.0},
               {.du_mm = -4.5, .dv_mm = 0.0, .dtheta_rad = 0.0});
}
BENCHMARK(pose_touch_latent)->Unit(benchmark::kMillisecond);

// The localizer's pose filter (make_pose_filter: 36 headings, both appearances, the motion
// floor) without robust_motion's wide component and with it (the default, one blur per heading
// layer): their ratio is the wide component's cost per pose touch.
void pose_touch_default_filter(benchmark::State& state, double wide) {
  const auto map = bench_map();
  tacmap::localizer_config c;
  c.headings = 36;
  c.wide_probability = wide;
  auto filter = tacmap::make_pose_filter(c, map, 3.4 / 3.0, {.width = 18, .height = 42});
  time_touches(state, filter, map, {.du_mm = 4.5, .dv_mm = 0.0, .dtheta_rad = 0.0},
               {.du_mm = -4.5, .dv_mm = 0.0, .dtheta_rad = 0.0});
}
BENCHMARK_CAPTURE(pose_touch_default_filter, no_wide, 0.0)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(pose_touch_default_filter, wide_default,
                  tacmap::localizer_config::default_wide_probability)
    ->Unit(benchmark::kMillisecond);

// Tracking under the default (issue 36): touches once localized (three full touches first),
// as time_touches times them, with tracking `params` (off: {}), and what share of them the
// tracked path took (counter `tracked`; the others are the whole grid: the scheduled re-check
// every `recheck_every` touches and any doubt) and the states it evaluated per touch.
template <class Filter>
void time_localized_touches(benchmark::State& state, Filter& filter,
                            const tacmap::image<float>& map, const tacmap::tracking_params& params,
                            const typename Filter::control_type& there,
                            const typename Filter::control_type& back) {
  const tacmap::image<float> a = map.block(30, 40, 42, 18);
  const tacmap::image<float> b = map.block(30, 44, 42, 18);
  filter.set_tracking({});
  filter.reset();
  filter.update(a);
  filter.predict(there);
  filter.update(b);
  filter.predict(back);
  filter.update(a);
  filter.set_tracking(params);
  bool at_a = true;
  double tracked = 0.0, evaluated = 0.0, touches = 0.0;
  for (auto _ : state) {
    filter.predict(at_a ? there : back);
    const tacmap::update_report r = filter.update(at_a ? b : a);
    at_a = !at_a;
    tracked += r.path == tacmap::update_path::tracked ? 1.0 : 0.0;
    evaluated += static_cast<double>(r.evaluated_states);
    touches += 1.0;
    benchmark::DoNotOptimize(filter.belief().data());
  }
  state.counters["tracked"] = tracked / touches;
  state.counters["evaluated"] = evaluated / touches;
}

// The localizer's planar filter (make_planar_filter, defaults) once localized: tracking off
// (today's front door) and `default_tracking()`.
void planar_touch_default_filter_localized(benchmark::State& state, bool tracking) {
  const auto map = bench_map();
  auto filter = tacmap::make_planar_filter({}, map, 3.4 / 3.0, {.width = 18, .height = 42});
  time_localized_touches(state, filter, map,
                         tracking ? tacmap::default_tracking() : tacmap::tracking_params{},
                         {.dx_mm = 4.5, .dy_mm = 0.0}, {.dx_mm = -4.5, .dy_mm = 0.0});
}
BENCHMARK_CAPTURE(planar_touch_default_filter_localized, full, false)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(planar_touch_default_filter_localized, tracked, true)
    ->Unit(benchmark::kMicrosecond);

// The localizer's pose filter with the rotated model's tracking hook: make_pose_filter's
// components (36 headings, both appearances, robust motion's floor and wide component, the
// default classic_sift rotated model and its parameters) with the model used directly, since
// `configured_rotated_measurement` does not forward the hook yet.
using pose_default_tracking_filter = tacmap::bayes_filter<
    tacmap::latent_grid<pose>,
    tacmap::robust_motion<tacmap::latent_motion<tacmap::pose_odometry_gaussian>>,
    tacmap::appearance_likelihood<tacmap::rotated_descriptor_likelihood<tacmap::classic_sift>>>;

pose_default_tracking_filter make_pose_default_tracking_filter(const tacmap::image<float>& map,
                                                               double mm_per_px) {
  tacmap::localizer_config c;
  c.headings = 36;
  const pose grid(tacmap::planar_grid<float>({.width = map.cols(), .height = map.rows()}, mm_per_px,
                                             {.width = 18, .height = 42}),
                  c.headings);
  tacmap::rotated_likelihood_params p;
  p.pairs = c.pairs;
  p.shape = c.shape;
  if (c.tau) p.tau = *c.tau;
  if (c.patch_spacing) p.spacing = *c.patch_spacing;
  p.tempering = c.tempering;
  const auto appearances = c.appearances();
  return pose_default_tracking_filter(
      tacmap::latent_grid<pose>(grid, tacmap::appearance_names(appearances)),
      tacmap::robust_motion(
          tacmap::latent_motion<tacmap::pose_odometry_gaussian>(
              tacmap::pose_odometry_gaussian(
                  {.sigma_mm = c.motion_sigma_mm, .k = c.motion_k, .sigma_rad = c.turn_sigma_rad}),
              {.switch_probability = c.switch_probability()}),
          tacmap::robust_motion_params{.lost_probability = c.lost(),
                                       .wide_probability = c.wide(),
                                       .wide_sigma_mm = c.wide_sigma_mm,
                                       .broad_probability = c.broad(),
                                       .broad_sigma_mm = c.broad_sigma_mm}),
      tacmap::appearance_likelihood<tacmap::rotated_descriptor_likelihood<tacmap::classic_sift>>(
          tacmap::rotated_descriptor_likelihood<tacmap::classic_sift>({}, map, grid, p),
          appearances));
}

void pose_touch_default_filter_localized(benchmark::State& state, bool tracking) {
  const auto map = bench_map();
  auto filter = make_pose_default_tracking_filter(map, 3.4 / 3.0);
  time_localized_touches(state, filter, map,
                         tracking ? tacmap::default_tracking() : tacmap::tracking_params{},
                         {.du_mm = 4.5, .dv_mm = 0.0, .dtheta_rad = 0.0},
                         {.du_mm = -4.5, .dv_mm = 0.0, .dtheta_rad = 0.0});
}
BENCHMARK_CAPTURE(pose_touch_default_filter_localized, full, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(pose_touch_default_filter_localized, tracked, true)
    ->Unit(benchmark::kMillisecond);

// Which object, and where (issue 15): one touch (predict + update) of the library filter
// (make_library_filter: the localizer's default filter per object) over N objects of the bench
// map's size, each its own map. Against planar_touch_default_filter (one object, the same filter)
// the cost should grow linearly with the library's states: N x. /all: every object evaluated
// at every touch (pruning off); /pruned: the default, after 8 touches on object 0, when the
// other objects' posteriors are below library_likelihood_params::prune_below and cost nothing.
void library_touch(benchmark::State& state, bool prune) {
  const auto objects = static_cast<unsigned>(state.range(0));
  std::vector<tacmap::library_map> maps;
  for (unsigned k = 0; k < objects; ++k)
    maps.push_back({"object " + std::to_string(k), bench_map(120, 120, 9 + k), 3.4 / 3.0});
  auto filter = tacmap::make_library_filter({}, maps);
  if (!prune) filter.measurement_model().set_params({.prune_below = 0.0});
  const auto& map = maps[0].map;
  const std::vector<tacmap::image<float>> a{map.block(30, 40, 42, 18)};
  const std::vector<tacmap::image<float>> b{map.block(30, 44, 42, 18)};
  const tacmap::odometry there{.dx_mm = 4.5, .dy_mm = 0.0}, back{.dx_mm = -4.5, .dy_mm = 0.0};
  bool at_a = true;
  const auto touch = [&] {
    filter.predict(at_a ? there : back);
    filter.update(at_a ? b : a);
    at_a = !at_a;
  };
  filter.update(a);
  for (int warm = 0; warm < 8; ++warm) touch();
  for (auto _ : state) {
    touch();
    benchmark::DoNotOptimize(filter.belief().data());
  }
  std::size_t evaluated = 0;
  for (const bool e : filter.measurement_model().evaluated()) evaluated += e ? 1U : 0U;
  state.counters["objects_evaluated"] = static_cast<double>(evaluated);
}
BENCHMARK_CAPTURE(library_touch, all, false)
    ->Arg(1)
    ->Arg(2)
    ->Arg(4)
    ->Arg(8)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(library_touch, pruned, true)->Arg(8)->Unit(benchmark::kMicrosecond);

}  // namespace
