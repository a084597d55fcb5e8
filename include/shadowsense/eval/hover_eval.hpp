// The hover-height estimate (sense/hover_height.hpp) measured on the scene generator, which
// knows each hand's true height (the tracking dataset does not).
//
// hover_samples_on_sim(renderer, segmenter, seed, frames) -> samples: (penumbra width, core
//   opacity, true height) of the largest shadow blob of `frames` random hover frames rendered
//   with `seed`; frames with no shadow, or whose largest shadow touches, are skipped.
// evaluate_hover_height(renderer, segmenter, fit_seed, test_seed, frames = 200)
//   ensures: a HoverHeightModel fitted on the samples of fit_seed, and its mean absolute and
//            root-mean-square error on those of test_seed, with the error of always answering
//            the mean training height as the baseline (0 errors when no test sample).
// Plain functions; the renderer and segmenter are the caller's (one thread each).
#pragma once

#include <shadowsense/core/version.hpp>
#include <shadowsense/sense/hover_height.hpp>
#include <shadowsense/sense/segmenter.hpp>
#include <shadowsense/sim/sim.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

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
