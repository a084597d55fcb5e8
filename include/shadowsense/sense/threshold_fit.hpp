// ThresholdFit (detail): the pixel-count fit both calibrations share - histograms of darkness
// (shadow vs not) and of (darkness, warmth) (contact vs not), and the thresholds that minimise
// the misclassified pixels (sense/fit_calibration.hpp, sense/calibrate_from_frames.hpp).
//
// best_threshold(pos, neg, lo, step) -> t
//   requires: pos and neg of one size n, histograms over bins [lo, lo + n*step).
//   ensures:  the t of "value >= t" with the fewest false positives + false negatives (ties: the
//             lowest).
// ThresholdFit: add(darkness, warmth, shadow_mask, contact_mask) counts a frame's pixels
//   (no mask: every pixel negative); add_shadow / add_contact count one sample; fit(luminance,
//   min_contact_darkness) -> LightThresholds: the shadow threshold, and the contact pair
//   (darkness >= min_contact_darkness) with the fewest misclassified samples; the bins of that
//   pair are kept for last_darkness_bin() / last_warmth_bin() (at 0 or nb: the edge of the
//   searched range). Bins of 0.005 over [-0.5, 1.0); values outside go to the end bins.
// Threading: a plain value; one thread per instance (fit() records the last bins).
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sense/pixel_rule.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <numeric>
#include <vector>

#include <opencv2/core.hpp>

SHADOWSENSE_NAMESPACE_BEGIN

namespace detail {

// Threshold t minimising false positives + false negatives for "value >= t" given histograms of
// positives and negatives over bins [lo, lo + n*step).
inline float best_threshold(const std::vector<double>& pos, const std::vector<double>& neg,
                            float lo, float step) {
  const std::size_t n = pos.size();
  double fn = 0; // positives below bin i
  double fp = std::accumulate(neg.begin(), neg.end(), 0.0);
  double best = fn + fp;
  std::size_t best_i = 0;
  for (std::size_t i = 1; i <= n; ++i) {
    fn += pos[i - 1];
    fp -= neg[i - 1];
    if (fn + fp < best) {
      best = fn + fp;
      best_i = i;
    }
  }
  return lo + step * static_cast<float>(best_i);
}

// Histograms of darkness (shadow vs not) and of (darkness, warmth) (contact vs not), and the
// thresholds minimising misclassified pixels.
class ThresholdFit {
public:
  static constexpr float lo = -0.5f, step = 0.005f;
  static constexpr int nb = 300; // bins over [-0.5, 1.0)

  ThresholdFit() : s_pos_(nb), s_neg_(nb), c_pos_(nb * nb), c_neg_(nb * nb) {}

  void add(const cv::Mat& darkness, const cv::Mat& warmth, const cv::Mat* shadow_mask,
           const cv::Mat* contact_mask) {
    for (int y = 0; y < darkness.rows; ++y) {
      const float* d = darkness.ptr<float>(y);
      const float* w = warmth.ptr<float>(y);
      const uchar* sm = shadow_mask ? shadow_mask->ptr<uchar>(y) : nullptr;
      const uchar* cm = contact_mask ? contact_mask->ptr<uchar>(y) : nullptr;
      for (int x = 0; x < darkness.cols; ++x) {
        const bool c = cm && cm[x];
        const bool s = c || (sm && sm[x]);
        (s ? s_pos_ : s_neg_)[static_cast<std::size_t>(bin(d[x]))] += 1;
        (c ? c_pos_ : c_neg_)[static_cast<std::size_t>(bin(d[x]) * nb + bin(w[x]))] += 1;
      }
    }
  }

  void add_shadow(float d, bool positive) {
    (positive ? s_pos_ : s_neg_)[static_cast<std::size_t>(bin(d))] += 1;
  }
  void add_contact(float d, float w, bool positive) {
    (positive ? c_pos_ : c_neg_)[static_cast<std::size_t>(bin(d) * nb + bin(w))] += 1;
    if (positive) ++contact_positives_;
  }
  double contact_positives() const { return contact_positives_; }
  // The q-quantile of the shadow negatives' darkness (upper edge of its bin; lo when none).
  float negative_quantile(double q) const {
    const double total = std::accumulate(s_neg_.begin(), s_neg_.end(), 0.0);
    double acc = 0;
    for (int i = 0; i < nb; ++i) {
      acc += s_neg_[static_cast<std::size_t>(i)];
      if (total > 0 && acc >= q * total) return lo + step * static_cast<float>(i + 1);
    }
    return lo;
  }
  // Bins of the last fit's contact thresholds (0 or nb: at the edge of the searched range).
  int last_darkness_bin() const { return last_bi_; }
  int last_warmth_bin() const { return last_bj_; }
  static int bin_of(float v) { return bin(v); }

  // min_contact_darkness: the contact darkness threshold searched from here up.
  LightThresholds fit(float luminance, float min_contact_darkness = 0.f) const {
    LightThresholds t;
    t.luminance = luminance;
    t.shadow_darkness = std::clamp(best_threshold(s_pos_, s_neg_, lo, step), 0.f, 1.f);
    // Contact: darkness >= td and warmth >= tw. 2-D suffix sums over the histograms.
    std::vector<double> sp((nb + 1) * (nb + 1)), sn((nb + 1) * (nb + 1));
    auto at = [&](std::vector<double>& v, int i, int j) -> double& {
      return v[static_cast<std::size_t>(i * (nb + 1) + j)];
    };
    for (int i = nb - 1; i >= 0; --i)
      for (int j = nb - 1; j >= 0; --j) {
        const std::size_t k = static_cast<std::size_t>(i * nb + j);
        at(sp, i, j) = c_pos_[k] + at(sp, i + 1, j) + at(sp, i, j + 1) - at(sp, i + 1, j + 1);
        at(sn, i, j) = c_neg_[k] + at(sn, i + 1, j) + at(sn, i, j + 1) - at(sn, i + 1, j + 1);
      }
    const double total_pos = at(sp, 0, 0);
    double best = -1;
    int bi = nb, bj = nb;
    for (int i = bin(std::max(0.f, min_contact_darkness)); i <= nb; ++i)
      for (int j = 0; j <= nb; ++j) {
        const double err = (total_pos - at(sp, i, j)) + at(sn, i, j);
        if (best < 0 || err < best) {
          best = err;
          bi = i;
          bj = j;
        }
      }
    last_bi_ = bi;
    last_bj_ = bj;
    t.contact_darkness = std::clamp(lo + step * static_cast<float>(bi), 0.f, 1.f);
    t.contact_warmth = std::clamp(lo + step * static_cast<float>(bj), -1.f, 1.f);
    return t;
  }

private:
  static int bin(float v) {
    return std::clamp(static_cast<int>(std::floor((v - lo) / step)), 0, nb - 1);
  }
  std::vector<double> s_pos_, s_neg_, c_pos_, c_neg_;
  double contact_positives_ = 0;
  mutable int last_bi_ = 0, last_bj_ = 0;
};

} // namespace detail

SHADOWSENSE_NAMESPACE_END
