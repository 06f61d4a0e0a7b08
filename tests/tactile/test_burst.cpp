// Tests of combine_burst (tactile/burst.hpp): several frames of one press combined robustly.
#include <doctest/doctest.h>

#include <cmath>
#include <vector>

#include "tacmap/sim/random.hpp"
#include "tacmap/sim/tactile_simulator.hpp"
#include "tacmap/tactile/burst.hpp"
#include "test_support.hpp"

namespace test_burst {

using tacmap::burst_frame_status;
using tacmap::burst_params;
using tacmap::burst_statistic;
using tacmap::combine_burst;
using tacmap::image;
using tacmap::tactile_frame;
using tacmap_test::message_of;

namespace {

// A press's pattern: a blob of 2000 counts at its peak.
image<float> pattern() {
  image<float> p(14, 6);
  for (Eigen::Index r = 0; r < 14; ++r)
    for (Eigen::Index c = 0; c < 6; ++c)
      p(r, c) = static_cast<float>(
          2000.0 * std::exp(-0.5 * (std::pow((static_cast<double>(r) - 6.0) / 3.0, 2) +
                                    std::pow((static_cast<double>(c) - 2.5) / 1.5, 2))));
  return p;
}

tactile_frame frame_of(const image<float>& counts, std::uint32_t sequence = 0) {
  tactile_frame f;
  f.counts = counts;
  f.sequence = sequence;
  f.timestamp = tactile_frame::clock::time_point{} + std::chrono::milliseconds(10 * sequence);
  return f;
}

// `n` frames of `scale` x pattern plus N(0, sigma) noise (clamped at 0), from `rng`.
std::vector<tactile_frame> noisy_burst(std::size_t n, double sigma, tacmap::sim_rng& rng,
                                       const std::vector<double>& scale = {}) {
  std::vector<tactile_frame> out;
  for (std::size_t i = 0; i < n; ++i) {
    image<float> c = pattern() * static_cast<float>(scale.empty() ? 1.0 : scale[i]);
    for (Eigen::Index t = 0; t < c.size(); ++t)
      c.data()[t] = std::max(0.0F, c.data()[t] + static_cast<float>(sigma * rng.normal()));
    out.push_back(frame_of(c, static_cast<std::uint32_t>(i)));
  }
  return out;
}

double rms(const image<float>& a, const image<float>& b) {
  return std::sqrt((a - b).cast<double>().square().mean());
}

}  // namespace

TEST_CASE("combine_burst: a settled burst's median is the pattern within noise / sqrt(n)") {
  tacmap::sim_rng rng(3);
  const auto burst = noisy_burst(20, 40.0, rng);
  const auto out = combine_burst(burst);
  CHECK(out.used == 20);
  for (const auto s : out.status) CHECK(s == burst_frame_status::used);
  // One frame's error is ~40 counts; the median of 20 is ~40 x 1.25 / sqrt(20) ~ 11.
  CHECK(rms(burst[0].counts, pattern()) > 30.0);
  CHECK(rms(out.frame.counts, pattern()) < 16.0);
  CHECK(out.frame.sequence == 19);  // the last frame used
  CHECK(out.frame.timestamp == burst.back().timestamp);
  CHECK(out.frame.geometry == burst[0].geometry);
}

TEST_CASE("combine_burst: the settling head and outlier frames are dropped and reported") {
  tacmap::sim_rng rng(5);
  // The press ramps up over four frames, then holds; frames 9 and 14 are glitches (a twitch of
  // the arm: 60 % and 150 % of the load).
  std::vector<double> scale(20, 1.0);
  scale[0] = 0.2;
  scale[1] = 0.5;
  scale[2] = 0.8;
  scale[3] = 0.9;
  scale[9] = 0.6;
  scale[14] = 1.5;
  const auto burst = noisy_burst(20, 20.0, rng, scale);
  const auto out = combine_burst(burst);
  for (std::size_t i = 0; i < 4; ++i) CHECK(out.status[i] == burst_frame_status::settling);
  CHECK(out.status[4] == burst_frame_status::used);
  CHECK(out.status[9] == burst_frame_status::outlier);
  CHECK(out.status[14] == burst_frame_status::outlier);
  CHECK(out.used == 14);
  CHECK(out.settled_total == doctest::Approx(pattern().sum()).epsilon(0.02));
  CHECK(rms(out.frame.counts, pattern()) < 12.0);
  // A plain mean of all frames is off by the ramp and the glitches (~ -5 % of the load).
  image<float> mean = image<float>::Zero(14, 6);
  for (const auto& f : burst) mean += f.counts / 20.0F;
  CHECK(rms(mean, pattern()) > 3.0 * rms(out.frame.counts, pattern()));
  CHECK(std::string(tacmap::to_string(out.status[0])) == "settling");
  CHECK(std::string(tacmap::to_string(out.status[9])) == "outlier");
}

TEST_CASE("combine_burst: a spike in one frame does not move the median; the trimmed mean") {
  std::vector<tactile_frame> burst;
  for (std::uint32_t i = 0; i < 5; ++i) burst.push_back(frame_of(pattern(), i));
  burst[2].counts(6, 2) = 4095.0F;  // a read-out glitch on one taxel
  const auto median = combine_burst(burst);
  CHECK(median.used == 5);  // the frame's total is within 15 % of the level: not an outlier
  CHECK(median.frame.counts(6, 2) == pattern()(6, 2));
  // The trimmed mean over 5 frames with 0.2 trimmed drops one value at each end: the spike too.
  const auto trimmed =
      combine_burst(burst, {.statistic = burst_statistic::trimmed_mean, .trim_fraction = 0.2});
  CHECK(trimmed.frame.counts(6, 2) == doctest::Approx(pattern()(6, 2)));
  // Without trimming, the mean carries a fifth of the spike.
  const auto plain =
      combine_burst(burst, {.statistic = burst_statistic::trimmed_mean, .trim_fraction = 0.0});
  CHECK(plain.frame.counts(6, 2) ==
        doctest::Approx((4.0 * pattern()(6, 2) + 4095.0) / 5.0).epsilon(1e-5));
}

TEST_CASE("combine_burst: one frame is itself; frames without contact combine to their median") {
  const auto one = combine_burst(std::vector<tactile_frame>{frame_of(pattern(), 7)});
  CHECK(one.used == 1);
  CHECK((one.frame.counts == pattern()).all());
  std::vector<tactile_frame> nothing(3, frame_of(image<float>::Zero(14, 6)));
  nothing[1].counts(0, 0) = 0.5F;  // below min_total: no load, no "unsettled" verdict
  const auto none = combine_burst(nothing);
  CHECK(none.used == 3);
  CHECK((none.frame.counts == 0.0F).all());
}

TEST_CASE("combine_burst: bad input is refused with a clear message") {
  CHECK(message_of([] {
          (void)combine_burst(std::vector<tactile_frame>{});
        }).find("the burst has no frames") != std::string::npos);
  std::vector<tactile_frame> mixed{frame_of(pattern()), frame_of(pattern())};
  mixed[1].geometry = {.rows = 6, .cols = 14, .pitch_mm = 3.4};
  mixed[1].counts = image<float>::Zero(6, 14);
  const std::string m = message_of([&] { (void)combine_burst(mixed); });
  CHECK(m.find("frame 1 of 2 has geometry 6 x 14") != std::string::npos);
  CHECK(m.find("frame 0 has 14 x 6") != std::string::npos);
  mixed[1] = frame_of(pattern());
  mixed[1].geometry.pitch_mm = 4.0;
  mixed[1].counts = pattern();
  CHECK(message_of([&] { (void)combine_burst(mixed); }).find("at 4 mm") != std::string::npos);
  mixed[1].geometry.pitch_mm = 3.4;
  mixed[1].counts(3, 3) = std::nanf("");
  CHECK(message_of([&] {
          (void)combine_burst(mixed);
        }).find("frame 1 of 2: tactile_frame: taxel (3, 3)") != std::string::npos);
  mixed[1].counts = pattern();
  CHECK(message_of([&] {
          (void)combine_burst(mixed, {.settle_tolerance = 0.2, .outlier_tolerance = 0.1});
        }).find("outlier_tolerance = 0.1") != std::string::npos);
  CHECK(message_of([&] {
          (void)combine_burst(mixed, {.trim_fraction = 0.5});
        }).find("trim_fraction = 0.5") != std::string::npos);
}

TEST_CASE("combine_burst: simulated frames of one press average the read-out noise down") {
  const image<float> relief = [] {
    image<float> r = image<float>::Zero(120, 120);
    r.block(30, 40, 20, 8).setConstant(4.0F);
    r.block(55, 52, 6, 25).setConstant(4.0F);
    return r;
  }();
  tacmap::simulator_params p;
  p.noise_counts = 80.0;
  tacmap::tactile_simulator sim(relief, {120, 120}, 3.4 / 3.0, p);
  const tacmap::map_pose pose{55.0, 50.0, 0.0};
  std::vector<tactile_frame> burst;
  for (int i = 0; i < 20; ++i) burst.push_back(sim.render(pose));
  const image<float> truth = sim.expected_counts(pose).cwiseMin(4095.0F);
  const auto out = combine_burst(burst);
  CHECK(out.used == 20);
  CHECK(rms(out.frame.counts, truth) < 0.5 * rms(burst[0].counts, truth));
}

}  // namespace test_burst
