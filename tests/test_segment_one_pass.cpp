// The segmenter's one pass over the frame (classify, smooth, contour image, row by row) against
// the multi-pass way: on generator frames (every tracking category, all three lighting presets,
// several seeds) and on frames with the real hand silhouettes of data/realhand, the masks,
// darkness and warmth must equal those of the plain multi-pass reference
// (sense/segment_reference.hpp: the rule in plain loops + cv::GaussianBlur + cv::threshold) with
// 0 differing pixels, and every blob must equal the one the multi-pass path of the segmenter
// itself finds (whole-frame rule, MaskSmoother::apply, BlobFinder::find). Also for the other
// mask_blur sizes (0, 3 and 7, which takes the multi-pass path), the paper's fixed colour ranges,
// and the adaptive model over a sequence. Every available per-row kernel is checked on the
// frames' rows against the portable one. Each blob's area, centroid and mean darkness are also
// checked against their definition, cv::moments and cv::mean over the blob's box, bit for bit.
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/sense/segment_reference.hpp>
#include <shadowsense/sense/segmenter.hpp>
#include <shadowsense/sim.hpp>

#include <doctest/doctest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

using namespace shadowsense;
namespace fs = std::filesystem;

namespace {

// The rule of Segmenter without the row interface: the segmenter takes its multi-pass path.
struct WholeFrameOnly {
  CalibratedRule rule;
  bool uses_reference() const { return rule.uses_reference(); }
  void classify(const PixelRuleInput& in, PixelRuleOutput& out) const { rule.classify(in, out); }
};
static_assert(PixelRule<WholeFrameOnly> && !RowPixelRule<WholeFrameOnly>);

int differing(const cv::Mat& a, const cv::Mat& b) {
  REQUIRE(a.size() == b.size());
  REQUIRE(a.type() == b.type());
  cv::Mat ne;
  cv::compare(a.reshape(1), b.reshape(1), ne, cv::CMP_NE);
  return cv::countNonZero(ne);
}

void check_same_blobs(const std::vector<Blob>& a, const std::vector<Blob>& b) {
  REQUIRE(a.size() == b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    CAPTURE(i);
    CHECK(a[i].box == b[i].box);
    CHECK(a[i].centroid == b[i].centroid);
    CHECK(a[i].area == b[i].area);
    CHECK(a[i].darkness == b[i].darkness);
    CHECK(a[i].edge_width == b[i].edge_width);
    CHECK(a[i].opacity == b[i].opacity);
    CHECK(a[i].touching == b[i].touching);
    CHECK(a[i].hover_height_cm == b[i].hover_height_cm);
  }
}

// Area, centroid and mean darkness of each blob as the segmenter defines them:
// cv::moments(mask(box), true) and cv::mean(darkness(box), mask(box)), bit for bit (the
// segmenter sums them itself in one pass over the box).
void check_blob_sums(const std::vector<Blob>& blobs, const cv::Mat& mask, const cv::Mat& darkness) {
  for (std::size_t i = 0; i < blobs.size(); ++i) {
    CAPTURE(i);
    const Blob& b = blobs[i];
    const cv::Moments m = cv::moments(mask(b.box), true);
    CHECK(b.area == m.m00);
    REQUIRE(m.m00 > 0);
    CHECK(b.centroid == cv::Point2f(static_cast<float>(b.box.x + m.m10 / m.m00),
                                    static_cast<float>(b.box.y + m.m01 / m.m00)));
    if (!darkness.empty())
      CHECK(b.darkness == static_cast<float>(cv::mean(darkness(b.box), mask(b.box))[0]));
  }
}

// The model planes the rule reads, rebuilt from the segmenter's public state: the inverse of
// the profile rounded to the nearest binary16 (OpenCV's rounding; `half` false: not rounded).
std::array<cv::Mat, 4> model_planes(const Segmenter& s, cv::Size size, bool half = true) {
  std::array<cv::Mat, 4> planes;
  if (!s.has_empty_skin()) {
    for (cv::Mat& p : planes) p = cv::Mat(size, CV_32F, cv::Scalar(1));
    return planes;
  }
  const cv::Mat& profile = s.empty_skin_profile();
  cv::Mat inv(profile.size(), CV_32FC3);
  for (int y = 0; y < profile.rows; ++y)
    for (int x = 0; x < profile.cols; ++x)
      for (int k = 0; k < 3; ++k) {
        const float p = profile.at<cv::Vec3f>(y, x)[k];
        const float v = p > 0 ? 1.f / p : 0.f;
        inv.at<cv::Vec3f>(y, x)[k] = half ? static_cast<float>(cv::float16_t(v)) : v;
      }
  cv::split(inv, planes.data());
  s.skin_area().convertTo(planes[3], CV_32F, 1.0 / 255);
  return planes;
}

cv::Mat skin_of(const Segmenter& s, cv::Size size) {
  return s.has_empty_skin() ? s.skin_area() : cv::Mat(size, CV_8UC1, cv::Scalar(255));
}

// One frame through the one pass (`one`) and the multi-pass path (`multi`), both fed every
// frame; checks masks, features and blobs. Returns the shadow pixels (so callers can check the
// frames are not all empty).
int check_frame(Segmenter& one, BasicSegmenter<WholeFrameOnly>& multi, const cv::Mat& frame) {
  // The reference reads the model as it is before this frame (the adaptive update comes after).
  const std::array<cv::Mat, 4> planes = model_planes(one, frame.size());
  cv::Mat inverse_profile;
  if (one.has_empty_skin()) cv::merge(planes.data(), 3, inverse_profile);
  const cv::Mat skin = skin_of(one, frame.size()).clone();
  Segmentation a, b;
  one.segment(frame, a);
  multi.segment(frame, b);
  CHECK(differing(a.shadow_mask, b.shadow_mask) == 0);
  CHECK(differing(a.contact_mask, b.contact_mask) == 0);
  check_same_blobs(a.shadows, b.shadows);
  check_same_blobs(a.contacts, b.contacts);
  CHECK(a.dropped_shadow_blobs == b.dropped_shadow_blobs);
  CHECK(a.dropped_contact_blobs == b.dropped_contact_blobs);
  CHECK(a.contact_point == b.contact_point);
  const SegmenterCalibration& c = one.config().calibration;
  const cv::Mat no_darkness;
  const cv::Mat& darkness = c.mode == SegmentMode::relative ? one.darkness() : no_darkness;
  check_blob_sums(a.shadows, a.shadow_mask, darkness);
  check_blob_sums(a.contacts, a.contact_mask, darkness);
  if (c.mode == SegmentMode::relative) {
    const cv::Vec3f ref = one.last_reference();
    if (!inverse_profile.empty())
      CHECK(ref == reference_colour(frame, inverse_profile, c.reference_percentile));
    const RelativeRule rule{c.shadow_darkness, c.contact_darkness, c.contact_warmth, c.by_light};
    const ReferenceMasks r = reference_relative_masks(frame, planes, skin, ref,
                                                      rule.thresholds_at(detail::luminance(ref)),
                                                      one.config().mask_blur);
    CHECK(differing(a.shadow_mask, r.shadow) == 0);
    CHECK(differing(a.contact_mask, r.contact) == 0);
    CHECK(differing(one.darkness(), r.darkness) == 0);
    CHECK(differing(one.warmth(), r.warmth) == 0);
  }
  return cv::countNonZero(a.shadow_mask);
}

struct Fixture {
  sim::Renderer renderer{sim::Rig::robot()};
  SimCalibration calibration = calibrate_on_sim(renderer, 0x0E, 30);

  std::vector<cv::Mat> generated_frames() {
    sim::TrackingSampleConfig variety;
    variety.lighting_weights = {1, 1, 1};
    std::vector<cv::Mat> frames;
    for (std::uint64_t seed = 0; seed < 4; ++seed)
      for (const sim::TrackCategory c : sim::all_track_categories)
        frames.push_back(
            sim::render_random_tracking_frame(
                renderer, c, sim::derive_seed(0x51 + seed, static_cast<int>(c)), variety)
                .image);
    return frames;
  }

  // Gesture frames with the real hand silhouettes (every gesture, randomised lighting).
  std::vector<cv::Mat> realhand_frames() {
    const fs::path dir = fs::path(SHADOWSENSE_SOURCE_DIR) / "data" / "realhand";
    REQUIRE(fs::exists(dir / "manifest.csv"));
    auto hands = std::make_shared<const std::vector<sim::HandSilhouette>>(
        sim::load_hand_silhouettes(dir, ""));
    sim::GestureSessionConfig config{.frames_per_gesture = 2, .randomise = true};
    config.real_hands = hands;
    config.real_hand_probability = 1;
    sim::User user;
    user.id = 7;
    const sim::GestureSession session(0x77, user, 0.4, config);
    std::vector<cv::Mat> frames;
    sim::Frame f;
    for (int i = 0; i < session.size(); ++i) {
      session.render(renderer, i, f);
      frames.push_back(f.image.clone());
    }
    return frames;
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

void check_frames(const SegmenterConfig& config, const std::vector<cv::Mat>& frames) {
  Segmenter one(config);
  BasicSegmenter<WholeFrameOnly> multi(config, WholeFrameOnly{CalibratedRule(config.calibration)});
  int shadow = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    CAPTURE(i);
    shadow += check_frame(one, multi, frames[i]);
  }
  CHECK(shadow > 0); // the frames have shadows to compare
}

} // namespace

TEST_CASE("one pass == multi-pass on generator frames, every category and light") {
  Fixture& f = fixture();
  const std::vector<cv::Mat> frames = f.generated_frames();
  for (const int blur : {5, 0, 3, 7}) {
    CAPTURE(blur);
    SegmenterConfig c = f.calibration.config;
    c.mask_blur = blur;
    check_frames(c, frames);
  }
}

TEST_CASE("one pass == multi-pass on frames of real hand silhouettes") {
  Fixture& f = fixture();
  check_frames(f.calibration.config, f.realhand_frames());
}

TEST_CASE("one pass == multi-pass: fixed colour ranges, and the adaptive model over a sequence") {
  Fixture& f = fixture();
  const std::vector<cv::Mat> frames = f.generated_frames();
  SegmenterConfig fixed = f.calibration.config;
  fixed.calibration.mode = SegmentMode::fixed_ranges;
  fixed.calibration.shadow_range = {{0, 0, 0}, {150, 150, 150}};
  check_frames(fixed, frames);
  SegmenterConfig adaptive = f.calibration.config;
  adaptive.adaptive = true;
  adaptive.adapt_rate = 0.2f;
  check_frames(adaptive, frames);
  SegmenterConfig uncalibrated; // no model: the flat stand-in planes
  check_frames(uncalibrated, frames);
}

TEST_CASE("every per-row kernel equals the portable one on the frames' rows") {
  Fixture& f = fixture();
  Segmenter seg(f.calibration.config);
  std::vector<cv::Mat> frames = f.generated_frames();
  for (const cv::Mat& m : f.realhand_frames()) frames.push_back(m);
  const detail::SegmentKernels& portable = segment_kernels(SegmentKernelKind::portable);
  int kinds = 0;
  const std::array<SegmentKernelKind, 3> vector_kinds{
      SegmentKernelKind::avx512, SegmentKernelKind::avx2, SegmentKernelKind::neon};
  for (const SegmentKernelKind kind : vector_kinds) {
    if (!segment_cpu_has(kind)) continue;
    ++kinds;
    CAPTURE(segment_kernel_name(kind));
    const detail::SegmentKernels& k = segment_kernels(kind);
    REQUIRE(k.kind == kind);
    for (const cv::Mat& frame : frames) {
      Segmentation s;
      seg.segment(frame, s); // the frame's reference
      const std::array<cv::Mat, 4> planes = model_planes(seg, frame.size());
      std::array<cv::Mat, 3> half;
      for (std::size_t k = 0; k < 3; ++k) planes[k].convertTo(half[k], CV_16F); // exact
      const cv::Vec3f ref = seg.last_reference();
      const detail::RelativeRowParams p{1.f / ref[0], 1.f / ref[1], 1.f / ref[2],
                                        0.2f,         0.45f,        0.08f};
      const int w = frame.cols;
      std::vector<float> d1(static_cast<std::size_t>(w)), w1(d1), d2(d1), w2(d1);
      std::vector<std::uint8_t> s1(static_cast<std::size_t>(w)), c1(s1), s2(s1), c2(s1);
      int differ = 0;
      for (int y = 0; y < frame.rows; ++y) {
        auto run = [&](const detail::SegmentKernels& kk, float* d, float* wm, std::uint8_t* sm,
                       std::uint8_t* cm) {
          kk.relative_row(p, frame.ptr<std::uint8_t>(y), half[0].ptr<std::uint16_t>(y),
                          half[1].ptr<std::uint16_t>(y), half[2].ptr<std::uint16_t>(y),
                          seg.skin_area().ptr<std::uint8_t>(y), w, d, wm, sm, cm);
        };
        run(portable, d1.data(), w1.data(), s1.data(), c1.data());
        run(k, d2.data(), w2.data(), s2.data(), c2.data());
        differ += d1 != d2 || w1 != w2 || s1 != s2 || c1 != c2;
      }
      CHECK(differ == 0);
    }
  }
  CHECK(kinds == std::count_if(vector_kinds.begin(), vector_kinds.end(),
                               [](SegmentKernelKind k) { return segment_cpu_has(k); }));
}

// The segmenter reads the empty-skin model's inverse rounded to binary16 (segmenter.hpp). Against
// the float model it replaced (the reference colour, thresholds and masks all made from the
// unrounded inverse, by the multi-pass oracle): the masks may differ only where a pixel's
// darkness or warmth lies within the rounding (a relative 2^-11 of its q) of a threshold.
TEST_CASE("the binary16 model against the float one: the masks of generator and real-hand frames "
          "within 1 in 10^4 pixels") {
  Fixture& f = fixture();
  std::vector<cv::Mat> frames = f.generated_frames();
  for (const cv::Mat& m : f.realhand_frames()) frames.push_back(m);
  Segmenter seg(f.calibration.config);
  const SegmenterCalibration& c = seg.config().calibration;
  REQUIRE(c.mode == SegmentMode::relative);
  const RelativeRule rule{c.shadow_darkness, c.contact_darkness, c.contact_warmth, c.by_light};
  double pixels = 0, shadow_differ = 0, contact_differ = 0, shadow_pixels = 0;
  int reference_differ = 0;
  float worst_darkness =
      0; // max |darkness (binary16) - darkness (float)| where the references agree
  for (std::size_t i = 0; i < frames.size(); ++i) {
    CAPTURE(i);
    const cv::Mat& frame = frames[i];
    Segmentation a;
    seg.segment(frame, a);
    const std::array<cv::Mat, 4> planes = model_planes(seg, frame.size(), false);
    cv::Mat inverse_profile;
    cv::merge(planes.data(), 3, inverse_profile);
    const cv::Vec3f ref = reference_colour(frame, inverse_profile, c.reference_percentile);
    const ReferenceMasks r = reference_relative_masks(frame, planes, seg.skin_area(), ref,
                                                      rule.thresholds_at(detail::luminance(ref)),
                                                      seg.config().mask_blur);
    pixels += static_cast<double>(frame.total());
    shadow_differ += differing(a.shadow_mask, r.shadow);
    contact_differ += differing(a.contact_mask, r.contact);
    shadow_pixels += cv::countNonZero(r.shadow);
    if (ref == seg.last_reference()) {
      cv::Mat diff;
      cv::absdiff(seg.darkness(), r.darkness, diff);
      double hi = 0;
      cv::minMaxLoc(diff, nullptr, &hi);
      worst_darkness = std::max(worst_darkness, static_cast<float>(hi));
    } else {
      ++reference_differ;
    }
  }
  MESSAGE("binary16 against float model over ", frames.size(), " frames: shadow pixels differing ",
          shadow_differ, ", contact ", contact_differ, " of ", pixels, " (shadow pixels ",
          shadow_pixels, "); frames whose reference differs ", reference_differ,
          "; max |darkness difference| where it agrees ", worst_darkness);
  CHECK(shadow_pixels > 0.01 * pixels); // the frames have shadows to compare
  CHECK(shadow_differ <= 1e-4 * pixels);
  CHECK(contact_differ <= 1e-4 * pixels);
  // q <= 3 (a pixel three times the lit skin), each inverse within 2^-11 of its float
  CHECK(worst_darkness <= 3.f * std::ldexp(1.f, -11));
}
