// Helpers to measure and calibrate the tracker against the scene generator: box IoU, running
// mean/SD, and a one-call calibration of the Segmenter from frames rendered by the generator
// (empty-skin frames + labelled touch frames with exact masks) - used by ss_track_eval, the
// benchmark and the tests. Calibrate on frames that are NOT in the evaluation set (another seed).
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sense/segmenter.hpp>
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

// A Segmenter config fitted on generator frames (its calibration holds the empty-skin model made
// from `empty_frames`, so save_calibration stores everything) plus those empty-skin frames.
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
  Segmenter model(out.config);
  model.set_empty_skin(out.empty_frames);
  out.config.calibration.empty_skin = model.empty_skin_model().clone();
  return out;
}

// A Segmenter ready to use: the calibration's empty-skin model, or (a calibration without one,
// e.g. loaded from a version-1 file) the model made from the empty frames.
inline Segmenter segmenter_from(const SimCalibration& c) {
  Segmenter s(c.config);
  if (!s.has_empty_skin()) s.set_empty_skin(c.empty_frames);
  return s;
}

// Hover-height samples (penumbra width, core opacity, true height of the hand) from `frames`
// random hover frames rendered with `seed`; frames where no untouched shadow is found are
// skipped. Uses the largest shadow blob.
inline std::vector<HoverSample> hover_samples_on_sim(sim::Renderer& renderer, Segmenter& segmenter,
                                                     std::uint64_t seed, int frames) {
  std::vector<HoverSample> out;
  Segmentation s;
  for (int i = 0; i < frames; ++i) {
    sim::TrackingSample sample;
    const sim::Frame f = sim::render_random_tracking_frame(
        renderer, sim::TrackCategory::hover, sim::derive_seed(seed, static_cast<std::uint64_t>(i)),
        {}, &sample);
    segmenter.segment(f.image, s);
    if (s.shadows.empty() || s.shadows[0].touching) continue;
    out.push_back({s.shadows[0].edge_width, s.shadows[0].opacity, sample.pose.height_cm});
  }
  return out;
}

struct HoverHeightResult {
  HoverHeightModel model;
  std::size_t fit_frames = 0, test_frames = 0;
  double mae_cm = 0, rmse_cm = 0;
  double baseline_mae_cm = 0; // always answering the mean training height
};

// Fits a HoverHeightModel on hover frames rendered with fit_seed and measures it on frames
// rendered with test_seed (the tracking dataset has no heights, the generator does).
inline HoverHeightResult evaluate_hover_height(sim::Renderer& renderer, Segmenter& segmenter,
                                               std::uint64_t fit_seed, std::uint64_t test_seed,
                                               int frames = 200) {
  HoverHeightResult r;
  const std::vector<HoverSample> fit = hover_samples_on_sim(renderer, segmenter, fit_seed, frames);
  const std::vector<HoverSample> test =
      hover_samples_on_sim(renderer, segmenter, test_seed, frames);
  r.model = fit_hover_height(fit);
  r.fit_frames = fit.size();
  r.test_frames = test.size();
  double mean_h = 0;
  for (const HoverSample& h : fit) mean_h += h.height_cm / static_cast<double>(fit.size());
  double se = 0;
  for (const HoverSample& h : test) {
    const double e = r.model.estimate(h.edge_width, h.opacity) - h.height_cm;
    r.mae_cm += std::abs(e);
    se += e * e;
    r.baseline_mae_cm += std::abs(mean_h - h.height_cm);
  }
  if (!test.empty()) {
    const double n = static_cast<double>(test.size());
    r.mae_cm /= n;
    r.rmse_cm = std::sqrt(se / n);
    r.baseline_mae_cm /= n;
  }
  return r;
}

SHADOWSENSE_NAMESPACE_END
