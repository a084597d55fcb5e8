// The generated frames the Python tests and the Python overhead bench share with C++: a
// scripted touch sequence on the robot rig (for the C++ == Python comparison) and 40 random
// tracking frames per rig (for the bench), each with the calibration fitted on its rig. Both
// are deterministic (fixed seeds), so the fixture program (fixture.cpp) and the Catch2 bench
// (bench/bench_python.cpp) produce the same pixels.
#pragma once

#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/sim.hpp>

#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

namespace shadowsense::python_fixture {

struct Scenes {
  SegmenterCalibration calibration; // with the empty-skin model
  std::vector<cv::Mat> frames;      // CV_8UC3, BGR
  std::vector<double> timestamps_ms;
};

// 24 frames on the robot rig (635x350): empty skin, a palm coming down, touching and sliding,
// lifted, empty again, a fist coming down and touching.
inline Scenes touch_sequence() {
  sim::Renderer renderer(sim::Rig::robot());
  Scenes out;
  out.calibration = calibrate_on_sim(renderer, 0xC0FFEE, 12).config.calibration;
  sim::User user;
  auto hand = [&](sim::HandShape shape, double x, double height) {
    sim::Scene s;
    sim::HandPose h;
    h.shape = shape;
    h.position_cm = {x, 0};
    h.height_cm = height;
    h.rotation_deg = -90;
    h.arm_elevation_deg = shape == sim::HandShape::fist ? 55 : 35;
    sim::add_hand(s.parts, user, h);
    return s;
  };
  std::vector<sim::Scene> script(3);
  for (double h : {8.0, 3.0, 0.0, 0.0}) script.push_back(hand(sim::HandShape::open, -10, h));
  for (int k = 1; k <= 6; ++k) script.push_back(hand(sim::HandShape::open, -10 + 3 * k, 0));
  for (double h : {3.0, 12.0}) script.push_back(hand(sim::HandShape::open, 8, h));
  for (int k = 0; k < 3; ++k) script.emplace_back();
  for (double h : {4.0, 0.0, 0.0, 0.0, 6.0}) script.push_back(hand(sim::HandShape::fist, 5, h));
  script.emplace_back();
  for (std::size_t i = 0; i < script.size(); ++i) {
    out.frames.push_back(
        renderer.render(script[i], sim::preset(sim::Lighting::daylight), 300 + i).image);
    out.timestamps_ms.push_back(1000.0 + 33.25 * static_cast<double>(i)); // not whole ms
  }
  return out;
}

// 40 random tracking frames (hover, palm, fist, finger, empty in turn) on `rig`, 10 ms apart.
inline Scenes bench_frames(const sim::Rig& rig, std::uint64_t seed) {
  sim::Renderer renderer(rig);
  Scenes out;
  out.calibration = calibrate_on_sim(renderer, seed, 20).config.calibration;
  for (std::uint64_t i = 0; i < 40; ++i) {
    out.frames.push_back(sim::render_random_tracking_frame(renderer,
                                                           static_cast<sim::TrackCategory>(i % 5),
                                                           sim::derive_seed(seed + 1, i))
                             .image);
    out.timestamps_ms.push_back(10.0 * static_cast<double>(i + 1));
  }
  return out;
}

} // namespace shadowsense::python_fixture
