// The scene generator's renderer: determinism, ground truth consistent with the pixels,
// lighting presets, contact colour and input validation.
#include <shadowsense/sim.hpp>

#include <doctest/doctest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdint>
#include <optional>
#include <vector>

using namespace shadowsense;
using namespace shadowsense::sim;

namespace {

bool identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

// Bounding box of a binary mask, or nothing.
std::optional<cv::Rect> box_of(const cv::Mat& mask) {
  if (cv::countNonZero(mask) == 0) return std::nullopt;
  return cv::boundingRect(mask);
}

// A noise-free light whose ambient and direct light have the same colour, so a pixel's
// shadow opacity can be read back from its ratio to the empty frame.
Light flat_light(Lighting preset_name, double azimuth) {
  Light l = preset(preset_name, azimuth);
  l.ambient_temp_k = l.colour_temp_k;
  return l;
}

struct PixelTruth {
  cv::Mat dark; // pixels whose darkening means shadow opacity >= 0.5
  cv::Mat warm; // skin-tinted pixels (contact)
};

// Reads the ground truth back from the pixels alone: the frame vs. the same scene without
// body parts (same fabric, light, no noise).
PixelTruth from_pixels(const cv::Mat& frame, const cv::Mat& empty, double ambient) {
  PixelTruth t;
  t.dark = cv::Mat::zeros(frame.size(), CV_8UC1);
  t.warm = cv::Mat::zeros(frame.size(), CV_8UC1);
  for (int y = 0; y < frame.rows; ++y)
    for (int x = 0; x < frame.cols; ++x) {
      const cv::Vec3b p = frame.at<cv::Vec3b>(y, x), e = empty.at<cv::Vec3b>(y, x);
      const double sum = p[0] + p[1] + p[2], esum = e[0] + e[1] + e[2];
      const double opacity = (1.0 - sum / esum) / (1.0 - ambient);
      if (opacity >= 0.5) t.dark.at<std::uint8_t>(y, x) = 255;
      // Skin tint: much redder relative to blue than the same fabric without the body.
      const double ratio = (p[2] + 0.5) / (p[0] + 0.5), empty_ratio = (e[2] + 0.5) / (e[0] + 0.5);
      if (ratio > 2.0 * empty_ratio) t.warm.at<std::uint8_t>(y, x) = 255;
    }
  return t;
}

void check_box_matches(const std::optional<cv::Rect>& gt, const std::optional<cv::Rect>& px,
                       int slack) {
  REQUIRE(gt.has_value() == px.has_value());
  if (!gt) return;
  CHECK(std::abs(gt->x - px->x) <= slack);
  CHECK(std::abs(gt->y - px->y) <= slack);
  CHECK(std::abs(gt->br().x - px->br().x) <= slack);
  CHECK(std::abs(gt->br().y - px->br().y) <= slack);
}

} // namespace

TEST_CASE("the same seed renders byte-identical frames; another noise seed differs") {
  Renderer a(Rig::tracking_box()), b(Rig::tracking_box());
  const TrackingSample s = random_tracking_sample(TrackCategory::palm, 42);
  const Frame fa = a.render(s.scene, s.light, s.noise_seed);
  const Frame fb = b.render(s.scene, s.light, s.noise_seed);
  CHECK(identical(fa.image, fb.image));
  CHECK(identical(fa.gt.shadow_mask, fb.gt.shadow_mask));
  CHECK(fa.gt.shadow_box == fb.gt.shadow_box);
  const Frame fc = a.render(s.scene, s.light, s.noise_seed + 1);
  CHECK_FALSE(identical(fa.image, fc.image));
  CHECK(identical(fa.gt.shadow_mask, fc.gt.shadow_mask)); // noise never touches ground truth

  // Reusing a Frame's buffers gives the same result as a fresh frame.
  Frame reused = a.render(random_tracking_sample(TrackCategory::hover, 7).scene, s.light, 3);
  a.render(s.scene, s.light, s.noise_seed, reused);
  CHECK(identical(reused.image, fa.image));

  // Random samples and slide plans are functions of the seed.
  CHECK(random_tracking_sample(TrackCategory::fist, 9).pose.position_cm ==
        random_tracking_sample(TrackCategory::fist, 9).pose.position_cm);
  const SlidePlan p1 = plan_slide(5, SlideGesture::finger, Direction::back);
  const SlidePlan p2 = plan_slide(5, SlideGesture::finger, Direction::back);
  REQUIRE(p1.num_frames() == p2.num_frames());
  CHECK(identical(render_slide_frame(a, p1, p1.num_frames() - 1).image,
                  render_slide_frame(b, p2, p2.num_frames() - 1).image));
}

TEST_CASE("Rng is a fixed sequence (SplitMix64), independent of the standard library") {
  Rng rng(1234567);
  // Reference values of SplitMix64 seeded with 1234567.
  CHECK(rng.next() == 6457827717110365317ull);
  CHECK(rng.next() == 3203168211198807973ull);
  Rng r2(0);
  CHECK(r2.next() == 0xE220A8397B1DCDAFull);
}

TEST_CASE("ground truth boxes agree with the rendered pixels (tracking rig, all categories)") {
  Renderer r(Rig::tracking_box(), RenderConfig{.sensor_noise = false});
  TrackingSampleConfig cfg;
  cfg.distractor_probability = 0;
  int with_contact = 0, with_shadow = 0;
  for (TrackCategory c : all_track_categories)
    for (std::uint64_t i = 0; i < 8; ++i) {
      CAPTURE(to_string(c));
      CAPTURE(i);
      TrackingSample s;
      const Frame f = render_random_tracking_frame(r, c, 100 + i, cfg, &s);
      Light light = s.light; // daylight, dusk or night, jittered
      light.ambient_temp_k = light.colour_temp_k;
      const Frame lit = r.render(s.scene, light, 0);
      Scene empty_scene = s.scene;
      empty_scene.parts.clear();
      const Frame empty = r.render(empty_scene, light, 0);
      const PixelTruth px = from_pixels(lit.image, empty.image, light.ambient);
      // Same ground truth whatever the light's colour, brightness and the sensor noise.
      CHECK(lit.gt.shadow_box == f.gt.shadow_box);
      check_box_matches(lit.gt.shadow_box, box_of(px.dark), 1);
      check_box_matches(lit.gt.contact_box, box_of(px.warm), 0);
      if (lit.gt.shadow_box) {
        // No dark pixel lies outside the shadow box grown by the 1 px slack.
        cv::Mat outside = px.dark.clone();
        cv::Rect grown(lit.gt.shadow_box->x - 1, lit.gt.shadow_box->y - 1,
                       lit.gt.shadow_box->width + 2, lit.gt.shadow_box->height + 2);
        outside(grown & cv::Rect(0, 0, outside.cols, outside.rows)).setTo(0);
        CHECK(cv::countNonZero(outside) == 0);
        ++with_shadow;
      }
      if (lit.gt.contact_box) {
        ++with_contact;
        REQUIRE(lit.gt.shadow_box);
        CHECK((*lit.gt.contact_box & *lit.gt.shadow_box) == *lit.gt.contact_box);
        REQUIRE(lit.gt.contact_point);
        CHECK(lit.gt.contact_box->contains(
            cv::Point(cvRound(lit.gt.contact_point->x), cvRound(lit.gt.contact_point->y))));
      } else {
        CHECK_FALSE(lit.gt.contact_point);
      }
      CHECK(category_visible(c, f.gt));
      if (c == TrackCategory::nothing) CHECK_FALSE(f.gt.shadow_box);
      CHECK(f.gt.px_per_cm == doctest::Approx(r.rig().px_per_cm()));
    }
  CHECK(with_contact == 24);
  CHECK(with_shadow == 32);
}

TEST_CASE("ground truth agrees with the pixels on the robot rig's elliptical surface") {
  Renderer r(Rig::robot(), RenderConfig{.sensor_noise = false});
  Rng rng(77);
  for (int i = 0; i < 6; ++i) {
    CAPTURE(i);
    User u = User::random(i, rng);
    HandPose p =
        random_hand_pose(i % 2 ? TrackCategory::palm : TrackCategory::hover, rng, {40, 15});
    if (i % 2) p.height_cm = 0;
    Scene s;
    add_hand(s.parts, u, p);
    const Light light = flat_light(Lighting::daylight, rng.uniform(-180, 180));
    const Frame f = r.render(s, light, 0);
    const Frame empty = r.render(Scene{}, light, 0);
    PixelTruth px = from_pixels(f.image, empty.image, light.ambient);
    px.dark.setTo(0, ~r.surface_mask());
    check_box_matches(f.gt.shadow_box, box_of(px.dark), 1);
    check_box_matches(f.gt.contact_box, box_of(px.warm), 0);
    // Ground truth is clipped to the visible skin.
    CHECK(cv::countNonZero(f.gt.shadow_mask & ~r.surface_mask()) == 0);
  }
}

TEST_CASE("distractor shadows darken the frame but never enter the ground truth") {
  Renderer r(Rig::tracking_box(), RenderConfig{.sensor_noise = false});
  const TrackingSample s = random_tracking_sample(TrackCategory::palm, 3);
  Scene with = s.scene;
  Rng rng(5);
  for (int i = 0; i < 3; ++i) with.distractors.push_back(random_distractor(rng, {13, 13}));
  const Frame a = r.render(s.scene, s.light, 1), b = r.render(with, s.light, 1);
  CHECK(identical(a.gt.shadow_mask, b.gt.shadow_mask));
  CHECK(identical(a.gt.contact_mask, b.gt.contact_mask));
  CHECK(cv::mean(b.image)[1] < cv::mean(a.image)[1]);
}

TEST_CASE("lighting presets differ measurably: daylight > dusk > night, night noisiest") {
  Renderer r(Rig::tracking_box());
  HandPose pose;
  pose.position_cm = {0, -3};
  pose.arm_elevation_deg = 25;
  Scene scene = tracking_scene(TrackCategory::palm, pose, User{});
  double mean[3], noise[3];
  const Lighting order[3] = {Lighting::daylight, Lighting::dusk, Lighting::night};
  for (int i = 0; i < 3; ++i) {
    const Light l = preset(order[i], 20);
    const Frame a = r.render(scene, l, 1), b = r.render(scene, l, 2);
    cv::Mat grey;
    cv::cvtColor(a.image, grey, cv::COLOR_BGR2GRAY);
    mean[i] = cv::mean(grey)[0];
    cv::Mat d;
    a.image.convertTo(d, CV_32F);
    cv::Mat e;
    b.image.convertTo(e, CV_32F);
    cv::Scalar m, sd;
    const cv::Mat diff = d - e;
    cv::meanStdDev(diff.reshape(1), m, sd);
    noise[i] = sd[0] / std::sqrt(2.0); // per-frame sensor noise
    // Contact pixels are skin-tinted (R > G > B clearly), shadows are not.
    const cv::Scalar contact = cv::mean(a.image, a.gt.contact_mask);
    CHECK(contact[2] > 1.5 * contact[1]);
    CHECK(contact[1] > 1.2 * contact[0]);
    const cv::Mat shadow_only = a.gt.shadow_mask & ~a.gt.contact_mask;
    REQUIRE(cv::countNonZero(shadow_only) > 100);
    const cv::Scalar shadow = cv::mean(a.image, shadow_only);
    CHECK(shadow[2] < 1.5 * shadow[0]);
    // Contact is the darkest class.
    CHECK(contact[0] + contact[1] + contact[2] < shadow[0] + shadow[1] + shadow[2]);
  }
  CHECK(mean[0] > mean[1] + 20);
  CHECK(mean[1] > mean[2] + 20);
  CHECK(noise[2] > 1.5 * noise[1]);
  CHECK(noise[1] > 1.5 * noise[0]);
  // The continuous level interpolates between presets.
  CHECK(light_from_level(0.75).brightness() > preset(Lighting::dusk).brightness());
  CHECK(light_from_level(0.75).brightness() < preset(Lighting::daylight).brightness());
  CHECK(preset(Lighting::night).exposure > preset(Lighting::daylight).exposure);
  // Exposure scales what the camera records, noise included.
  Light brighter = preset(Lighting::dusk);
  brighter.exposure *= 1.5;
  const Frame dim = r.render(scene, preset(Lighting::dusk), 1),
              lifted = r.render(scene, brighter, 1);
  CHECK(cv::mean(lifted.image)[1] > 1.3 * cv::mean(dim.image)[1]);
  CHECK(light_from_level(0.75).label == Lighting::custom);
}

TEST_CASE("hover shadows blur and fade with height; contact is sharp") {
  Renderer r(Rig::tracking_box(), RenderConfig{.sensor_noise = false});
  CHECK(r.opacity_at(0) > r.opacity_at(5));
  CHECK(r.opacity_at(5) > r.opacity_at(20));
  CHECK(r.opacity_at(20) >= 0.5); // hovering hands up to 20 cm still cast a shadow
  CHECK(r.opacity_at(35) < 0.5);  // people far away never do
  CHECK(r.penumbra_cm(20) > r.penumbra_cm(5));
  User u;
  HandPose low, high;
  low.height_cm = 5, high.height_cm = 15;
  const Light l = preset(Lighting::daylight, 0);
  const Frame a = r.render(tracking_scene(TrackCategory::hover, low, u), l, 0);
  const Frame b = r.render(tracking_scene(TrackCategory::hover, high, u), l, 0);
  double min_a, min_b, max_a, max_b;
  cv::minMaxLoc(a.gt.shadow_opacity, &min_a, &max_a);
  cv::minMaxLoc(b.gt.shadow_opacity, &min_b, &max_b);
  CHECK(max_a > max_b);
  // Count penumbra pixels (0.1 < opacity < 0.9): the higher hand has a wider one.
  const auto penumbra = [](const cv::Mat& o) { return cv::countNonZero((o > 0.1) & (o < 0.9)); };
  CHECK(penumbra(b.gt.shadow_opacity) > penumbra(a.gt.shadow_opacity));
  // A touching palm: every contact pixel has opacity exactly 1 and no soft edge.
  const Frame c = r.render(tracking_scene(TrackCategory::palm, low, u), l, 0);
  CHECK(cv::countNonZero(c.gt.contact_mask) > 1000);
  CHECK(cv::countNonZero((c.gt.shadow_opacity == 1.0f) & ~c.gt.contact_mask) == 0);
}

TEST_CASE("slides: frame counts, distance, direction and per-frame ground truth") {
  Renderer r(Rig::tracking_box(), RenderConfig{.sensor_noise = false});
  SlideConfig cfg;
  cfg.variety.lighting_weights = {1, 0, 0};
  for (Direction d : all_directions)
    for (SlideGesture g : {SlideGesture::palm, SlideGesture::finger}) {
      CAPTURE(to_string(d));
      CAPTURE(to_string(g));
      const SlidePlan plan = plan_slide(17 + static_cast<int>(d), g, d, cfg);
      REQUIRE(plan.num_frames() >= 8);
      REQUIRE(plan.num_frames() <= 80);
      CHECK(plan.distance_cm >= 10);
      CHECK(plan.distance_cm <= 26);
      CHECK(plan.timestamps_ms[1] == doctest::Approx(1000.0 / 13.0));
      const Frame first = render_slide_frame(r, plan, 0);
      const Frame last = render_slide_frame(r, plan, plan.num_frames() - 1);
      REQUIRE(first.gt.contact_point);
      REQUIRE(last.gt.contact_point);
      const cv::Point2f moved = *last.gt.contact_point - *first.gt.contact_point;
      const cv::Point2d dir = direction_vector(d);
      const double along = (moved.x * dir.x + moved.y * dir.y) / r.rig().px_per_cm();
      CHECK(along > 0.6 * plan.distance_cm);
      CHECK(along < 1.3 * plan.distance_cm);
    }
  CHECK(direction_vector(Direction::front) == cv::Point2d(0, -1));
  CHECK(direction_vector(Direction::right) == cv::Point2d(1, 0));
}

TEST_CASE("bad input is rejected with a message naming the problem") {
  Rig bad = Rig::tracking_box();
  bad.image_size = {-5, 10};
  CHECK_THROWS_AS(Renderer{bad}, InvalidArgument);
  CHECK_THROWS_WITH_AS(light_from_level(1.5), doctest::Contains("outside [0, 1]"), InvalidArgument);
  CHECK_THROWS_WITH_AS(track_category_from_string("wave"),
                       doctest::Contains("unknown tracking category"), InvalidArgument);
  CHECK_THROWS_AS(direction_from_string("up"), InvalidArgument);
  CHECK_THROWS_AS(lighting_from_string("noon"), InvalidArgument);
  Light mislabelled = preset(Lighting::night);
  mislabelled.level = 0.3;
  CHECK_THROWS_WITH_AS(mislabelled.validate(),
                       doctest::Contains("does not match the preset 'night'"), InvalidArgument);
  Renderer r(Rig::tracking_box());
  Scene s;
  BodyPart p;
  p.outline_cm = {{0, 0}, {1, 0}, {0, 1}};
  p.height_cm = {0, 0};
  s.parts.push_back(p);
  CHECK_THROWS_WITH_AS(r.render(s, preset(Lighting::dusk), 0),
                       doctest::Contains("one value per outline vertex"), InvalidArgument);
  User u;
  u.hand_length_cm = -3;
  CHECK_THROWS_WITH_AS(tracking_scene(TrackCategory::palm, HandPose{}, u),
                       doctest::Contains("hand_length_cm"), InvalidArgument);
  CHECK_THROWS_WITH_AS(tracking_scene(TrackCategory::hover, HandPose{}, User{}),
                       doctest::Contains("height_cm > 0"), InvalidArgument);
  SlideConfig sc;
  sc.min_frames = 10, sc.max_frames = 5;
  CHECK_THROWS_AS(plan_slide(1, SlideGesture::palm, Direction::left, sc), InvalidArgument);
  Distractor d;
  d.outline_cm = p.outline_cm;
  d.opacity = 0.7;
  Scene s2;
  s2.distractors.push_back(d);
  CHECK_THROWS_WITH_AS(r.render(s2, preset(Lighting::dusk), 0), doctest::Contains("opacity"),
                       InvalidArgument);
}

TEST_CASE("rig geometry: the fisheye round-trips, scales and surfaces") {
  for (const Rig& rig : {Rig::robot(), Rig::tracking_box()}) {
    CAPTURE(rig.name);
    for (const cv::Point2d p :
         {cv::Point2d{0, 0}, cv::Point2d{5, -3}, cv::Point2d{-12, 12.5}, cv::Point2d{40, 10}}) {
      const cv::Point2d q = rig.unproject(rig.project(p));
      CHECK(q.x == doctest::Approx(p.x).epsilon(1e-9));
      CHECK(q.y == doctest::Approx(p.y).epsilon(1e-9));
    }
    // On the axis, 1 cm on the skin is px_per_cm pixels; towards the edge the fisheye shrinks it.
    const double on_axis = rig.project({1, 0}).x - rig.project({0, 0}).x;
    CHECK(on_axis == doctest::Approx(rig.px_per_cm()).epsilon(0.01));
    CHECK(rig.local_px_per_cm({20, 0}) < rig.local_px_per_cm({0, 0}));
    Renderer r(rig);
    const cv::Mat& s = r.surface_mask();
    CHECK(s.at<std::uint8_t>(rig.image_size.height / 2, rig.image_size.width / 2) == 255);
  }
  // The tracking box: the 26 x 26.6 cm top fills the 200x205 frame (barrel corners aside).
  const Rig box = Rig::tracking_box();
  CHECK(box.project({13, 0}).x == doctest::Approx(199.5).epsilon(1e-3));
  CHECK(box.px_per_cm() == doctest::Approx(7.90).epsilon(0.01));
  Renderer rb(box);
  CHECK(cv::countNonZero(rb.surface_mask()) > 0.97 * 200 * 205);
  // The robot: an ellipse inside the frame, corners show the interior.
  Renderer rr(Rig::robot());
  CHECK(rr.surface_mask().at<std::uint8_t>(0, 0) == 0);
  CHECK(rr.surface_mask().at<std::uint8_t>(349, 634) == 0);
  const double ellipse = 3.14159265358979 * (317.5 - 8) * (175 - 7);
  CHECK(cv::countNonZero(rr.surface_mask()) == doctest::Approx(ellipse).epsilon(0.01));
}

TEST_CASE("slides have contact in every frame and varied speeds") {
  Renderer r(Rig::tracking_box(), RenderConfig{.sensor_noise = false});
  std::vector<double> speeds;
  for (int k = 0; k < 8; ++k) {
    const SlidePlan plan = plan_slide(300 + static_cast<std::uint64_t>(k),
                                      k % 2 ? SlideGesture::finger : SlideGesture::palm,
                                      all_directions[static_cast<std::size_t>(k % 4)]);
    speeds.push_back(plan.distance_cm * plan.fps / (plan.num_frames() - 1));
    const std::vector<Frame> frames = render_slide(r, plan);
    REQUIRE(static_cast<int>(frames.size()) == plan.num_frames());
    int with_contact = 0;
    for (const Frame& f : frames) with_contact += f.gt.contact_box ? 1 : 0;
    CAPTURE(k);
    CHECK(with_contact == plan.num_frames());
  }
  const auto [lo, hi] = std::minmax_element(speeds.begin(), speeds.end());
  CHECK(*hi > 2.0 * *lo); // cm/s differ a lot between sequences
}
