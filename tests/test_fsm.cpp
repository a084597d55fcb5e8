// The touch state machine (paper Fig. 7): exact event sequences for hand-built observation streams.
#include <shadowsense/sense/touch_state_machine.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <vector>

using namespace shadowsense;

namespace {
TouchObservation nothing() {
  return {};
}
TouchObservation shadow_only() {
  return {true, std::nullopt};
}
TouchObservation contact(float x, float y) {
  return {true, cv::Point2f(x, y)};
}

struct Rec {
  double t;
  TouchState from, to;
  Direction dir;
};

std::vector<Rec> run(TouchStateMachine& fsm,
                     const std::vector<std::pair<double, TouchObservation>>& s) {
  std::vector<Rec> out;
  for (const auto& [t, o] : s)
    for (const TouchEvent& e : fsm.update(t, o))
      out.push_back({e.timestamp_ms, e.from, e.to, e.direction});
  return out;
}
} // namespace

TEST_CASE("the paper's Fig. 8 sequence: none, appear, touch, move, lift, none") {
  TouchStateMachine fsm;
  CHECK(fsm.state() == TouchState::none);
  const auto ev = run(fsm, {{0, nothing()},
                            {100, shadow_only()},
                            {200, contact(50, 50)},
                            {300, contact(51, 50)}, // 1 px: stays touch
                            {400, contact(56, 50)}, // 5 px: move, right
                            {500, contact(61, 50)},
                            {600, nothing()},   // contact and shadow lost at 600
                            {700, nothing()},   // 100 ms < 150: nothing yet
                            {750, nothing()}}); // exactly 150 ms: lift and disappear
  REQUIRE(ev.size() == 5);
  CHECK(ev[0].t == 100);
  CHECK(ev[0].to == TouchState::appear);
  CHECK(ev[1].t == 200);
  CHECK(ev[1].to == TouchState::touch);
  CHECK(ev[2].t == 400);
  CHECK(ev[2].from == TouchState::touch);
  CHECK(ev[2].to == TouchState::move);
  CHECK(ev[2].dir == Direction::right);
  CHECK(ev[3].t == 750);
  CHECK(ev[3].to == TouchState::lift);
  CHECK(ev[4].t == 750);
  CHECK(ev[4].from == TouchState::lift);
  CHECK(ev[4].to == TouchState::none);
  CHECK(fsm.state() == TouchState::none);
  CHECK(fsm.voted_direction() == Direction::right);
  CHECK(fsm.votes() == std::array<int, 4>{2, 0, 0, 0});
}

TEST_CASE("contact and shadow in the first frame give appear and touch at the same timestamp") {
  TouchStateMachine fsm;
  const auto& ev = fsm.update(5, contact(10, 10));
  REQUIRE(ev.size() == 2);
  CHECK(ev[0].to == TouchState::appear);
  CHECK(ev[1].to == TouchState::touch);
  CHECK(ev[1].timestamp_ms == 5);
  REQUIRE(ev[1].position.has_value());
  CHECK(ev[1].position->x == 10);
}

TEST_CASE("flicker shorter than the hysteresis window is suppressed") {
  TouchStateMachine fsm;
  std::vector<std::pair<double, TouchObservation>> s;
  double t = 0;
  // Contact at a fixed point, dropping out for two frames (66 ms at 30 fps) every five frames.
  for (int i = 0; i < 60; ++i, t += 33)
    s.push_back({t, (i % 5 == 3 || i % 5 == 4) ? shadow_only() : contact(20, 20)});
  const auto ev = run(fsm, s);
  REQUIRE(ev.size() == 2); // appear + touch, nothing else
  CHECK(fsm.state() == TouchState::touch);
  // Shadow flicker in appear is suppressed too.
  TouchStateMachine a;
  const auto ev2 = run(a, {{0, shadow_only()},
                           {50, nothing()},
                           {100, nothing()},
                           {149, nothing()},
                           {160, shadow_only()}});
  REQUIRE(ev2.size() == 1);
  CHECK(a.state() == TouchState::appear);
}

TEST_CASE("exactly at the window edge the loss transition fires; just before it does not") {
  SUBCASE("lift fires at t_loss + 150 exactly") {
    TouchStateMachine fsm;
    run(fsm, {{0, contact(1, 1)}, {10, shadow_only()}});
    CHECK(fsm.update(159.999, shadow_only()).empty());
    CHECK(fsm.state() == TouchState::touch);
    const auto& ev = fsm.update(160, shadow_only());
    REQUIRE(ev.size() == 1);
    CHECK(ev[0].to == TouchState::lift);
    CHECK(ev[0].timestamp_ms == 160);
  }
  SUBCASE("a contact exactly at the edge frame does not lift (detection wins)") {
    TouchStateMachine fsm;
    run(fsm, {{0, contact(1, 1)}, {10, shadow_only()}});
    CHECK(fsm.update(160, contact(1, 1)).empty());
    CHECK(fsm.state() == TouchState::touch);
  }
  SUBCASE("disappear from appear at t_loss + hysteresis with a custom window") {
    TouchStateMachine fsm({.hysteresis_ms = 100});
    run(fsm, {{0, shadow_only()}, {20, nothing()}});
    CHECK(fsm.update(119, nothing()).empty());
    const auto& ev = fsm.update(120, nothing());
    REQUIRE(ev.size() == 1);
    CHECK(ev[0].to == TouchState::none);
  }
  SUBCASE("zero hysteresis: the first missing frame transitions") {
    TouchStateMachine fsm({.hysteresis_ms = 0});
    run(fsm, {{0, contact(1, 1)}});
    const auto& ev = fsm.update(1, shadow_only());
    REQUIRE(ev.size() == 1);
    CHECK(ev[0].to == TouchState::lift);
  }
}

TEST_CASE("lift then re-touch and then disappear") {
  TouchStateMachine fsm;
  const auto ev = run(fsm, {{0, contact(5, 5)},
                            {100, shadow_only()},
                            {250, shadow_only()}, // lift
                            {300, contact(9, 5)}, // touch again
                            {400, nothing()},
                            {500, nothing()},
                            {550, nothing()}}); // lift + none
  REQUIRE(ev.size() == 6);
  CHECK(ev[2].to == TouchState::lift);
  CHECK(ev[2].t == 250);
  CHECK(ev[3].from == TouchState::lift);
  CHECK(ev[3].to == TouchState::touch);
  CHECK(ev[4].to == TouchState::lift);
  CHECK(ev[5].to == TouchState::none);
  CHECK(ev[5].t == 550);
}

TEST_CASE("move threshold is strict and move returns to touch when the differential drops") {
  TouchStateMachine fsm;
  const auto ev = run(fsm, {{0, contact(0, 0)},
                            {10, contact(2, 0)},   // exactly 2 px: not a move
                            {20, contact(2, 2.5)}, // 2.5 px: move (back = +y)
                            {30, contact(2, 3)}}); // 0.5 px: back to touch
  REQUIRE(ev.size() == 4);
  CHECK(ev[2].to == TouchState::move);
  CHECK(ev[2].t == 20);
  CHECK(ev[3].from == TouchState::move);
  CHECK(ev[3].to == TouchState::touch);
}

TEST_CASE("directions follow the default mapping and a custom mapping") {
  auto slide = [](TouchStateMachine& fsm, float dx, float dy) {
    for (int i = 0; i < 10; ++i) fsm.update(i * 77.0, contact(100 + dx * i, 100 + dy * i));
    return fsm.voted_direction();
  };
  TouchStateMachine a, b, c, d;
  CHECK(slide(a, 5, 0) == Direction::right);
  CHECK(slide(b, -5, 0) == Direction::left);
  CHECK(slide(c, 0, -5) == Direction::front);
  CHECK(slide(d, 0, 5) == Direction::back);
  TouchStateMachine e({.axes = {.positive_x = Direction::front,
                                .negative_x = Direction::back,
                                .negative_y = Direction::left,
                                .positive_y = Direction::right}});
  CHECK(slide(e, 5, 0) == Direction::front);
  TouchStateMachine f({.axes = {.positive_x = Direction::front,
                                .negative_x = Direction::back,
                                .negative_y = Direction::left,
                                .positive_y = Direction::right}});
  CHECK(slide(f, 0, -5) == Direction::left);
}

TEST_CASE("diagonals: the dominant axis wins; an exact tie follows Config::diagonal_tie") {
  auto slide = [](TouchStateMachine&& fsm, float dx, float dy) {
    for (int i = 0; i < 8; ++i) fsm.update(i * 50.0, contact(100 + dx * i, 100 + dy * i));
    return fsm.voted_direction();
  };
  CHECK(slide(TouchStateMachine{}, 4, -3.9f) == Direction::right);
  CHECK(slide(TouchStateMachine{}, 3.9f, -4) == Direction::front);
  CHECK(slide(TouchStateMachine{}, -4, 4) == Direction::left);
  CHECK(slide(TouchStateMachine({.diagonal_tie = DiagonalTie::vertical}), -4, 4) ==
        Direction::back);
}

TEST_CASE("the windowed direction averages over direction_window_ms") {
  TouchStateMachine fsm; // 300 ms window
  // Right by 3 px per 100 ms, then a single 10 px jump left: the window mean is still right? No:
  // window [300,600] holds p(300)=9, p(400)=12, p(500)=15, p(600)=5 -> mean (5-9)/3 < 0: left.
  const auto ev = run(fsm, {{0, contact(0, 0)},
                            {100, contact(3, 0)},
                            {200, contact(6, 0)},
                            {300, contact(9, 0)},
                            {400, contact(12, 0)},
                            {500, contact(15, 0)},
                            {600, contact(5, 0)}});
  REQUIRE(ev.size() == 4);
  CHECK(ev[2].to == TouchState::move);
  CHECK(ev[2].dir == Direction::right);
  CHECK(ev[3].from == TouchState::move);
  CHECK(ev[3].to == TouchState::move);
  CHECK(ev[3].dir == Direction::left);
  CHECK(fsm.votes() == std::array<int, 4>{5, 1, 0, 0});
  CHECK(fsm.voted_direction() == Direction::right);
}

TEST_CASE("a vote tie goes to the larger summed displacement") {
  TouchStateMachine fsm({.direction_window_ms = 1}); // window holds only the last step
  run(fsm, {{0, contact(0, 0)}, {10, contact(3, 0)}, {20, contact(3, -10)}});
  CHECK(fsm.votes() == std::array<int, 4>{1, 0, 1, 0});
  CHECK(fsm.voted_direction() == Direction::front);
}

TEST_CASE("very fast slides: large per-frame displacement is one clean move") {
  TouchStateMachine fsm;
  std::vector<std::pair<double, TouchObservation>> s;
  for (int i = 0; i < 4; ++i) s.push_back({i * 77.0, contact(10.0f + 60.0f * i, 100)});
  const auto ev = run(fsm, s);
  REQUIRE(ev.size() == 3);
  CHECK(ev[2].to == TouchState::move);
  CHECK(fsm.voted_direction() == Direction::right);
  CHECK(fsm.votes() == std::array<int, 4>{3, 0, 0, 0});
}

TEST_CASE("an empty sequence and a sequence without motion have no direction") {
  CHECK(sequence_direction({}, {}) == Direction::none);
  CHECK(sequence_direction({0, 10, 20}, {contact(1, 1), contact(1, 1), contact(1.5f, 1)}) ==
        Direction::none);
  CHECK(sequence_direction({0, 10}, {contact(0, 0), contact(0, 9)}) == Direction::back);
  CHECK_THROWS_AS(sequence_direction({0}, {}), InvalidArgument);
}

TEST_CASE("non-monotonic, repeated and non-finite timestamps are rejected with a clear error") {
  TouchStateMachine fsm;
  fsm.update(10, nothing());
  CHECK_THROWS_WITH_AS(fsm.update(10, nothing()),
                       doctest::Contains("timestamps must be strictly increasing"),
                       InvalidArgument);
  CHECK_THROWS_AS(fsm.update(5, nothing()), InvalidArgument);
  CHECK_THROWS_AS(fsm.update(std::numeric_limits<double>::quiet_NaN(), nothing()), InvalidArgument);
  CHECK_THROWS_AS(fsm.update(20, contact(std::numeric_limits<float>::infinity(), 0)),
                  InvalidArgument);
  CHECK_NOTHROW(fsm.update(11, nothing())); // the rejected calls changed nothing
  fsm.reset();
  CHECK_NOTHROW(fsm.update(0, nothing()));
}

TEST_CASE("invalid configurations are rejected") {
  CHECK_THROWS_AS(TouchStateMachine({.hysteresis_ms = -1}), InvalidArgument);
  CHECK_THROWS_AS(TouchStateMachine({.direction_window_ms = 0}), InvalidArgument);
  CHECK_THROWS_AS(TouchStateMachine({.axes = {.positive_x = Direction::right,
                                              .negative_x = Direction::right,
                                              .negative_y = Direction::front,
                                              .positive_y = Direction::back}}),
                  InvalidArgument);
  CHECK(direction_from_string("front") == Direction::front);
  CHECK_THROWS_AS(direction_from_string("up"), InvalidArgument);
}

TEST_CASE("a slow slide: per-frame steps below the threshold, caught by differential_window_ms") {
  std::vector<double> ts;
  std::vector<TouchObservation> obs;
  for (int i = 0; i < 30; ++i) {
    ts.push_back(i * 20.0); // 50 fps, 1 px per frame
    obs.push_back(contact(10.0f + i, 50));
  }
  CHECK(sequence_direction(ts, obs) == Direction::none); // the paper's per-frame differential
  TouchStateMachine fsm({.differential_window_ms = 60});
  std::vector<Rec> ev;
  for (std::size_t i = 0; i < ts.size(); ++i)
    for (const TouchEvent& e : fsm.update(ts[i], obs[i]))
      ev.push_back({e.timestamp_ms, e.from, e.to, e.direction});
  // 3 px over the 60 ms window first exceeds 2 px at t = 60.
  REQUIRE(ev.size() == 3);
  CHECK(ev[2].to == TouchState::move);
  CHECK(ev[2].t == 60);
  CHECK(fsm.voted_direction() == Direction::right);
  CHECK(fsm.votes() == std::array<int, 4>{27, 0, 0, 0});
  CHECK_THROWS_AS(TouchStateMachine({.differential_window_ms = -1}), InvalidArgument);
}
