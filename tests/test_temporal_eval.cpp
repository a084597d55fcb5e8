// The temporal gesture recogniser on generated sequences (sim/touch_sequences.hpp) at 15, 30 and
// 60 fps with dropped and duplicated frames: per-gesture precision, recall, F1, confusion and
// latency (printed), and the generator's own guarantees (determinism, truth intervals, frame
// loss, bad configs).
#include <shadowsense/eval/temporal_eval.hpp>

#include <doctest/doctest.h>

#include <iostream>

using namespace shadowsense;

TEST_CASE("the touch sequence generator: deterministic, truth in time order, frames lost") {
  sim::TouchSequenceConfig c;
  c.gestures = 30;
  const sim::TouchSequence a = sim::make_touch_sequence(c, 7), b = sim::make_touch_sequence(c, 7);
  REQUIRE(a.frames.size() == b.frames.size());
  for (std::size_t i = 0; i < a.frames.size(); ++i) {
    CHECK(a.frames[i].timestamp_ms == b.frames[i].timestamp_ms);
    CHECK(a.frames[i].tracks.size() == b.frames[i].tracks.size());
    CHECK(a.shapes[i].label == b.shapes[i].label);
  }
  CHECK(a.truth.size() >= 30); // a punch adds its hit
  for (std::size_t i = 1; i < a.truth.size(); ++i)
    CHECK(a.truth[i].start_ms >= a.truth[i - 1].start_ms - 1000);
  for (const auto& t : a.truth) CHECK(t.end_ms > t.start_ms);
  // 3 % dropped: fewer frames than the span holds, timestamps strictly increasing
  const double span = a.frames.back().timestamp_ms;
  CHECK(a.frames.size() < static_cast<std::size_t>(span * c.fps / 1000.0) + 1);
  for (std::size_t i = 1; i < a.frames.size(); ++i)
    CHECK(a.frames[i].timestamp_ms > a.frames[i - 1].timestamp_ms);
  c.fps = 2;
  CHECK_THROWS_AS(sim::make_touch_sequence(c, 1), InvalidArgument);
  c = {};
  c.drop_rate = 0.5;
  CHECK_THROWS_AS(sim::make_touch_sequence(c, 1), InvalidArgument);
}

TEST_CASE("temporal gestures on generated users at 15, 30 and 60 fps") {
  for (double fps : {15.0, 30.0, 60.0}) {
    sim::TouchSequenceConfig c;
    c.fps = fps;
    const TemporalEvalResult r = evaluate_temporal(c, 1000, 40);
    std::cout << "== " << fps << " fps, 3% dropped, 2% duplicated frames\n"
              << format_temporal_eval(r) << std::flush;
    CHECK(r.users == 40);
    // Issue 23's targets: macro-F1 >= 0.97 at 30 fps with no gesture below 0.9, >= 0.93 at 15
    // fps; median latency from a gesture's end to its event <= 150 ms.
    CHECK(r.macro_f1() >= (fps >= 30 ? 0.97 : 0.93));
    if (fps >= 30)
      for (std::size_t g = 0; g < TemporalEvalResult::n; ++g) {
        CAPTURE(to_string(all_touch_gestures[g]));
        CHECK(r.f1(g) >= 0.9);
      }
    CHECK(r.latency_quantile(TemporalEvalResult::n, 0.5) <= 150);
    // Latency is at most the lift's frame interval after a dropped frame or two, never negative.
    CHECK(r.latency_quantile(TemporalEvalResult::n, 0.0) >= 0);
  }
}

namespace {

GestureEvent predicted(TouchGesture g, int track, double start, double end, int reps = 1) {
  GestureEvent e;
  e.gesture = g;
  e.track_id = track;
  e.start_ms = start;
  e.end_ms = end;
  e.decided_ms = end + 10;
  e.repetitions = reps;
  return e;
}

constexpr auto idx = [](TouchGesture g) { return static_cast<std::size_t>(g); };

} // namespace

TEST_CASE("score_temporal: best_one takes one prediction per truth, its own gesture first") {
  using G = TouchGesture;
  const std::vector<sim::TouchGestureTruth> truth = {{G::pat, 1, 1000, 2000, 3, Direction::none},
                                                     {G::hold, 2, 3000, 5000, 1, Direction::none}};
  // On track 1: a tap, then the pat (two repetitions: a repetition error), then another pat;
  // on track 2 a tap only; on track 3 (no truth) a hit.
  const std::vector<GestureEvent> p = {
      predicted(G::tap, 1, 1000, 1100), predicted(G::pat, 1, 1200, 1900, 2),
      predicted(G::pat, 1, 1950, 2020, 3), predicted(G::tap, 2, 3000, 3100),
      predicted(G::hit, 3, 6000, 6050)};
  TemporalEvalResult r;
  score_temporal(truth, p, 33, TemporalTrackMatch::same_id, r);
  CHECK(r.tp[idx(G::pat)] == 1);
  CHECK(r.repetition_errors == 1); // the first pat found is the two-repetition one
  CHECK(r.latency_ms[idx(G::pat)].empty());
  CHECK(r.fn[idx(G::hold)] == 1);
  CHECK(r.confusion[idx(G::hold)][idx(G::tap)] == 1);
  // Left over: the first tap and the second pat on track 1, the hit on track 3.
  CHECK(r.fp[idx(G::tap)] == 2); // track 2's tap (as the hold's confusion) + track 1's
  CHECK(r.fp[idx(G::pat)] == 1);
  CHECK(r.fp[idx(G::hit)] == 1);
  CHECK(r.confusion[TemporalEvalResult::n][idx(G::hit)] == 1);

  // any_track: the hold may take a prediction from another track (rendered frames).
  TemporalEvalResult any;
  score_temporal({{G::hold, 1, 3000, 5000, 1, Direction::none}},
                 {predicted(G::hold, 7, 3000, 5000)}, 33, TemporalTrackMatch::any_track, any);
  CHECK(any.tp[idx(G::hold)] == 1);
  CHECK(any.latency_ms[idx(G::hold)] == std::vector<double>{10});
}

TEST_CASE("score_temporal: all_overlapping, the rule pre-registered for real timing") {
  using G = TouchGesture;
  const TemporalScoring rule{.match = TemporalTrackMatch::same_id,
                             .claim = TemporalClaim::all_overlapping,
                             .double_tap_as_tap = true,
                             .repetitions = false};
  const std::vector<sim::TouchGestureTruth> truth = {{G::tap, 1, 1000, 2000, 1, Direction::none},
                                                     {G::rub, 2, 3000, 4000, 1, Direction::none},
                                                     {G::hold, 3, 5000, 7000, 1, Direction::none}};
  const std::vector<GestureEvent> p = {
      predicted(G::double_tap, 1, 1000, 1300, 2), // a tap for this source: the true positive
      predicted(G::tap, 1, 1500, 1600),           // the capture's repeated tap: ignored
      predicted(G::stroke, 1, 1700, 1990),        // another gesture on the tap: a false positive
      predicted(G::stroke, 2, 3000, 3500),        // the rub read as two strokes: two FPs, a miss
      predicted(G::stroke, 2, 3600, 4000),
      predicted(G::hold, 3, 7100, 9000), // starts 100 ms after the hold: outside 33 ms
      predicted(G::tap, 4, 100, 200)};   // no truth on track 4
  TemporalEvalResult r;
  score_temporal(truth, p, 33, rule, r);
  CHECK(r.tp[idx(G::tap)] == 1);
  CHECK(r.fp[idx(G::tap)] == 1); // only track 4's
  CHECK(r.latency_ms[idx(G::tap)] == std::vector<double>{1310 - 2000});
  CHECK(r.repetition_errors == 0);
  CHECK(r.fp[idx(G::stroke)] == 3);
  CHECK(r.fn[idx(G::rub)] == 1);
  CHECK(r.confusion[idx(G::rub)][idx(G::stroke)] == 1);
  CHECK(r.fn[idx(G::hold)] == 1);
  CHECK(r.confusion[idx(G::hold)][TemporalEvalResult::n] == 1);
  CHECK(r.fp[idx(G::hold)] == 1);
  CHECK(r.confusion[TemporalEvalResult::n][idx(G::hold)] == 1);
  CHECK(r.confusion[TemporalEvalResult::n][idx(G::tap)] == 1);
  CHECK(r.tp[idx(G::double_tap)] + r.fp[idx(G::double_tap)] + r.fn[idx(G::double_tap)] == 0);
}
