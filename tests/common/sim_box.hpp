// The generator's test box and its calibration, shared by the tests that segment or track
// generator frames (test_track_sim, test_touch_pipeline, test_contact_roc).
//
// sim::Renderer& box_renderer()
//   ensures: one renderer of sim::Rig::tracking_box() per test program, built on first use.
// const SimCalibration& box_calibration()
//   ensures: calibrate_on_sim(box_renderer(), 0xCA11B, 60), computed once per test program; its
//            frames use a seed no test frame uses.
// Not thread-safe beyond the first call's static initialisation: tests call them from one thread.
#pragma once

#include <shadowsense/eval/track_eval.hpp>

namespace shadowsense::test {

inline sim::Renderer& box_renderer() {
  static sim::Renderer r(sim::Rig::tracking_box());
  return r;
}

inline const SimCalibration& box_calibration() {
  static const SimCalibration c = calibrate_on_sim(box_renderer(), 0xCA11B, 60);
  return c;
}

} // namespace shadowsense::test
