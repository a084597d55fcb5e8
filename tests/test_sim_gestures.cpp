// Gesture scenes and recording sessions on the robot rig.
#include <shadowsense/sim.hpp>

#include <doctest/doctest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

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
