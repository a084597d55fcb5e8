// CameraHealth: tells a dead, blinded or frozen camera from a skin with hands on it, so that a
// lens cap, the lights going off, a saturated sensor or a frozen driver is reported as a camera
// fault instead of a whole-skin shadow (which the segmenter would track as a touch and the
// classifier read as a hug).
//
// Each update(frame) looks at a grid of samples (every sample_step-th pixel of every
// sample_step-th row) and decides, in this order:
//   dark       at least fault_fraction of the samples have every channel <= dark_level
//              (a lens cap, lights off, a dead sensor: black, or black with a few bright pixels);
//   saturated  at least fault_fraction of the samples have every channel >= saturated_level
//              (the sensor clipped white: nothing of the skin can be seen);
//   frozen     the samples have been byte-identical for frozen_frames frames in a row (a real
//              sensor's noise changes some sample every frame; a stalled driver repeats its
//              buffer). The frame that completes the run is the first reported frozen;
//   none       otherwise.
// Thresholds were set against the project's frames (docs/camera_faults.md): on about 6,000
// generator and rendered real-hand frames, night and daylight, the largest dark fraction seen
// was 0.84 (a night hug: its skin outside the arm still lit) and the largest saturated
// fraction 0.76 (a bright empty skin; 0.92 at >= 254, so only fully clipped pixels count),
// against 0.99 here.
//
// CameraHealthConfig::validate() throws InvalidArgument naming the field: dark_level in
//   [0, 254], saturated_level in [1, 255] and > dark_level, fault_fraction in (0.5, 1],
//   frozen_frames 0 (off) or >= 2, sample_step in [1, 64].
// CameraHealth(config = {})  requires: config.validate() passes.
// update(frame) -> CameraFault
//   requires: nothing: a frame that is empty or not 8-bit with 1, 3 or 4 channels is not judged
//             (none is returned; the segmenter reports what is wrong with it). Its size may
//             change from frame to frame (a new size restarts the frozen count).
//   ensures:  the frame's fault as above; fault() returns it until the next update. No heap
//             allocation.
// reset(): forgets the previous frame (the frozen count starts again).
// The grid's counts and the frozen check's signature come from sense/camera_scan.hpp (an
// AVX-512 kernel where the CPU has one, else a portable loop; the same result from both).
// Threading: one instance per thread (it holds the previous frame's signature); it has no owner
// check of its own: the TouchPipeline that holds it has one.
#pragma once

#include <shadowsense/core/codegen.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/sense/camera_scan.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>

SHADOWSENSE_NAMESPACE_BEGIN

enum class CameraFault { none, dark, saturated, frozen };

inline const char* to_string(CameraFault f) {
  switch (f) {
  case CameraFault::none:
    return "none";
  case CameraFault::dark:
    return "dark";
  case CameraFault::saturated:
    return "saturated";
  case CameraFault::frozen:
    return "frozen";
  }
  return "?";
}

struct CameraHealthConfig {
  bool enabled = true;          // false: every frame is judged none
  int dark_level = 16;          // a sample is dark when every channel is at most this
  int saturated_level = 255;    // a sample is saturated when every channel is at least this
  double fault_fraction = 0.99; // the share of dark (saturated) samples that makes the fault
  int frozen_frames = 30;       // identical frames in a row that make a frozen camera; 0 = off
  int sample_step = 4;          // every n-th pixel of every n-th row is sampled

  void validate() const {
    const auto fail = [](const std::string& what) {
      SHADOWSENSE_THROW(InvalidArgument("CameraHealthConfig: " + what));
    };
    if (!(dark_level >= 0 && dark_level <= 254))
      fail("dark_level is " + std::to_string(dark_level) + "; expected 0..254");
    if (!(saturated_level >= 1 && saturated_level <= 255 && saturated_level > dark_level))
      fail("saturated_level is " + std::to_string(saturated_level) +
           "; expected 1..255 and above dark_level (" + std::to_string(dark_level) + ")");
    if (!(fault_fraction > 0.5 && fault_fraction <= 1.0))
      fail("fault_fraction is " + std::to_string(fault_fraction) + "; expected (0.5, 1]");
    if (!(frozen_frames == 0 || frozen_frames >= 2))
      fail("frozen_frames is " + std::to_string(frozen_frames) + "; expected 0 (off) or >= 2");
    if (!(sample_step >= 1 && sample_step <= 64))
      fail("sample_step is " + std::to_string(sample_step) + "; expected 1..64");
  }
};

namespace detail {
// The scan's view of an 8-bit frame of 1, 3 or 4 channels under a config: alpha is not looked at.
inline CameraScanGrid camera_scan_grid(const cv::Mat& frame, const CameraHealthConfig& config) {
  CameraScanGrid grid;
  grid.data = frame.data;
  grid.row_stride = frame.step[0];
  grid.cols = frame.cols;
  grid.rows = frame.rows;
  grid.channels = frame.channels();
  grid.colour = grid.channels == 1 ? 1 : 3;
  grid.step = config.sample_step;
  grid.dark_level = config.dark_level;
  grid.saturated_level = config.saturated_level;
  return grid;
}
} // namespace detail

class CameraHealth {
public:
  using Config = CameraHealthConfig;

  explicit CameraHealth(const Config& config = {}) : config_(config) { config_.validate(); }

  CameraFault update(const cv::Mat& frame) {
    fault_ = judge(frame);
    return fault_;
  }

  CameraFault fault() const { return fault_; }
  // Frames in a row whose samples equalled the previous frame's (0 after a change).
  int repeated_frames() const { return repeats_; }
  const Config& config() const { return config_; }

  void reset() {
    have_signature_ = false;
    repeats_ = 0;
    fault_ = CameraFault::none;
  }

private:
  CameraFault judge(const cv::Mat& frame) {
    const int channels = frame.channels();
    if (!config_.enabled || frame.empty() || frame.depth() != CV_8U ||
        !(channels == 1 || channels == 3 || channels == 4)) {
      reset();
      return CameraFault::none;
    }
    const detail::CameraScan scan = detail::camera_scan(detail::camera_scan_grid(frame, config_));
    const std::int64_t samples = scan.samples, dark = scan.dark, saturated = scan.saturated;
    const std::uint64_t hash = scan.hash;
    const bool same =
        have_signature_ && hash == signature_ && frame.size() == size_ && channels == channels_;
    repeats_ = same ? repeats_ + 1 : 0;
    signature_ = hash;
    size_ = frame.size();
    channels_ = channels;
    have_signature_ = true;
    const double need = config_.fault_fraction * static_cast<double>(samples);
    if (static_cast<double>(dark) >= need) return CameraFault::dark;
    if (static_cast<double>(saturated) >= need) return CameraFault::saturated;
    if (config_.frozen_frames > 0 && repeats_ + 1 >= config_.frozen_frames)
      return CameraFault::frozen;
    return CameraFault::none;
  }

  Config config_;
  CameraFault fault_ = CameraFault::none;
  bool have_signature_ = false;
  std::uint64_t signature_ = 0;
  cv::Size size_{};
  int channels_ = 0;
  int repeats_ = 0;
};

SHADOWSENSE_NAMESPACE_END
