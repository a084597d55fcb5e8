// TemporalGestureRecogniser (sense/temporal_gestures.hpp) on exact per-frame sequences: every
// rule with its exact events, the boundaries (the longest tap, the shortest hold, the slowest
// pat, the slowest hit approach, the longest double-tap gap), several tracks at once, bad input
// (non-monotonic timestamps, duplicate ids, non-finite contacts, a track vanishing mid-gesture),
// no allocation per frame after warm-up, and a user's own recogniser through the concept.
#include <shadowsense/sense/temporal_gestures.hpp>

#include "common/counting_new.hpp"

#include <doctest/doctest.h>

#include <optional>
#include <string>
#include <vector>

using namespace shadowsense;

namespace {

// px_per_cm 10: still radius 15 px, stroke 30 px, rub amplitude 15 px, repeat radius 40 px,
// palm area 1200 px^2.
TemporalGestureConfig config10() {
  TemporalGestureConfig c;
  c.px_per_cm = 10;
  return c;
}

struct T { // one track in one frame
  int id = 1;
  std::optional<cv::Point2f> contact{};
  double area = 100;
};

struct Feed {
  TemporalGestureRecogniser r{config10()};
  TouchFrame f;
  OutputGesture g;
  std::vector<GestureEvent> all;

  const std::vector<GestureEvent>& frame(double t, std::vector<T> tracks,
                                         const std::string& label = "") {
    f.timestamp_ms = t;
    f.tracks.clear();
    for (const T& x : tracks) {
      TouchTrack tr;
      tr.id = x.id;
      tr.matched = true;
      tr.position = x.contact ? *x.contact : cv::Point2f(50, 50);
      tr.contact = x.contact;
      tr.contact_area = x.contact ? x.area : 0;
      f.tracks.push_back(tr);
    }
    g.available = true;
    g.label = label;
    g.confidence = label.empty() ? 0.f : 0.75f;
    const auto& ev = r.update(f, g);
    all.insert(all.end(), ev.begin(), ev.end());
    return ev;
  }
  // Hover (no contact) from t0 to t1 inclusive, every `step` ms.
  void hover(double t0, double t1, double step = 20, const std::string& label = "", int id = 1) {
    for (double t = t0; t <= t1 + 1e-9; t += step) frame(t, {{id, std::nullopt}}, label);
  }
  // Contact at p from t0 to t1 inclusive, every `step` ms.
  void touch(double t0, double t1, cv::Point2f p, const std::string& label = "point",
             double step = 20, int id = 1, double area = 100) {
    for (double t = t0; t <= t1 + 1e-9; t += step) frame(t, {{id, p, area}}, label);
  }
};

void check_event(const GestureEvent& e, TouchGesture g, GesturePhase phase, int track, double start,
                 double end, double decided, int reps = 1) {
  CHECK(to_string(e.gesture) == std::string(to_string(g)));
  CHECK(to_string(e.phase) == std::string(to_string(phase)));
  CHECK(e.track_id == track);
  CHECK(e.start_ms == start);
  CHECK(e.end_ms == end);
  CHECK(e.decided_ms == decided);
  CHECK(e.repetitions == reps);
}

} // namespace

TEST_CASE("tap: reported at lift; the longest tap is tap_max_contact_ms, one frame more is none") {
  Feed a;
  a.hover(0, 380);
  a.touch(400, 680, {100, 100}); // lift frame at 700: d = 300 = tap_max_contact_ms
  CHECK(a.all.empty());
  const auto& ev = a.frame(700, {{1, std::nullopt}});
  REQUIRE(ev.size() == 1);
  check_event(ev[0], TouchGesture::tap, GesturePhase::complete, 1, 400, 700, 700);
  CHECK(ev[0].position == cv::Point2f(100, 100));
  CHECK(ev[0].hand_shape.view() == "point");
  CHECK(ev[0].confidence == 1.0f);
  CHECK(ev[0].direction == Direction::none);

  Feed b;
  b.hover(0, 380);
  b.touch(400, 700, {100, 100}); // lift at 720: d = 320
  b.hover(720, 1500);
  CHECK(b.all.empty()); // a plain touch
}

TEST_CASE("double tap: the tap is revised at the second lift; the gap limit is inclusive") {
  Feed a;
  a.hover(0, 380);
  a.touch(400, 480, {100, 100});
  a.hover(500, 780);             // tap at 500
  a.touch(800, 880, {110, 100}); // gap 800 - 500 = 300 = double_tap_max_gap_ms
  a.hover(900, 1500);
  REQUIRE(a.all.size() == 2);
  check_event(a.all[0], TouchGesture::tap, GesturePhase::complete, 1, 400, 500, 500);
  check_event(a.all[1], TouchGesture::double_tap, GesturePhase::revised, 1, 400, 900, 900, 2);
  CHECK(a.all[1].position == cv::Point2f(100, 100));

  Feed b;
  b.hover(0, 380);
  b.touch(400, 480, {100, 100});
  b.hover(500, 800);
  b.touch(820, 900, {100, 100}); // gap 320: a new tap
  b.hover(920, 1500);
  REQUIRE(b.all.size() == 2);
  check_event(b.all[0], TouchGesture::tap, GesturePhase::complete, 1, 400, 500, 500);
  check_event(b.all[1], TouchGesture::tap, GesturePhase::complete, 1, 820, 920, 920);

  Feed c; // the second tap too far away (> 40 px): a new tap
  c.hover(0, 380);
  c.touch(400, 480, {100, 100});
  c.hover(500, 780);
  c.touch(800, 880, {141, 100});
  c.hover(900, 1000);
  REQUIRE(c.all.size() == 2);
  check_event(c.all[1], TouchGesture::tap, GesturePhase::complete, 1, 800, 900, 900);
}

TEST_CASE("hold: began at exactly hold_min_ms of still contact, ended at lift") {
  Feed a;
  a.hover(0, 980);
  a.touch(1000, 1980, {100, 100}, "palm");
  CHECK(a.all.empty()); // 980 ms: not yet
  const auto& ev = a.frame(2000, {{1, cv::Point2f(101, 100)}}, "palm");
  REQUIRE(ev.size() == 1);
  check_event(ev[0], TouchGesture::hold, GesturePhase::began, 1, 1000, 2000, 2000);
  a.touch(2020, 2480, {100, 100}, "palm");
  a.frame(2500, {{1, std::nullopt}});
  REQUIRE(a.all.size() == 2);
  check_event(a.all[1], TouchGesture::hold, GesturePhase::ended, 1, 1000, 2500, 2500);
  CHECK(a.all[1].hand_shape.view() == "palm");

  Feed b; // moved beyond the still radius (15 px) before 1 s: no hold, and too short a stroke
  b.hover(0, 980);
  b.touch(1000, 1500, {100, 100}, "palm");
  b.touch(1520, 2400, {116, 100}, "palm");
  b.hover(2420, 2600);
  CHECK(b.all.empty());
}

TEST_CASE("a hold that starts to travel ends there, and the travel is a stroke") {
  Feed a;
  a.hover(0, 480, 20, "palm");
  a.touch(500, 1500, {100, 100}, "palm"); // hold began at 1500
  for (int k = 1; k <= 10; ++k) // 8 px per frame to the left: leaves the 15 px circle at k = 2
    a.frame(1500 + 20 * k, {{1, cv::Point2f(100.f - 8 * k, 100)}}, "palm");
  a.frame(1720, {{1, std::nullopt}}, "palm");
  REQUIRE(a.all.size() == 3);
  check_event(a.all[0], TouchGesture::hold, GesturePhase::began, 1, 500, 1500, 1500);
  check_event(a.all[1], TouchGesture::hold, GesturePhase::ended, 1, 500, 1540, 1540);
  check_event(a.all[2], TouchGesture::stroke, GesturePhase::complete, 1, 1540, 1720, 1720);
  CHECK(a.all[2].direction == Direction::left);
  CHECK(a.all[2].length_px == 64.0f); // from x = 84 to x = 20
  CHECK(a.all[2].position == cv::Point2f(84, 100));

  Feed b; // a hold that moves a little and stops: the hold ends, the rest is a plain touch
  b.hover(0, 480, 20, "palm");
  b.touch(500, 1500, {100, 100}, "palm");
  b.touch(1520, 1600, {120, 100}, "palm");
  b.frame(1620, {{1, std::nullopt}}, "palm");
  REQUIRE(b.all.size() == 2);
  check_event(b.all[1], TouchGesture::hold, GesturePhase::ended, 1, 500, 1520, 1520);
}

TEST_CASE("pat: palm contacts in one place, each one revising the count; the slowest pat") {
  Feed a;
  a.hover(0, 480, 20, "palm");
  a.touch(500, 680, {100, 100}, "palm", 20, 1, 2000);
  a.hover(700, 1180, 20, "palm"); // pat 1 at 700
  a.touch(1200, 1380, {105, 95}, "palm", 20, 1, 2000);
  a.hover(1400, 1980, 20, "palm"); // pat 2 at 1400; next contact after 600 = pat_max_gap_ms
  a.touch(2000, 2180, {100, 100}, "palm", 20, 1, 2000);
  a.hover(2200, 3000, 20, "palm");
  REQUIRE(a.all.size() == 3);
  check_event(a.all[0], TouchGesture::pat, GesturePhase::complete, 1, 500, 700, 700, 1);
  check_event(a.all[1], TouchGesture::pat, GesturePhase::revised, 1, 500, 1400, 1400, 2);
  check_event(a.all[2], TouchGesture::pat, GesturePhase::revised, 1, 500, 2200, 2200, 3);
  CHECK(a.all[2].hand_shape.view() == "palm");
  CHECK(a.all[2].confidence == 1.0f);

  Feed b; // a gap of 620 ms: two separate pats
  b.hover(0, 480, 20, "palm");
  b.touch(500, 680, {100, 100}, "palm");
  b.hover(700, 1300, 20, "palm");
  b.touch(1320, 1500, {100, 100}, "palm");
  b.hover(1520, 1600, 20, "palm");
  REQUIRE(b.all.size() == 2);
  check_event(b.all[1], TouchGesture::pat, GesturePhase::complete, 1, 1320, 1520, 1520, 1);
}

TEST_CASE("without a classifier reading the contact area decides palm (pat) or finger (tap)") {
  Feed a;
  a.hover(0, 480);
  a.touch(500, 600, {100, 100}, "", 20, 1, 1200); // 12 cm^2 at 10 px/cm: a palm
  a.hover(620, 700);
  a.touch(800, 900, {100, 100}, "", 20, 1, 1199); // a fingertip
  a.hover(920, 1000);
  REQUIRE(a.all.size() == 2);
  check_event(a.all[0], TouchGesture::pat, GesturePhase::complete, 1, 500, 620, 620);
  check_event(a.all[1], TouchGesture::tap, GesturePhase::complete, 1, 800, 920, 920);
  CHECK(a.all[0].hand_shape.view() == "");
}

TEST_CASE("stroke: direction, length and speed at lift") {
  Feed a;
  a.hover(0, 480);
  for (int k = 0; k <= 20; ++k) // 500..900 ms, 10 px per frame to the right, 2 px down
    a.frame(500 + 20 * k, {{1, cv::Point2f(100.f + 10 * k, 100.f + 0.1f * k)}}, "palm");
  a.frame(920, {{1, std::nullopt}}, "palm");
  REQUIRE(a.all.size() == 1);
  const GestureEvent& e = a.all[0];
  check_event(e, TouchGesture::stroke, GesturePhase::complete, 1, 500, 920, 920);
  CHECK(e.direction == Direction::right);
  CHECK(e.length_px == doctest::Approx(std::hypot(200.0, 2.0)).epsilon(1e-5));
  CHECK(e.speed_px_s == doctest::Approx(std::hypot(200.0, 2.0) / 0.42).epsilon(1e-5));
  CHECK(e.confidence == 1.0f);

  Feed b; // towards -y: front; 29 px is short of a stroke, 30 px is one
  b.hover(0, 80);
  for (int k = 0; k <= 29; ++k) b.frame(100 + 20 * k, {{1, cv::Point2f(100.f, 100.f - k)}});
  b.frame(700, {{1, std::nullopt}});
  CHECK(b.all.empty());
  b.hover(720, 2000);
  for (int k = 0; k <= 30; ++k) b.frame(3000 + 20 * k, {{1, cv::Point2f(100.f, 100.f - k)}});
  b.frame(3620, {{1, std::nullopt}});
  REQUIRE(b.all.size() == 1);
  CHECK(b.all[0].direction == Direction::front);
  CHECK(b.all[0].length_px == 30.0f);
}

TEST_CASE("rub: back and forth in contact, reversals counted with amplitude hysteresis") {
  Feed a;
  a.hover(0, 80);
  const float xs[] = {0, 20, 40, 20, 0, 20, 40, 20, 0};
  double t = 100;
  for (float x : xs) a.frame(t, {{1, cv::Point2f(100 + x, 100)}}, "palm"), t += 20;
  a.frame(t, {{1, std::nullopt}}, "palm");
  REQUIRE(a.all.size() == 1);
  check_event(a.all[0], TouchGesture::rub, GesturePhase::complete, 1, 100, 280, 280, 3);
  CHECK(a.all[0].length_px == 160.0f);

  Feed b; // swings of 14 px (< 15 px amplitude) never reverse
  b.hover(0, 80);
  t = 100;
  for (int k = 0; k < 9; ++k) b.frame(t, {{1, cv::Point2f(k % 2 ? 114.f : 100.f, 100)}}), t += 20;
  b.frame(t, {{1, std::nullopt}});
  // never left the 15 px still radius: a still fingertip contact of 180 ms, a tap
  REQUIRE(b.all.size() == 1);
  check_event(b.all[0], TouchGesture::tap, GesturePhase::complete, 1, 100, 280, 280);
}

TEST_CASE("hit: a palm contact right after the shadow appeared; the slowest approach") {
  Feed a; // appears at 0, contact at 200 (= hit_max_approach_ms), lift at 400 (200 ms contact)
  a.hover(0, 180, 20, "palm");
  a.touch(200, 380, {100, 100}, "palm");
  a.hover(400, 500, 20, "palm");
  REQUIRE(a.all.size() == 1);
  check_event(a.all[0], TouchGesture::hit, GesturePhase::complete, 1, 200, 400, 400);

  Feed b; // contact at 220: a pat
  b.hover(0, 200, 20, "palm");
  b.touch(220, 400, {100, 100}, "palm");
  b.hover(420, 500, 20, "palm");
  REQUIRE(b.all.size() == 1);
  check_event(b.all[0], TouchGesture::pat, GesturePhase::complete, 1, 220, 420, 420);

  Feed c; // a fingertip with the same timing: a tap (a hit needs a palm or fist)
  c.hover(0, 180, 20, "point");
  c.touch(200, 380, {100, 100}, "point");
  c.hover(400, 500, 20, "point");
  REQUIRE(c.all.size() == 1);
  check_event(c.all[0], TouchGesture::tap, GesturePhase::complete, 1, 200, 400, 400);
}

TEST_CASE("hug, punch and two_hands: label intervals on track 0") {
  Feed a;
  a.frame(0, {{1, cv::Point2f(10, 20)}, {2, cv::Point2f(30, 40)}}, "hug");
  a.frame(33, {{1, cv::Point2f(10, 20)}, {2, cv::Point2f(30, 40)}}, "hug");
  a.frame(66, {{1, cv::Point2f(10, 20)}}, "punch");
  a.frame(99, {}, "");
  REQUIRE(a.all.size() >= 4);
  std::vector<GestureEvent> label;
  for (const GestureEvent& e : a.all)
    if (e.track_id == 0) label.push_back(e);
  REQUIRE(label.size() == 4);
  check_event(label[0], TouchGesture::hug, GesturePhase::began, 0, 0, 0, 0);
  CHECK(label[0].position == cv::Point2f(20, 30));
  CHECK(label[0].confidence == 0.75f);
  check_event(label[1], TouchGesture::hug, GesturePhase::ended, 0, 0, 33, 66);
  check_event(label[2], TouchGesture::punch, GesturePhase::began, 0, 66, 66, 66);
  check_event(label[3], TouchGesture::punch, GesturePhase::ended, 0, 66, 66, 99);
  CHECK(label[3].hand_shape.view() == "punch");
}

TEST_CASE("a contact read as hug or two_hands is part of that gesture: no hold, no pat") {
  Feed a;
  a.hover(0, 480, 20, "hug");
  a.touch(500, 2000, {100, 100}, "hug"); // 1.5 s still: would be a hold
  a.hover(2020, 2100, 20, "");
  REQUIRE(a.all.size() == 2);
  check_event(a.all[0], TouchGesture::hug, GesturePhase::began, 0, 0, 0, 0);
  check_event(a.all[1], TouchGesture::hug, GesturePhase::ended, 0, 0, 2000, 2020);
}

TEST_CASE("several tracks are recognised independently, events ordered by track id") {
  Feed a;
  for (double t = 0; t <= 380; t += 20) a.frame(t, {{1, std::nullopt}, {2, std::nullopt}});
  for (double t = 400; t <= 1480; t += 20) {
    std::vector<T> tr{{1, std::nullopt}, {2, cv::Point2f(50, 50)}};
    if (t <= 480) tr[0].contact = cv::Point2f(150, 150);
    a.frame(t, tr, "point");
  }
  a.frame(1500, {{1, std::nullopt}, {2, std::nullopt}});
  REQUIRE(a.all.size() == 3);
  check_event(a.all[0], TouchGesture::tap, GesturePhase::complete, 1, 400, 500, 500);
  check_event(a.all[1], TouchGesture::hold, GesturePhase::began, 2, 400, 1400, 1400);
  check_event(a.all[2], TouchGesture::hold, GesturePhase::ended, 2, 400, 1500, 1500);
}

TEST_CASE("flush ends every contact as a lift at its timestamp") {
  Feed a;
  a.hover(0, 380);
  a.touch(400, 480, {100, 100});
  const auto& ev = a.r.flush(500);
  REQUIRE(ev.size() == 1);
  check_event(ev[0], TouchGesture::tap, GesturePhase::complete, 1, 400, 500, 500);
  // a new stream: track 1 is new (a first contact again)
  a.all.clear();
  a.touch(600, 700, {100, 100}, "palm");
  a.frame(720, {{1, std::nullopt}}, "palm");
  REQUIRE(a.all.size() == 1);
  CHECK(a.all[0].gesture == TouchGesture::hit);
}

TEST_CASE("bad input: clear errors and nothing changed") {
  Feed a;
  a.hover(0, 380);
  a.touch(400, 440, {100, 100});
  CHECK_THROWS_WITH_AS(a.frame(440, {{1, cv::Point2f(100, 100)}}),
                       doctest::Contains("not after the previous one"), InvalidArgument);
  CHECK_THROWS_WITH_AS(a.frame(430, {{1, cv::Point2f(100, 100)}}),
                       doctest::Contains("strictly increasing"), InvalidArgument);
  CHECK_THROWS_AS(a.frame(std::nan(""), {{1, std::nullopt}}), InvalidArgument);
  CHECK_THROWS_WITH_AS(a.frame(450, {{1, std::nullopt}, {1, std::nullopt}}),
                       doctest::Contains("appears twice"), InvalidArgument);
  CHECK_THROWS_WITH_AS(a.frame(450, {{0, std::nullopt}}), doctest::Contains("not positive"),
                       InvalidArgument);
  CHECK_THROWS_WITH_AS(a.frame(450, {{1, cv::Point2f(std::nanf(""), 0)}}),
                       doctest::Contains("non-finite contact"), InvalidArgument);
  CHECK_THROWS_AS(a.frame(450, {{1, cv::Point2f(1, 1), -1}}), InvalidArgument);
  // the sequence goes on as if the bad frames were never given
  a.touch(460, 480, {100, 100});
  a.frame(500, {{1, std::nullopt}});
  REQUIRE(a.all.size() == 1);
  check_event(a.all[0], TouchGesture::tap, GesturePhase::complete, 1, 400, 500, 500);

  TemporalGestureConfig c;
  c.hold_min_ms = 200;
  CHECK_THROWS_WITH_AS(TemporalGestureRecogniser{c}, doctest::Contains("hold_min_ms"),
                       InvalidArgument);
  c = {};
  c.px_per_cm = 0;
  CHECK_THROWS_WITH_AS(TemporalGestureRecogniser{c}, doctest::Contains("px_per_cm"),
                       InvalidArgument);
}

TEST_CASE("a track vanishing mid-gesture: no tap, a begun hold ends at its last contact") {
  Feed a;
  a.hover(0, 380);
  a.touch(400, 460, {100, 100});
  a.frame(480, {}); // track 1 gone while touching
  a.frame(500, {{1, std::nullopt}});
  a.hover(520, 700);
  CHECK(a.all.empty());

  Feed b;
  b.hover(0, 380);
  b.touch(400, 1500, {100, 100}, "palm");
  b.frame(1520, {{2, std::nullopt}}); // 1 vanished, 2 appeared
  REQUIRE(b.all.size() == 2);
  check_event(b.all[0], TouchGesture::hold, GesturePhase::began, 1, 400, 1400, 1400);
  check_event(b.all[1], TouchGesture::hold, GesturePhase::ended, 1, 400, 1500, 1520);

  Feed c; // a pending double tap is forgotten when the track goes
  c.hover(0, 380);
  c.touch(400, 480, {100, 100});
  c.frame(500, {{1, std::nullopt}});
  c.frame(520, {});
  c.touch(600, 680, {100, 100}); // track 1 again: a new track state, no double tap
  c.frame(700, {{1, std::nullopt}});
  REQUIRE(c.all.size() == 2);
  CHECK(c.all[1].gesture == TouchGesture::tap);
}

TEST_CASE("no heap allocation per frame after warm-up (4 tracks tapping, stroking, holding)") {
  Feed a;
  a.f.tracks.reserve(8);
  auto run = [&](double t0, int frames) {
    for (int i = 0; i < frames; ++i) {
      const double t = t0 + 20 * i;
      const int phase = i % 60;
      a.f.timestamp_ms = t;
      a.f.tracks.clear();
      for (int id = 1; id <= 4; ++id) {
        TouchTrack tr;
        tr.id = id;
        tr.matched = true;
        if (phase < 5 * id + 40) // each touches for a different time: taps, pats, holds
          tr.contact = cv::Point2f(50.f * id + static_cast<float>(id == 4 ? phase : 0), 50.f);
        tr.contact_area = 500.0 * id;
        a.f.tracks.push_back(tr);
      }
      a.g.available = true;
      a.g.label = (i / 30) % 2 ? "palm" : "point";
      (void)a.r.update(a.f, a.g);
    }
  };
  run(0, 240);
  const std::size_t before = counting_new::count();
  run(10000, 600);
  CHECK(counting_new::count() - before == 0);
}

namespace {
// A user's own recogniser: every contact start is a "tap".
struct TouchDownRecogniser {
  std::vector<GestureEvent> out;
  const std::vector<GestureEvent>& update(const TouchFrame& f, const OutputGesture&) {
    out.clear();
    for (const TouchTrack& t : f.tracks)
      if (t.contact) {
        GestureEvent& e = out.emplace_back();
        e.track_id = t.id;
        e.start_ms = f.timestamp_ms;
      }
    return out;
  }
  const std::vector<GestureEvent>& flush(double) { return out; }
};

template <TemporalRecogniser R>
std::size_t count_events(R& r, const TouchFrame& f) {
  return r.update(f, OutputGesture{}).size();
}
} // namespace

TEST_CASE("a user's own recogniser models TemporalRecogniser") {
  static_assert(TemporalRecogniser<TouchDownRecogniser>);
  static_assert(TemporalRecogniser<TemporalRecogniserArchetype>);
  static_assert(!TemporalRecogniser<int>);
  TouchDownRecogniser mine;
  TouchFrame f;
  TouchTrack t;
  t.id = 3;
  t.contact = cv::Point2f(1, 2);
  f.tracks.push_back(t);
  CHECK(count_events(mine, f) == 1);
  CHECK(mine.out[0].track_id == 3);
}
