// Domain randomisation of the scene generator (sim/randomise.hpp): deterministic for a seed,
// different across seeds, every drawn value inside its documented range, ground truth kept
// consistent with the pixels, and off by default.
#include <shadowsense/sim.hpp>

#include <doctest/doctest.h>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

using namespace shadowsense;
using namespace shadowsense::sim;

namespace {
bool same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}
GestureSessionConfig randomised(int frames) {
  GestureSessionConfig c;
  c.frames_per_gesture = frames;
  c.randomise = true;
  return c;
}
} // namespace

TEST_CASE("randomisation is off by default and leaves the session's own draws unchanged") {
  CHECK_FALSE(GestureSessionConfig{}.randomise);
  Renderer r(Rig::robot());
  User user;
  user.id = 2;
  const GestureSession plain(5, user, 1.0, {.frames_per_gesture = 1});
  const GestureSession rnd(5, user, 1.0, randomised(1));
  // Same poses and timing: the randomisation has its own random stream.
  CHECK(plain.info(3).timestamp_ms == rnd.info(3).timestamp_ms);
  CHECK(plain.light().shadow_azimuth_deg == rnd.light().shadow_azimuth_deg);
  CHECK(plain.user().hand_length_cm == user.hand_length_cm);
  CHECK(rnd.user().hand_length_cm ==
        doctest::Approx(user.hand_length_cm * rnd.domain().hand_scale));
  // The renderer's shading is restored after a randomised frame.
  const RenderConfig before = r.config();
  Frame f;
  rnd.render(r, 2, f);
  CHECK(r.config().penumbra_base_cm == before.penumbra_base_cm);
  CHECK(r.config().max_opacity == before.max_opacity);
  CHECK(r.config().skin_transmission == before.skin_transmission);
  Frame a, b;
  plain.render(r, 2, a);
  Renderer fresh(Rig::robot());
  plain.render(fresh, 2, b);
  CHECK(same(a.image, b.image)); // a randomised frame in between changed nothing
}

TEST_CASE("a seed gives identical randomised frames; other seeds give other frames") {
  Renderer r1(Rig::robot()), r2(Rig::robot());
  User user;
  const GestureSession a(11, user, 0.5, randomised(2)), b(11, user, 0.5, randomised(2)),
      c(12, user, 0.5, randomised(2));
  for (int i : {0, 3, 7, 11}) {
    CAPTURE(i);
    Frame fa, fb, fc;
    a.render(r1, i, fa);
    b.render(r2, i, fb);
    c.render(r1, i, fc);
    CHECK(same(fa.image, fb.image));
    CHECK(same(fa.gt.shadow_mask, fb.gt.shadow_mask));
    CHECK(same(fa.gt.contact_mask, fb.gt.contact_mask));
    CHECK_FALSE(same(fa.image, fc.image));
  }
}

TEST_CASE("every drawn value lies inside its documented range and the ranges are covered") {
  const DomainRanges r;
  struct Field {
    const char* name;
    Range range;
    std::function<double(const DomainSample&)> get;
  };
  const std::vector<Field> fields{
      {"weave_period_x", r.weave_period_px, [](const DomainSample& d) { return d.weave_period_x; }},
      {"weave_contrast", r.weave_contrast, [](const DomainSample& d) { return d.weave_contrast; }},
      {"seam_period", r.seam_period_px, [](const DomainSample& d) { return d.seam_period; }},
      {"seam_contrast", r.seam_contrast, [](const DomainSample& d) { return d.seam_contrast; }},
      {"light_temp_k", r.light_temp_k, [](const DomainSample& d) { return d.light_temp_k; }},
      {"ambient", r.ambient, [](const DomainSample& d) { return d.ambient; }},
      {"zenith_deg", r.zenith_deg, [](const DomainSample& d) { return d.zenith_deg; }},
      {"white_balance_r", r.white_balance,
       [](const DomainSample& d) { return d.white_balance[2]; }},
      {"gamma", r.gamma, [](const DomainSample& d) { return d.gamma; }},
      {"penumbra_base_cm", r.penumbra_base_cm,
       [](const DomainSample& d) { return d.penumbra_base_cm; }},
      {"max_opacity", r.max_opacity, [](const DomainSample& d) { return d.max_opacity; }},
      {"optical_blur_px", r.optical_blur_px,
       [](const DomainSample& d) { return d.optical_blur_px; }},
      {"lens_k1", r.lens_k1, [](const DomainSample& d) { return d.lens_k1; }},
      {"lens_centre_x", r.lens_centre_shift_px,
       [](const DomainSample& d) { return d.lens_centre_shift.x; }},
      {"shot_noise", r.shot_noise, [](const DomainSample& d) { return d.shot_noise; }},
      {"hand_scale", r.hand_scale, [](const DomainSample& d) { return d.hand_scale; }},
      {"arm_elevation_offset_deg", r.arm_elevation_offset_deg,
       [](const DomainSample& d) { return d.arm_elevation_offset_deg; }},
      {"press_depth", r.press_depth, [](const DomainSample& d) { return d.press_depth; }},
  };
  std::vector<DomainSample> samples;
  for (std::uint64_t s = 0; s < 200; ++s) samples.push_back(DomainSample::draw(s, r));
  for (const auto& f : fields) {
    CAPTURE(f.name);
    double lo = 1e300, hi = -1e300;
    for (const auto& d : samples) {
      const double v = f.get(d);
      CHECK(v >= f.range.lo);
      CHECK(v <= f.range.hi);
      lo = std::min(lo, v), hi = std::max(hi, v);
    }
    // 200 uniform draws cover all but the outer 10% at each end (probability of failure
    // below 1e-9 per side).
    const double span = f.range.hi - f.range.lo;
    CHECK(lo < f.range.lo + 0.1 * span);
    CHECK(hi > f.range.hi - 0.1 * span);
  }
  int jpeg = 0, seams = 0, occluded = 0;
  for (const auto& d : samples) {
    jpeg += d.jpeg_quality > 0;
    seams += d.seams != SeamPattern::none;
    occluded += d.occluders > 0;
    if (d.jpeg_quality > 0) {
      CHECK(d.jpeg_quality >= 25);
      CHECK(d.jpeg_quality <= 95);
    }
    CHECK(d.occluders <= r.max_occluders);
  }
  CHECK(jpeg > 100); // probability 0.7
  CHECK(jpeg < 180);
  CHECK(seams > 110); // probability 0.75
  CHECK(seams < 190);
  CHECK(occluded > 100); // 2 of 3 counts
  // Big-body hugs (probability 0.5) draw a body radius and a chest pull inside their ranges;
  // the others keep the hug around the visible top (both 0).
  int big = 0;
  double radius_lo = 1e300, radius_hi = 0, pull_lo = 1e300, pull_hi = 0;
  for (const auto& d : samples) {
    if (d.hug_body_radius_cm == 0) {
      CHECK(d.hug_centre_pull == 0);
      continue;
    }
    ++big;
    radius_lo = std::min(radius_lo, d.hug_body_radius_cm);
    radius_hi = std::max(radius_hi, d.hug_body_radius_cm);
    pull_lo = std::min(pull_lo, d.hug_centre_pull);
    pull_hi = std::max(pull_hi, d.hug_centre_pull);
  }
  CHECK(big > 70);
  CHECK(big < 130);
  CHECK(radius_lo >= r.hug_body_radius_cm.lo);
  CHECK(radius_lo < r.hug_body_radius_cm.lo + 10);
  CHECK(radius_hi <= r.hug_body_radius_cm.hi);
  CHECK(radius_hi > r.hug_body_radius_cm.hi - 10);
  CHECK(pull_lo >= r.hug_centre_pull.lo);
  CHECK(pull_lo < 0.15);
  CHECK(pull_hi <= r.hug_centre_pull.hi);
  CHECK(pull_hi > r.hug_centre_pull.hi - 0.15);
  // Pure function of the seed.
  CHECK(DomainSample::draw(7, r).lens_k1 == DomainSample::draw(7, r).lens_k1);
}

TEST_CASE("randomised frames keep ground truth consistent: touches have contact inside shadow, "
          "nothing has no box") {
  Renderer r(Rig::robot());
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    Rng urng(seed);
    const User user = User::random(static_cast<int>(seed), urng);
    const GestureSession s(seed * 31, user, seed % 2 ? 0.0 : 1.0, randomised(1));
    for (int i = 0; i < s.size(); ++i) {
      Frame f;
      GestureFrameInfo info;
      s.render(r, i, f, &info);
      CAPTURE(seed);
      CAPTURE(i);
      REQUIRE(f.image.type() == CV_8UC3);
      REQUIRE(f.image.size() == cv::Size(635, 350));
      if (info.gesture == Gesture::nothing) {
        CHECK_FALSE(f.gt.shadow_box);
        CHECK_FALSE(f.gt.contact_box);
        continue;
      }
      REQUIRE(f.gt.contact_box);
      REQUIRE(f.gt.shadow_box);
      CHECK((*f.gt.contact_box & *f.gt.shadow_box) == *f.gt.contact_box);
      // Every contact pixel is also a shadow pixel.
      cv::Mat outside;
      cv::bitwise_and(f.gt.contact_mask, ~f.gt.shadow_mask, outside);
      CHECK(cv::countNonZero(outside) == 0);
    }
  }
}

TEST_CASE("bad ranges and renderer changes are rejected with a message") {
  DomainRanges r;
  r.lens_k1 = {0.2, -0.2};
  CHECK_THROWS_WITH_AS(DomainSample::draw(1, r), doctest::Contains("lens_k1"), InvalidArgument);
  r = {};
  r.max_opacity = {0.3, 0.9};
  CHECK_THROWS_WITH_AS(r.validate(), doctest::Contains("max_opacity"), InvalidArgument);
  r = {};
  r.press_depth = {0.0, 1.5};
  CHECK_THROWS_WITH_AS(r.validate(), doctest::Contains("press_depth"), InvalidArgument);
  r = {};
  r.hug_body_radius_cm = {5, 90};
  CHECK_THROWS_WITH_AS(r.validate(), doctest::Contains("hug_body_radius_cm"), InvalidArgument);
  r = {};
  r.big_body_hug_probability = 1.5;
  CHECK_THROWS_WITH_AS(r.validate(), doctest::Contains("big_body_hug_probability"),
                       InvalidArgument);
  GestureSessionConfig c = randomised(1);
  c.ranges.max_occluders = 100;
  CHECK_THROWS_WITH_AS(GestureSession(1, User{}, 1.0, c), doctest::Contains("max_occluders"),
                       InvalidArgument);
  Renderer rr(Rig::robot());
  RenderConfig other = rr.config();
  other.fabric_seed += 1;
  CHECK_THROWS_WITH_AS(rr.set_shading(other), doctest::Contains("fixed at construction"),
                       InvalidArgument);
  Frame f;
  f.image = cv::Mat(10, 10, CV_8UC1, cv::Scalar(0));
  CHECK_THROWS_WITH_AS(apply_camera(DomainSample{}, rr.surface_mask(), 1, f),
                       doctest::Contains("CV_8UC3"), InvalidArgument);
}
