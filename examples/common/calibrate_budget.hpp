// ss_calibrate's memory plan (--max-memory-mb): how many decoded frames it may hold so that its
// peak stays within a budget whatever the number of input frames.
//
// estimate(size, frames, labelled) -> bytes: the program itself (kProgramBytes: code, libraries,
//   buffers), the fit's planes (the empty-skin model, its smoothed profile and inverse, the
//   per-frame features: kFitBytesPerPixel a pixel; with labelled touch frames the box search's
//   own segmenter too: kBoxSearchBytesPerPixel; both measured on 3840x2160 with a margin,
//   docs/calibration.md) and `frames` decoded frames (3 bytes a pixel each).
// frames_within(size, budget, labelled) -> the most frames whose estimate is within the budget
//   (0 when the fit alone does not fit).
// split(empty_wanted, touch_wanted, room) -> how many of each to hold with room for `room`
//   frames: all of both when they fit; else the touch frames get at most half the room (at least
//   one when any is wanted) and the empty frames the rest. ok = false when room is too small for
//   one frame of each kind wanted (the caller refuses the run, naming the budget it needs).
// Plain functions (any thread).
#pragma once

#include <opencv2/core.hpp>

#include <algorithm>
#include <cstddef>

namespace calib_budget {

inline constexpr double kMiB = 1024.0 * 1024.0;
inline constexpr double kProgramBytes = 100 * kMiB;
inline constexpr double kFitBytesPerPixel = 66;       // measured 62.6 at 4K
inline constexpr double kBoxSearchBytesPerPixel = 80; // measured 74
inline constexpr double kFrameBytesPerPixel = 3;      // CV_8UC3
inline constexpr long long kDefaultMiB = 900;         // 944 MB: under 1 GB

inline double estimate(cv::Size size, std::size_t frames, bool labelled) {
  const double px = static_cast<double>(size.area());
  return kProgramBytes + (labelled ? kBoxSearchBytesPerPixel : kFitBytesPerPixel) * px +
         kFrameBytesPerPixel * px * static_cast<double>(frames);
}

inline std::size_t frames_within(cv::Size size, double budget_bytes, bool labelled) {
  const double room = budget_bytes - estimate(size, 0, labelled);
  const double frame = kFrameBytesPerPixel * static_cast<double>(std::max(1, size.area()));
  return room <= 0 ? 0 : static_cast<std::size_t>(room / frame);
}

struct Split {
  std::size_t empty = 0, touch = 0;
  bool ok = true;
};

inline Split split(std::size_t empty_wanted, std::size_t touch_wanted, std::size_t room) {
  Split s{empty_wanted, touch_wanted, true};
  if (empty_wanted + touch_wanted <= room) return s;
  const std::size_t need = (empty_wanted ? 1 : 0) + (touch_wanted ? 1 : 0);
  if (room < need)
    return {std::min<std::size_t>(empty_wanted, 1), std::min<std::size_t>(touch_wanted, 1), false};
  s.touch = std::min(touch_wanted, std::max<std::size_t>(touch_wanted ? 1 : 0, room / 2));
  s.empty = std::min(empty_wanted, room - s.touch);
  s.touch = std::min(touch_wanted, room - s.empty); // the empty frames may want less than the rest
  return s;
}

} // namespace calib_budget
