// Domain randomisation of the scene generator: per-session variation of everything a gesture
// classifier must not depend on (fabric weave and seams, skin and light colour, exposure and
// white balance, blur/penumbra, lens distortion, sensor noise, JPEG-like compression, hand
// shapes and sizes, arm and body poses, occluders). Off by default: a GestureSession without
// `GestureSessionConfig::randomise` renders byte-identical frames to before.
//
// Everything is drawn from the session seed with sim::Rng (its own stream, so the
// unrandomised draws of a session are unchanged) and from the frame's noise seed: a seed gives
// the same frames on every platform and thread count. Ranges: docs/scene_generator.md.
//
//   DomainRanges
//     The uniform ranges of every randomised quantity ([lo, hi] pairs). validate() throws
//     InvalidArgument naming the field when a range is reversed or outside what the renderer
//     accepts.
//
//   DomainSample DomainSample::draw(std::uint64_t seed, const DomainRanges& r)
//     requires: r.validate() passes (checked; InvalidArgument otherwise).
//     ensures: a sample inside the ranges, a pure function of (seed, r).
//
//   User randomise_user(User u, const DomainSample& d)
//     ensures: the body measurements scaled by the sample; the result passes User::validate().
//   Light randomise_light(Light l, const DomainSample& d)
//     ensures: colour temperatures, ambient, zenith and brightness from the sample; passes
//     Light::validate() (label and level are kept).
//   (randomise_pose(GesturePose, DomainSample) is in gestures.hpp, next to GesturePose.)
//   RenderConfig randomise_shading(RenderConfig c, const DomainSample& d)
//     ensures: penumbra, opacity and skin transmission from the sample; passes validate().
//   std::vector<Distractor> random_occluders(const DomainSample& d, std::uint64_t seed)
//     ensures: d.occluders distractors of opacity < 0.5 (never part of the ground truth).
//   void apply_camera(const DomainSample& d, const cv::Mat& surface, std::uint64_t seed,
//                     Frame& f)
//     requires: f.image CV_8UC3 of surface's size (CV_8UC1); f.gt masks of that size.
//     ensures: the fabric texture (weave, seams), white balance, exposure, gamma, optical
//     blur, lens distortion (image AND ground truth masks, opacity and boxes remapped
//     together), sensor noise and JPEG-like compression applied, in that order; deterministic
//     in (d, seed). Throws InvalidArgument on a frame of the wrong type or size.
//
// Threading: all functions are pure (no shared state); DomainSample is a value.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sim/body.hpp>
#include <shadowsense/sim/lighting.hpp>
#include <shadowsense/sim/renderer.hpp>
#include <shadowsense/sim/rng.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN
namespace sim {

struct Range {
  double lo = 0, hi = 0;
  double draw(Rng& rng) const { return lo == hi ? lo : rng.uniform(lo, hi); }
};

enum class SeamPattern { none, channels, grid, diamonds };

struct DomainRanges {
  // Fabric (multiplicative texture on the visible skin, image pixels).
  Range weave_period_px{1.8, 6.0};
  Range weave_contrast{0.0, 0.08};
  double seam_probability = 0.75; // else no seams; patterns channels / grid / diamonds alike
  Range seam_period_px{18, 90};
  Range seam_width_px{1.0, 4.0};
  Range seam_contrast{-0.25, 0.35}; // > 0 darker seams, < 0 brighter (thinner fabric)
  // Light and colour.
  Range light_temp_k{2200, 9500};
  Range ambient_temp_k{4000, 11000};
  Range ambient{0.18, 0.6};
  Range zenith_deg{0, 60};
  Range brightness_gain{0.55, 1.25};      // on the light's recorded brightness
  Range white_balance{0.75, 1.3};         // per channel camera gain (B, G, R)
  Range gamma{0.75, 1.35};                // recorded = 255 (v / 255)^gamma
  Range skin_transmission_gain{0.5, 2.0}; // per channel, on RenderConfig's
  // Blur and penumbra.
  Range penumbra_base_cm{0.05, 0.6};
  Range penumbra_per_cm{0.05, 0.3};
  Range max_opacity{0.7, 1.0};
  Range opacity_half_height_cm{12, 45};
  Range optical_blur_px{0.0, 1.6}; // Gaussian sigma of the lens/focus blur
  // Lens: radial distortion about a shifted centre, r' = r (1 + k1 (r / R)^2).
  Range lens_k1{-0.18, 0.18};
  Range lens_centre_shift_px{-20, 20};
  // Sensor noise: sigma^2 = read^2 + shot x value, per channel (8-bit units).
  Range read_noise{0.5, 6.0};
  Range shot_noise{0.0, 0.25};
  double jpeg_probability = 0.7;
  Range jpeg_quality{25, 95};
  // Body: scales on User's measurements (after User::random) and pose offsets.
  Range hand_scale{0.8, 1.2};
  Range palm_width_scale{0.88, 1.12};
  Range finger_scale{0.88, 1.12};
  Range arm_width_scale{0.8, 1.25};
  Range arm_elevation_offset_deg{-15, 20};
  Range wrist_bend_offset_deg{-20, 20};
  Range spread_offset{-0.3, 0.3};
  Range hug_reach_scale{0.8, 1.2};
  // How hard people press into the soft skin (0 = only the knuckle face of a punch and the
  // middle of a hugging chest touch; 1 = the whole fist face, most of the chest).
  Range press_depth{0.0, 1.0};
  // Hugs of a robot body larger than its visible top: the arms wrap around a centre this far
  // behind the chest (else around the visible top's centre), and the chest lands anywhere
  // between its usual place at the view's edge and the view's middle (pull 0 .. 1).
  double big_body_hug_probability = 0.5;
  Range hug_body_radius_cm{35, 90};
  Range hug_centre_pull{0.0, 0.9};
  // Occluders: sharp-ish shadows of objects (bags, sleeves, cables) that are not the user.
  int max_occluders = 2;

  void validate() const {
    auto check = [](const Range& r, const char* name, double lo, double hi) {
      detail::require(std::isfinite(r.lo) && std::isfinite(r.hi) && r.lo <= r.hi && r.lo >= lo &&
                          r.hi <= hi,
                      std::string("DomainRanges: ") + name + " must be a range lo <= hi inside [" +
                          std::to_string(lo) + ", " + std::to_string(hi) + "]");
    };
    check(weave_period_px, "weave_period_px", 1.0, 100);
    check(weave_contrast, "weave_contrast", 0, 0.3);
    check(seam_period_px, "seam_period_px", 4, 1000);
    check(seam_width_px, "seam_width_px", 0.3, 50);
    check(seam_contrast, "seam_contrast", -0.9, 0.9);
    check(light_temp_k, "light_temp_k", 1000, 40000);
    check(ambient_temp_k, "ambient_temp_k", 1000, 40000);
    check(ambient, "ambient", 0, 0.95);
    check(zenith_deg, "zenith_deg", 0, 75);
    check(brightness_gain, "brightness_gain", 0.05, 4);
    check(white_balance, "white_balance", 0.1, 4);
    check(gamma, "gamma", 0.2, 5);
    check(skin_transmission_gain, "skin_transmission_gain", 0.1, 5);
    check(penumbra_base_cm, "penumbra_base_cm", 0, 5);
    check(penumbra_per_cm, "penumbra_per_cm", 0, 2);
    check(max_opacity, "max_opacity", 0.51, 1);
    check(opacity_half_height_cm, "opacity_half_height_cm", 1, 500);
    check(optical_blur_px, "optical_blur_px", 0, 10);
    check(lens_k1, "lens_k1", -0.4, 0.4);
    check(lens_centre_shift_px, "lens_centre_shift_px", -100, 100);
    check(read_noise, "read_noise", 0, 64);
    check(shot_noise, "shot_noise", 0, 4);
    check(jpeg_quality, "jpeg_quality", 1, 100);
    check(hand_scale, "hand_scale", 0.4, 2);
    check(palm_width_scale, "palm_width_scale", 0.6, 1.5);
    check(finger_scale, "finger_scale", 0.6, 1.4);
    check(arm_width_scale, "arm_width_scale", 0.4, 2);
    check(arm_elevation_offset_deg, "arm_elevation_offset_deg", -60, 60);
    check(wrist_bend_offset_deg, "wrist_bend_offset_deg", -40, 40);
    check(spread_offset, "spread_offset", -1, 1);
    check(hug_reach_scale, "hug_reach_scale", 0.3, 2);
    check(press_depth, "press_depth", 0, 1);
    check(hug_body_radius_cm, "hug_body_radius_cm", 10, 500);
    check(hug_centre_pull, "hug_centre_pull", 0, 0.95);
    detail::require(seam_probability >= 0 && seam_probability <= 1 && jpeg_probability >= 0 &&
                        jpeg_probability <= 1 && big_body_hug_probability >= 0 &&
                        big_body_hug_probability <= 1,
                    "DomainRanges: seam_probability, jpeg_probability and "
                    "big_body_hug_probability must be in [0, 1]");
    detail::require(max_occluders >= 0 && max_occluders <= 8,
                    "DomainRanges: max_occluders must be in [0, 8]");
  }
};

struct DomainSample {
  double weave_period_x = 3, weave_period_y = 3, weave_angle_deg = 0, weave_contrast = 0;
  SeamPattern seams = SeamPattern::none;
  double seam_period = 40, seam_width = 2, seam_contrast = 0, seam_angle_deg = 0;
  cv::Point2d seam_offset{0, 0};
  double light_temp_k = 6000, ambient_temp_k = 7500, ambient = 0.3, zenith_deg = 30;
  double brightness_gain = 1;
  cv::Vec3d white_balance{1, 1, 1};
  double gamma = 1;
  cv::Vec3d skin_transmission_gain{1, 1, 1};
  double penumbra_base_cm = 0.12, penumbra_per_cm = 0.11, max_opacity = 0.97,
         opacity_half_height_cm = 25, optical_blur_px = 0;
  double lens_k1 = 0;
  cv::Point2d lens_centre_shift{0, 0};
  cv::Vec3d read_noise{1, 1, 1};
  double shot_noise = 0;
  int jpeg_quality = 0; // 0 = no compression
  double hand_scale = 1, palm_width_scale = 1, finger_scale = 1, arm_width_scale = 1;
  double arm_elevation_offset_deg = 0, wrist_bend_offset_deg = 0, spread_offset = 0,
         hug_reach_scale = 1;
  double press_depth = 0;
  double hug_body_radius_cm = 0, hug_centre_pull = 0; // 0: a hug around the visible top
  int occluders = 0;

  static DomainSample draw(std::uint64_t seed, const DomainRanges& r) {
    r.validate();
    Rng rng(derive_seed(seed, 0xD0A1D0A1ull));
    DomainSample d;
    d.weave_period_x = r.weave_period_px.draw(rng);
    d.weave_period_y = r.weave_period_px.draw(rng);
    d.weave_angle_deg = rng.uniform(0, 90);
    d.weave_contrast = r.weave_contrast.draw(rng);
    d.seams = rng.chance(r.seam_probability) ? static_cast<SeamPattern>(rng.integer(1, 3))
                                             : SeamPattern::none;
    d.seam_period = r.seam_period_px.draw(rng);
    d.seam_width = r.seam_width_px.draw(rng);
    d.seam_contrast = r.seam_contrast.draw(rng);
    d.seam_angle_deg = rng.uniform(0, 180);
    d.seam_offset = {rng.uniform(0, d.seam_period), rng.uniform(0, d.seam_period)};
    d.light_temp_k = r.light_temp_k.draw(rng);
    d.ambient_temp_k = r.ambient_temp_k.draw(rng);
    d.ambient = r.ambient.draw(rng);
    d.zenith_deg = r.zenith_deg.draw(rng);
    d.brightness_gain = r.brightness_gain.draw(rng);
    for (int c = 0; c < 3; ++c) d.white_balance[c] = r.white_balance.draw(rng);
    d.gamma = r.gamma.draw(rng);
    for (int c = 0; c < 3; ++c) d.skin_transmission_gain[c] = r.skin_transmission_gain.draw(rng);
    d.penumbra_base_cm = r.penumbra_base_cm.draw(rng);
    d.penumbra_per_cm = r.penumbra_per_cm.draw(rng);
    d.max_opacity = r.max_opacity.draw(rng);
    d.opacity_half_height_cm = r.opacity_half_height_cm.draw(rng);
    d.optical_blur_px = r.optical_blur_px.draw(rng);
    d.lens_k1 = r.lens_k1.draw(rng);
    d.lens_centre_shift = {r.lens_centre_shift_px.draw(rng), r.lens_centre_shift_px.draw(rng)};
    const double read = r.read_noise.draw(rng);
    for (int c = 0; c < 3; ++c) d.read_noise[c] = read * rng.uniform(0.7, 1.3);
    d.shot_noise = r.shot_noise.draw(rng);
    d.jpeg_quality = rng.chance(r.jpeg_probability)
                         ? static_cast<int>(std::lround(r.jpeg_quality.draw(rng)))
                         : 0;
    d.hand_scale = r.hand_scale.draw(rng);
    d.palm_width_scale = r.palm_width_scale.draw(rng);
    d.finger_scale = r.finger_scale.draw(rng);
    d.arm_width_scale = r.arm_width_scale.draw(rng);
    d.arm_elevation_offset_deg = r.arm_elevation_offset_deg.draw(rng);
    d.wrist_bend_offset_deg = r.wrist_bend_offset_deg.draw(rng);
    d.spread_offset = r.spread_offset.draw(rng);
    d.hug_reach_scale = r.hug_reach_scale.draw(rng);
    d.occluders = r.max_occluders > 0 ? rng.integer(0, r.max_occluders) : 0;
    // Drawn last, so the draws above are those of the samples before these fields existed.
    d.press_depth = r.press_depth.draw(rng);
    if (rng.chance(r.big_body_hug_probability)) {
      d.hug_body_radius_cm = r.hug_body_radius_cm.draw(rng);
      d.hug_centre_pull = r.hug_centre_pull.draw(rng);
    }
    return d;
  }
};

inline User randomise_user(User u, const DomainSample& d) {
  u.hand_length_cm = std::clamp(u.hand_length_cm * d.hand_scale, 6.0, 39.0);
  u.palm_width_ratio = std::clamp(u.palm_width_ratio * d.palm_width_scale, 0.25, 0.75);
  u.finger_ratio = std::clamp(u.finger_ratio * d.finger_scale, 0.55, 1.45);
  u.finger_width_cm = std::clamp(u.finger_width_cm * d.hand_scale, 0.4, 4.9);
  u.arm_width_cm = std::clamp(u.arm_width_cm * d.hand_scale * d.arm_width_scale, 1.1, 19.0);
  u.validate();
  return u;
}

inline Light randomise_light(Light l, const DomainSample& d) {
  l.colour_temp_k = d.light_temp_k;
  l.ambient_temp_k = d.ambient_temp_k;
  l.ambient = d.ambient;
  l.zenith_deg = d.zenith_deg;
  l.intensity = std::clamp(l.intensity * d.brightness_gain, 1.0, 2550.0);
  l.validate();
  return l;
}

inline RenderConfig randomise_shading(RenderConfig c, const DomainSample& d) {
  c.penumbra_base_cm = d.penumbra_base_cm;
  c.penumbra_per_cm = d.penumbra_per_cm;
  c.max_opacity = d.max_opacity;
  c.opacity_half_height_cm = d.opacity_half_height_cm;
  for (int i = 0; i < 3; ++i)
    c.skin_transmission[i] = static_cast<float>(
        std::clamp(c.skin_transmission[i] * d.skin_transmission_gain[i], 0.01, 0.9));
  c.validate();
  return c;
}

// Occluders on the robot's skin plane (cm extents +-50 x +-24).
inline std::vector<Distractor> random_occluders(const DomainSample& d, std::uint64_t seed) {
  Rng rng(derive_seed(seed, 0x0CC1));
  std::vector<Distractor> out;
  for (int i = 0; i < d.occluders; ++i) {
    Distractor o;
    o.kind = Distractor::Kind::far_object;
    const cv::Point2d c{rng.uniform(-45, 45), rng.uniform(-22, 22)};
    const double a = rng.uniform(0, 3.14159265358979323846);
    const BodyPart b =
        rng.chance(0.5)
            ? internal::segment(PartKind::other, c,
                                c + cv::Point2d{std::cos(a), std::sin(a)} * rng.uniform(8, 30),
                                rng.uniform(0.5, 4), rng.uniform(0.5, 4), 0, 0)
            : internal::blob(PartKind::other, c, {std::cos(a), std::sin(a)}, rng.uniform(3, 12),
                             rng.uniform(2, 8), 0, rng.uniform(2, 6), 20);
    o.outline_cm = b.outline_cm;
    o.opacity = rng.uniform(0.15, 0.45);
    o.blur_cm = rng.uniform(0.2, 2.5);
    out.push_back(std::move(o));
  }
  return out;
}

namespace internal {
// Standard JPEG luminance / chrominance quantisation tables (ITU T.81 Annex K).
inline constexpr std::array<int, 64> jpeg_luma{
    16, 11, 10, 16, 24,  40,  51,  61,  12, 12, 14, 19, 26,  58,  60,  55,
    14, 13, 16, 24, 40,  57,  69,  56,  14, 17, 22, 29, 51,  87,  80,  62,
    18, 22, 37, 56, 68,  109, 103, 77,  24, 35, 55, 64, 81,  104, 113, 92,
    49, 64, 78, 87, 103, 121, 120, 101, 72, 92, 95, 98, 112, 100, 103, 99};
inline constexpr std::array<int, 64> jpeg_chroma{
    17, 18, 24, 47, 99, 99, 99, 99, 18, 21, 26, 66, 99, 99, 99, 99, 24, 26, 56, 99, 99, 99,
    99, 99, 47, 66, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99,
    99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99, 99};

// 2^18 N(0, 1) samples from a fixed seed, built once (thread-safe static initialisation).
inline const std::vector<float>& normal_table() {
  static const std::vector<float> table = [] {
    std::vector<float> t(std::size_t{1} << 18);
    Rng rng(0x7AB1E5EEDull);
    for (float& v : t) v = static_cast<float>(rng.normal());
    return t;
  }();
  return table;
}

// Quantises every 8x8 block of a CV_32F plane (values 0..255) in the DCT domain.
inline void jpeg_plane(cv::Mat& plane, const std::array<int, 64>& table, int quality) {
  const double s = quality < 50 ? 5000.0 / quality : 200.0 - 2.0 * quality;
  std::array<float, 64> q{};
  for (std::size_t i = 0; i < 64; ++i)
    q[i] = static_cast<float>(std::clamp(std::floor((table[i] * s + 50) / 100), 1.0, 255.0));
  const int w = (plane.cols + 7) / 8 * 8, h = (plane.rows + 7) / 8 * 8;
  cv::Mat padded;
  cv::copyMakeBorder(plane, padded, 0, h - plane.rows, 0, w - plane.cols, cv::BORDER_REPLICATE);
  // Orthonormal 8-point DCT-II basis: c[k][n] = a_k cos((2n + 1) k pi / 16).
  std::array<float, 64> c{};
  for (int k = 0; k < 8; ++k)
    for (int n = 0; n < 8; ++n)
      c[static_cast<std::size_t>(k * 8 + n)] =
          static_cast<float>((k == 0 ? std::sqrt(0.125) : 0.5) *
                             std::cos((2 * n + 1) * k * 3.14159265358979323846 / 16));
  float blk[64], tmp[64];
  for (int y = 0; y < h; y += 8)
    for (int x = 0; x < w; x += 8) {
      for (int i = 0; i < 8; ++i) {
        const float* row = padded.ptr<float>(y + i) + x;
        for (int j = 0; j < 8; ++j) blk[i * 8 + j] = row[j] - 128.0f;
      }
      // Forward: tmp = C blk, blk = tmp C^T; quantise; inverse: tmp = C^T blk, blk = tmp C.
      for (int k = 0; k < 8; ++k)
        for (int j = 0; j < 8; ++j) {
          float acc = 0;
          for (int n = 0; n < 8; ++n)
            acc += c[static_cast<std::size_t>(k * 8 + n)] * blk[n * 8 + j];
          tmp[k * 8 + j] = acc;
        }
      for (int i = 0; i < 8; ++i)
        for (int k = 0; k < 8; ++k) {
          float acc = 0;
          for (int n = 0; n < 8; ++n)
            acc += tmp[i * 8 + n] * c[static_cast<std::size_t>(k * 8 + n)];
          const float qq = q[static_cast<std::size_t>(i * 8 + k)];
          blk[i * 8 + k] = std::round(acc / qq) * qq;
        }
      for (int n = 0; n < 8; ++n)
        for (int j = 0; j < 8; ++j) {
          float acc = 0;
          for (int k = 0; k < 8; ++k)
            acc += c[static_cast<std::size_t>(k * 8 + n)] * blk[k * 8 + j];
          tmp[n * 8 + j] = acc;
        }
      for (int i = 0; i < 8; ++i) {
        float* row = padded.ptr<float>(y + i) + x;
        for (int n = 0; n < 8; ++n) {
          float acc = 0;
          for (int k = 0; k < 8; ++k)
            acc += tmp[i * 8 + k] * c[static_cast<std::size_t>(k * 8 + n)];
          row[n] = acc + 128.0f;
        }
      }
    }
  padded(cv::Rect(0, 0, plane.cols, plane.rows)).copyTo(plane);
}
} // namespace internal

inline void apply_camera(const DomainSample& d, const cv::Mat& surface, std::uint64_t seed,
                         Frame& f) {
  detail::require(f.image.type() == CV_8UC3 && surface.type() == CV_8UC1 &&
                      f.image.size() == surface.size(),
                  "apply_camera: expected a CV_8UC3 frame of the surface mask's size");
  const cv::Size size = f.image.size();
  cv::Mat img;
  f.image.convertTo(img, CV_32FC3);
  // Fabric texture on the visible skin: weave and seams (image coordinates, bent by the lens
  // distortion below like the real fabric is bent by the fisheye).
  {
    const double wa = d.weave_angle_deg * internal::deg;
    const double sa = d.seam_angle_deg * internal::deg;
    const double ca = std::cos(wa), sn = std::sin(wa), cs = std::cos(sa), ss = std::sin(sa);
    const double tau = 6.283185307179586;
    auto seam = [&](double u) { // distance to the nearest seam line along u, as a profile
      const double m = std::fmod(std::abs(u), d.seam_period);
      const double dist = std::min(m, d.seam_period - m) / d.seam_width;
      return std::exp(-0.5 * dist * dist);
    };
    for (int y = 0; y < size.height; ++y) {
      auto* p = img.ptr<cv::Vec3f>(y);
      const auto* s = surface.ptr<std::uint8_t>(y);
      for (int x = 0; x < size.width; ++x) {
        if (!s[x]) continue;
        const double u = ca * x + sn * y, v = -sn * x + ca * y;
        double t = 1.0 + d.weave_contrast * std::sin(tau * u / d.weave_period_x) *
                             std::sin(tau * v / d.weave_period_y);
        if (d.seams != SeamPattern::none) {
          const double a = cs * (x + d.seam_offset.x) + ss * (y + d.seam_offset.y);
          const double b = -ss * (x + d.seam_offset.x) + cs * (y + d.seam_offset.y);
          double prof = seam(a);
          if (d.seams == SeamPattern::grid) prof = std::max(prof, seam(b));
          if (d.seams == SeamPattern::diamonds)
            prof = std::max(seam((a + b) * 0.7071067811865476), seam((a - b) * 0.7071067811865476));
          t *= 1.0 - d.seam_contrast * prof;
        }
        p[x] *= static_cast<float>(t);
      }
    }
  }
  // White balance, exposure (already in the light) and gamma.
  {
    const cv::Scalar wb(d.white_balance[0], d.white_balance[1], d.white_balance[2]);
    cv::multiply(img, wb, img);
    cv::max(img, 0.0, img);
    cv::min(img, 255.0, img);
    if (d.gamma != 1.0) {
      img *= 1.0 / 255.0;
      cv::pow(img, d.gamma, img);
      img *= 255.0;
    }
  }
  if (d.optical_blur_px > 0.2) {
    const int k = 2 * static_cast<int>(std::ceil(3.0 * d.optical_blur_px)) + 1;
    cv::GaussianBlur(img, img, cv::Size(k, k), d.optical_blur_px, d.optical_blur_px,
                     cv::BORDER_REFLECT101);
  }
  // Lens: radial distortion about a shifted centre, applied to pixels and ground truth alike.
  if (d.lens_k1 != 0.0 || d.lens_centre_shift != cv::Point2d{0, 0}) {
    cv::Mat mx(size, CV_32FC1), my(size, CV_32FC1);
    const cv::Point2d c{size.width / 2.0 - 0.5 + d.lens_centre_shift.x,
                        size.height / 2.0 - 0.5 + d.lens_centre_shift.y};
    const double R = std::hypot(size.width, size.height) / 2.0;
    for (int y = 0; y < size.height; ++y) {
      auto* px = mx.ptr<float>(y);
      auto* py = my.ptr<float>(y);
      for (int x = 0; x < size.width; ++x) {
        const double dx = x - c.x, dy = y - c.y;
        const double r2 = (dx * dx + dy * dy) / (R * R);
        const double k = 1.0 + d.lens_k1 * r2;
        px[x] = static_cast<float>(c.x + dx * k);
        py[x] = static_cast<float>(c.y + dy * k);
      }
    }
    cv::remap(img, img, mx, my, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    GroundTruth& gt = f.gt;
    cv::remap(gt.shadow_opacity, gt.shadow_opacity, mx, my, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
              0);
    cv::remap(gt.contact_mask, gt.contact_mask, mx, my, cv::INTER_NEAREST, cv::BORDER_CONSTANT, 0);
    cv::compare(gt.shadow_opacity, 0.5, gt.shadow_mask, cv::CMP_GE);
    cv::bitwise_or(gt.shadow_mask, gt.contact_mask, gt.shadow_mask);
    gt.shadow_box.reset();
    gt.contact_box.reset();
    gt.contact_point.reset();
    const cv::Rect sb = cv::boundingRect(gt.shadow_mask);
    if (sb.area() > 0) gt.shadow_box = sb;
    const cv::Moments m = cv::moments(gt.contact_mask, true);
    if (m.m00 > 0) {
      gt.contact_box = cv::boundingRect(gt.contact_mask);
      gt.contact_point =
          cv::Point2f(static_cast<float>(m.m10 / m.m00), static_cast<float>(m.m01 / m.m00));
    }
  }
  // Sensor noise: Gaussian read noise + signal-dependent shot noise, per channel. Each row
  // reads a window of a fixed table of N(0, 1) samples at a random offset (one draw per row).
  {
    const std::vector<float>& table = internal::normal_table();
    const std::size_t row = 3 * static_cast<std::size_t>(size.width);
    detail::require(table.size() > row, "apply_camera: frame too wide for the noise table");
    Rng rng(derive_seed(seed, 0x5E45));
    const float r[3] = {static_cast<float>(d.read_noise[0] * d.read_noise[0]),
                        static_cast<float>(d.read_noise[1] * d.read_noise[1]),
                        static_cast<float>(d.read_noise[2] * d.read_noise[2])};
    const float shot = static_cast<float>(d.shot_noise);
    for (int y = 0; y < size.height; ++y) {
      float* p = img.ptr<float>(y);
      const float* nz = table.data() + rng.next() % (table.size() - row);
      for (std::size_t i = 0; i < row; ++i)
        p[i] += std::sqrt(r[i % 3] + shot * std::max(p[i], 0.0f)) * nz[i];
    }
    cv::max(img, 0.0, img);
    cv::min(img, 255.0, img);
  }
  // JPEG-like compression: YCrCb, 2x2 chroma subsampling, 8x8 DCT quantisation.
  if (d.jpeg_quality > 0) {
    cv::Mat ycc;
    cv::cvtColor(img, ycc, cv::COLOR_BGR2YCrCb);
    std::array<cv::Mat, 3> ch;
    cv::split(ycc, ch.data());
    internal::jpeg_plane(ch[0], internal::jpeg_luma, d.jpeg_quality);
    for (int c = 1; c < 3; ++c) {
      cv::Mat small;
      cv::resize(ch[static_cast<std::size_t>(c)], small,
                 cv::Size((size.width + 1) / 2, (size.height + 1) / 2), 0, 0, cv::INTER_AREA);
      internal::jpeg_plane(small, internal::jpeg_chroma, d.jpeg_quality);
      cv::resize(small, ch[static_cast<std::size_t>(c)], size, 0, 0, cv::INTER_LINEAR);
    }
    cv::merge(ch.data(), 3, ycc);
    cv::cvtColor(ycc, img, cv::COLOR_YCrCb2BGR);
  }
  img.convertTo(f.image, CV_8U);
}

} // namespace sim
SHADOWSENSE_NAMESPACE_END
