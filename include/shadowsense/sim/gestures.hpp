// The paper's six social-touch gestures on the robot rig (section 5.1): nothing, hug, palm,
// point, punch, two_hands; and recording sessions (one per user and lighting, gestures in
// blocks, in time order, with a smooth pose drift within each block). With
// GestureSessionConfig::randomise a session also draws a DomainSample (randomise.hpp) and renders
// its fabric, light, camera, body and occluders from it; the renderer's shading is set for the
// frame and restored afterwards (the Renderer is used, not shared: one per thread as always).
// With GestureSessionConfig::pixel_scale each gesture block draws a pixel scale of the body
// (Scene::zoom), so one generator covers cameras that see hands smaller or larger. With
// GestureSessionConfig::real_hands some hands of palm, point, punch, two_hands and hug frames
// are real hand silhouettes (silhouette_hand.hpp) instead of the parametric polygons.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sim/body.hpp>
#include <shadowsense/sim/lighting.hpp>
#include <shadowsense/sim/randomise.hpp>
#include <shadowsense/sim/renderer.hpp>
#include <shadowsense/sim/rng.hpp>
#include <shadowsense/sim/silhouette_hand.hpp>

#include <opencv2/core.hpp>

#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN
namespace sim {

enum class Gesture { nothing, hug, palm, point, punch, two_hands };
inline constexpr std::array<Gesture, 6> all_gestures{Gesture::nothing, Gesture::hug,
                                                     Gesture::palm,    Gesture::point,
                                                     Gesture::punch,   Gesture::two_hands};

inline std::string_view to_string(Gesture g) {
  switch (g) {
  case Gesture::nothing:
    return "nothing";
  case Gesture::hug:
    return "hug";
  case Gesture::palm:
    return "palm";
  case Gesture::point:
    return "point";
  case Gesture::punch:
    return "punch";
  case Gesture::two_hands:
    return "two_hands";
  }
  return "nothing";
}
inline Gesture gesture_from_string(std::string_view s) {
  for (Gesture g : all_gestures)
    if (to_string(g) == s) return g;
  SHADOWSENSE_THROW(InvalidArgument("unknown gesture class '" + std::string(s) +
                                    "'; expected nothing, hug, palm, point, punch or two_hands"));
}

// Where and how a gesture is performed (robot skin plane, cm). Unused fields are ignored.
struct GesturePose {
  cv::Point2d position_cm{0, 0}; // palm / fingertip / knuckles; centre of both hands; chest
  double rotation_deg = -90;     // direction the fingers point; for hug: where the person stands
  double spread = 0.5;
  double arm_elevation_deg = 35;
  double wrist_bend_deg = 0;
  double hand_gap_cm = 24;    // two_hands: distance between the palm centres
  double body_height_cm = 50; // nothing: height of the closest body part above the skin
  double hug_reach = 1.0;     // hug: how far the arms wrap around (0.6 .. 1.3)
  // hug: radius of the body the arms wrap around, its centre behind the chest (0: the
  // visible top's centre), and how far the chest moves from position_cm to the view's middle.
  double hug_body_radius_cm = 0, hug_centre_pull = 0;
  double press_depth = 0; // punch and hug: how hard the fist or chest presses (0 .. 1)
  bool left = false;

  void validate() const {
    detail::require(std::isfinite(position_cm.x) && std::isfinite(position_cm.y) &&
                        std::isfinite(rotation_deg),
                    "GesturePose: position_cm and rotation_deg must be finite");
    detail::require(spread >= 0 && spread <= 1, "GesturePose: spread must be in [0, 1]");
    detail::require(hand_gap_cm >= 0 && hand_gap_cm <= 200,
                    "GesturePose: hand_gap_cm must be in [0, 200]");
    detail::require(
        body_height_cm >= 30 && body_height_cm <= 300,
        "GesturePose: body_height_cm must be in [30, 300] (a nothing frame casts no shadow box)");
    detail::require(hug_reach >= 0.2 && hug_reach <= 2,
                    "GesturePose: hug_reach must be in [0.2, 2]");
    detail::require(hug_body_radius_cm == 0 ||
                        (hug_body_radius_cm >= 10 && hug_body_radius_cm <= 500),
                    "GesturePose: hug_body_radius_cm must be 0 or in [10, 500]");
    detail::require(hug_centre_pull >= 0 && hug_centre_pull <= 0.95,
                    "GesturePose: hug_centre_pull must be in [0, 0.95]");
    detail::require(press_depth >= 0 && press_depth <= 1,
                    "GesturePose: press_depth must be in [0, 1]");
  }
};

// Domain randomisation of a pose (randomise.hpp): arm elevation, wrist bend, spread and hug
// reach offset by the sample, clamped to the valid ranges of GesturePose and HandPose; press
// depth and the hug's body size and chest place set from it.
inline GesturePose randomise_pose(GesturePose p, const DomainSample& d) {
  p.arm_elevation_deg = std::clamp(p.arm_elevation_deg + d.arm_elevation_offset_deg, 5.0, 85.0);
  p.wrist_bend_deg = std::clamp(p.wrist_bend_deg + d.wrist_bend_offset_deg, -55.0, 55.0);
  p.spread = std::clamp(p.spread + d.spread_offset, 0.0, 1.0);
  p.hug_reach = std::clamp(p.hug_reach * d.hug_reach_scale, 0.3, 1.9);
  p.press_depth = std::clamp(d.press_depth, 0.0, 1.0);
  p.hug_body_radius_cm =
      d.hug_body_radius_cm == 0 ? 0.0 : std::clamp(d.hug_body_radius_cm, 10.0, 500.0);
  p.hug_centre_pull = std::clamp(d.hug_centre_pull, 0.0, 0.95);
  p.validate();
  return p;
}

namespace internal {
// Appends segments along a polyline with linearly varying width and height.
inline void add_limb(std::vector<BodyPart>& out, PartKind kind,
                     const std::vector<cv::Point2d>& path, double w0, double w1, double h0,
                     double h1) {
  const std::size_t n = path.size();
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const double a = static_cast<double>(i) / static_cast<double>(n - 1);
    const double b = static_cast<double>(i + 1) / static_cast<double>(n - 1);
    out.push_back(segment(kind, path[i], path[i + 1], w0 + (w1 - w0) * a, w0 + (w1 - w0) * b,
                          h0 + (h1 - h0) * a, h0 + (h1 - h0) * b));
  }
}

inline HandPose hand_from(const GesturePose& g, HandShape shape) {
  HandPose h;
  h.position_cm = g.position_cm;
  h.rotation_deg = g.rotation_deg;
  h.spread = g.spread;
  h.arm_elevation_deg = g.arm_elevation_deg;
  h.wrist_bend_deg = g.wrist_bend_deg;
  h.press_depth = g.press_depth;
  h.left = g.left;
  h.shape = shape;
  return h;
}

// Hug: the chest presses against the skin at the side the person stands on (or, pulled by
// hug_centre_pull, nearer the view's middle); the arms wrap around along a circle about the
// body's centre (the visible top's centre, or hug_body_radius_cm behind the chest for a
// larger body), forearms and hands in contact. press_depth widens the chest's contact patch
// towards the torso's outline.
inline void add_hug(std::vector<BodyPart>& out, const User& user, const GesturePose& g,
                    std::array<const HandSilhouette*, 2> real = {}) {
  const double a = g.rotation_deg * deg;
  const cv::Point2d out_dir{std::cos(a), std::sin(a)}; // from the robot centre to the person
  const cv::Point2d side{-out_dir.y, out_dir.x};
  const cv::Point2d chest = g.position_cm * (1.0 - g.hug_centre_pull);
  const double s = user.hand_length_cm / 18.0;
  out.push_back(blob(PartKind::torso, chest + out_dir * (4 * s), side, 19 * s, 12 * s, 4.0));
  const double press = g.press_depth;
  out.push_back(
      blob(PartKind::torso, chest, side, (13 + 3 * press) * s, (5 + 5 * press) * s, 0.0, 3.0));
  const bool big = g.hug_body_radius_cm > 0;
  const cv::Point2d centre = big ? chest - out_dir * g.hug_body_radius_cm : cv::Point2d{0, 0};
  // Arms: along a circle around the centre through the shoulders; around a larger body the
  // sweep angle shrinks so that the arms keep their length.
  const double rx = std::max(std::hypot(chest.x - centre.x, chest.y - centre.y), 8.0);
  // Shoulder radius of a typical hug around the visible top: a larger body keeps these arc
  // lengths and this closing-in, not the angles.
  const double top_radius = 25.0 * s;
  for (int k = -1; k <= 1; k += 2) {
    const cv::Point2d shoulder = chest + side * (k * 17 * s) + out_dir * (3 * s) - centre;
    const double phi0 = std::atan2(shoulder.y, shoulder.x);
    const double r0 = std::hypot(shoulder.x, shoulder.y);
    std::vector<cv::Point2d> upper, fore;
    const int steps = 4;
    const double length_keep = big ? std::min(1.0, top_radius / r0) : 1.0;
    const double sweep_upper = 0.45 * g.hug_reach * length_keep,
                 sweep_fore = 0.5 * g.hug_reach * length_keep;
    // Sign of the sweep: the arm goes around on its own side of the body.
    const double dir =
        (side * k).dot(cv::Point2d{-std::sin(phi0), std::cos(phi0)}) >= 0 ? 1.0 : -1.0;
    for (int i = 0; i <= steps; ++i) {
      const double t = static_cast<double>(i) / steps;
      const double phi = phi0 + dir * sweep_upper * t;
      const double r = r0 * (1 - 0.15 * t) + rx * 0.15 * t;
      upper.push_back(centre + cv::Point2d{r * std::cos(phi), r * std::sin(phi)});
    }
    const cv::Point2d last = upper.back() - centre;
    const double phi1 = phi0 + dir * sweep_upper, r1 = std::hypot(last.x, last.y);
    for (int i = 0; i <= steps; ++i) {
      const double t = static_cast<double>(i) / steps;
      const double phi = phi1 + dir * sweep_fore * t;
      const double r = big ? r1 - 0.1 * t * std::min(r1, top_radius) : r1 * (1 - 0.1 * t);
      fore.push_back(centre + cv::Point2d{r * std::cos(phi), r * std::sin(phi)});
    }
    add_limb(out, PartKind::upper_arm, upper, user.arm_width_cm * 1.6, user.arm_width_cm * 1.35,
             3.0, 1.0);
    add_limb(out, PartKind::forearm, fore, user.arm_width_cm * 1.3, user.arm_width_cm, 0.0, 0.0);
    // The hand continues the forearm, flat on the skin.
    const cv::Point2d tip = fore.back(), before = fore[fore.size() - 2];
    const cv::Point2d d = tip - before;
    HandPose hp;
    hp.rotation_deg = std::atan2(d.y, d.x) / deg;
    hp.position_cm =
        tip + d * (1.0 / std::max(std::hypot(d.x, d.y), 1e-9)) * (0.3 * user.hand_length_cm);
    hp.spread = g.spread * 0.5;
    hp.left = k < 0;
    hp.arm_elevation_deg = 5;
    // Only the hand itself: the forearm is already drawn along the path.
    if (const HandSilhouette* r = real[k < 0 ? 0 : 1]) {
      add_silhouette_hand(out, user, hp, *r, false);
      continue;
    }
    std::vector<BodyPart> hand;
    add_hand(hand, user, hp);
    for (auto& p : hand)
      if (p.kind == PartKind::palm || p.kind == PartKind::finger || p.kind == PartKind::thumb)
        out.push_back(p);
  }
}
} // namespace internal

// The scene of one gesture frame on the robot rig. real: silhouettes replacing the parametric
// hands (nullptr: parametric) - [0] the hand of palm, point and punch, the right hand of
// two_hands and the hug's left (k = -1) hand; [1] the other hand of two_hands and hug. Their
// shapes are the caller's choice (GestureSession picks open hands for palm, two_hands, hug).
inline Scene gesture_scene(Gesture gesture, const User& user, const GesturePose& pose,
                           std::array<const HandSilhouette*, 2> real = {}) {
  user.validate();
  pose.validate();
  auto hand = [&](const HandPose& hp, const HandSilhouette* r, std::vector<BodyPart>& out) {
    if (r)
      add_silhouette_hand(out, user, hp, *r);
    else
      add_hand(out, user, hp);
  };
  Scene scene;
  scene.skin_tone = user.skin_tone;
  switch (gesture) {
  case Gesture::nothing: {
    // Standing close without touching: torso and a hanging arm far above the skin.
    const double a = pose.rotation_deg * internal::deg;
    const cv::Point2d out_dir{std::cos(a), std::sin(a)};
    const cv::Point2d side{-out_dir.y, out_dir.x};
    const double h = pose.body_height_cm;
    scene.parts.push_back(internal::blob(PartKind::torso, pose.position_cm, side, 20, 12, h));
    HandPose hp = internal::hand_from(pose, HandShape::open);
    hp.height_cm = h - 5;
    hp.position_cm = pose.position_cm + side * 22.0;
    add_hand(scene.parts, user, hp);
    break;
  }
  case Gesture::hug:
    internal::add_hug(scene.parts, user, pose, real);
    break;
  case Gesture::palm:
    hand(internal::hand_from(pose, HandShape::open), real[0], scene.parts);
    break;
  case Gesture::point:
    hand(internal::hand_from(pose, HandShape::point), real[0], scene.parts);
    break;
  case Gesture::punch:
    hand(internal::hand_from(pose, HandShape::fist), real[0], scene.parts);
    break;
  case Gesture::two_hands: {
    const double a = pose.rotation_deg * internal::deg;
    const cv::Point2d side{-std::sin(a), std::cos(a)}; // to the right of the finger direction
    HandPose right = internal::hand_from(pose, HandShape::open), left = right;
    right.position_cm = pose.position_cm + side * (pose.hand_gap_cm / 2);
    left.position_cm = pose.position_cm - side * (pose.hand_gap_cm / 2);
    right.left = false, left.left = true;
    right.rotation_deg -= 6, left.rotation_deg += 6; // hands slightly turned in
    right.wrist_bend_deg = pose.wrist_bend_deg, left.wrist_bend_deg = -pose.wrist_bend_deg;
    hand(right, real[0], scene.parts);
    hand(left, real[1], scene.parts);
    break;
  }
  }
  return scene;
}

// A random pose for a gesture on the robot rig (plane extents of its visible top: about
// +-80 cm across, heavily compressed by the fisheye, and +-20 cm up/down).
inline GesturePose random_gesture_pose(Gesture gesture, Rng& rng) {
  GesturePose p;
  // People stand in front of or behind the robot (y sides), occasionally at its ends.
  const bool ends = rng.chance(0.2);
  const double stand = ends ? (rng.chance(0.5) ? 0.0 : 180.0) : (rng.chance(0.5) ? 90.0 : -90.0);
  p.rotation_deg = stand + 180 + rng.uniform(-35, 35); // fingers point away from the person
  p.position_cm = {rng.uniform(-35, 35), rng.uniform(-11, 11)};
  p.spread = rng.uniform(0, 1);
  p.arm_elevation_deg = rng.uniform(20, 50);
  p.wrist_bend_deg = rng.uniform(-15, 15);
  p.left = rng.chance(0.4);
  switch (gesture) {
  case Gesture::nothing:
    p.body_height_cm = rng.uniform(32, 70);
    p.rotation_deg = stand + rng.uniform(-30, 30);
    break;
  case Gesture::hug: {
    p.rotation_deg = (rng.chance(0.5) ? 90.0 : -90.0) + rng.uniform(-20, 20);
    const double a = p.rotation_deg * internal::deg;
    const double r = rng.uniform(15, 23);
    p.position_cm = {r * std::cos(a) + rng.uniform(-15, 15), r * std::sin(a)};
    p.hug_reach = rng.uniform(0.7, 1.3);
    break;
  }
  case Gesture::punch:
    p.arm_elevation_deg = rng.uniform(45, 75);
    break;
  case Gesture::point:
    p.arm_elevation_deg = rng.uniform(30, 60);
    break;
  case Gesture::two_hands:
    // Both hands side by side from the front or the back.
    p.rotation_deg = (rng.chance(0.5) ? 90.0 : -90.0) + rng.uniform(-25, 25);
    p.hand_gap_cm = rng.uniform(14, 32);
    p.position_cm = {rng.uniform(-20, 20), rng.uniform(-6, 6)};
    break;
  default:
    break;
  }
  return p;
}

// Smooth drift of a pose over a block of a session: every parameter follows its own slow
// sinusoids (period 3-12 s), so consecutive frames are similar and split by time is honest.
struct PoseDrift {
  std::array<double, 12> phase{}, freq{};

  static PoseDrift random(Rng& rng) {
    PoseDrift d;
    for (std::size_t i = 0; i < d.phase.size(); ++i) {
      d.phase[i] = rng.uniform(0, 6.283185307179586);
      d.freq[i] = 1.0 / rng.uniform(3.0, 12.0);
    }
    return d;
  }
  double wave(std::size_t i, double t_s) const {
    return 0.6 * std::sin(6.283185307179586 * freq[i] * t_s + phase[i]) +
           0.4 * std::sin(6.283185307179586 * freq[i + 6] * 1.7 * t_s + phase[i + 6]);
  }
  GesturePose apply(GesturePose p, double t_s) const {
    p.position_cm.x += 4.0 * wave(0, t_s);
    p.position_cm.y += 2.5 * wave(1, t_s);
    p.rotation_deg += 10.0 * wave(2, t_s);
    p.spread = std::clamp(p.spread + 0.15 * wave(3, t_s), 0.0, 1.0);
    p.arm_elevation_deg = std::clamp(p.arm_elevation_deg + 6.0 * wave(4, t_s), 5.0, 85.0);
    p.hand_gap_cm = std::max(8.0, p.hand_gap_cm + 3.0 * wave(5, t_s));
    p.body_height_cm = std::max(32.0, p.body_height_cm + 8.0 * wave(5, t_s));
    return p;
  }
};

struct GestureSessionConfig {
  int frames_per_gesture = 3; // frames of each gesture in the session (paper: 85)
  double fps = 10.0;
  double gap_ms = 3000.0; // pause between gesture blocks
  double distractor_probability = 0.25;
  // Domain randomisation (randomise.hpp): off = the frames of the unrandomised generator,
  // byte for byte. On: one DomainSample per session, drawn from the session seed.
  bool randomise = false;
  DomainRanges ranges{};
  // Pixel scale of the body (Scene::zoom), drawn log-uniformly in [lo, hi] for every gesture
  // block from the session seed (its own stream: the other draws are unchanged), about the
  // block's anchor (the hand's touch point, the hands' centre, the chest, the standing body).
  // {1, 1}: no draw, the frames of before this existed, byte for byte.
  Range pixel_scale{1.0, 1.0};
  // Real hand silhouettes (silhouette_hand.hpp): each hand of a palm, point, punch, two_hands
  // or hug frame is, with real_hand_probability, one of these of the gesture's shape (open for
  // palm, two_hands and hug; point; fist for punch), drawn per frame from the session seed
  // (its own stream). A gesture without silhouettes of its shape keeps the parametric hands.
  // nullptr: none, the frames of before this existed.
  std::shared_ptr<const std::vector<HandSilhouette>> real_hands = nullptr;
  double real_hand_probability = 0.5;

  void validate() const {
    detail::require(real_hand_probability >= 0 && real_hand_probability <= 1,
                    "GestureSessionConfig: real_hand_probability must be in [0, 1]");
    if (real_hands)
      for (const HandSilhouette& h : *real_hands) h.validate();
    if (randomise) ranges.validate();
    detail::require(std::isfinite(pixel_scale.lo) && std::isfinite(pixel_scale.hi) &&
                        pixel_scale.lo >= 0.25 && pixel_scale.lo <= pixel_scale.hi &&
                        pixel_scale.hi <= 4,
                    "GestureSessionConfig: pixel_scale must be a range 0.25 <= lo <= hi <= 4");
    detail::require(frames_per_gesture >= 1 && frames_per_gesture <= 100000,
                    "GestureSessionConfig: frames_per_gesture must be in [1, 100000], got " +
                        std::to_string(frames_per_gesture));
    detail::require(std::isfinite(fps) && fps > 0 && fps <= 1000,
                    "GestureSessionConfig: fps must be in (0, 1000]");
    detail::require(gap_ms >= 0 && std::isfinite(gap_ms),
                    "GestureSessionConfig: gap_ms must be >= 0");
    detail::require(distractor_probability >= 0 && distractor_probability <= 1,
                    "GestureSessionConfig: distractor_probability must be in [0, 1]");
  }
};

struct GestureFrameInfo {
  Gesture gesture = Gesture::nothing;
  int user = 0;
  Light light;
  std::string session;
  int frame_index = 0;
  double timestamp_ms = 0;
};

// One recording session: a user under one lighting, performing the gestures in blocks
// (all_gestures order) in time order. Frames are random-access and deterministic.
class GestureSession {
public:
  GestureSession(std::uint64_t seed, const User& user, double lighting_level,
                 GestureSessionConfig config = {})
      : seed_(seed), user_(user), config_(config) {
    user.validate();
    config.validate();
    Rng rng(derive_seed(seed, 0x5E55));
    light_ = light_from_level(lighting_level, rng.uniform(-180, 180));
    for (auto& w : wrinkle_) w = static_cast<float>(rng.uniform(-0.06, 0.06));
    if (rng.chance(config.distractor_probability))
      distractors_.push_back(random_distractor(rng, {50, 24}));
    for (std::size_t g = 0; g < all_gestures.size(); ++g) {
      Rng block(derive_seed(seed, 100 + g));
      poses_[g] = random_gesture_pose(all_gestures[g], block);
      drifts_[g] = PoseDrift::random(block);
    }
    if (config.real_hands)
      for (std::size_t i = 0; i < config.real_hands->size(); ++i)
        real_of_[static_cast<std::size_t>((*config.real_hands)[i].shape)].push_back(i);
    if (config.pixel_scale.lo != 1.0 || config.pixel_scale.hi != 1.0)
      for (std::size_t g = 0; g < all_gestures.size(); ++g) {
        Rng z(derive_seed(seed, 0x5CA1E000ull + g));
        zoom_[g] = std::exp(
            Range{std::log(config.pixel_scale.lo), std::log(config.pixel_scale.hi)}.draw(z));
      }
    if (config.randomise) {
      domain_ = DomainSample::draw(seed, config.ranges);
      user_ = randomise_user(user_, domain_);
      light_ = randomise_light(light_, domain_);
      for (auto& o : random_occluders(domain_, seed)) distractors_.push_back(std::move(o));
    }
    name_ = "u" + std::to_string(user.id) + "_" + std::string(to_string(light_.label));
    if (light_.label == Lighting::custom)
      name_ += std::to_string(static_cast<int>(std::lround(lighting_level * 100)));
  }

  int size() const { return config_.frames_per_gesture * static_cast<int>(all_gestures.size()); }
  const std::string& name() const { return name_; }
  const Light& light() const { return light_; }
  const User& user() const { return user_; }
  // The session's domain sample (meaningful only with config.randomise).
  const DomainSample& domain() const { return domain_; }
  // The pixel scale (Scene::zoom) of a gesture's block; 1 unless config.pixel_scale is set.
  double zoom(Gesture g) const { return zoom_[static_cast<std::size_t>(g)]; }

  GestureFrameInfo info(int index) const {
    check(index);
    GestureFrameInfo i;
    const int block = index / config_.frames_per_gesture;
    i.gesture = all_gestures[static_cast<std::size_t>(block)];
    i.user = user_.id;
    i.session = name_;
    i.frame_index = index;
    i.timestamp_ms = 1000.0 * index / config_.fps + block * config_.gap_ms;
    Rng rng(derive_seed(seed_, 0xF00D0000ull + static_cast<std::uint64_t>(index)));
    i.light = jitter(light_, rng, 0.3);
    return i;
  }

  Scene scene(int index) const {
    check(index);
    const int block = index / config_.frames_per_gesture;
    const double t_s = static_cast<double>(index % config_.frames_per_gesture) / config_.fps;
    const auto b = static_cast<std::size_t>(block);
    GesturePose pose = drifts_[b].apply(poses_[b], t_s);
    if (config_.randomise) pose = randomise_pose(pose, domain_);
    Scene s = gesture_scene(all_gestures[b], user_, pose, real_hands(index));
    if (zoom_[b] != 1.0) {
      s.zoom = zoom_[b];
      // The anchor: where the gesture is performed (add_hug's chest for a hug).
      s.zoom_centre_cm = all_gestures[b] == Gesture::hug
                             ? pose.position_cm * (1.0 - pose.hug_centre_pull)
                             : pose.position_cm;
    }
    s.wrinkle = wrinkle_;
    s.distractors = distractors_;
    Rng rng(derive_seed(seed_, 0xD15A0000ull + static_cast<std::uint64_t>(index)));
    if (rng.chance(0.5 * config_.distractor_probability))
      s.distractors.push_back(random_distractor(rng, {50, 24}));
    return s;
  }

  void render(Renderer& renderer, int index, Frame& out,
              GestureFrameInfo* info_out = nullptr) const {
    const GestureFrameInfo i = info(index);
    const std::uint64_t noise_seed =
        derive_seed(seed_, 0xAB0000ull + static_cast<std::uint64_t>(index));
    render_scene(renderer, scene(index), i.light, noise_seed, out);
    if (info_out) *info_out = i;
  }

  // The session's empty skin: no body and no distractor, the session's light (unjittered) and
  // skin wrinkle, and with config.randomise its shading and camera; k picks the sensor noise.
  // What a robot would record for its calibration (ss_gesture_data --empty-skin).
  void render_empty_skin(Renderer& renderer, int k, Frame& out) const {
    Scene s;
    s.wrinkle = wrinkle_;
    const std::uint64_t noise_seed =
        derive_seed(seed_, 0xE5C10000ull + static_cast<std::uint64_t>(k));
    render_scene(renderer, s, light_, noise_seed, out);
  }

private:
  // A scene as this session's camera sees it: with config.randomise, the session's shading
  // (on the shared renderer, restored even if rendering throws) and camera.
  void render_scene(Renderer& renderer, const Scene& scene, const Light& light,
                    std::uint64_t noise_seed, Frame& out) const {
    if (!config_.randomise) {
      renderer.render(scene, light, noise_seed, out);
      return;
    }
    struct Restore {
      Renderer& r;
      RenderConfig c;
      ~Restore() { r.set_shading(c); }
    } restore{renderer, renderer.config()};
    renderer.set_shading(randomise_shading(restore.c, domain_));
    renderer.render(scene, light, noise_seed, out);
    apply_camera(domain_, renderer.surface_mask(), noise_seed, out);
  }

  std::uint64_t seed_;
  User user_;
  GestureSessionConfig config_;
  Light light_;
  std::array<float, 4> wrinkle_{};
  std::vector<Distractor> distractors_;
  std::array<GesturePose, 6> poses_{};
  std::array<PoseDrift, 6> drifts_{};
  std::array<double, 6> zoom_{1, 1, 1, 1, 1, 1};
  std::array<std::vector<std::size_t>, 3> real_of_; // silhouette indices by HandShape
  DomainSample domain_{};
  std::string name_;

  // The silhouettes of a frame's hands (nullptr: parametric).
  std::array<const HandSilhouette*, 2> real_hands(int index) const {
    std::array<const HandSilhouette*, 2> r{};
    if (!config_.real_hands) return r;
    const Gesture g = all_gestures[static_cast<std::size_t>(index / config_.frames_per_gesture)];
    const HandShape shape = g == Gesture::point   ? HandShape::point
                            : g == Gesture::punch ? HandShape::fist
                                                  : HandShape::open;
    if (g == Gesture::nothing) return r;
    const std::vector<std::size_t>& pool = real_of_[static_cast<std::size_t>(shape)];
    if (pool.empty()) return r;
    Rng rng(derive_seed(seed_, 0x4EA10000ull + static_cast<std::uint64_t>(index)));
    for (auto& h : r)
      if (rng.chance(config_.real_hand_probability))
        h = &(*config_.real_hands)[pool[static_cast<std::size_t>(
            rng.integer(0, static_cast<int>(pool.size()) - 1))]];
    return r;
  }

  void check(int index) const {
    detail::require(index >= 0 && index < size(), "GestureSession: frame index " +
                                                      std::to_string(index) + " outside [0, " +
                                                      std::to_string(size()) + ")");
  }
};

} // namespace sim
SHADOWSENSE_NAMESPACE_END
