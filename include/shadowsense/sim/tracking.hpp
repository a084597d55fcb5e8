// Tracking-rig scenes (the paper's test box, section 5.2): single frames of the five
// categories and slide sequences (about 13 fps, 8-80 frames, 10-26 cm, four directions,
// palm or fingertip), each frame with its ground truth.
//
// Direction convention (robot frame = image axes): right = +x, left = -x,
// front = -y (up in the image), back = +y.
#pragma once

#include <shadowsense/core/direction.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/sim/body.hpp>
#include <shadowsense/sim/lighting.hpp>
#include <shadowsense/sim/renderer.hpp>
#include <shadowsense/sim/rng.hpp>

#include <opencv2/core.hpp>

#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN
namespace sim {

enum class TrackCategory { nothing, hover, palm, fist, finger };
inline constexpr std::array<TrackCategory, 5> all_track_categories{
    TrackCategory::nothing, TrackCategory::hover, TrackCategory::palm, TrackCategory::fist,
    TrackCategory::finger};

inline std::string_view to_string(TrackCategory c) {
  switch (c) {
  case TrackCategory::nothing:
    return "nothing";
  case TrackCategory::hover:
    return "hover";
  case TrackCategory::palm:
    return "palm";
  case TrackCategory::fist:
    return "fist";
  case TrackCategory::finger:
    return "finger";
  }
  return "nothing";
}
inline TrackCategory track_category_from_string(std::string_view s) {
  for (TrackCategory c : all_track_categories)
    if (to_string(c) == s) return c;
  SHADOWSENSE_THROW(InvalidArgument("unknown tracking category '" + std::string(s) +
                                    "'; expected nothing, hover, palm, fist or finger"));
}

// The dataset format's slide gesture label (io/labels.hpp).
using shadowsense::all_directions;
using shadowsense::Direction;
using shadowsense::movement_direction_from_string;
using shadowsense::slide_gesture_from_string;
using shadowsense::SlideGesture;
using shadowsense::to_string;

// Unit vector of a direction in image axes (x right, y down): front = up = -y.
inline cv::Point2d direction_vector(Direction d) {
  switch (d) {
  case Direction::left:
    return {-1, 0};
  case Direction::right:
    return {1, 0};
  case Direction::front:
    return {0, -1};
  case Direction::back:
    return {0, 1};
  case Direction::none:
    break;
  }
  return {0, 0};
}

// The scene of one tracking frame. The category decides contact and hand shape:
// palm = open hand touching, fist = fist touching, finger = fingertip touching (pose.position
// is the fingertip), hover = pose.shape at pose.height_cm > 0, nothing = no body part.
inline Scene tracking_scene(TrackCategory category, const HandPose& pose, const User& user) {
  Scene scene;
  scene.skin_tone = user.skin_tone;
  HandPose p = pose;
  switch (category) {
  case TrackCategory::nothing:
    return scene;
  case TrackCategory::hover:
    detail::require(pose.height_cm > 0,
                    "tracking_scene: a hover frame needs pose.height_cm > 0, got " +
                        std::to_string(pose.height_cm));
    break;
  case TrackCategory::palm:
    p.shape = HandShape::open, p.height_cm = 0;
    break;
  case TrackCategory::fist:
    p.shape = HandShape::fist, p.height_cm = 0;
    break;
  case TrackCategory::finger:
    p.shape = HandShape::point, p.height_cm = 0;
    break;
  }
  add_hand(scene.parts, user, p);
  return scene;
}

// Renders one tracking-rig frame of a category at a given pose. `renderer` must use the
// tracking rig (or any rig; the pose is in that rig's skin-plane cm).
inline Frame render_tracking_frame(Renderer& renderer, TrackCategory category, const HandPose& pose,
                                   const User& user = {},
                                   const Light& light = preset(Lighting::daylight),
                                   std::uint64_t noise_seed = 0) {
  return renderer.render(tracking_scene(category, pose, user), light, noise_seed);
}

// Variety of randomly drawn tracking frames and slides.
struct TrackingSampleConfig {
  // Probability of each lighting preset (daylight, dusk, night). Ignored if level >= 0.
  std::array<double, 3> lighting_weights{0.5, 0.3, 0.2};
  double lighting_level = -1; // >= 0: use light_from_level(level) for every sample
  double distractor_probability = 0.2;
  cv::Size2d area_half_cm{10.0, 10.0}; // where touches land (box top is 13 x 13.3)

  void validate() const {
    double s = 0;
    for (double w : lighting_weights) {
      detail::require(w >= 0 && std::isfinite(w),
                      "TrackingSampleConfig: lighting_weights must be >= 0");
      s += w;
    }
    detail::require(
        lighting_level >= 0 ? lighting_level <= 1 : s > 0,
        "TrackingSampleConfig: need lighting_level in [0,1] or a positive lighting weight");
    detail::require(distractor_probability >= 0 && distractor_probability <= 1,
                    "TrackingSampleConfig: distractor_probability must be in [0, 1]");
    detail::require(area_half_cm.width >= 0 && area_half_cm.height >= 0,
                    "TrackingSampleConfig: area_half_cm must be >= 0");
  }
  Light draw_light(Rng& rng) const {
    const double az = rng.uniform(-180, 180);
    if (lighting_level >= 0) return jitter(light_from_level(lighting_level, az), rng, 0.5);
    const double total = lighting_weights[0] + lighting_weights[1] + lighting_weights[2];
    double u = rng.uniform() * total;
    Lighting l = Lighting::night;
    if (u < lighting_weights[0])
      l = Lighting::daylight;
    else if (u < lighting_weights[0] + lighting_weights[1])
      l = Lighting::dusk;
    Light light = jitter(preset(l, az), rng, 0.5);
    light.label = l;
    return light;
  }
};

// Everything that defines one random tracking frame.
struct TrackingSample {
  TrackCategory category = TrackCategory::nothing;
  User user;
  HandPose pose;
  Light light;
  Scene scene;
  std::uint64_t noise_seed = 0;
};

inline HandPose random_hand_pose(TrackCategory category, Rng& rng, cv::Size2d area_half_cm) {
  HandPose p;
  p.position_cm = {rng.uniform(-area_half_cm.width, area_half_cm.width),
                   rng.uniform(-area_half_cm.height, area_half_cm.height)};
  p.rotation_deg = rng.uniform(-180, 180);
  p.spread = rng.uniform(0, 1);
  p.left = rng.chance(0.5);
  p.wrist_bend_deg = rng.uniform(-20, 20);
  p.arm_elevation_deg = rng.uniform(20, 55);
  switch (category) {
  case TrackCategory::fist:
    p.shape = HandShape::fist, p.arm_elevation_deg = rng.uniform(45, 75);
    break;
  case TrackCategory::finger:
    p.shape = HandShape::point, p.arm_elevation_deg = rng.uniform(30, 60);
    break;
  case TrackCategory::hover: {
    const double u = rng.uniform();
    p.shape = u < 0.6 ? HandShape::open : u < 0.8 ? HandShape::fist : HandShape::point;
    p.height_cm = rng.uniform(5, 20);
    break;
  }
  default:
    break;
  }
  return p;
}

inline TrackingSample random_tracking_sample(TrackCategory category, std::uint64_t seed,
                                             const TrackingSampleConfig& config = {},
                                             const User* user = nullptr) {
  config.validate();
  Rng rng(derive_seed(seed, 0x7EAC));
  TrackingSample s;
  s.category = category;
  s.user = user ? *user : User::random(static_cast<int>(seed % 1000), rng);
  s.pose = random_hand_pose(category, rng, config.area_half_cm);
  s.light = config.draw_light(rng);
  s.scene = tracking_scene(category, s.pose, s.user);
  if (category == TrackCategory::nothing && rng.chance(0.5)) {
    // Someone standing a metre away: a faint, very soft shadow far above the skin.
    HandPose far = s.pose;
    far.height_cm = rng.uniform(60, 120);
    far.shape = HandShape::open;
    add_hand(s.scene.parts, s.user, far);
  }
  for (auto& w : s.scene.wrinkle) w = static_cast<float>(rng.uniform(-0.06, 0.06));
  if (rng.chance(config.distractor_probability))
    s.scene.distractors.push_back(random_distractor(rng, {13, 13}));
  s.noise_seed = rng.next();
  return s;
}

// True if a rendered frame shows what its category promises (hover: a shadow and no
// contact; palm/fist/finger: a contact of at least 16 px; nothing: no box).
inline bool category_visible(TrackCategory category, const GroundTruth& gt) {
  switch (category) {
  case TrackCategory::nothing:
    return !gt.shadow_box && !gt.contact_box;
  case TrackCategory::hover:
    // A shadow of at least 1% of the frame (not a sliver at the edge) and no contact.
    return gt.shadow_box && !gt.contact_box &&
           cv::countNonZero(gt.shadow_mask) * 100 >= gt.shadow_mask.rows * gt.shadow_mask.cols;
  default:
    return gt.contact_box && cv::countNonZero(gt.contact_mask) >= 16;
  }
}

// Draws random samples (seed, seed+1, ... derived) until the category is visible in the frame
// (a shadow thrown off the box top, a touch at the edge), at most 32 attempts.
inline Frame render_random_tracking_frame(Renderer& renderer, TrackCategory category,
                                          std::uint64_t seed,
                                          const TrackingSampleConfig& config = {},
                                          TrackingSample* sample_out = nullptr,
                                          const User* user = nullptr) {
  Frame f;
  TrackingSample s;
  for (std::uint64_t attempt = 0; attempt < 32; ++attempt) {
    s = random_tracking_sample(category, derive_seed(seed, attempt), config, user);
    renderer.render(s.scene, s.light, s.noise_seed, f);
    if (category_visible(category, f.gt)) break;
  }
  if (sample_out) *sample_out = s;
  return f;
}

// ---------------------------------------------------------------------------------------
// Slides

struct SlideConfig {
  double fps = 13.0;
  int min_frames = 8, max_frames = 80;
  double min_distance_cm = 10.0, max_distance_cm = 26.0;
  cv::Size2d area_half_cm{12.5, 12.8}; // the touch anchor stays inside this (box top 13 x 13.3)
  TrackingSampleConfig variety{};

  void validate() const {
    detail::require(std::isfinite(fps) && fps > 0 && fps <= 1000,
                    "SlideConfig: fps must be in (0, 1000]");
    detail::require(min_frames >= 2 && max_frames >= min_frames && max_frames <= 10000,
                    "SlideConfig: need 2 <= min_frames <= max_frames <= 10000");
    detail::require(min_distance_cm > 0 && max_distance_cm >= min_distance_cm,
                    "SlideConfig: need 0 < min_distance_cm <= max_distance_cm");
    detail::require(area_half_cm.width > 0 && area_half_cm.height > 0,
                    "SlideConfig: area_half_cm must be positive");
    variety.validate();
  }
};

// A slide sequence before rendering: one hand pose and timestamp per frame.
struct SlidePlan {
  SlideGesture gesture = SlideGesture::palm;
  Direction direction = Direction::right;
  double distance_cm = 0; // travel of the touch anchor (palm centre / fingertip)
  double fps = 13;
  User user;
  Light light;
  Scene extras; // fabric wrinkles and distractors shared by all frames
  std::vector<HandPose> poses;
  std::vector<double> timestamps_ms;
  std::uint64_t seed = 0;
  int num_frames() const { return static_cast<int>(poses.size()); }
};

// user: the performer (default: a random one drawn from the seed).
inline SlidePlan plan_slide(std::uint64_t seed, SlideGesture gesture, Direction direction,
                            const SlideConfig& config = {}, const User* user = nullptr) {
  config.validate();
  Rng rng(derive_seed(seed, 0x511DE));
  SlidePlan plan;
  plan.gesture = gesture;
  plan.direction = direction;
  plan.seed = seed;
  plan.fps = config.fps;
  plan.user = User::random(static_cast<int>(seed % 1000), rng);
  if (user) user->validate(), plan.user = *user;
  plan.light = config.variety.draw_light(rng);
  for (auto& w : plan.extras.wrinkle) w = static_cast<float>(rng.uniform(-0.06, 0.06));
  plan.extras.skin_tone = plan.user.skin_tone;
  if (rng.chance(config.variety.distractor_probability))
    plan.extras.distractors.push_back(random_distractor(rng, {13, 13}));
  const int n = rng.integer(config.min_frames, config.max_frames);
  plan.distance_cm = rng.uniform(config.min_distance_cm, config.max_distance_cm);
  const cv::Point2d u = direction_vector(direction), lat{-u.y, u.x};
  const double along_half =
      std::abs(u.x) > 0 ? config.area_half_cm.width : config.area_half_cm.height;
  const double lat_half =
      std::abs(u.x) > 0 ? config.area_half_cm.height : config.area_half_cm.width;
  const double room = 2 * along_half - plan.distance_cm;
  // Start at a random position from which the whole slide stays in the area (centred when
  // the slide is longer than the area).
  const double s0 = room > 0 ? -along_half + rng.uniform(0, room) : -plan.distance_cm / 2;
  const double l0 = rng.uniform(-0.75, 0.75) * lat_half;
  HandPose base = random_hand_pose(
      gesture == SlideGesture::palm ? TrackCategory::palm : TrackCategory::finger, rng, {0, 0});
  base.shape = gesture == SlideGesture::palm ? HandShape::open : HandShape::point;
  base.rotation_deg = -90 + rng.uniform(-45, 45);
  // Varied speed: a mix of constant speed and ease-in/ease-out, a slight sideways wobble and
  // a slow wrist rotation.
  const double ease = rng.uniform(0, 1);
  const double wobble = rng.uniform(0, 0.6), wobble_f = rng.uniform(0.3, 1.5),
               wobble_p = rng.uniform(0, 6.283);
  const double turn = rng.uniform(-8, 8);
  for (int i = 0; i < n; ++i) {
    const double t = n > 1 ? static_cast<double>(i) / (n - 1) : 0.0;
    const double smooth = t * t * (3 - 2 * t);
    const double progress = (1 - ease) * t + ease * smooth;
    HandPose p = base;
    const double lateral = l0 + wobble * std::sin(6.283185307179586 * wobble_f * t + wobble_p);
    p.position_cm = u * (s0 + plan.distance_cm * progress) + lat * lateral;
    p.rotation_deg = base.rotation_deg + turn * t;
    plan.poses.push_back(p);
    plan.timestamps_ms.push_back(1000.0 * i / config.fps);
  }
  return plan;
}

inline Scene slide_scene(const SlidePlan& plan, int index) {
  detail::require(index >= 0 && index < plan.num_frames(),
                  "slide_scene: frame index " + std::to_string(index) + " outside [0, " +
                      std::to_string(plan.num_frames()) + ")");
  Scene scene = plan.extras;
  add_hand(scene.parts, plan.user, plan.poses[static_cast<std::size_t>(index)]);
  return scene;
}

inline void render_slide_frame(Renderer& renderer, const SlidePlan& plan, int index, Frame& out) {
  Rng rng(derive_seed(plan.seed, 0xF4A3E000ull + static_cast<std::uint64_t>(index)));
  const Light light = jitter(plan.light, rng, 0.3);
  renderer.render(slide_scene(plan, index), light, rng.next(), out);
}
inline Frame render_slide_frame(Renderer& renderer, const SlidePlan& plan, int index) {
  Frame f;
  render_slide_frame(renderer, plan, index, f);
  return f;
}
inline std::vector<Frame> render_slide(Renderer& renderer, const SlidePlan& plan) {
  std::vector<Frame> frames(static_cast<std::size_t>(plan.num_frames()));
  for (int i = 0; i < plan.num_frames(); ++i)
    render_slide_frame(renderer, plan, i, frames[static_cast<std::size_t>(i)]);
  return frames;
}

} // namespace sim
SHADOWSENSE_NAMESPACE_END
