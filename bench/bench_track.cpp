// Tracker frames per second on one core (segmentation + multi-touch ids + state machine), at
// 200x205 (tracking rig) and 635x350 (robot rig), printed next to the shadow/contact IoU the
// same segmenter reaches on the same frames (speed is only meaningful next to accuracy).
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/sense/touch_state_machine.hpp>
#include <shadowsense/sense/tracker.hpp>

#include <catch2/catch.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <vector>

using namespace shadowsense;

namespace {

struct Fixture {
  std::vector<sim::Frame> frames;
  Segmenter segmenter;
};

Fixture make(const sim::Rig& rig, std::uint64_t calib_seed, std::uint64_t eval_seed) {
  sim::Renderer renderer(rig);
  Fixture f{{}, segmenter_from(calibrate_on_sim(renderer, calib_seed, 100))};
  for (std::uint64_t i = 0; i < 40; ++i)
    f.frames.push_back(sim::render_random_tracking_frame(
        renderer, static_cast<sim::TrackCategory>(i % 5), sim::derive_seed(eval_seed, i)));
  // Accuracy on exactly these frames.
  RunningStats shadow, contact;
  int missed = 0, false_pos = 0;
  Segmentation s;
  for (const sim::Frame& fr : f.frames) {
    f.segmenter.segment(fr.image, s);
    if (fr.gt.shadow_box && s.shadow_box) shadow.add(box_iou(*fr.gt.shadow_box, *s.shadow_box));
    if (fr.gt.contact_box && s.contact_box)
      contact.add(box_iou(*fr.gt.contact_box, *s.contact_box));
    missed += (fr.gt.shadow_box && !s.shadow_box) + (fr.gt.contact_box && !s.contact_box);
    false_pos += (!fr.gt.shadow_box && s.shadow_box) + (!fr.gt.contact_box && s.contact_box);
  }
  std::printf("%s rig %dx%d, %zu frames (all categories, default lighting mix): shadow IoU %.3f "
              "(n=%zu), contact IoU %.3f (n=%zu), missed %d, false positives %d\n",
              rig.name.c_str(), rig.image_size.width, rig.image_size.height, f.frames.size(),
              shadow.mean(), shadow.count(), contact.mean(), contact.count(), missed, false_pos);
  return f;
}

} // namespace

TEST_CASE("tracker frames per second, with IoU on the same frames") {
  cv::setNumThreads(1);
  Fixture small = make(sim::Rig::tracking_box(), 0xB0, 0xB1);
  Fixture large = make(sim::Rig::robot(), 0xB2, 0xB3);
  Segmentation s;
  ContactTracker tracker;
  TouchStateMachine fsm;
  std::vector<Detection> detections;
  double t = 0;
  std::size_t i = 0;
  auto step = [&](Fixture& f) {
    f.segmenter.segment(f.frames[i++ % f.frames.size()].image, s);
    detections.clear();
    for (const Blob& b : s.contacts) detections.push_back({b.centroid, b.box});
    t += 10;
    tracker.update(detections, t);
    fsm.update(t, {s.shadow_box.has_value(), s.contact_point});
    return s.shadows.size() + s.contacts.size();
  };
  // One benchmark iteration = all 40 frames of the fixture (per-frame time = mean / 40).
  auto all = [&](Fixture& f) {
    std::size_t n = 0;
    for (std::size_t k = 0; k < f.frames.size(); ++k) n += step(f);
    return n;
  };
  BENCHMARK("tracker 200x205 (segment + ids + state machine), 40 frames") {
    return all(small);
  };
  BENCHMARK("tracker 635x350 (segment + ids + state machine), 40 frames") {
    return all(large);
  };
  // The same as frames per second: best of 5 runs of 25 passes (least disturbed by other load).
  for (Fixture* f : {&small, &large}) {
    double best = 1e30;
    for (int run = 0; run < 5; ++run) {
      const auto t0 = std::chrono::steady_clock::now();
      for (int pass = 0; pass < 25; ++pass) all(*f);
      best = std::min(best,
                      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    const double frames = 25.0 * static_cast<double>(f->frames.size());
    std::printf("tracker %dx%d: %.0f frames/s on one core (best of 5 runs of %.0f frames)\n",
                f->frames[0].image.cols, f->frames[0].image.rows, frames / best, frames);
  }
}
