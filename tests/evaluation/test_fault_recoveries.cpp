// "Recovered within k touches" after each injected fault (tacmap::fault_recoveries, the
// k-recovery columns of tacmap-evaluate), on hand-made sequences of errors and faults.
#include <doctest/doctest.h>

#include <cstddef>
#include <vector>

#include "tacmap/sim/experiment.hpp"
#include "tacmap/sim/faults.hpp"

namespace test_fault_recoveries {

namespace {

enum class fault { none, outlier, slip };

// One record per (error mm, fault before that touch).
std::vector<tacmap::touch_record> sequence(const std::vector<std::pair<double, fault>>& touches) {
  std::vector<tacmap::touch_record> out;
  for (const auto& [error_mm, f] : touches) {
    tacmap::touch_record r;
    r.step = out.size();
    r.error_mm = error_mm;
    r.odometry_outlier = f == fault::outlier;
    r.moved_unseen = f == fault::slip;
    out.push_back(r);
  }
  return out;
}

constexpr auto o = fault::none;

}  // namespace

TEST_CASE("a slip recovered from at the third touch after it counts within 3, not within 2") {
  // Touch 4 (index 3) slipped; below 5 mm again from index 6, three touches after it.
  const auto r = sequence({{1, o},
                           {1, o},
                           {1, o},
                           {20, fault::slip},
                           {20, o},
                           {18, o},
                           {2, o},
                           {1, o},
                           {1, o},
                           {1, o}});
  const auto k3 = tacmap::fault_recoveries(r, 3);
  CHECK(k3.faults == 1);
  CHECK(k3.counted == 1);
  CHECK(k3.recovered == 1);
  const auto k2 = tacmap::fault_recoveries(r, 2);
  CHECK(k2.counted == 1);  // index 5 = 3 + 2 is in the sequence: judged, and failed
  CHECK(k2.recovered == 0);
  CHECK(tacmap::fault_recoveries(r, 5).recovered == 1);
}

TEST_CASE("back below the threshold must stay there: a relapse before the end is no recovery") {
  const auto r =
      sequence({{1, o}, {20, fault::slip}, {3, o}, {12, o}, {20, o}, {20, o}, {20, o}, {20, o}});
  const auto k3 = tacmap::fault_recoveries(r, 3);
  CHECK(k3.counted == 1);
  CHECK(k3.recovered == 0);
  // Never lost: an outlier the filter absorbed is recovered at once (within 0 touches).
  const auto absorbed = sequence({{1, o}, {2, fault::outlier}, {1, o}, {1, o}});
  CHECK(tacmap::fault_recoveries(absorbed, 0).recovered == 1);
}

TEST_CASE("a fault too close to the end to judge is not counted as a failure") {
  // The slip at the last-but-one touch: within 3 cannot be judged unless it recovered.
  const auto lost = sequence({{1, o}, {1, o}, {1, o}, {1, o}, {20, fault::slip}, {20, o}});
  const auto k3 = tacmap::fault_recoveries(lost, 3);
  CHECK(k3.faults == 1);
  CHECK(k3.counted == 0);
  CHECK(k3.recovered == 0);
  CHECK(tacmap::fault_recoveries(lost, 1).counted == 1);  // index 5 = 4 + 1 exists: a failure
  const auto back = sequence({{1, o}, {1, o}, {1, o}, {1, o}, {20, fault::slip}, {2, o}});
  CHECK(tacmap::fault_recoveries(back, 3).counted == 1);
  CHECK(tacmap::fault_recoveries(back, 3).recovered == 1);
}

TEST_CASE("each outlier's window closes at the next fault") {
  // Outliers at indices 1 and 3; the first is recovered from at index 2, before the second; the
  // second is not within 1 touch (index 4 still off), and is within 2 (index 5 on).
  const auto r =
      sequence({{1, o}, {9, fault::outlier}, {2, o}, {9, fault::outlier}, {9, o}, {1, o}, {1, o}});
  const auto k1 = tacmap::fault_recoveries(r, 1);
  CHECK(k1.faults == 2);
  CHECK(k1.counted == 2);
  CHECK(k1.recovered == 1);
  const auto k2 = tacmap::fault_recoveries(r, 2);
  CHECK(k2.recovered == 2);
  // Within 3 the first outlier's window (indices 1-2) is too short to judge a failure, but it
  // recovered, so it counts.
  CHECK(tacmap::fault_recoveries(r, 3).counted == 2);
  // The sums over sequences.
  tacmap::recovery_count total;
  total += k1;
  total += k2;
  CHECK(total.faults == 4);
  CHECK(total.recovered == 3);
  // No faults: nothing to count.
  const auto clean = tacmap::fault_recoveries(sequence({{1, o}, {30, o}}), 3);
  CHECK(clean.faults == 0);
  CHECK(clean.counted == 0);
}

}  // namespace test_fault_recoveries
