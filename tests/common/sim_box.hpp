// The generator's test box and its calibration, shared by the tests that segment or track
// generator frames (test_track_sim, test_calibration, test_touch_pipeline, test_contact_roc).
//
// sim::Renderer& box_renderer()
//   ensures: one renderer of sim::Rig::tracking_box() per test program, built on first use.
// const SimCalibration& box_calibration()
//   ensures: calibrate_on_sim(box_renderer(), 0xCA11B, 60), computed once per test program; its
//            frames use a seed no test frame uses.
// check_random_tracking_frames(seg)
//   segments 12 random generator frames of each tracking category (nothing, hover, palm, fist,
//   finger; the generator's default mix of lighting; fixed seeds) with seg and checks, per
//   category: no missed box, no false positive, shadow IoU >= 0.85 (hover) / 0.93 (touches),
//   contact IoU >= 0.85 (touches). Used by test_track_sim (the box calibration) and
//   test_calibration (a calibration fitted from box labels): both must meet the same bar.
// Not thread-safe beyond the first call's static initialisation: tests call them from one thread.
#pragma once

#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/sense/segmenter.hpp>

#include <doctest/doctest.h>

namespace shadowsense::test {

inline sim::Renderer& box_renderer() {
  static sim::Renderer r(sim::Rig::tracking_box());
  return r;
}

inline const SimCalibration& box_calibration() {
  static const SimCalibration c = calibrate_on_sim(box_renderer(), 0xCA11B, 60);
  return c;
}

template <class SegmenterT>
void check_random_tracking_frames(SegmenterT& seg) {
  sim::TrackingSampleConfig variety; // the generator's default mix of lighting
  const char* names[] = {"nothing", "hover", "palm", "fist", "finger"};
  for (int c = 0; c < 5; ++c) {
    RunningStats shadow_iou, contact_iou;
    int shadow_miss = 0, contact_miss = 0, shadow_fp = 0, contact_fp = 0;
    for (int i = 0; i < 12; ++i) {
      const sim::Frame f = sim::render_random_tracking_frame(
          box_renderer(), static_cast<sim::TrackCategory>(c), 0x7E57 + 1000 * c + i, variety);
      const Segmentation s = seg.segment(f.image);
      if (f.gt.shadow_box) {
        if (s.shadow_box)
          shadow_iou.add(box_iou(*s.shadow_box, *f.gt.shadow_box));
        else
          ++shadow_miss;
      } else if (s.shadow_box)
        ++shadow_fp;
      if (f.gt.contact_box) {
        if (s.contact_box)
          contact_iou.add(box_iou(*s.contact_box, *f.gt.contact_box));
        else
          ++contact_miss;
      } else if (s.contact_box)
        ++contact_fp;
    }
    INFO(names[c] << ": shadow IoU " << shadow_iou.mean() << " contact IoU " << contact_iou.mean());
    CHECK(shadow_miss == 0);
    CHECK(contact_miss == 0);
    CHECK(shadow_fp == 0);
    CHECK(contact_fp == 0);
    if (c == 1) CHECK(shadow_iou.mean() >= 0.85);
    if (c >= 2) {
      CHECK(shadow_iou.mean() >= 0.93);
      CHECK(contact_iou.mean() >= 0.85);
    }
  }
}

} // namespace shadowsense::test
