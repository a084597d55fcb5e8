// Gesture scenes and recording sessions on the robot rig.
#include <shadowsense/sim.hpp>

#include <doctest/doctest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <string>

using namespace shadowsense;
using namespace shadowsense::sim;

TEST_CASE("gesture names round-trip and unknown classes are rejected") {
  for (Gesture g : all_gestures) CHECK(gesture_from_string(to_string(g)) == g);
  CHECK_THROWS_WITH_AS(gesture_from_string("wave"),
                       doctest::Contains("unknown gesture class 'wave'"), InvalidArgument);
}

TEST_CASE("every session frame shows its gesture: contact for touches, no box for nothing") {
  Renderer r(Rig::robot());
  Frame f;
  for (int u = 0; u < 4; ++u) {
    Rng rng(static_cast<std::uint64_t>(u));
    const User user = User::random(u, rng);
    for (double level : {1.0, 0.5, 0.0}) {
      const GestureSession s(static_cast<std::uint64_t>(1000 + 7 * u) +
                                 static_cast<std::uint64_t>(level * 10),
                             user, level, {.frames_per_gesture = 2});
      REQUIRE(s.size() == 12);
      for (int i = 0; i < s.size(); ++i) {
        GestureFrameInfo info;
        s.render(r, i, f, &info);
        CAPTURE(s.name());
        CAPTURE(i);
        CHECK(info.frame_index == i);
        CHECK(info.session == s.name());
        CHECK(info.gesture == all_gestures[static_cast<std::size_t>(i / 2)]);
        if (info.gesture == Gesture::nothing) {
          CHECK_FALSE(f.gt.shadow_box);
          CHECK_FALSE(f.gt.contact_box);
        } else {
          CHECK(f.gt.contact_box);
          CHECK(f.gt.shadow_box);
        }
        if (i > 0) CHECK(info.timestamp_ms > s.info(i - 1).timestamp_ms);
      }
    }
  }
}

TEST_CASE("sessions are deterministic, named by user and lighting, and drift smoothly") {
  Renderer r(Rig::robot());
  User user;
  user.id = 3;
  const GestureSession a(9, user, 0.5, {.frames_per_gesture = 20}),
      b(9, user, 0.5, {.frames_per_gesture = 20});
  CHECK(a.name() == "u3_dusk");
  CHECK(GestureSession(9, user, 0.3).name() == "u3_custom30");
  const Frame fa = [&] {
    Frame f;
    a.render(r, 45, f);
    return f;
  }();
  const Frame fb = [&] {
    Frame f;
    b.render(r, 45, f);
    return f;
  }();
  CHECK(cv::norm(fa.image, fb.image, cv::NORM_INF) == 0);
  // Palm block (frames 40..59): consecutive frames move less than frames far apart.
  const auto centre = [&](int i) {
    Frame f;
    a.render(r, i, f);
    REQUIRE(f.gt.contact_point);
    return *f.gt.contact_point;
  };
  const double step = cv::norm(centre(41) - centre(40));
  CHECK(step < 12.0); // 0.1 s apart: a few px at most
  CHECK_THROWS_AS(a.scene(a.size()), InvalidArgument);
  CHECK_THROWS_AS(GestureSession(1, user, 0.5, {.frames_per_gesture = -2}), InvalidArgument);
  CHECK_THROWS_AS(GestureSession(1, user, 1.5), InvalidArgument);
}

TEST_CASE("two_hands shows two separate contact regions, palm one") {
  Renderer r(Rig::robot(), RenderConfig{.sensor_noise = false});
  GesturePose p;
  p.position_cm = {0, 0};
  p.hand_gap_cm = 26;
  const Light l = preset(Lighting::daylight, 0);
  const Frame two = r.render(gesture_scene(Gesture::two_hands, User{}, p), l, 0);
  const Frame one = r.render(gesture_scene(Gesture::palm, User{}, p), l, 0);
  cv::Mat labels;
  const int n_two = cv::connectedComponents(two.gt.contact_mask, labels) - 1;
  const int n_one = cv::connectedComponents(one.gt.contact_mask, labels) - 1;
  CHECK(n_two >= 2);
  CHECK(n_one >= 1);
  CHECK(two.gt.contact_box->width > one.gt.contact_box->width);
}

TEST_CASE("a punch pressed deeper touches with more of the fist; the knuckle face alone is less") {
  Renderer r(Rig::robot(), RenderConfig{.sensor_noise = false});
  const Light l = preset(Lighting::daylight, 0);
  GesturePose p;
  p.position_cm = {5, 2};
  const Frame knuckles = r.render(gesture_scene(Gesture::punch, User{}, p), l, 0);
  p.press_depth = 1;
  const Frame pressed = r.render(gesture_scene(Gesture::punch, User{}, p), l, 0);
  const int a0 = cv::countNonZero(knuckles.gt.contact_mask);
  const int a1 = cv::countNonZero(pressed.gt.contact_mask);
  CAPTURE(a0);
  CAPTURE(a1);
  CHECK(a0 > 0);
  // The fist face (0.38 x 0.52 hand lengths) against the knuckle strip (0.14 x 0.46).
  CHECK(a1 > 2 * a0);
  // The shadow box holds the contact in both.
  CHECK((pressed.gt.contact_box.value() & pressed.gt.shadow_box.value()) ==
        pressed.gt.contact_box.value());
}

TEST_CASE("a hug around a larger body keeps the hands near the chest's row; around the visible "
          "top they wrap past the centre") {
  const User u;
  GesturePose p;
  p.rotation_deg = 90; // the person stands at +y
  p.position_cm = {0, 19};
  auto hands_y = [&](const GesturePose& g) {
    double y = 0;
    int n = 0;
    for (const auto& part : gesture_scene(Gesture::hug, u, g).parts)
      if (part.kind == PartKind::palm)
        for (const auto& v : part.outline_cm) y += v.y, ++n;
    REQUIRE(n > 0);
    return y / n;
  };
  const double wrapped = hands_y(p);
  CHECK(wrapped < 0); // past the robot's centre, on the far side
  p.hug_body_radius_cm = 90;
  p.hug_centre_pull = 0.9;
  const double chest_y = 19 * (1 - 0.9);
  const double beside = hands_y(p);
  CAPTURE(beside);
  CHECK(std::abs(beside - chest_y) < 12);
  // press_depth widens the chest's contact patch.
  Renderer r(Rig::robot(), RenderConfig{.sensor_noise = false});
  const Light l = preset(Lighting::daylight, 0);
  const int light_press =
      cv::countNonZero(r.render(gesture_scene(Gesture::hug, u, p), l, 0).gt.contact_mask);
  p.press_depth = 1;
  const int hard_press =
      cv::countNonZero(r.render(gesture_scene(Gesture::hug, u, p), l, 0).gt.contact_mask);
  CHECK(hard_press > light_press + light_press / 4);
  // Out-of-range pose values are rejected by name.
  p.hug_body_radius_cm = 5;
  CHECK_THROWS_WITH_AS(gesture_scene(Gesture::hug, u, p), doctest::Contains("hug_body_radius_cm"),
                       InvalidArgument);
  p.hug_body_radius_cm = 0;
  p.press_depth = 2;
  CHECK_THROWS_WITH_AS(gesture_scene(Gesture::punch, u, p), doctest::Contains("press_depth"),
                       InvalidArgument);
}

TEST_CASE("a session's empty skin: no body, the session's light, deterministic per noise index") {
  Renderer r(Rig::robot());
  User user;
  user.id = 4;
  for (const bool randomise : {false, true}) {
    const GestureSession s(11, user, 0.0, {.frames_per_gesture = 2, .randomise = randomise});
    Frame e0, e0b, e1, touch;
    s.render_empty_skin(r, 0, e0);
    s.render_empty_skin(r, 0, e0b);
    s.render_empty_skin(r, 1, e1);
    CHECK(cv::countNonZero(e0.gt.shadow_mask) == 0);
    CHECK(cv::countNonZero(e0.gt.contact_mask) == 0);
    CHECK_FALSE(e0.gt.shadow_box);
    CHECK(cv::norm(e0.image, e0b.image, cv::NORM_INF) == 0); // same k: the same frame
    CHECK(cv::norm(e0.image, e1.image, cv::NORM_INF) > 0);   // another k: other sensor noise
    // The session's light: the empty skin is as bright as the session's frames away from the
    // shadow (within the frames' own light jitter), and brighter than all of them on average.
    s.render(r, 4, touch); // a palm frame (block 2)
    REQUIRE(touch.gt.contact_point);
    cv::Mat lit = touch.gt.shadow_mask == 0;
    const double empty_lit = cv::mean(e0.image, lit)[1], touch_lit = cv::mean(touch.image, lit)[1];
    CHECK(std::abs(empty_lit - touch_lit) < 0.35 * touch_lit);
    CHECK(cv::mean(e0.image)[1] > cv::mean(touch.image)[1]);
  }
}
