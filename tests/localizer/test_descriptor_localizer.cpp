// The generic front door (issue 33): a user's descriptor through `descriptor_localizer`, a
// user's measurement policy through `basic_localizer`, the shared step's honest restarts, bad
// descriptors refused by name, the cost guard, and recognition over a library.
#include <doctest/doctest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>

#include "../measurement/raw_patch_descriptor.hpp"
#include "tacmap/descriptor/dense_sift.hpp"
#include "tacmap/library_localizer.hpp"
#include "tacmap/localizer.hpp"
#include "tacmap/testing/localizer_conformance.hpp"
#include "test_support.hpp"

namespace test_descriptor_localizer {

// The suite users run, on a test descriptor without any hook but H1 (its inverted touch is
// described), through the generic distance path, and on SIFT-lite (the contrast hook H3).
TEST_CASE_TEMPLATE_INVOKE(tacmap_localizer_conformance, tacmap_test::raw_patch,
                          tacmap_test::raw_patch_generic, tacmap::sift_lite);

namespace {

using tacmap::testing::localizer_test_taxels;

// The map and frames of the conformance check (see localizer_conformance.hpp).
const tacmap::image<float>& taxels() {
  static const tacmap::image<float> t = localizer_test_taxels(26, 22, 9);
  return t;
}
const tacmap::image<float>& test_map() {
  static const tacmap::image<float> m = tacmap::detail::resize_taxels(
      taxels(), 3 * taxels().rows(), 3 * taxels().cols(), tacmap::resize_method::bilinear);
  return m;
}
constexpr double mm_per_px = 3.4 / 3.0;
tacmap::tactile_frame frame_at(Eigen::Index tr, Eigen::Index tc) {
  tacmap::tactile_frame f;
  f.counts = 3000.0F * taxels().block(tr, tc, 14, 6).array();
  return f;
}

// A descriptor that misbehaves on demand: NaN, a field of the wrong dimension, an empty field.
enum class fault { none, nan, wrong_dimension, empty_field };
struct faulty_patch {
  using scalar_type = float;
  using column = Eigen::Ref<const Eigen::Array<float, Eigen::Dynamic, 1>>;
  static constexpr bool euclidean_distance = true;
  std::shared_ptr<fault> mode = std::make_shared<fault>(fault::none);
  // Only images of this many rows misbehave (0: all): the touch, not the map.
  Eigen::Index only_rows = 0;
  Eigen::Index dimension() const { return 16; }
  Eigen::Index patch_size() const { return 4; }
  tacmap::descriptor_field<float> compute(const tacmap::image<float>& img) const {
    auto f = tacmap_test::raw_patch{.patch = 4}.compute(img);
    if (only_rows != 0 && img.rows() != only_rows) return f;
    switch (*mode) {
      case fault::nan:
        f.values(3, f.values.cols() / 2) = std::numeric_limits<float>::quiet_NaN();
        break;
      case fault::wrong_dimension:
        f.values.conservativeResize(17, Eigen::NoChange);
        f.values.row(16).setZero();
        break;
      case fault::empty_field:
        f = {};
        break;
      case fault::none:
        break;
    }
    return f;
  }
  float distance(column a, column b) const { return std::sqrt((a - b).square().sum()); }
};

tacmap::localizer_config fast() {
  tacmap::localizer_config c;
  c.features = tacmap::window_features::shared_dense;
  return c;
}

}  // namespace

TEST_CASE("a descriptor that returns NaN, a wrong dimension or no field is refused by name") {
  for (const fault bad : {fault::nan, fault::wrong_dimension, fault::empty_field}) {
    CAPTURE(static_cast<int>(bad));
    faulty_patch d;
    *d.mode = bad;
    // At preparation: the map's field (shared_dense) and every window's (per_window).
    for (const auto features :
         {tacmap::window_features::shared_dense, tacmap::window_features::per_window}) {
      auto c = fast();
      c.features = features;
      const std::string what = tacmap_test::message_of(
          [&] { tacmap::descriptor_localizer<faulty_patch> loc(test_map(), mm_per_px, c, {}, d); });
      CHECK(what.find("faulty_patch") != std::string::npos);
      if (bad == fault::nan) CHECK(what.find("value nan") != std::string::npos);
      if (bad == fault::wrong_dimension) CHECK(what.find("17 values") != std::string::npos);
      if (bad == fault::empty_field) CHECK(what.find("0 x 0 positions") != std::string::npos);
    }
    // At a touch (only the 42-row touch misbehaves): refused before the belief changes.
    faulty_patch on_touch;
    on_touch.only_rows = 42;
    tacmap::descriptor_localizer<faulty_patch> loc(test_map(), mm_per_px, fast(), {}, on_touch);
    loc.touch(frame_at(3, 4));
    const tacmap::image<float> before = loc.belief();
    *on_touch.mode = bad;
    const std::string what =
        tacmap_test::message_of([&] { loc.touch(frame_at(5, 4), tacmap::odometry{.dy_mm = 6.8}); });
    CHECK(what.find("faulty_patch") != std::string::npos);
    CHECK(what.find("the touch") != std::string::npos);
    CHECK(loc.touches() == 1);
    CHECK((loc.belief() - before).abs().maxCoeff() == 0.0F);
  }
}

namespace {
// A user's measurement policy without a pose model (P1), whose model can be made to fail: NaN
// or -infinity everywhere. Such failures are the model's, not the prediction's: never a restart.
struct failing_model {
  using measurement_type = tacmap::image<float>;
  std::shared_ptr<float> value = std::make_shared<float>(0.0F);
  void log_likelihood(const tacmap::planar_grid<float>& g, const measurement_type& z,
                      Eigen::ArrayXf& out) const {
    out.resize(g.size());
    for (Eigen::Index i = 0; i < g.size(); ++i) out(i) = -0.01F * static_cast<float>(i % 7);
    if (*value != 0.0F) out.setConstant(*value);
    (void)z;
  }
};
struct failing_policy {
  using planar_model = failing_model;
  failing_model model;
  planar_model planar(const tacmap::localizer_config&, const tacmap::image<float>&,
                      tacmap::pixel_size) const {
    return model;
  }
};
static_assert(tacmap::localizer_measurement<failing_policy>);
static_assert(!tacmap::localizes_headings<failing_policy>);
}  // namespace

TEST_CASE("a failing model propagates its error, never a silent restart; a policy without P1") {
  for (const float bad :
       {std::numeric_limits<float>::quiet_NaN(), -std::numeric_limits<float>::infinity()}) {
    failing_policy p;
    auto c = fast();
    c.lost_probability = 0.0;  // the paper's motion: restarts are possible
    c.wide_probability = 0.0;
    tacmap::basic_localizer<failing_policy> loc(test_map(), mm_per_px, c, {}, p);
    loc.touch(frame_at(3, 4));
    *p.model.value = bad;
    CHECK_THROWS_AS(loc.touch(frame_at(3, 4), tacmap::odometry{}), std::domain_error);
    CHECK(loc.restarts() == 0);
    CHECK(loc.touches() == 1);
  }
  auto c = fast();
  c.headings = 4;
  CHECK(tacmap_test::message_of([&] {
          tacmap::basic_localizer<failing_policy> loc(test_map(), mm_per_px, c);
        }).find("has no (x, y, theta) model") != std::string::npos);
}

namespace {
// Everything a refused touch must leave as it was: the filter's belief bit for bit, the counters.
template <class Loc>
struct localizer_state {
  Eigen::ArrayXf belief;
  std::size_t touches, restarts;
  explicit localizer_state(const Loc& loc)
      : belief(filter_belief(loc)), touches(loc.touches()), restarts(loc.restarts()) {}
  static Eigen::ArrayXf filter_belief(const Loc& loc) {
    if constexpr (requires { loc.planar_filter(); })
      return loc.planar_filter()->belief();
    else
      return loc.filter().belief();
  }
  [[nodiscard]] bool same(const Loc& loc) const {
    const Eigen::ArrayXf now = filter_belief(loc);
    return now.size() == belief.size() && (now == belief).all() && loc.touches() == touches &&
           loc.restarts() == restarts;
  }
};
}  // namespace

TEST_CASE("a touch whose update throws after its motion was applied changes nothing") {
  // The fuzz finding: the model's +infinity (std::domain_error from the update) on a touch with
  // motion left the prediction applied, and touch_at then applied the same motion again.
  const float inf = std::numeric_limits<float>::infinity();
  auto c = fast();
  const tacmap::odometry right{.dx_mm = 3.4};
  const tacmap::tactile_frame burst[] = {frame_at(3, 5), frame_at(3, 5)};
  failing_policy p;
  tacmap::basic_localizer<failing_policy> loc(test_map(), mm_per_px, c, {}, p);
  loc.touch(frame_at(3, 4));
  loc.touch(frame_at(3, 5), right);  // concentrated enough that a prediction shows
  using state = localizer_state<tacmap::basic_localizer<failing_policy>>;
  const state before(loc);
  *p.model.value = inf;
  CHECK_THROWS_AS(loc.touch(frame_at(3, 6), right), std::domain_error);
  CHECK(before.same(loc));
  CHECK_THROWS_AS(loc.touch(frame_at(3, 6), tacmap::sensor_odometry{.du_mm = 3.4}),
                  std::domain_error);
  CHECK(before.same(loc));
  CHECK_THROWS_AS(loc.touch(std::span<const tacmap::tactile_frame>(burst), right),
                  std::domain_error);
  CHECK(before.same(loc));
  // touch_at: the refused pose is not recorded, so the next touch_at's motion is counted once.
  // Reference: the same touches with the refused call left out.
  *p.model.value = 0.0F;
  tacmap::basic_localizer<failing_policy> ref(test_map(), mm_per_px, c, {}, p);
  for (auto* l : {&loc, &ref}) {
    l->reset();
    l->touch_at(frame_at(3, 4), {.x_mm = 10.0, .y_mm = 5.0});
  }
  *p.model.value = inf;
  const state at_first(loc);
  CHECK_THROWS_AS(loc.touch_at(frame_at(3, 5), {.x_mm = 13.4, .y_mm = 5.0}), std::domain_error);
  CHECK(at_first.same(loc));
  CHECK_THROWS_AS(
      loc.touch_at(std::span<const tacmap::tactile_frame>(burst), {.x_mm = 13.4, .y_mm = 5.0}),
      std::domain_error);
  CHECK(at_first.same(loc));
  *p.model.value = 0.0F;
  loc.touch_at(frame_at(3, 6), {.x_mm = 16.8, .y_mm = 5.0});
  ref.touch_at(frame_at(3, 6), {.x_mm = 16.8, .y_mm = 5.0});
  CHECK((loc.planar_filter()->belief() == ref.planar_filter()->belief()).all());
  CHECK(loc.touches() == 2);
}

TEST_CASE("a refused library touch changes nothing") {
  const float inf = std::numeric_limits<float>::infinity();
  failing_policy p;
  tacmap::basic_library_localizer<failing_policy> lib(
      {{"a", test_map(), mm_per_px}, {"b", test_map().colwise().reverse(), mm_per_px}}, fast(), {},
      {}, {}, p);
  lib.touch(frame_at(3, 4));
  using state = localizer_state<tacmap::basic_library_localizer<failing_policy>>;
  const state before(lib);
  *p.model.value = inf;
  CHECK_THROWS_AS(lib.touch(frame_at(3, 5), tacmap::odometry{.dx_mm = 3.4}), std::domain_error);
  CHECK(before.same(lib));
}

TEST_CASE("a touch that rules out every predicted state restarts, counted; a uniform one cannot") {
  // -infinity outside a band of states the first touch confines the belief to, then a touch
  // allowed only far outside it: the documented contradiction.
  struct banded {
    using measurement_type = tacmap::image<float>;
    std::shared_ptr<int> phase = std::make_shared<int>(0);
    void log_likelihood(const tacmap::planar_grid<float>& g, const measurement_type&,
                        Eigen::ArrayXf& out) const {
      out.resize(g.size());
      // Phase 0 allows the first quarter of the states (rows), phase 1 the last: 18 rows
      // (20 mm) apart, beyond the motion's reach.
      const Eigen::Index quarter = g.size() / 4;
      for (Eigen::Index i = 0; i < g.size(); ++i) {
        const bool allowed = *phase == 0 ? i < quarter : i >= g.size() - quarter;
        out(i) = allowed ? 0.0F : -std::numeric_limits<float>::infinity();
      }
    }
  };
  struct banded_policy {
    using planar_model = banded;
    banded model;
    planar_model planar(const tacmap::localizer_config&, const tacmap::image<float>&,
                        tacmap::pixel_size) const {
      return model;
    }
  };
  banded_policy p;
  auto c = fast();
  c.lost_probability = 0.0;
  c.wide_probability = 0.0;
  tacmap::basic_localizer<banded_policy> loc(test_map(), mm_per_px, c, {}, p);
  CHECK_FALSE(loc.touch(frame_at(3, 4)).restarted);
  *p.model.phase = 1;
  const auto r = loc.touch(frame_at(3, 4), tacmap::odometry{});
  CHECK(r.restarted);
  CHECK(loc.restarts() == 1);
  CHECK(r.log_prediction_support == -std::numeric_limits<double>::infinity());
  CHECK(static_cast<double>(loc.belief().sum()) == doctest::Approx(1.0).epsilon(1e-4));
}

namespace {
// A descriptor whose compute() takes at least 2 ms: a stand-in for an expensive one.
struct slow_patch {
  using scalar_type = float;
  using column = Eigen::Ref<const Eigen::Array<float, Eigen::Dynamic, 1>>;
  static constexpr bool euclidean_distance = true;
  Eigen::Index dimension() const { return 16; }
  Eigen::Index patch_size() const { return 4; }
  tacmap::descriptor_field<float> compute(const tacmap::image<float>& img) const {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    return tacmap_test::raw_patch{.patch = 4}.compute(img);
  }
  float distance(column a, column b) const { return std::sqrt((a - b).square().sum()); }
};
}  // namespace

TEST_CASE("the cost guard refuses a per-window preparation above the budget, with the figures") {
  // 37 x 49 = 1813 windows at >= 2 ms: >= 3.6 s, above a 1 s budget.
  auto c = fast();
  c.features = tacmap::window_features::per_window;
  c.preparation_budget_s = 1.0;
  const auto start = std::chrono::steady_clock::now();
  try {
    tacmap::descriptor_localizer<slow_patch> loc(test_map(), mm_per_px, c);
    FAIL("a preparation of >= 3.6 s was not refused with a 1 s budget");
  } catch (const tacmap::preparation_over_budget& e) {
    CHECK(e.estimated_seconds >= 3.6);
    CHECK(e.budget_seconds == 1.0);
    const std::string what = e.what();
    CHECK(what.find("slow_patch") != std::string::npos);
    CHECK(what.find("1813 windows") != std::string::npos);
    CHECK(what.find("preparation_budget_s = 1") != std::string::npos);
    CHECK(what.find("shared_dense") != std::string::npos);
    CHECK(what.find("describe_windows") != std::string::npos);
  }
  // Refused after timing a few windows, not after describing them all.
  CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(2));
  // The shared dense field is one compute(): no guard, prepared.
  c.features = tacmap::window_features::shared_dense;
  tacmap::descriptor_localizer<slow_patch> shared(test_map(), mm_per_px, c);
  CHECK(shared.touch(frame_at(2, 2)).accepted());
  c.preparation_budget_s = 0.0;
  c.features = tacmap::window_features::per_window;
  CHECK(tacmap_test::message_of([&] {
          tacmap::descriptor_localizer<slow_patch> loc(test_map(), mm_per_px, c);
        }).find("preparation_budget_s = 0") != std::string::npos);
}

TEST_CASE("a custom descriptor with unknown heading, and appearance = unsigned refused by name") {
  auto c = fast();
  c.headings = 4;
  // Planar unless asked (compile time): the refusal names the setting that compiles it in.
  using planar_only = tacmap::descriptor_localizer<tacmap_test::raw_patch>;
  static_assert(!planar_only::has_headings);
  static_assert(std::is_same_v<planar_only::pose_filter_type, tacmap::detail::no_pose_filter>);
  CHECK(tacmap_test::message_of([&] {
          planar_only loc(test_map(), mm_per_px, c);
        }).find("use descriptor_localizer<D, tacmap::heading_support::localized>") !=
        std::string::npos);
  static_assert(tacmap::localizer::has_headings);  // the default keeps both filters
  tacmap::descriptor_localizer<tacmap_test::raw_patch, tacmap::heading_support::localized> loc(
      test_map(), mm_per_px, c);
  REQUIRE(loc.pose_filter() != nullptr);
  const auto r = loc.touch(frame_at(3, 4));
  CHECK(r.accepted());
  CHECK(loc.heading_belief().size() == 4);
  c.headings = 0;
  c.appearance = tacmap::appearance_handling::unsigned_gradients;
  CHECK(tacmap_test::message_of([&] {
          tacmap::descriptor_localizer<tacmap_test::raw_patch> bad(test_map(), mm_per_px, c);
        }).find("raw_patch_t<true>>: appearance = unsigned") != std::string::npos);
}

TEST_CASE("a custom descriptor recognises the object over a library") {
  const tacmap::image<float> other_taxels = localizer_test_taxels(26, 22, 31);
  const tacmap::image<float> other =
      tacmap::detail::resize_taxels(other_taxels, 78, 66, tacmap::resize_method::bilinear);
  tacmap::basic_library_localizer<tacmap::descriptor_measurement<tacmap_test::raw_patch>> lib(
      {{"other", other, mm_per_px}, {"pattern", test_map(), mm_per_px}}, fast());
  tacmap::library_touch_result r;
  const std::pair<Eigen::Index, Eigen::Index> path[] = {{2, 3}, {5, 3}, {5, 8}, {9, 8}, {9, 12}};
  for (std::size_t t = 0; t < 5; ++t) {
    const auto [tr, tc] = path[t];
    if (t == 0) {
      r = lib.touch(frame_at(tr, tc));
    } else {
      const auto [pr, pc] = path[t - 1];
      r = lib.touch(frame_at(tr, tc),
                    tacmap::odometry{.dx_mm = 3.4 * static_cast<double>(tc - pc),
                                     .dy_mm = 3.4 * static_cast<double>(tr - pr)});
    }
  }
  CHECK(r.object_name == "pattern");
  CHECK(r.object_probability[1] > 0.99);
  CHECK(r.verdict == tacmap::verdict::localized);
  CHECK(lib.touches() == 5);
}

}  // namespace test_descriptor_localizer
