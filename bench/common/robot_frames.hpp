// The robot rig's generator frames every whole-frame benchmark times (bench_frame, frame_time,
// roofline), so their figures are for the same pixels.
//
// RobotFrames(n)
//   ensures: renderer of sim::Rig::robot(); calibration = calibrate_on_sim(renderer, 0xF0, 50);
//            frames: n tracking frames (CV_8UC3, BGR), category i % 5 (every category in turn),
//            seed derive_seed(0xF1, i). Deterministic: the same n gives the same pixels.
// A plain value; build it on one thread.
#pragma once

#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/sim.hpp>

#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

namespace bench {

struct RobotFrames {
  shadowsense::sim::Renderer renderer{shadowsense::sim::Rig::robot()};
  shadowsense::SimCalibration calibration = shadowsense::calibrate_on_sim(renderer, 0xF0, 50);
  std::vector<cv::Mat> frames;

  explicit RobotFrames(int n) {
    namespace sim = shadowsense::sim;
    for (int i = 0; i < n; ++i)
      frames.push_back(
          sim::render_random_tracking_frame(renderer, static_cast<sim::TrackCategory>(i % 5),
                                            sim::derive_seed(0xF1, static_cast<std::uint64_t>(i)))
              .image);
  }
};

} // namespace bench
