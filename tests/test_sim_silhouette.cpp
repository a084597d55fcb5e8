// Real hand silhouettes in the scene generator (sim/silhouette_hand.hpp,
// sim/hand_silhouette_file.hpp): the rendered ground truth is the placed silhouette, hands are
// mirrored and lifted by pose, sessions mix them in deterministically, the loader rejects bad
// folders with a message naming the problem.
#include <shadowsense/sim.hpp>

#include <doctest/doctest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/pinhole_rig.hpp"
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

using namespace shadowsense;
using namespace shadowsense::sim;
namespace fs = std::filesystem;

namespace {

// A drawn open hand, 100 rows (fingers up, wrist on the last row): a palm, four fingers with
// gaps between them and a thumb to the right, asymmetric so a mirror image differs.
cv::Mat drawn_hand() {
  cv::Mat m = cv::Mat::zeros(100, 70, CV_8UC1);
  cv::rectangle(m, cv::Rect(12, 45, 40, 55), 255, cv::FILLED); // palm down to the wrist
  for (int i = 0; i < 4; ++i)
    cv::rectangle(m, cv::Rect(12 + 11 * i, 8 + 4 * (i % 2), 7, 40), 255, cv::FILLED);
  cv::fillConvexPoly(m, std::vector<cv::Point>{{50, 60}, {66, 42}, {69, 46}, {52, 75}}, 255);
  return m;
}

User plain_user() {
  User u;
  u.hand_length_cm = 18; // the silhouette's length_cm applies unscaled
  return u;
}

HandPose touching(cv::Point2d at, bool left = false) {
  HandPose p;
  p.position_cm = at;
  p.rotation_deg = -90; // fingers towards the image's top
  p.left = left;
  return p;
}

Frame render_hand(Renderer& r, const HandSilhouette& s, const HandPose& pose) {
  Scene scene;
  add_silhouette_hand(scene.parts, plain_user(), pose, s);
  Light l = preset(Lighting::daylight, 0);
  l.zenith_deg = 0;
  return r.render(scene, l, 0);
}

double iou(const cv::Mat& a, const cv::Mat& b) {
  return static_cast<double>(cv::countNonZero(a & b)) / cv::countNonZero(a | b);
}

} // namespace

TEST_CASE("a touching silhouette's contact ground truth is the silhouette, placed and mirrored") {
  Renderer r(test::pinhole_rig(), RenderConfig{.sensor_noise = false});
  HandSilhouette s{drawn_hand(), 10.0, HandShape::open, "drawn"}; // 0.1 cm = 1 px per row
  const cv::Point2d at{2.0, 1.0};
  const Frame f = render_hand(r, s, touching(at));
  const cv::Mat& contact = f.gt.contact_mask;
  // The mask's pixels, one image pixel each, at the place the anchor (its centroid) puts them.
  const cv::Moments m = cv::moments(s.mask, true);
  const cv::Point2d c_img = r.rig().project(at);
  const cv::Point shift{static_cast<int>(std::lround(c_img.x - m.m10 / m.m00)),
                        static_cast<int>(std::lround(c_img.y - m.m01 / m.m00))};
  cv::Mat want = cv::Mat::zeros(contact.size(), CV_8UC1);
  s.mask.copyTo(want(cv::Rect(shift, s.mask.size())));
  // Contours trace boundary pixel centres and the polygon fill includes its boundary pixels, so
  // on this rig the fill gives the mask back; approxPolyDP may move a corner by <= 0.5 px (a
  // few pixels of the 3,700).
  CHECK(iou(contact, want) > 0.99);
  CHECK(std::abs(cv::countNonZero(contact) - cv::countNonZero(want)) <
        0.01 * cv::countNonZero(want));
  const cv::Rect got = cv::boundingRect(contact), exp = cv::boundingRect(want);
  CHECK(std::abs(got.x - exp.x) <= 1);
  CHECK(std::abs(got.y - exp.y) <= 1);
  CHECK(std::abs(got.width - exp.width) <= 1);
  CHECK(std::abs(got.height - exp.height) <= 1);
  REQUIRE(f.gt.contact_point);
  CHECK(std::abs(f.gt.contact_point->x - c_img.x) < 0.75);
  CHECK(std::abs(f.gt.contact_point->y - c_img.y) < 0.75);

  // A left hand is the mirror image about the anchor's column (the thumb on the other side).
  const Frame fl = render_hand(r, s, touching(at, true));
  cv::Mat mirrored;
  cv::flip(want, mirrored, 1);
  const int dx = static_cast<int>(std::lround(2 * c_img.x - (contact.cols - 1)));
  cv::Mat want_left = cv::Mat::zeros(contact.size(), CV_8UC1);
  const cv::Mat shifted = (cv::Mat_<double>(2, 3) << 1, 0, dx, 0, 1, 0);
  cv::warpAffine(mirrored, want_left, shifted, contact.size(), cv::INTER_NEAREST);
  CHECK(iou(fl.gt.contact_mask, want_left) > 0.99);
  CHECK(iou(fl.gt.contact_mask, contact) < 0.8); // it is not the right hand again

  // Twice the user's hand length: twice the size, four times the area less the boundary pixels
  // the fill adds (a constant in pixels, not scaled: about half a pixel around an outline of
  // ~600 px is 4% of the 3,700 px area at size 1).
  User big = plain_user();
  big.hand_length_cm = 36;
  Scene scene;
  add_silhouette_hand(scene.parts, big, touching(at), s);
  Light l = preset(Lighting::daylight, 0);
  l.zenith_deg = 0;
  const Frame fb = r.render(scene, l, 0);
  CHECK(static_cast<double>(cv::countNonZero(fb.gt.contact_mask)) / cv::countNonZero(contact) ==
        doctest::Approx(4.0).epsilon(0.05));
}

TEST_CASE("a silhouette fist touches with its knuckle band; pressing harder, with all of it") {
  Renderer r(test::pinhole_rig(), RenderConfig{.sensor_noise = false});
  cv::Mat fist = cv::Mat::zeros(80, 60, CV_8UC1);
  cv::ellipse(fist, cv::Point(30, 40), cv::Size(26, 45), 0, 0, 360, 255, cv::FILLED);
  HandSilhouette s{fist, 8.0, HandShape::fist, "fist"};
  HandPose p = touching({0, 0});
  p.press_depth = 0;
  const Frame light_press = render_hand(r, s, p);
  // The top 35% of the 80 rows = 28 rows touch; the rest is lifted 2 cm (a soft shadow only).
  const cv::Rect band = cv::boundingRect(light_press.gt.contact_mask);
  CHECK(std::abs(band.height - 28) <= 1);
  CHECK(cv::countNonZero(light_press.gt.shadow_mask) >
        2 * cv::countNonZero(light_press.gt.contact_mask));
  // The band's centroid is the anchor.
  REQUIRE(light_press.gt.contact_point);
  const cv::Point2d c = r.rig().project({0, 0});
  CHECK(std::abs(light_press.gt.contact_point->y - c.y) < 0.75);
  p.press_depth = 1;
  const Frame hard = render_hand(r, s, p);
  CHECK(std::abs(cv::boundingRect(hard.gt.contact_mask).height - 80) <= 1);
  // A pointing hand touches with its top quarter only.
  s.shape = HandShape::point;
  const Frame point = render_hand(r, s, touching({0, 0}));
  CHECK(std::abs(cv::boundingRect(point.gt.contact_mask).height - 20) <= 1);
}

TEST_CASE("sessions mix real hands in per frame, deterministically, only where they fit") {
  auto hands = std::make_shared<std::vector<HandSilhouette>>();
  hands->push_back({drawn_hand(), 18.5, HandShape::open, "open"});
  cv::Mat fist = cv::Mat::zeros(80, 60, CV_8UC1);
  cv::ellipse(fist, cv::Point(30, 40), cv::Size(26, 45), 0, 0, 360, 255, cv::FILLED);
  hands->push_back({fist, 10.5, HandShape::fist, "fist"});
  User user;
  user.id = 4;
  GestureSessionConfig plain{.frames_per_gesture = 4, .randomise = true};
  GestureSessionConfig never = plain, always = plain, half = plain;
  never.real_hands = always.real_hands = half.real_hands = hands;
  never.real_hand_probability = 0;
  always.real_hand_probability = 1;
  half.real_hand_probability = 0.5;
  const GestureSession a(31, user, 0.5, plain), n(31, user, 0.5, never), y(31, user, 0.5, always),
      h1(31, user, 0.5, half), h2(31, user, 0.5, half);
  Renderer r(Rig::robot());
  Frame fa, fn, f1, f2;
  int real_frames = 0, parametric_frames = 0;
  for (int i = 0; i < a.size(); ++i) {
    CAPTURE(i);
    const Gesture g = all_gestures[static_cast<std::size_t>(i / 4)];
    // Probability 0: the frames of a session without silhouettes, byte for byte.
    a.render(r, i, fa);
    n.render(r, i, fn);
    CHECK(cv::norm(fa.image, fn.image, cv::NORM_INF) == 0);
    // The same seed: the same frames.
    h1.render(r, i, f1);
    h2.render(r, i, f2);
    CHECK(cv::norm(f1.image, f2.image, cv::NORM_INF) == 0);
    // Probability 1: no parametric finger or thumb where a silhouette of the shape exists
    // (palm, two_hands, hug: open; punch: fist); point has none and stays parametric, nothing
    // is never replaced.
    const Scene s = y.scene(i);
    int fingers = 0;
    for (const BodyPart& p : s.parts)
      fingers += p.kind == PartKind::finger || p.kind == PartKind::thumb;
    if (g == Gesture::point || g == Gesture::nothing)
      CHECK(fingers > 0);
    else
      CHECK(fingers == 0);
    // Probability 0.5: a mix over the frames of the replaceable gestures.
    if (g == Gesture::palm || g == Gesture::punch) {
      int f = 0;
      for (const BodyPart& p : h1.scene(i).parts)
        f += p.kind == PartKind::finger || p.kind == PartKind::thumb;
      (f == 0 ? real_frames : parametric_frames)++;
    }
  }
  CHECK(real_frames > 0);
  CHECK(parametric_frames > 0);
  GestureSessionConfig bad = half;
  bad.real_hand_probability = 1.5;
  CHECK_THROWS_WITH_AS(bad.validate(), doctest::Contains("real_hand_probability"), InvalidArgument);
}

TEST_CASE("load_hand_silhouettes reads a manifest folder and rejects bad ones by name") {
  const fs::path dir = fs::path(SHADOWSENSE_TEST_TMP_DIR) / "silhouettes";
  fs::remove_all(dir);
  fs::create_directories(dir / "palm");
  REQUIRE(cv::imwrite((dir / "palm" / "a.png").string(), drawn_hand()));
  cv::Mat no_wrist = drawn_hand();
  no_wrist.row(no_wrist.rows - 1).setTo(0);
  REQUIRE(cv::imwrite((dir / "palm" / "nowrist.png").string(), no_wrist));
  auto write = [&](const std::string& text) { std::ofstream(dir / "manifest.csv") << text; };
  write("file,pose,split\npalm/a.png,palm,train\npalm/a.png,punch,heldout\n");
  const auto train = load_hand_silhouettes(dir);
  REQUIRE(train.size() == 1);
  CHECK(train[0].shape == HandShape::open);
  CHECK(train[0].length_cm == 18.5);
  CHECK(train[0].name == "palm/a.png");
  CHECK(cv::countNonZero(train[0].mask) == cv::countNonZero(drawn_hand()));
  const auto all = load_hand_silhouettes(dir, "");
  REQUIRE(all.size() == 2);
  CHECK(all[1].shape == HandShape::fist);
  CHECK(all[1].length_cm == 10.5);
  write("file,pose,length_cm\npalm/a.png,point,12.5\n");
  CHECK(load_hand_silhouettes(dir).at(0).length_cm == 12.5);

  write("file,pose\npalm/a.png,wave\n");
  CHECK_THROWS_WITH_AS(load_hand_silhouettes(dir),
                       doctest::Contains("manifest.csv:2: unknown pose 'wave'"), DatasetError);
  write("file,pose\n../palm/a.png,palm\n");
  CHECK_THROWS_WITH_AS(load_hand_silhouettes(dir), doctest::Contains("inside the folder"),
                       DatasetError);
  write("name,pose\npalm/a.png,palm\n");
  CHECK_THROWS_WITH_AS(load_hand_silhouettes(dir), doctest::Contains("columns file and pose"),
                       DatasetError);
  write("file,pose,split\npalm/a.png,palm,heldout\n");
  CHECK_THROWS_WITH_AS(load_hand_silhouettes(dir),
                       doctest::Contains("no silhouette with split 'train'"), DatasetError);
  write("file,pose,length_cm\npalm/a.png,palm,1000\n");
  CHECK_THROWS_WITH_AS(load_hand_silhouettes(dir), doctest::Contains("length_cm must be"),
                       DatasetError);
  write("file,pose\npalm/missing.png,palm\n");
  CHECK_THROWS_AS(load_hand_silhouettes(dir), IoError);
  write("file,pose\npalm/nowrist.png,palm\n");
  CHECK_THROWS_WITH_AS(load_hand_silhouettes(dir),
                       doctest::Contains("no hand pixel on the mask's last row"), InvalidArgument);
  fs::remove_all(dir);
}
