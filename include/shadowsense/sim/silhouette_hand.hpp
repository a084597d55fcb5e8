// Real hand shapes for the scene generator: a hand made from a binary silhouette (a mask of a
// real hand seen from above or below, fingers up, wrist on the bottom row) instead of the
// parametric polygons of body.hpp, placed, rotated, lifted and shadowed by the same renderer
// (its lens, skin, light and blur physics) with the generator's arm behind the wrist.
//
//   struct HandSilhouette { mask, length_cm, shape, name }
//     mask: CV_8UC1, nonzero = hand; the fingers (or knuckles) towards row 0, the wrist on the
//     last row. length_cm: the mask's height on the skin for a hand 18 cm long (a User's hand
//     length scales it). shape: the pose the hand shows (open palm, point, fist).
//     validate() throws InvalidArgument naming the problem: wrong type, smaller than 4x4, no
//     hand pixel on the last row, length outside [3, 40] cm.
//
//   void add_silhouette_hand(std::vector<BodyPart>& out, const User& user, const HandPose& pose,
//                            const HandSilhouette& s, bool with_arm = true)
//     requires: user, pose and s valid (checked; InvalidArgument otherwise).
//     ensures: appends the silhouette's outlines (external contours of the mask; holes are
//     filled) as parts at the pose's place: scaled to s.length_cm x user.hand_length_cm / 18,
//     the fingers along pose.rotation_deg, mirrored for a left hand. The touching band - all
//     of an open hand; a fist's knuckle band, from 35% of its length (press_depth 0) to all of
//     it (1), the rest 2 (1 - press_depth) cm higher; a pointing hand's top 25%, the rest 3 cm
//     higher - lies at pose.height_cm with its centroid on pose.position_cm. with_arm: the
//     wrist, forearm and upper arm of add_hand behind the mask's bottom row (as wide as the
//     mask's wrist, within 0.6-1.4x the user's arm width).
//
//   The loader of a silhouette folder (manifest.csv + masks) is sim/hand_silhouette_file.hpp.
//
// Threading: HandSilhouette is a value; the functions are pure apart from reading files.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sim/body.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN
namespace sim {

struct HandSilhouette {
  cv::Mat mask;
  double length_cm = 18.0;
  HandShape shape = HandShape::open;
  std::string name;

  void validate() const {
    const std::string what = "HandSilhouette '" + name + "': ";
    detail::require(mask.type() == CV_8UC1 && mask.rows >= 4 && mask.cols >= 4,
                    what + "mask must be CV_8UC1 and at least 4x4");
    detail::require(cv::countNonZero(mask.row(mask.rows - 1)) > 0,
                    what + "no hand pixel on the mask's last row (the wrist must be there)");
    detail::require(std::isfinite(length_cm) && length_cm >= 3 && length_cm <= 40,
                    what + "length_cm must be in [3, 40]");
  }
};

inline double silhouette_default_length_cm(HandShape s) {
  switch (s) {
  case HandShape::open:
    return 18.5;
  case HandShape::point:
    return 15.0;
  case HandShape::fist:
    return 10.5;
  }
  return 18.5;
}

namespace internal {
// External contours of mask rows [r0, r1) in hand-frame cm: lx = (u - wrist_u) cpp across,
// ly = (rows - v) cpp from the wrist towards the fingers. Contours under 3 px are dropped.
inline std::vector<std::vector<cv::Point2d>>
silhouette_outlines(const cv::Mat& mask, int r0, int r1, double wrist_u, double cpp) {
  std::vector<std::vector<cv::Point2d>> out;
  if (r1 <= r0) return out;
  cv::Mat band = cv::Mat::zeros(mask.size(), CV_8UC1);
  mask.rowRange(r0, r1).copyTo(band.rowRange(r0, r1));
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(band, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  for (const auto& c : contours) {
    if (c.size() < 3 || cv::contourArea(c) < 3.0) continue;
    std::vector<cv::Point> simple;
    cv::approxPolyDP(c, simple, 0.5, true);
    if (simple.size() < 3) continue;
    std::vector<cv::Point2d> poly;
    poly.reserve(simple.size());
    for (const cv::Point& p : simple)
      poly.push_back({(p.x - wrist_u) * cpp, (mask.rows - p.y) * cpp});
    out.push_back(std::move(poly));
  }
  return out;
}
} // namespace internal

inline void add_silhouette_hand(std::vector<BodyPart>& out, const User& user, const HandPose& pose,
                                const HandSilhouette& s, bool with_arm = true) {
  user.validate();
  pose.validate();
  s.validate();
  using internal::deg;
  cv::Mat mask;
  cv::compare(s.mask, 0, mask, cv::CMP_GT);
  const int rows = mask.rows;
  const double cpp = s.length_cm * user.hand_length_cm / 18.0 / rows; // cm per mask pixel
  const double h = pose.height_cm;
  // The touching band (top rows) and how much higher the rest of the hand is.
  double band = 1.0, rest_lift = 0.0, arm_lift = 1.2, elevation = pose.arm_elevation_deg;
  PartKind kind = PartKind::palm;
  switch (s.shape) {
  case HandShape::open:
    break;
  case HandShape::fist:
    band = 0.35 + 0.65 * pose.press_depth;
    rest_lift = 2.0 * (1.0 - pose.press_depth);
    arm_lift = 3.5;
    elevation = std::max(elevation, 40.0);
    kind = PartKind::fist;
    break;
  case HandShape::point:
    band = 0.25;
    rest_lift = 3.0;
    arm_lift = 4.0;
    elevation = std::max(elevation, 30.0);
    kind = PartKind::finger;
    break;
  }
  const int split = std::clamp(static_cast<int>(std::lround(band * rows)), 1, rows);
  // Wrist: the centre of the last row's hand pixels; its width sizes the arm.
  const cv::Mat last = mask.row(rows - 1);
  int u0 = -1, u1 = -1;
  for (int u = 0; u < mask.cols; ++u)
    if (last.at<std::uint8_t>(0, u)) {
      if (u0 < 0) u0 = u;
      u1 = u;
    }
  const double wrist_u = 0.5 * (u0 + u1);
  // Anchor: the centroid of the touching band, placed on pose.position_cm.
  const cv::Moments m = cv::moments(mask.rowRange(0, split), true);
  detail::require(m.m00 > 0, "HandSilhouette '" + s.name + "': no hand pixel in its touching band");
  const cv::Point2d anchor{(m.m10 / m.m00 - wrist_u) * cpp, (rows - m.m01 / m.m00) * cpp};
  const double side = pose.left ? -1.0 : 1.0;
  const cv::Point2d f{std::cos(pose.rotation_deg * deg), std::sin(pose.rotation_deg * deg)};
  const cv::Point2d t{-f.y * side, f.x * side};
  const cv::Point2d origin = pose.position_cm - (t * anchor.x + f * anchor.y);
  auto at = [&](cv::Point2d l) { return origin + t * l.x + f * l.y; };
  auto emit = [&](const std::vector<std::vector<cv::Point2d>>& polys, PartKind k, double height) {
    for (const auto& poly : polys) {
      BodyPart p;
      p.kind = k;
      for (const cv::Point2d& l : poly) p.outline_cm.push_back(at(l));
      p.height_cm.assign(p.outline_cm.size(), height);
      out.push_back(std::move(p));
    }
  };
  emit(internal::silhouette_outlines(mask, 0, split, wrist_u, cpp), kind, h);
  emit(internal::silhouette_outlines(mask, split, rows, wrist_u, cpp),
       s.shape == HandShape::open ? PartKind::palm : PartKind::fist, h + rest_lift);
  if (with_arm) {
    const double ww =
        std::clamp((u1 - u0 + 1) * cpp, 0.6 * user.arm_width_cm, 1.4 * user.arm_width_cm);
    internal::add_arm(out, user, pose, at({0.0, 0.0}), h + arm_lift, elevation, ww);
  }
}

} // namespace sim
SHADOWSENSE_NAMESPACE_END
