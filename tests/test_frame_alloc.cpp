// The whole frame allocates nothing after warm-up: TouchPipeline::update (segmenter, tracker,
// state machines) and Classifier::classify (frame encoder + forward pass of the shipped model)
// on robot-rig generator frames: slides (long tracks whose direction window slides) and random
// tracking frames (tracks appearing and ending). Counted by replacing the global operator new in
// this test binary only (bench/common/counting_new.hpp) (AddressSanitizer keeps working: this
// operator new takes precedence over its replacement and the memory still comes from its
// intercepted malloc).
#include <shadowsense/backends/densenet/classifier.hpp>
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/runtime/densenet_runtime.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>
#include <shadowsense/sim.hpp>

#include <doctest/doctest.h>

#include "common/counting_new.hpp"

#include <vector>

using namespace shadowsense;

TEST_CASE("counting operator new sees allocations in this binary") {
  const std::size_t before = counting_new::count();
  std::vector<int> v(100, 7);
  CHECK(v[99] == 7);
  CHECK(counting_new::count() - before >= 1);
}

TEST_CASE("the whole frame (touch pipeline + classifier) allocates nothing after warm-up") {
  sim::Renderer renderer(sim::Rig::robot());
  const SimCalibration calibration = calibrate_on_sim(renderer, 0xA110C, 12);
  std::vector<cv::Mat> frames;
  int i = 0;
  for (sim::SlideGesture g : {sim::SlideGesture::palm, sim::SlideGesture::finger}) {
    sim::SlideConfig config;
    config.max_frames = 16;
    const Direction d = i % 2 ? Direction::left : Direction::front;
    const sim::SlidePlan plan =
        sim::plan_slide(0xA110C + static_cast<std::uint64_t>(i), g, d, config);
    ++i;
    for (int k = 0; k < plan.num_frames(); ++k)
      frames.push_back(sim::render_slide_frame(renderer, plan, k).image);
  }
  for (int k = 0; k < 10; ++k)
    frames.push_back(
        sim::render_random_tracking_frame(renderer, static_cast<sim::TrackCategory>(k % 5),
                                          sim::derive_seed(0xA110D, static_cast<std::uint64_t>(k)))
            .image);
  TouchPipeline pipeline(segmenter_from(calibration));
  const ModelFile model = ModelFile::load(SHADOWSENSE_SOURCE_DIR "/models/default.ssm");
  auto classifier = make_densenet_classifier(model, {.threads = 1});
  Classification result;
  double t = 0;
  std::size_t tracks = 0, events = 0;
  auto run = [&] {
    for (const cv::Mat& f : frames) {
      const TouchFrame& out = pipeline.update(f, t += 33.0);
      tracks += out.tracks.size();
      events += out.events.size();
      classifier.classify(f, result);
    }
  };
  run(); // warm-up: buffers grow to the scene
  const std::size_t before = counting_new::count();
  counting_new::measuring = true;
  run();
  run();
  const std::size_t after = counting_new::count();
  INFO(frames.size() << " frames x 2");
  CHECK(after - before == 0);
  // The frames did exercise the pipeline: tracks and events every round.
  CHECK(tracks > 3 * frames.size() / 2);
  CHECK(events > 0);
}

TEST_CASE("the composed Runtime (touch pipeline + gated classifier + sink frame) allocates "
          "nothing after warm-up") {
  sim::Renderer renderer(sim::Rig::robot());
  const SimCalibration calibration = calibrate_on_sim(renderer, 0xA110C, 12);
  std::vector<cv::Mat> frames;
  for (int k = 0; k < 20; ++k) // every category, also empty skin (the gate closes and opens)
    frames.push_back(
        sim::render_random_tracking_frame(renderer, static_cast<sim::TrackCategory>(k % 5),
                                          sim::derive_seed(0xA110E, static_cast<std::uint64_t>(k)))
            .image);
  const ModelFile model = ModelFile::load(SHADOWSENSE_SOURCE_DIR "/models/default.ssm");
  Runtime sense(TouchPipeline(segmenter_from(calibration)),
                make_densenet_classifier(model, {.threads = 1}));
  double t = 0;
  std::size_t classified = 0, gated = 0, mismatched = 0;
  auto run = [&] {
    for (const cv::Mat& f : frames) {
      const RuntimeFrame& r = sense.update(f, t += 33.0);
      (r.classified ? classified : gated) += 1;
      mismatched += sense.output().frame_index != r.frame_index;
    }
  };
  run(); // warm-up
  const std::size_t before = counting_new::count();
  counting_new::measuring = true;
  run();
  run();
  CHECK(counting_new::count() - before == 0);
  CHECK(mismatched == 0);
  CHECK(classified > 0);
  CHECK(gated > 0);
}
