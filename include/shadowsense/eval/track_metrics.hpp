// Small measures of the tracking evaluation: box IoU, box centre, and a running mean and
// standard deviation.
//
// box_iou(a, b): intersection over union (0 when either box is empty).
// box_centre(r): the centre in pixels, with inclusive pixel coverage (x .. x + w - 1).
// RunningStats: add(v); count(), mean() (0 when empty), sd() (sample standard deviation, 0 for
//   fewer than two values); Welford's update.
// Plain functions; RunningStats is a plain value (one thread per instance).
#pragma once

#include <shadowsense/core/version.hpp>

#include <opencv2/core.hpp>

#include <cmath>
#include <cstddef>

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

SHADOWSENSE_NAMESPACE_END
