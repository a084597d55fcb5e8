// Hover height of a shadow that touches nothing (paper 3.1: the shadow blurs and fades as the
// part rises), from two measurements the segmenter makes on each untouched shadow blob: the
// width of its penumbra (Blob::edge_width, px) and the opacity of its core (Blob::opacity).
//
// HoverHeightModel::estimate(edge_width, opacity)
//   ensures: intercept + per_edge_px * edge_width + per_opacity * opacity, clamped at 0 (cm).
// fit_hover_height(samples)
//   requires: at least 3 finite samples that vary enough to determine the three coefficients.
//   ensures:  the least-squares model.
//   throws:   InvalidArgument otherwise.
// Plain values; no shared state (any thread).
#pragma once

#include <shadowsense/core/error.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// Hover height of a shadow that touches nothing, from its penumbra width and core opacity
// (paper 3.1: the shadow blurs and fades as the part rises): height = intercept + per_edge_px *
// edge_width + per_opacity * opacity, clamped at 0. Fit it with fit_hover_height.
struct HoverHeightModel {
  double intercept = 0;
  double per_edge_px = 0;
  double per_opacity = 0;
  double estimate(float edge_width, float opacity) const {
    return std::max(0.0, intercept + per_edge_px * edge_width + per_opacity * opacity);
  }
};

struct HoverSample {
  float edge_width = 0; // Blob::edge_width
  float opacity = 0;    // Blob::opacity
  double height_cm = 0; // true height of the hovering part
};

// Least-squares fit of a HoverHeightModel. Throws InvalidArgument with fewer than 3 samples,
// non-finite values, or samples that do not determine the three coefficients.
inline HoverHeightModel fit_hover_height(const std::vector<HoverSample>& samples) {
  detail::require(samples.size() >= 3, "fit_hover_height: " + std::to_string(samples.size()) +
                                           " samples; expected at least 3");
  cv::Mat a(static_cast<int>(samples.size()), 3, CV_64F),
      b(static_cast<int>(samples.size()), 1, CV_64F);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const HoverSample& s = samples[i];
    detail::require(std::isfinite(s.edge_width) && std::isfinite(s.opacity) &&
                        std::isfinite(s.height_cm),
                    "fit_hover_height: sample " + std::to_string(i) + " is not finite");
    const int r = static_cast<int>(i);
    a.at<double>(r, 0) = 1;
    a.at<double>(r, 1) = s.edge_width;
    a.at<double>(r, 2) = s.opacity;
    b.at<double>(r, 0) = s.height_cm;
  }
  cv::Mat x;
  const cv::Mat ata = a.t() * a;
  detail::require(
      std::abs(cv::determinant(ata)) > 1e-9,
      "fit_hover_height: the samples do not vary enough in edge width and darkness to fit "
      "the model");
  cv::solve(ata, a.t() * b, x, cv::DECOMP_CHOLESKY);
  return {x.at<double>(0), x.at<double>(1), x.at<double>(2)};
}

SHADOWSENSE_NAMESPACE_END
