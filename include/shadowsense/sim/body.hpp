// Body parts as layered 2D silhouettes with a height above the skin, and builders for hands
// (open / fist / pointing), wrist, forearm and upper arm. Heights drive the shadow: its
// penumbra grows and its darkness falls with height; parts at height 0 are in contact.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sim/rng.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN
namespace sim {

enum class PartKind { finger, thumb, palm, fist, wrist, forearm, upper_arm, torso, other };

// One silhouette: a polygon on the skin plane (cm, see Rig) with a height per vertex (cm
// above the skin). A part touches the skin iff every vertex height is 0; touching parts
// render sharp, darkest and skin-tinted.
struct BodyPart {
  PartKind kind = PartKind::other;
  std::vector<cv::Point2d> outline_cm;
  std::vector<double> height_cm; // one per outline vertex

  bool in_contact() const {
    return std::all_of(height_cm.begin(), height_cm.end(), [](double h) { return h <= 0.0; });
  }
  double mean_height() const {
    double s = 0;
    for (double h : height_cm) s += h;
    return height_cm.empty() ? 0.0 : s / static_cast<double>(height_cm.size());
  }
  void validate() const {
    detail::require(outline_cm.size() >= 3, "BodyPart: outline needs at least 3 vertices");
    detail::require(height_cm.size() == outline_cm.size(),
                    "BodyPart: height_cm must have one value per outline vertex (" +
                        std::to_string(outline_cm.size()) + "), got " +
                        std::to_string(height_cm.size()));
    for (std::size_t i = 0; i < outline_cm.size(); ++i) {
      detail::require(std::isfinite(outline_cm[i].x) && std::isfinite(outline_cm[i].y),
                      "BodyPart: outline vertex " + std::to_string(i) + " is not finite");
      detail::require(std::isfinite(height_cm[i]) && height_cm[i] >= 0 && height_cm[i] <= 500,
                      "BodyPart: height of vertex " + std::to_string(i) +
                          " must be in [0, 500] cm");
    }
  }
};

// Shadows of things that are not the user's body: never part of the ground truth. Their
// opacity is kept below 0.5 so they can never cross the ground truth's half-penumbra line.
struct Distractor {
  enum class Kind { far_object, passer_by };
  Kind kind = Kind::far_object;
  std::vector<cv::Point2d> outline_cm;
  double opacity = 0.25; // peak, < 0.5
  double blur_cm = 4.0;  // penumbra sigma
};

struct Scene {
  std::vector<BodyPart> parts;
  std::vector<Distractor> distractors;
  std::array<float, 4> wrinkle{}; // weights of the fabric's wrinkle fields (about +-0.06)
  double skin_tone = 0.5;         // 0 light .. 1 dark: colour of contact areas
  // Pixel scale of the body: the renderer draws every body part, its shadow's shift along the
  // light and its penumbra `zoom` times larger about `zoom_centre_cm` (plane cm), as a camera
  // nearer the skin or with more pixels per cm would see them; heights, and so opacities, are
  // physical and unchanged. Distractors are not scaled. 1 = the rig as it is.
  double zoom = 1.0;
  cv::Point2d zoom_centre_cm{0, 0};

  void validate() const {
    for (const auto& p : parts) p.validate();
    for (const auto& d : distractors) {
      detail::require(d.outline_cm.size() >= 3, "Distractor: outline needs >= 3 vertices");
      detail::require(d.opacity >= 0 && d.opacity < 0.5,
                      "Distractor: opacity must be in [0, 0.5) so it never counts as a shadow");
      detail::require(d.blur_cm >= 0 && d.blur_cm <= 50, "Distractor: blur_cm must be in [0, 50]");
    }
    for (float w : wrinkle)
      detail::require(std::isfinite(w) && std::abs(w) <= 0.5f,
                      "Scene: wrinkle weights must be in [-0.5, 0.5]");
    detail::require(skin_tone >= 0 && skin_tone <= 1, "Scene: skin_tone must be in [0, 1]");
    detail::require(std::isfinite(zoom) && zoom >= 0.25 && zoom <= 4,
                    "Scene: zoom must be in [0.25, 4], got " + std::to_string(zoom));
    detail::require(std::isfinite(zoom_centre_cm.x) && std::isfinite(zoom_centre_cm.y),
                    "Scene: zoom_centre_cm must be finite");
  }
};

// A person's body measurements (the paper: hand lengths 15.7-19.1 cm; we draw 15-20).
struct User {
  int id = 0;
  double hand_length_cm = 18.0;   // wrist crease to middle fingertip
  double palm_width_ratio = 0.47; // palm width / hand length
  double finger_ratio = 1.0;      // finger length scale: slender vs. stubby hands
  double finger_width_cm = 1.8;
  double spread = 0.5;       // habitual finger spread, 0..1
  double arm_width_cm = 6.0; // at the wrist
  double skin_tone = 0.5;

  static User random(int id, Rng& rng) {
    User u;
    u.id = id;
    u.hand_length_cm = rng.uniform(15.0, 20.0);
    u.palm_width_ratio = rng.uniform(0.43, 0.51);
    u.finger_ratio = rng.uniform(0.92, 1.08);
    u.finger_width_cm = u.hand_length_cm * rng.uniform(0.09, 0.11);
    u.spread = rng.uniform(0.2, 0.8);
    u.arm_width_cm = u.hand_length_cm * rng.uniform(0.31, 0.37);
    u.skin_tone = rng.uniform(0.0, 1.0);
    return u;
  }
  void validate() const {
    detail::require(hand_length_cm >= 5 && hand_length_cm <= 40,
                    "User: hand_length_cm must be in [5, 40]");
    detail::require(palm_width_ratio > 0.2 && palm_width_ratio < 0.8,
                    "User: palm_width_ratio must be in (0.2, 0.8)");
    detail::require(finger_ratio > 0.5 && finger_ratio < 1.5,
                    "User: finger_ratio must be in (0.5, 1.5)");
    detail::require(finger_width_cm > 0.3 && finger_width_cm < 5,
                    "User: finger_width_cm must be in (0.3, 5)");
    detail::require(spread >= 0 && spread <= 1, "User: spread must be in [0, 1]");
    detail::require(arm_width_cm > 1 && arm_width_cm < 20, "User: arm_width_cm must be in (1, 20)");
    detail::require(skin_tone >= 0 && skin_tone <= 1, "User: skin_tone must be in [0, 1]");
  }
};

enum class HandShape { open, fist, point };

struct HandPose {
  // The touch anchor on the skin plane (cm): palm centre (open), knuckle centre (fist) or
  // index fingertip (point).
  cv::Point2d position_cm{0.0, 0.0};
  double rotation_deg = -90.0; // direction the fingers point (image axes; -90 = up/front)
  double height_cm = 0.0;      // lowest point of the hand above the skin; 0 = touching
  HandShape shape = HandShape::open;
  double spread = 0.5;           // 0 closed .. 1 wide (open hand)
  bool left = false;             // left hand = mirror image of a right hand
  double arm_elevation_deg = 35; // forearm angle above the skin
  double wrist_bend_deg = 0;     // forearm direction relative to straight behind the hand
  double press_depth = 0;        // fist: 0 = the knuckle face touches, 1 = the whole fist face

  void validate() const {
    detail::require(std::isfinite(position_cm.x) && std::isfinite(position_cm.y),
                    "HandPose: position_cm must be finite");
    detail::require(std::isfinite(rotation_deg), "HandPose: rotation_deg must be finite");
    detail::require(height_cm >= 0 && height_cm <= 200, "HandPose: height_cm must be in [0, 200]");
    detail::require(spread >= 0 && spread <= 1, "HandPose: spread must be in [0, 1]");
    detail::require(arm_elevation_deg >= 0 && arm_elevation_deg <= 89,
                    "HandPose: arm_elevation_deg must be in [0, 89]");
    detail::require(wrist_bend_deg >= -60 && wrist_bend_deg <= 60,
                    "HandPose: wrist_bend_deg must be in [-60, 60]");
    detail::require(press_depth >= 0 && press_depth <= 1,
                    "HandPose: press_depth must be in [0, 1]");
  }
};

namespace internal {
inline constexpr double deg = 3.14159265358979323846 / 180.0;

// A capsule-like segment from a to b (plane cm): widths wa, wb, heights ha, hb linearly
// along the axis, rounded ends.
inline BodyPart segment(PartKind kind, cv::Point2d a, cv::Point2d b, double wa, double wb,
                        double ha, double hb) {
  BodyPart p;
  p.kind = kind;
  cv::Point2d d = b - a;
  const double len = std::max(std::hypot(d.x, d.y), 1e-6);
  const cv::Point2d u = d * (1.0 / len), n{-u.y, u.x};
  constexpr int cap = 5;
  constexpr double pi = 3.14159265358979323846;
  auto push = [&](cv::Point2d v) {
    p.outline_cm.push_back(v);
    const double t = std::clamp((v - a).dot(u) / len, 0.0, 1.0);
    p.height_cm.push_back(std::max(0.0, ha + (hb - ha) * t));
  };
  for (int i = 0; i <= cap; ++i) { // cap around b, from +n through +u to -n
    const double t = pi / 2 - pi * i / cap;
    push(b + (n * std::sin(t) + u * std::cos(t)) * (wb / 2));
  }
  for (int i = 0; i <= cap; ++i) { // cap around a, from -n through -u to +n
    const double t = -pi / 2 - pi * i / cap;
    push(a + (n * std::sin(t) + u * std::cos(t)) * (wa / 2));
  }
  return p;
}

// Rounded rectangle (superellipse, exponent 4) centred at c with half sizes along (u, n).
inline BodyPart blob(PartKind kind, cv::Point2d c, cv::Point2d u, double half_u, double half_n,
                     double height, double exponent = 4.0, int points = 24) {
  BodyPart p;
  p.kind = kind;
  const cv::Point2d n{-u.y, u.x};
  constexpr double pi = 3.14159265358979323846;
  for (int i = 0; i < points; ++i) {
    const double t = 2 * pi * i / points;
    const double ct = std::cos(t), st = std::sin(t);
    const double x = std::copysign(std::pow(std::abs(ct), 2.0 / exponent), ct) * half_u;
    const double y = std::copysign(std::pow(std::abs(st), 2.0 / exponent), st) * half_n;
    p.outline_cm.push_back(c + u * x + n * y);
    p.height_cm.push_back(height);
  }
  return p;
}
// The wrist, forearm and upper arm behind a hand whose wrist is at `wrist` (plane cm), at
// height h_wrist, the forearm rising at elevation_deg; ww: the width at the wrist.
inline void add_arm(std::vector<BodyPart>& out, const User& user, const HandPose& pose,
                    cv::Point2d wrist, double h_wrist, double elevation_deg, double ww) {
  const double L = user.hand_length_cm;
  const double side = pose.left ? -1.0 : 1.0;
  const double a = (pose.rotation_deg + 180.0 + pose.wrist_bend_deg * side) * deg;
  const cv::Point2d back{std::cos(a), std::sin(a)};
  const double e = elevation_deg * deg;
  const double forearm = 26.0 * L / 18.0, upper = 30.0 * L / 18.0;
  const double we = ww * 1.35;
  auto along = [&](double s) { return wrist + back * (s * std::cos(e)); };
  const double s1 = 0.3 * forearm;
  out.push_back(segment(PartKind::wrist, along(-0.02 * L), along(s1), ww, ww * 1.1, h_wrist,
                        h_wrist + s1 * std::sin(e)));
  const double h_elbow = h_wrist + forearm * std::sin(e);
  out.push_back(segment(PartKind::forearm, along(s1), along(forearm), ww * 1.1, we,
                        h_wrist + s1 * std::sin(e), h_elbow));
  const double e2 = std::min(e + 25 * deg, 80 * deg);
  const cv::Point2d elbow = along(forearm);
  out.push_back(segment(PartKind::upper_arm, elbow, elbow + back * (upper * std::cos(e2)), we,
                        we * 1.2, h_elbow, h_elbow + upper * std::sin(e2)));
}
} // namespace internal

// Appends the parts of one hand with its wrist, forearm and upper arm to `out`.
inline void add_hand(std::vector<BodyPart>& out, const User& user, const HandPose& pose) {
  user.validate();
  pose.validate();
  using internal::deg;
  const double L = user.hand_length_cm;
  const double pl = 0.55 * L, pw = user.palm_width_ratio * L, fw = user.finger_width_cm;
  const double h = pose.height_cm;
  const double side = pose.left ? -1.0 : 1.0; // thumb side for a palm seen from below
  const cv::Point2d f{std::cos(pose.rotation_deg * deg), std::sin(pose.rotation_deg * deg)};
  const cv::Point2d t{-f.y * side, f.x * side}; // lateral, towards the thumb
  // Hand frame: origin at the palm centre, ly along the fingers, lx towards the thumb.
  cv::Point2d origin = pose.position_cm;
  auto at = [&](double lx, double ly) { return origin + t * lx + f * ly; };
  auto dir = [&](double angle_deg) { // angle from +ly towards +lx
    return cv::Point2d{std::sin(angle_deg * deg), std::cos(angle_deg * deg)};
  };
  const double spread = 0.3 + 1.2 * pose.spread;
  const std::array<double, 4> base_x{0.36, 0.12, -0.12, -0.35};
  const std::array<double, 4> base_dy{0.0, 0.01, 0.0, -0.05};
  const std::array<double, 4> length{0.39, 0.45, 0.42, 0.33};
  const std::array<double, 4> width{1.0, 1.05, 1.0, 0.85};
  const std::array<double, 4> angle{14, 4, -6, -18};

  auto finger = [&](int i, double h_base, double h_mid, double h_tip, double split) {
    const cv::Point2d b{pw * base_x[i], pl / 2 + L * base_dy[i] - 0.04 * L};
    const cv::Point2d d = dir(angle[i] * spread);
    const double len = length[i] * L * user.finger_ratio + 0.04 * L;
    const double w = fw * width[i];
    const cv::Point2d m = b + d * (len * split), e = b + d * (len - w * 0.45);
    out.push_back(internal::segment(PartKind::finger, at(b.x, b.y), at(m.x, m.y), w, w * 0.95,
                                    h_base, h_mid));
    out.push_back(internal::segment(PartKind::finger, at(m.x, m.y), at(e.x, e.y), w * 0.95,
                                    w * 0.85, h_mid, h_tip));
  };
  auto thumb = [&](double h_base, double h_tip) {
    const cv::Point2d b{pw * 0.40, -pl * 0.18};
    const cv::Point2d d = dir(48 + 25 * pose.spread);
    const double len = 0.34 * L * user.finger_ratio;
    const cv::Point2d m = b + d * (len * 0.5), e = b + d * (len - fw * 0.5);
    out.push_back(internal::segment(PartKind::thumb, at(b.x, b.y), at(m.x, m.y), fw * 1.25,
                                    fw * 1.1, h_base, (h_base + h_tip) / 2));
    out.push_back(internal::segment(PartKind::thumb, at(m.x, m.y), at(e.x, e.y), fw * 1.1, fw * 1.0,
                                    (h_base + h_tip) / 2, h_tip));
  };
  auto arm = [&](cv::Point2d wrist_local, double h_wrist, double elevation_deg) {
    internal::add_arm(out, user, pose, at(wrist_local.x, wrist_local.y), h_wrist, elevation_deg,
                      user.arm_width_cm);
  };

  switch (pose.shape) {
  case HandShape::open: {
    // Lifted hands curl the fingers slightly; a touching palm lies flat.
    const double curl = h > 0 ? 0.6 : 0.0;
    out.push_back(internal::blob(PartKind::palm, at(0, 0), f, pl / 2, pw / 2, h));
    for (int i = 0; i < 4; ++i) finger(i, h, h + curl * 0.5, h + curl, 0.5);
    thumb(h, h + curl);
    arm({0, -pl / 2 + 0.02 * L}, h + 1.2, pose.arm_elevation_deg);
    break;
  }
  case HandShape::fist: {
    // Punch: the flat of the proximal phalanges (the knuckle face) touches; the rest of the
    // fist and the thumb are above it, lower the deeper the fist presses into the soft skin
    // (press_depth 1: the whole fist face touches). origin = knuckle centre.
    const double half_w = 0.26 * L, half_l = 0.19 * L;
    const double lift = 2.0 * (1.0 - pose.press_depth);
    out.push_back(internal::blob(PartKind::fist, at(0, -half_l + 0.08 * L), f, half_l, half_w,
                                 h + lift, 4.0));
    out.push_back(internal::blob(PartKind::fist, at(0, 0), f, 0.07 * L, 0.23 * L, h, 6.0, 28));
    const cv::Point2d tb{0.20 * L, -0.18 * L}, te{0.05 * L, 0.0};
    out.push_back(internal::segment(PartKind::thumb, at(tb.x, tb.y), at(te.x, te.y), fw * 1.2,
                                    fw * 1.1, h + 2.5, h + 1.5));
    arm({0, -2 * half_l + 0.1 * L}, h + 3.5, std::max(pose.arm_elevation_deg, 40.0));
    break;
  }
  case HandShape::point: {
    // Index finger extended to the skin, the other fingers curled under the palm.
    // origin is placed so that the index fingertip lands on position_cm.
    const double len = length[0] * L * user.finger_ratio + 0.04 * L;
    const cv::Point2d knuckle{0.18 * L, 0.16 * L};
    const double reach = len * std::cos(12 * deg) - fw * 0.45;
    const cv::Point2d tip_local = knuckle + cv::Point2d{0, reach};
    origin = pose.position_cm - (t * tip_local.x + f * tip_local.y);
    const double hb = h + 3.0;
    out.push_back(internal::blob(PartKind::fist, at(0, -0.05 * L), f, 0.24 * L, 0.25 * L, hb, 4.0));
    const cv::Point2d m = knuckle + cv::Point2d{0, reach * 0.72};
    out.push_back(internal::segment(PartKind::finger, at(knuckle.x, knuckle.y), at(m.x, m.y), fw,
                                    fw * 0.95, hb, h + 0.5));
    out.push_back(internal::segment(PartKind::finger, at(m.x, m.y), at(tip_local.x, tip_local.y),
                                    fw * 0.95, fw * 0.85, h, h));
    const cv::Point2d tb{0.24 * L, -0.12 * L}, te{0.08 * L, 0.06 * L};
    out.push_back(internal::segment(PartKind::thumb, at(tb.x, tb.y), at(te.x, te.y), fw * 1.2,
                                    fw * 1.1, hb, hb));
    arm({0, -0.28 * L}, hb + 1.0, std::max(pose.arm_elevation_deg, 30.0));
    break;
  }
  }
}

// Draws a random user-drawn distractor around the visible area (cm extents of the surface).
inline Distractor random_distractor(Rng& rng, cv::Size2d half_extent_cm) {
  Distractor d;
  d.kind = rng.chance(0.5) ? Distractor::Kind::far_object : Distractor::Kind::passer_by;
  const cv::Point2d c{rng.uniform(-half_extent_cm.width, half_extent_cm.width),
                      rng.uniform(-half_extent_cm.height, half_extent_cm.height)};
  const double a = rng.uniform(0, 3.14159265358979323846);
  const cv::Point2d u{std::cos(a), std::sin(a)};
  const double s = std::min(half_extent_cm.width, half_extent_cm.height);
  const BodyPart b = d.kind == Distractor::Kind::far_object
                         ? internal::blob(PartKind::other, c, u, s * rng.uniform(0.3, 0.8),
                                          s * rng.uniform(0.15, 0.5), 0, rng.uniform(2, 5), 20)
                         : internal::blob(PartKind::other, c, u, s * rng.uniform(0.8, 1.6),
                                          s * rng.uniform(0.3, 0.6), 0, 2.0, 20);
  d.outline_cm = b.outline_cm;
  d.opacity =
      d.kind == Distractor::Kind::far_object ? rng.uniform(0.12, 0.40) : rng.uniform(0.08, 0.30);
  d.blur_cm =
      d.kind == Distractor::Kind::far_object ? rng.uniform(1.0, 4.0) : rng.uniform(4.0, 9.0);
  return d;
}

} // namespace sim
SHADOWSENSE_NAMESPACE_END
