// frame_time: the whole frame of the shipped model, per stage and together, on one core, with
// the heap allocations each stage makes per frame after warm-up. Stages, each timed alone on
// the same generator frames (robot rig, all tracking categories, a fixed seed):
//   segment    Segmenter::segment (shadow + contact masks and blobs)
//   pipeline   TouchPipeline::update (segment + multi-touch ids + one state machine per track)
//   encode     FrameEncoder::run (dark-frame rule, resize, crop, contrast, Normalize)
//   forward    Classifier::classify(tensor) (the DenseNet forward pass + softmax + label)
//   classify   Classifier::classify(frame, out) (encode + forward)
//   frame      pipeline + classify on every frame (no gating)
//   runtime    Runtime::update: the composed type ss_track runs (pipeline + the classifier
//              gated by the shadow + the sinks' OutputFrame); on these frames the gate is
//              closed on the empty-skin fifth
// Times are medians over rounds of the per-frame mean (each round runs every frame once), as
// wall time and as the thread's CPU time (the CPU time is the figure to trust when other
// processes share the machine). Allocations are counted by this program's own global operator
// new (common/counting_new.hpp; the library is not changed for it).
// With --period-ms P the frames come at a camera's pace: each step starts P ms after the
// previous one started, the thread sleeping in between, and only the step is timed. A robot's
// loop runs that way, and the first step after an idle gap can run slower than back-to-back
// rounds show (docs/roofline.md, "At a camera's pace").
//   frame_time [--model PATH] [--frames N] [--rounds R] [--period-ms P] [--json]
#include <shadowsense/backends/densenet/classifier.hpp>
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/runtime/densenet_runtime.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>
#include <shadowsense/sim.hpp>

#include "common/bench_util.hpp"
#include "common/counting_new.hpp"
#include "common/frame_options.hpp"
#include "common/robot_frames.hpp"

#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace ss = shadowsense;
using bench::thread_cpu_ms;

namespace {

constexpr std::string_view usage =
    "usage: frame_time [--model PATH] [--frames N] [--rounds R] [--period-ms P] [--json]\n"
    "       [--help] [--version]\n"
    "Times the whole frame of a model (default models/default.ssm) on one core: segmenter,\n"
    "touch pipeline, frame encoder, forward pass, classify, and all of it together, on robot-rig\n"
    "generator frames; prints per-frame median wall and CPU ms and heap allocations per frame\n"
    "after warm-up.\n"
    "  --period-ms P  start a step every P ms (a camera's pace, e.g. 33.3 for 30 fps), sleeping\n"
    "                 in between, and time the steps only (default 0: back to back)\n";

struct StageResult {
  std::string name;
  double wall_ms = 0, cpu_ms = 0, allocations = 0;
};

// Runs step(i) for every frame index, `rounds` times after one warm-up round; the medians of
// the per-frame means, and the allocations per frame of the measured rounds. With period_ms >
// 0 every step starts period_ms after the one before (sleeping until then) and the per-frame
// means are of the steps alone.
StageResult measure(const std::string& name, int frames, int rounds, double period_ms,
                    const std::function<void(int)>& step) {
  for (int i = 0; i < frames; ++i) step(i); // warm-up: buffers, caches
  using clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<clock::duration>(
      std::chrono::duration<double, std::milli>(period_ms));
  auto next = clock::now();
  std::vector<double> wall, cpu;
  std::size_t allocs = 0;
  for (int r = 0; r < rounds; ++r) {
    counting_new::measuring = true;
    const std::size_t a0 = counting_new::count();
    double wall_ms = 0, cpu_ms = 0;
    if (period_ms > 0) {
      for (int i = 0; i < frames; ++i) {
        next += period;
        std::this_thread::sleep_until(next); // outside the counted region: it may allocate
        const double c0 = thread_cpu_ms();
        const auto t0 = clock::now();
        step(i);
        const auto t1 = clock::now();
        cpu_ms += thread_cpu_ms() - c0;
        wall_ms += std::chrono::duration<double, std::milli>(t1 - t0).count();
      }
    } else {
      const double c0 = thread_cpu_ms();
      const auto t0 = clock::now();
      for (int i = 0; i < frames; ++i) step(i);
      const auto t1 = clock::now();
      cpu_ms = thread_cpu_ms() - c0;
      wall_ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
    }
    allocs += counting_new::count() - a0;
    counting_new::measuring = false;
    wall.push_back(wall_ms / frames);
    cpu.push_back(cpu_ms / frames);
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  return {name, median(wall), median(cpu), double(allocs) / (double(frames) * rounds)};
}

} // namespace

int main(int argc, char** argv) {
  bench::FrameOptions options{.frames = 40};
  const std::string& model_path = options.model_path;
  const int &frames = options.frames, &rounds = options.rounds;
  const bool& json = options.json;
  double period_ms = 0;
  return cli::run("frame_time", [&] {
    cli::Parser p("frame_time", "");
    bench::declare_frame_options(p, usage, options);
    p.option("--period-ms", "P", "start a step every P ms, sleeping in between (0: back to back)",
             period_ms)
        .range(0.0, 10000.0);
    p.parse(argc, argv);
    cv::setNumThreads(1);
    const ss::ModelFile model = ss::ModelFile::load(model_path);
    auto classifier = ss::make_densenet_classifier(model, {.threads = 1});

    const bench::RobotFrames fixture(frames);
    const ss::SimCalibration& calibration = fixture.calibration;
    const std::vector<cv::Mat>& images = fixture.frames;

    ss::Segmenter segmenter = ss::segmenter_from(calibration);
    ss::Segmentation seg;
    ss::TouchPipeline pipeline(ss::segmenter_from(calibration));
    ss::FrameEncoder encoder(ss::FrameEncoder::Config{model.preprocess, ss::ChannelOrder::bgr});
    ss::Tensor input;
    encoder.run(images[0], input);
    ss::Classification result;
    double t_ms = 0;
    std::size_t sink = 0;

    std::vector<StageResult> out;
    out.push_back(measure("segment", frames, rounds, period_ms, [&](int i) {
      segmenter.segment(images[static_cast<std::size_t>(i)], seg);
      sink += seg.shadows.size();
    }));
    out.push_back(measure("pipeline", frames, rounds, period_ms, [&](int i) {
      sink += pipeline.update(images[static_cast<std::size_t>(i)], t_ms += 33.0).tracks.size();
    }));
    out.push_back(measure("encode", frames, rounds, period_ms,
                          [&](int i) { encoder.run(images[static_cast<std::size_t>(i)], input); }));
    out.push_back(measure("forward", frames, rounds, period_ms, [&](int) {
      classifier.classify(input, result);
      sink += static_cast<std::size_t>(result.index);
    }));
    out.push_back(measure("classify", frames, rounds, period_ms, [&](int i) {
      classifier.classify(images[static_cast<std::size_t>(i)], result);
      sink += static_cast<std::size_t>(result.index);
    }));
    out.push_back(measure("frame", frames, rounds, period_ms, [&](int i) {
      const cv::Mat& im = images[static_cast<std::size_t>(i)];
      sink += pipeline.update(im, t_ms += 33.0).tracks.size();
      classifier.classify(im, result);
      sink += static_cast<std::size_t>(result.index);
    }));

    ss::Runtime runtime(ss::TouchPipeline(ss::segmenter_from(calibration)),
                        ss::make_densenet_classifier(model, {.threads = 1}));
    std::size_t classified = 0;
    out.push_back(measure("runtime", frames, rounds, period_ms, [&](int i) {
      const ss::RuntimeFrame& r = runtime.update(images[static_cast<std::size_t>(i)], t_ms += 33.0);
      sink += r.touch.tracks.size() + runtime.output().events.size();
      classified += r.classified;
    }));

    const double parts = out[1].cpu_ms + out[4].cpu_ms;
    if (json) {
      std::printf("{\"model\": \"%s\", \"frame\": [%d, %d], \"input\": [%d, %d], "
                  "\"period_ms\": %.3f, \"stages\": [",
                  model_path.c_str(), images[0].cols, images[0].rows, input.h(), input.w(),
                  period_ms);
      for (std::size_t i = 0; i < out.size(); ++i)
        std::printf("%s{\"stage\": \"%s\", \"wall_ms\": %.4f, \"cpu_ms\": %.4f, "
                    "\"allocations_per_frame\": %.3f}",
                    i ? ", " : "", out[i].name.c_str(), out[i].wall_ms, out[i].cpu_ms,
                    out[i].allocations);
      std::printf("], \"sum_of_parts_cpu_ms\": %.4f, \"checksum\": %zu}\n", parts, sink);
    } else {
      std::printf("model %s, frames %dx%d (robot rig), network input %dx%d, %d frames x %d "
                  "rounds, 1 thread",
                  model_path.c_str(), images[0].cols, images[0].rows, input.w(), input.h(), frames,
                  rounds);
      if (period_ms > 0)
        std::printf(", one step every %.1f ms (sleeping in between; steps timed alone)\n",
                    period_ms);
      else
        std::printf(", back to back\n");
      std::printf(
          "| stage | wall ms/frame | CPU ms/frame | allocations/frame |\n|---|---|---|---|\n");
      for (const auto& s : out)
        std::printf("| %s | %.3f | %.3f | %.2f |\n", s.name.c_str(), s.wall_ms, s.cpu_ms,
                    s.allocations);
      std::printf("sum of parts (pipeline + classify), CPU: %.3f ms; checksum %zu\n", parts, sink);
      std::printf("runtime: the classifier ran on %zu of %zu frame visits (the gate)\n", classified,
                  static_cast<std::size_t>(frames) * static_cast<std::size_t>(rounds + 1));
    }
    return 0;
  });
}
