// The Segmenter calibrated on frames of the scene generator (empty-skin frames + touch frames
// labelled by the generator's exact masks), for ss_track_eval, the benchmarks and the tests.
// Calibrate on frames that are NOT in the evaluated set (another seed).
//
// calibrate_on_sim(renderer, seed, frames = 100, base = {}) -> SimCalibration
//   requires: frames >= 10 (InvalidArgument).
//   ensures:  base with the thresholds fitted (fit_calibration, three light groups) on `frames`
//             random tracking frames rendered with `seed` (one in five empty, the rest hover,
//             palm, fist and finger in turn, all lighting presets equally), and the empty-skin
//             model made from the empty frames; those frames kept in SimCalibration.
// segmenter_from(c) -> Segmenter: c's calibration, its empty-skin model made from c's empty
//   frames when the calibration has none.
// Plain functions; the renderer is the caller's (one thread per renderer).
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sense/fit_calibration.hpp>
#include <shadowsense/sense/segmenter.hpp>
#include <shadowsense/sim/sim.hpp>

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

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

SHADOWSENSE_NAMESPACE_END
