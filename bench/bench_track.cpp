// Tracker frames per second on one core (segmentation + multi-touch ids + state machine), at
// 200x205 (tracking rig) and 635x350 (robot rig), printed next to the shadow/contact IoU the
// same segmenter reaches on the same frames (speed is only meaningful next to accuracy).
#include <shadowsense/fsm.hpp>
#include <shadowsense/track.hpp>
#include <shadowsense/track_eval.hpp>

#include <catch2/catch.hpp>

#include <opencv2/core.hpp>

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
  BENCHMARK("tracker 200x205 (segment + ids + state machine), one frame") {
    return step(small);
  };
  BENCHMARK("tracker 635x350 (segment + ids + state machine), one frame") {
    return step(large);
  };
  BENCHMARK("segment only 200x205, one frame") {
    small.segmenter.segment(small.frames[i++ % small.frames.size()].image, s);
    return s.shadows.size();
  };
}
