// fit_calibration: the segmenter's thresholds and colour ranges fitted on frames labelled pixel
// by pixel (generator renders, a painting tool), the empty skin's frames optional.
//
// fit_calibration(empty_frames, touch_frames, base, light_groups)
//   requires: at least one touch frame; every frame CV_8UC3; every mask CV_8UC1 of its image's
//             size; light_groups >= 0 (0 = automatic).
//   ensures:  relative-mode thresholds (shadow_darkness; contact_darkness and contact_warmth
//             jointly) minimising misclassified pixels over all frames, per light group when
//             light_groups > 1, and the fixed-mode colour ranges; base's other fields kept.
//   throws:   InvalidArgument.
// A robot's own frames (empty skin plus coarse boxes or no labels) are calibrated by
// calibrate_from_frames (sense/calibrate_from_frames.hpp). sense/calibration.hpp includes both.
// Plain functions; no shared state (any thread).
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/core/image_check.hpp>
#include <shadowsense/sense/segmenter.hpp>
#include <shadowsense/sense/threshold_fit.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <numeric>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// A touch frame with its labels: masks of the same size, CV_8UC1, non-zero = pixel in the class.
// The contact pixels should also be marked in shadow_mask (a contact is part of the shadow); the
// fit treats them so either way.
struct LabelledFrame {
  cv::Mat image;
  cv::Mat shadow_mask;
  cv::Mat contact_mask;
};

namespace detail {

inline void require_label_mask(const cv::Mat& m, const cv::Mat& image, const std::string& name) {
  require(!m.empty() && m.type() == CV_8UC1 && m.size() == image.size(),
          name + " must be a CV_8UC1 mask of the image's size (" + std::to_string(image.cols) +
              "x" + std::to_string(image.rows) + ")");
}

inline cv::Vec3b channel_percentile(const std::array<std::array<double, 256>, 3>& h, double p) {
  cv::Vec3b out;
  for (int k = 0; k < 3; ++k) {
    const double total = std::accumulate(h[k].begin(), h[k].end(), 0.0);
    double acc = 0;
    int v = 0;
    for (; v < 255; ++v) {
      acc += h[k][v];
      if (acc >= p * total && acc > 0) break;
    }
    out[k] = static_cast<uchar>(v);
  }
  return out;
}

} // namespace detail

// Fits the relative-mode thresholds (shadow_darkness; contact_darkness and contact_warmth jointly)
// by minimising misclassified pixels over all given frames, and the fixed-mode colour ranges
// (contact: the 0.5..99.5 percentiles of contact pixels per channel; shadow: from the 0.1
// percentile of shadow pixels up to just below the 1st percentile of empty-skin pixels). `base`
// supplies the pre-blur and reference percentile the fitted values will be used with; the
// returned calibration keeps base's mode. Throws InvalidArgument if no touch frame is given, a
// frame is not an 8-bit colour image, or a mask does not match its image.
inline SegmenterCalibration fit_calibration(const std::vector<cv::Mat>& empty_frames,
                                            const std::vector<LabelledFrame>& touch_frames,
                                            const Segmenter::Config& base = {},
                                            int light_groups = 0) {
  detail::require(!touch_frames.empty(),
                  "fit_calibration: no labelled touch frames; expected at least one");
  for (std::size_t i = 0; i < empty_frames.size(); ++i)
    require_colour_image(empty_frames[i],
                         ("fit_calibration: empty_frames[" + std::to_string(i) + "]").c_str());
  for (std::size_t i = 0; i < touch_frames.size(); ++i) {
    const std::string n = "fit_calibration: touch_frames[" + std::to_string(i) + "]";
    require_colour_image(touch_frames[i].image, (n + ".image").c_str());
    detail::require_label_mask(touch_frames[i].shadow_mask, touch_frames[i].image,
                               n + ".shadow_mask");
    detail::require_label_mask(touch_frames[i].contact_mask, touch_frames[i].image,
                               n + ".contact_mask");
  }
  // Features with the relative mode on each frame's own reference.
  Segmenter::Config cfg = base;
  cfg.calibration.mode = SegmentMode::relative;
  cfg.calibration.by_light.clear();
  cfg.adaptive = false;
  cfg.mask_blur = 0;
  Segmenter seg(cfg);
  if (!empty_frames.empty()) seg.set_empty_skin(empty_frames);
  Segmentation scratch;
  // Pass 1: each frame's reference luminance, to group frames by light level.
  std::vector<const cv::Mat*> images;
  for (const cv::Mat& e : empty_frames) images.push_back(&e);
  for (const LabelledFrame& f : touch_frames) images.push_back(&f.image);
  std::vector<float> lum(images.size());
  for (std::size_t i = 0; i < images.size(); ++i) {
    seg.segment(*images[i], scratch);
    lum[i] = detail::luminance(seg.last_reference());
  }
  // Groups: equal-count quantiles of the labelled frames' luminance.
  int groups = light_groups;
  if (groups == 0) groups = std::clamp(static_cast<int>(touch_frames.size()) / 8, 1, 6);
  detail::require(groups >= 1, "fit_calibration: light_groups must be >= 0");
  std::vector<float> sorted(lum.begin() + static_cast<std::ptrdiff_t>(empty_frames.size()),
                            lum.end());
  std::sort(sorted.begin(), sorted.end());
  std::vector<float> upper_edge; // group g holds luminance <= upper_edge[g]
  for (int g = 1; g < groups; ++g)
    upper_edge.push_back(
        sorted[static_cast<std::size_t>(g) * sorted.size() / static_cast<std::size_t>(groups)]);
  auto group_of = [&](float l) {
    return static_cast<int>(std::upper_bound(upper_edge.begin(), upper_edge.end(), l) -
                            upper_edge.begin());
  };
  std::vector<detail::ThresholdFit> fits(static_cast<std::size_t>(groups) + 1); // last = all
  std::vector<std::vector<float>> group_lum(static_cast<std::size_t>(groups));
  std::array<std::array<double, 256>, 3> h_contact{}, h_shadow{}, h_empty{};
  for (std::size_t i = 0; i < images.size(); ++i) {
    const bool labelled = i >= empty_frames.size();
    const LabelledFrame* lf = labelled ? &touch_frames[i - empty_frames.size()] : nullptr;
    seg.segment(*images[i], scratch);
    const int g = group_of(lum[i]);
    if (labelled) group_lum[static_cast<std::size_t>(g)].push_back(lum[i]);
    const cv::Mat* sm = lf ? &lf->shadow_mask : nullptr;
    const cv::Mat* cm = lf ? &lf->contact_mask : nullptr;
    fits[static_cast<std::size_t>(g)].add(seg.darkness(), seg.warmth(), sm, cm);
    fits.back().add(seg.darkness(), seg.warmth(), sm, cm);
    cv::Mat smooth;
    if (cfg.pre_blur > 1)
      cv::blur(*images[i], smooth, cv::Size(cfg.pre_blur, cfg.pre_blur), cv::Point(-1, -1),
               cv::BORDER_REPLICATE);
    else
      smooth = *images[i];
    for (int y = 0; y < smooth.rows; ++y) {
      const cv::Vec3b* px = smooth.ptr<cv::Vec3b>(y);
      for (int x = 0; x < smooth.cols; ++x) {
        const bool c = cm && cm->at<uchar>(y, x);
        const bool s = c || (sm && sm->at<uchar>(y, x));
        auto& h = c ? h_contact : (s ? h_shadow : h_empty);
        for (int k = 0; k < 3; ++k) h[k][px[x][k]] += 1;
      }
    }
  }
  SegmenterCalibration cal = base.calibration;
  const LightThresholds all = fits.back().fit(0);
  cal.shadow_darkness = all.shadow_darkness;
  cal.contact_darkness = all.contact_darkness;
  cal.contact_warmth = all.contact_warmth;
  cal.by_light.clear();
  if (groups > 1)
    for (int g = 0; g < groups; ++g) {
      auto& gl = group_lum[static_cast<std::size_t>(g)];
      if (gl.empty()) continue;
      std::sort(gl.begin(), gl.end());
      const float median = gl[gl.size() / 2];
      if (!cal.by_light.empty() && median <= cal.by_light.back().luminance) continue;
      cal.by_light.push_back(fits[static_cast<std::size_t>(g)].fit(median));
    }

  // Fixed ranges (the paper's mode), for comparison and for rigs with constant light.
  if (std::accumulate(h_contact[0].begin(), h_contact[0].end(), 0.0) > 0)
    cal.contact_range = {detail::channel_percentile(h_contact, 0.005),
                         detail::channel_percentile(h_contact, 0.995)};
  auto merged = h_shadow;
  for (int k = 0; k < 3; ++k)
    for (int v = 0; v < 256; ++v) merged[k][v] += h_contact[k][v];
  if (std::accumulate(merged[0].begin(), merged[0].end(), 0.0) > 0) {
    cv::Vec3b lower = detail::channel_percentile(merged, 0.001);
    cv::Vec3b upper = detail::channel_percentile(merged, 0.99);
    if (std::accumulate(h_empty[0].begin(), h_empty[0].end(), 0.0) > 0) {
      const cv::Vec3b empty_low = detail::channel_percentile(h_empty, 0.01);
      for (int k = 0; k < 3; ++k)
        upper[k] =
            static_cast<uchar>(std::max<int>(lower[k], std::min<int>(upper[k], empty_low[k] - 1)));
    }
    cal.shadow_range = {lower, upper};
  }
  detail::validate_calibration(cal, "fit_calibration");
  return cal;
}

SHADOWSENSE_NAMESPACE_END
