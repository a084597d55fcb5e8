// The tracker on frames rendered by the scene generator, against its exact ground truth.
// Calibration frames use a different seed from every frame evaluated here.
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/sense/touch_state_machine.hpp>
#include <shadowsense/sense/tracker.hpp>

#include "common/sim_box.hpp"

#include <doctest/doctest.h>

#include <string>
#include <vector>

using namespace shadowsense;

namespace {

sim::HandPose finger_at(double x_cm, double y_cm, double rotation_deg = -90) {
  sim::HandPose p;
  p.shape = sim::HandShape::point;
  p.position_cm = {x_cm, y_cm};
  p.rotation_deg = rotation_deg;
  p.arm_elevation_deg = 40;
  return p;
}

sim::Frame render(const std::vector<sim::HandPose>& hands, sim::Lighting light,
                  std::uint64_t seed) {
  sim::Scene scene;
  sim::User user;
  for (const auto& h : hands) sim::add_hand(scene.parts, user, h);
  return test::box_renderer().render(scene, sim::preset(light), seed);
}

} // namespace

TEST_CASE(
    "two simultaneous fingertip touches: two contact blobs at the true centroids, stable ids") {
  Segmenter seg = segmenter_from(test::box_calibration());
  ContactTracker tracker;
  int left_id = 0;
  for (int step = 0; step < 5; ++step) {
    // The fingers slide apart, 0.8 cm per frame each.
    const double dx = 0.8 * step;
    const sim::Frame f = render({finger_at(-3 - dx, 2, -120), finger_at(4 + dx, -2, -60)},
                                sim::Lighting::dusk, 100 + static_cast<std::uint64_t>(step));
    const Segmentation s = seg.segment(f.image);
    REQUIRE(s.contacts.size() == 2);
    // Truth per finger: the centroid of each connected component of the contact mask.
    cv::Mat labels, stats, centroids;
    REQUIRE(cv::connectedComponentsWithStats(f.gt.contact_mask, labels, stats, centroids) == 3);
    for (const Blob& b : s.contacts) {
      double best = 1e9;
      for (int k = 1; k <= 2; ++k)
        best = std::min(best, std::hypot(b.centroid.x - centroids.at<double>(k, 0),
                                         b.centroid.y - centroids.at<double>(k, 1)));
      CHECK(best < 1.0);
    }
    std::vector<Detection> d;
    for (const Blob& b : s.contacts) d.push_back({b.centroid, b.box});
    const auto& tracks = tracker.update(d, 77.0 * step);
    REQUIRE(tracks.size() == 2);
    CHECK(tracks[0].id == 1);
    CHECK(tracks[1].id == 2);
    if (step == 0) left_id = tracks[0].position.x < tracks[1].position.x ? 1 : 2;
  }
  // The id that started on the left finger stayed on it.
  const auto& t = tracker.tracks();
  CHECK((t[0].position.x < t[1].position.x ? 1 : 2) == left_id);
}

TEST_CASE("a touch at the image border: the contact box reaches the edge like the truth") {
  Segmenter seg = segmenter_from(test::box_calibration());
  // Fingertip pointing right, beyond the right edge of the box top: only the finger's base is
  // on the visible skin.
  const sim::Frame f = render({finger_at(13.5, 1, 0)}, sim::Lighting::daylight, 7);
  REQUIRE(f.gt.contact_box);
  CHECK(f.gt.contact_box->br().x >= f.image.cols - 3);
  const Segmentation s = seg.segment(f.image);
  REQUIRE(s.contact_box);
  CHECK(box_iou(*s.contact_box, *f.gt.contact_box) > 0.85);
  CHECK(s.contact_box->br().x >= f.gt.contact_box->br().x - 1);
  REQUIRE(s.shadow_box);
  CHECK(box_iou(*s.shadow_box, *f.gt.shadow_box) > 0.93);
}

TEST_CASE("a shadow entering from outside the frame: the arm's shadow box starts at the edge") {
  Segmenter seg = segmenter_from(test::box_calibration());
  sim::HandPose p = finger_at(0, 8, -90); // arm towards the bottom edge
  p.shape = sim::HandShape::open;
  p.height_cm = 6; // hovering
  const sim::Frame f = render({p}, sim::Lighting::night, 9);
  REQUIRE(f.gt.shadow_box);
  REQUIRE_FALSE(f.gt.contact_box);
  CHECK(f.gt.shadow_box->br().y >= f.image.rows - 4); // the truth reaches the bottom edge
  const Segmentation s = seg.segment(f.image);
  CHECK_FALSE(s.contact_box);
  REQUIRE(s.shadow_box);
  CHECK(s.shadow_box->br().y >= f.gt.shadow_box->br().y - 2);
  CHECK(box_iou(*s.shadow_box, *f.gt.shadow_box) > 0.85);
}

TEST_CASE("random frames of every category, all lighting: IoU, misses and false positives") {
  Segmenter seg = segmenter_from(test::box_calibration());
  test::check_random_tracking_frames(seg);
}

TEST_CASE("slides rendered by the generator: the state machine reports the true direction") {
  Segmenter seg = segmenter_from(test::box_calibration());
  int i = 0;
  for (sim::SlideGesture g : {sim::SlideGesture::palm, sim::SlideGesture::finger})
    for (sim::Direction d : sim::all_directions) {
      sim::SlideConfig cfg;
      cfg.max_frames = 20; // keep the test short
      const sim::SlidePlan plan =
          sim::plan_slide(0x511DE + static_cast<std::uint64_t>(i++), g, d, cfg);
      TouchStateMachine fsm({.differential_window_ms = 300});
      bool touched = false;
      for (int k = 0; k < plan.num_frames(); ++k) {
        const sim::Frame f = sim::render_slide_frame(test::box_renderer(), plan, k);
        const Segmentation s = seg.segment(f.image);
        fsm.update(plan.timestamps_ms[static_cast<std::size_t>(k)],
                   {s.shadow_box.has_value(), s.contact_point});
        touched = touched || fsm.state() == TouchState::touch || fsm.state() == TouchState::move;
      }
      CHECK(touched);
      CHECK(std::string(to_string(fsm.voted_direction())) == std::string(sim::to_string(d)));
    }
}

TEST_CASE("images of the wrong size for the empty-skin model are rejected") {
  Segmenter seg = segmenter_from(test::box_calibration());
  CHECK_THROWS_WITH_AS(seg.segment(cv::Mat(100, 100, CV_8UC3, cv::Scalar::all(128))),
                       doctest::Contains("empty-skin model is 200x205"), InvalidArgument);
  CHECK_THROWS_AS(seg.set_empty_skin({}), InvalidArgument);
  CHECK_THROWS_AS(calibrate_on_sim(test::box_renderer(), 1, 5), InvalidArgument);
}

TEST_CASE(
    "robot rig (635x350, elliptical skin): pixels off the skin never count, boxes still fit") {
  // Most of the frame's corners are robot interior here; they must not bias the calibration
  // (they once drove the fitted shadow threshold to 1) nor the darkness map.
  sim::Renderer robot(sim::Rig::robot());
  const SimCalibration cal = calibrate_on_sim(robot, 0x40B07, 60);
  for (const LightThresholds& t : cal.config.calibration.by_light) CHECK(t.shadow_darkness < 0.6f);
  Segmenter seg = segmenter_from(cal);
  RunningStats shadow_iou, contact_iou;
  for (int i = 0; i < 9; ++i) {
    const sim::Frame f = sim::render_random_tracking_frame(
        robot, static_cast<sim::TrackCategory>(2 + i % 3), 0x40B08 + static_cast<std::uint64_t>(i));
    const Segmentation s = seg.segment(f.image);
    REQUIRE(s.shadow_box);
    REQUIRE(s.contact_box);
    shadow_iou.add(box_iou(*s.shadow_box, *f.gt.shadow_box));
    contact_iou.add(box_iou(*s.contact_box, *f.gt.contact_box));
    CHECK(cv::countNonZero((seg.darkness() != 0) & ~seg.skin_area()) == 0);
  }
  CHECK(shadow_iou.mean() >= 0.9);
  CHECK(contact_iou.mean() >= 0.95);
}
