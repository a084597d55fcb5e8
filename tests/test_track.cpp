// Multi-touch track IDs: exact expectations on hand-built detection streams.
#include <shadowsense/sense/tracker.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <vector>

using namespace shadowsense;

namespace {
Detection at(float x, float y) {
  return {cv::Point2f(x, y), cv::Rect(int(x) - 2, int(y) - 2, 5, 5)};
}
} // namespace

TEST_CASE("two simultaneous touches keep their ids while they move, whatever the detection order") {
  ContactTracker tracker;
  std::vector<Detection> d{at(20, 50), at(150, 50)};
  auto t = tracker.update(d, 0);
  REQUIRE(t.size() == 2);
  CHECK(t[0].id == 1);
  CHECK(t[1].id == 2);
  for (int i = 1; i <= 10; ++i) {
    // Swap the order every other frame; the left touch slides right, the right one slides down.
    std::vector<Detection> f{at(20.f + 5 * i, 50), at(150, 50.f + 4 * i)};
    if (i % 2) std::swap(f[0], f[1]);
    const auto& tr = tracker.update(f, 33.0 * i);
    REQUIRE(tr.size() == 2);
    CHECK(tr[0].id == 1);
    CHECK(tr[0].position.x == doctest::Approx(20 + 5 * i));
    CHECK(tr[1].id == 2);
    CHECK(tr[1].position.y == doctest::Approx(50 + 4 * i));
    CHECK(tr[0].matched);
    CHECK(f[static_cast<std::size_t>(tr[0].detection_index)].position.x ==
          doctest::Approx(20 + 5 * i));
  }
}

TEST_CASE("a brief dropout keeps the id; a long one ends the track and a new id starts") {
  ContactTracker tracker; // max_missing_ms = 150
  tracker.update(std::vector<Detection>{at(50, 50)}, 0);
  CHECK(tracker.update(std::vector<Detection>{}, 100).size() == 1); // coasting
  CHECK_FALSE(tracker.tracks()[0].matched);
  auto t = tracker.update(std::vector<Detection>{at(52, 50)}, 140);
  REQUIRE(t.size() == 1);
  CHECK(t[0].id == 1);
  CHECK(tracker.update(std::vector<Detection>{}, 289.9).size() == 1);
  CHECK(tracker.update(std::vector<Detection>{}, 290).empty()); // exactly 150 ms unseen: dropped
  t = tracker.update(std::vector<Detection>{at(52, 50)}, 300);
  REQUIRE(t.size() == 1);
  CHECK(t[0].id == 2); // ids are never reused
}

TEST_CASE("a very fast slide is followed through constant-velocity prediction") {
  ContactTracker tracker({.max_distance_px = 30});
  // Steps of 25, 40, 45 and 45 px per frame: the last ones are farther than the gate from the
  // previous position, but close to the predicted one.
  const float xs[] = {10, 35, 75, 120, 165};
  for (int i = 0; i < 5; ++i) {
    const auto& t = tracker.update(std::vector<Detection>{at(xs[i], 100)}, 77.0 * i);
    REQUIRE(t.size() == 1);
    CHECK(t[0].id == 1);
  }
  // Velocity: first estimate 25/77, then smoothed with weight 0.5: (25+40)/2, then (32.5+45)/2, ...
  CHECK(tracker.tracks()[0].velocity.x == doctest::Approx(((32.5 + 45) / 2 + 45) / 2 / 77.0));
}

TEST_CASE("a rub at 15 fps keeps one track: at each turn the hand is near its last position") {
  // 28 px amplitude at 3.75 Hz (a fast rub, issue 23's generator), sampled every 66.7 ms: 90
  // degrees of phase per frame. At a turn the constant-velocity prediction points 40-50 px the
  // wrong way, outside the 40 px gate; the last position is within it.
  ContactTracker tracker;
  for (int k = 0; k < 22; ++k) {
    const double t = 1000.0 / 15 * k;
    const float x = static_cast<float>(100 + 28 * std::sin(2 * CV_PI * 3.75 * t / 1000));
    const auto& tr = tracker.update(std::vector<Detection>{at(x, 100)}, t);
    CAPTURE(k);
    REQUIRE(tr.size() == 1);
    CHECK(tr[0].id == 1);
    CHECK(tr[0].matched);
  }
}

TEST_CASE("hits_to_confirm debounces new tracks") {
  ContactTracker tracker({.hits_to_confirm = 3});
  CHECK_FALSE(tracker.update(std::vector<Detection>{at(5, 5)}, 0)[0].confirmed);
  CHECK_FALSE(tracker.update(std::vector<Detection>{at(5, 5)}, 10)[0].confirmed);
  CHECK(tracker.update(std::vector<Detection>{at(5, 5)}, 20)[0].confirmed);
  CHECK(
      tracker.update(std::vector<Detection>{}, 30)[0].confirmed); // stays confirmed while coasting
}

TEST_CASE("detections outside the gate start new tracks; the closest pair wins a conflict") {
  ContactTracker tracker({.max_distance_px = 10});
  tracker.update(std::vector<Detection>{at(0, 0)}, 0);
  const auto& t = tracker.update(std::vector<Detection>{at(8, 0), at(3, 0), at(50, 50)}, 10);
  REQUIRE(t.size() == 3);
  CHECK(t[0].id == 1);
  CHECK(t[0].position.x == doctest::Approx(3));
  CHECK(t[1].id == 2);
  CHECK(t[1].position.x == doctest::Approx(8));
  CHECK(t[2].id == 3);
  CHECK(tracker.find(3).has_value());
  CHECK_FALSE(tracker.find(4).has_value());
}

TEST_CASE("bad timestamps, positions and configs are rejected") {
  ContactTracker tracker;
  tracker.update(std::vector<Detection>{}, 5);
  CHECK_THROWS_WITH_AS(tracker.update(std::vector<Detection>{}, 5),
                       doctest::Contains("strictly increasing"), InvalidArgument);
  CHECK_THROWS_AS(tracker.update(std::vector<Detection>{}, std::numeric_limits<double>::infinity()),
                  InvalidArgument);
  CHECK_THROWS_AS(
      tracker.update(std::vector<Detection>{at(std::numeric_limits<float>::quiet_NaN(), 0)}, 6),
      InvalidArgument);
  CHECK_THROWS_AS(ContactTracker({.max_distance_px = 0}), InvalidArgument);
  CHECK_THROWS_AS(ContactTracker({.hits_to_confirm = 0}), InvalidArgument);
  CHECK_THROWS_AS(ContactTracker({.velocity_smoothing = 0}), InvalidArgument);
}

TEST_CASE("two detections 0.1 ms apart with 0.5 px jitter keep their track id") {
  ContactTracker tracker;
  const Detection a{{100.f, 100.f}, {}};
  const Detection b{{100.5f, 100.f}, {}};
  tracker.update(std::vector<Detection>{a}, 0.0);
  tracker.update(std::vector<Detection>{b}, 0.1); // a near-duplicate frame
  const auto& t = tracker.update(std::vector<Detection>{a}, 33.4);
  REQUIRE(t.size() == 1);
  CHECK(t[0].id == 1);
  CHECK(t[0].hits == 3);
  // Steps of normal length still estimate the velocity: -0.5 px over 33.3 ms, then 10 px over
  // 10 ms, smoothed with weight 0.5.
  CHECK(t[0].velocity.x == doctest::Approx(-0.5 / 33.3));
  tracker.update(std::vector<Detection>{Detection{{110.f, 100.f}, {}}}, 43.4);
  CHECK(tracker.tracks()[0].velocity.x == doctest::Approx(0.5 * (-0.5 / 33.3) + 0.5 * 1.0));
  CHECK_THROWS_AS(ContactTracker({.min_velocity_dt_ms = -1}), InvalidArgument);
}
