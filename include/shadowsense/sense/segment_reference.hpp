// The segmenter's masks the multi-pass way, as they were made before the one pass over the frame
// (segmenter.hpp): the relative rule over the whole frame in plain loops (skin weight read from
// the model's fourth plane), then each class mask smoothed by OpenCV (cv::GaussianBlur +
// cv::threshold). Slow and plain on purpose: the oracle the one pass and its kernels are tested
// against (tests/test_segment_one_pass.cpp), like gemm_reference.hpp for the GEMM kernels.
//
// reference_relative_masks(bgr, inverse_model, skin, reference, thresholds, mask_blur)
//   requires: what RelativeRule::classify requires of its input (pixel_rule.hpp); mask_blur 0, 1
//             or odd <= 31.
//   ensures:  the shadow and contact masks after smoothing (0/255), and the darkness and warmth
//             planes, of RelativeRule with those thresholds: the Segmenter's
//             shadow_mask, contact_mask, darkness() and warmth() for that frame.
// reference_colour(bgr, inverse_profile, percentile)
//   requires: bgr CV_8UC3; inverse_profile CV_32FC3 of its size (1 / the empty-skin model, 0 off
//             the skin); percentile in (0, 1].
//   ensures:  the frame's reference colour as the segmenter computes it: per channel, that
//             percentile of B / model (quarter-unit bins) over every third pixel of every third
//             row on the skin.
// reference_contours(mask): cv::findContours(mask, RETR_EXTERNAL, CHAIN_APPROX_SIMPLE).
// Plain functions; any thread.
#pragma once

#include <shadowsense/sense/pixel_rule.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

struct ReferenceMasks {
  cv::Mat shadow, contact, darkness, warmth;
};

SHADOWSENSE_STRICT_FP inline ReferenceMasks
reference_relative_masks(const cv::Mat& bgr, const std::array<cv::Mat, 4>& inverse_model,
                         const cv::Mat& skin, cv::Vec3f reference, const LightThresholds& th,
                         int mask_blur) {
  SHADOWSENSE_STRICT_FP_BODY
  ReferenceMasks out;
  const cv::Size size = bgr.size();
  out.shadow.create(size, CV_8UC1);
  out.contact.create(size, CV_8UC1);
  out.darkness.create(size, CV_32F);
  out.warmth.create(size, CV_32F);
  const float gb = 1.f / reference[0], gg = 1.f / reference[1], gr = 1.f / reference[2];
  for (int y = 0; y < size.height; ++y) {
    const uchar* src = bgr.ptr<uchar>(y);
    const uchar* v = skin.ptr<uchar>(y);
    for (int x = 0; x < size.width; ++x) {
      const float qb = static_cast<float>(src[3 * x]) * inverse_model[0].at<float>(y, x) * gb;
      const float qg = static_cast<float>(src[3 * x + 1]) * inverse_model[1].at<float>(y, x) * gg;
      const float qr = static_cast<float>(src[3 * x + 2]) * inverse_model[2].at<float>(y, x) * gr;
      const float d = inverse_model[3].at<float>(y, x) - (qb + qg + qr) * (1.f / 3.f);
      const float w = qr - qb;
      out.darkness.at<float>(y, x) = d;
      out.warmth.at<float>(y, x) = w;
      const uchar contact = (d >= th.contact_darkness && w >= th.contact_warmth) ? v[x] : 0;
      out.contact.at<uchar>(y, x) = contact;
      out.shadow.at<uchar>(y, x) =
          static_cast<uchar>((d >= th.shadow_darkness ? v[x] : uchar(0)) | contact);
    }
  }
  if (mask_blur > 1)
    for (cv::Mat* m : {&out.shadow, &out.contact}) {
      cv::Mat blurred;
      cv::GaussianBlur(*m, blurred, cv::Size(mask_blur, mask_blur), 0, 0, cv::BORDER_REPLICATE);
      cv::threshold(blurred, *m, 127, 255, cv::THRESH_BINARY);
    }
  return out;
}

inline cv::Vec3f reference_colour(const cv::Mat& bgr, const cv::Mat& inverse_profile,
                                  float percentile) {
  constexpr int bins = 1024;
  std::array<std::vector<int>, 3> hist;
  for (auto& h : hist) h.assign(bins, 0);
  int n = 0;
  for (int y = 1; y < bgr.rows; y += 3)
    for (int x = 1; x < bgr.cols; x += 3) {
      const cv::Vec3f inv = inverse_profile.at<cv::Vec3f>(y, x);
      if (inv[0] == 0.f) continue;
      const cv::Vec3b px = bgr.at<cv::Vec3b>(y, x);
      for (int k = 0; k < 3; ++k)
        ++hist[static_cast<std::size_t>(k)][static_cast<std::size_t>(
            std::clamp(static_cast<int>(px[k] * inv[k] * 4.f), 0, bins - 1))];
      ++n;
    }
  const int target = std::max(1, static_cast<int>(std::ceil(percentile * n)));
  cv::Vec3f ref;
  for (int k = 0; k < 3; ++k) {
    int above = n, v = bins - 1;
    for (; v > 0; --v) {
      above -= hist[static_cast<std::size_t>(k)][static_cast<std::size_t>(v)];
      if (above < target) break;
    }
    ref[k] = std::max(1.0f, (static_cast<float>(v) + 0.5f) * 0.25f);
  }
  return ref;
}

inline std::vector<std::vector<cv::Point>> reference_contours(const cv::Mat& mask) {
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  return contours;
}

SHADOWSENSE_NAMESPACE_END
