// Helpers to measure and calibrate the tracker against the scene generator: box IoU, running
// mean/SD, and a one-call calibration of the Segmenter from frames rendered by the generator
// (empty-skin frames + labelled touch frames with exact masks) - used by ss_track_eval, the
// benchmark and the tests. Calibrate on frames that are NOT in the evaluation set (another seed).
#pragma once

#include <shadowsense/error.hpp>
#include <shadowsense/segment.hpp>
#include <shadowsense/sim/sim.hpp>

#include <opencv2/core.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// Intersection over union of two boxes (0 when either is empty).
inline double box_iou(const cv::Rect& a, const cv::Rect& b) {
  const double inter = (a & b).area();
  const double uni = static_cast<double>(a.area()) + b.area() - inter;
  return uni > 0 ? inter / uni : 0.0;
}

// Centre of a box in pixels, with inclusive pixel coverage (x .. x + w - 1).
inline cv::Point2d box_centre(const cv::Rect& r) {
  return {r.x + (r.width - 1) / 2.0, r.y + (r.height - 1) / 2.0};
}

// Mean and sample standard deviation, accumulated (Welford).
class RunningStats {
public:
  void add(double v) {
    ++n_;
    const double d = v - mean_;
    mean_ += d / static_cast<double>(n_);
    m2_ += d * (v - mean_);
  }
  std::size_t count() const { return n_; }
  double mean() const { return n_ ? mean_ : 0.0; }
  double sd() const { return n_ > 1 ? std::sqrt(m2_ / static_cast<double>(n_ - 1)) : 0.0; }

private:
  std::size_t n_ = 0;
  double mean_ = 0, m2_ = 0;
};

// A Segmenter config fitted on generator frames plus the empty-skin frames it was fitted with
// (hand them to Segmenter::set_empty_skin).
struct SimCalibration {
  Segmenter::Config config;
  std::vector<cv::Mat> empty_frames;
};

// Renders `frames` random tracking frames (one in five of the empty skin, the rest hover, palm,
// fist and finger in turn) with `seed`, over all lighting presets equally, and fits the
// segmenter's thresholds on them (per light level: one group per preset). Throws
// InvalidArgument for frames < 10.
inline SimCalibration calibrate_on_sim(sim::Renderer& renderer, std::uint64_t seed,
                                       int frames = 100, Segmenter::Config base = {}) {
  detail::require(frames >= 10, "calibrate_on_sim: frames is " + std::to_string(frames) +
                                    "; expected at least 10");
  sim::TrackingSampleConfig variety;
  variety.lighting_weights = {1, 1, 1};
  SimCalibration out;
  std::vector<LabelledFrame> labelled;
  for (int i = 0; i < frames; ++i) {
    const auto category = static_cast<sim::TrackCategory>(i % 5);
    sim::Frame f = sim::render_random_tracking_frame(
        renderer, category, sim::derive_seed(seed, static_cast<std::uint64_t>(i)), variety);
    if (category == sim::TrackCategory::nothing)
      out.empty_frames.push_back(f.image);
    else
      labelled.push_back({f.image, f.gt.shadow_mask, f.gt.contact_mask});
  }
  out.config = base;
  out.config.calibration = fit_calibration(out.empty_frames, labelled, base, 3);
  return out;
}

// A Segmenter ready to use: calibrate_on_sim + set_empty_skin.
inline Segmenter segmenter_from(const SimCalibration& c) {
  Segmenter s(c.config);
  s.set_empty_skin(c.empty_frames);
  return s;
}

SHADOWSENSE_NAMESPACE_END
