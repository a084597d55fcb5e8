// The whole frame of the shipped model (models/default.ssm) on one core, per stage and
// together, on robot-rig generator frames: segmenter, touch pipeline (segmenter + ids + state
// machines), frame encoder, forward pass, classify (encode + forward) and the whole frame
// (pipeline + classify); and the frame encoder alone with each input encoding (the shipped
// model's geometry, the sim calibration's empty skin). One benchmark iteration = every fixture
// frame once (per-frame time = mean / frames). bench/frame_time prints the same stages as a table
// with heap allocations per frame. Last, the segmenter's reference samples (the one gather of
// its pass) per kernel, on frames in and out of the cache.
#include <shadowsense/backends/densenet/classifier.hpp>
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/sense/segment_kernels.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>
#include <shadowsense/sim.hpp>

#include <catch2/catch.hpp>

#include "common/robot_frames.hpp"

#include <opencv2/core.hpp>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

using namespace shadowsense;

namespace {

// The fixture both cases share: the shipped model, the sim calibration and ten robot-rig
// tracking frames (two of each track category; common/robot_frames.hpp).
struct RobotFrames : bench::RobotFrames {
  ModelFile model =
      ModelFile::load(std::filesystem::path(SHADOWSENSE_SOURCE_DIR) / "models" / "default.ssm");
  RobotFrames() : bench::RobotFrames(10) {}
};

} // namespace

TEST_CASE("whole frame of the shipped model, per stage (robot rig, 1 thread, 10 frames)") {
  cv::setNumThreads(1);
  const RobotFrames fixture;
  const ModelFile& model = fixture.model;
  const SimCalibration& calibration = fixture.calibration;
  const std::vector<cv::Mat>& frames = fixture.frames;
  auto classifier = make_densenet_classifier(model, {.threads = 1});
  Segmenter segmenter = segmenter_from(calibration);
  TouchPipeline pipeline(segmenter_from(calibration));
  FrameEncoder encoder(FrameEncoder::Config{model.preprocess, ChannelOrder::bgr});
  Segmentation seg;
  Tensor input;
  encoder.run(frames[0], input);
  Classification result;
  double t = 0;

  BENCHMARK("segment x10") {
    for (const cv::Mat& f : frames) segmenter.segment(f, seg);
    return seg.shadows.size();
  };
  BENCHMARK("pipeline x10") {
    std::size_t n = 0;
    for (const cv::Mat& f : frames) n += pipeline.update(f, t += 33.0).tracks.size();
    return n;
  };
  BENCHMARK("encode x10") {
    for (const cv::Mat& f : frames) encoder.run(f, input);
    return input.size();
  };
  BENCHMARK("forward x10") {
    for (std::size_t i = 0; i < frames.size(); ++i) classifier.classify(input, result);
    return result.index;
  };
  BENCHMARK("classify x10") {
    for (const cv::Mat& f : frames) classifier.classify(f, result);
    return result.index;
  };
  BENCHMARK("whole frame (pipeline + classify) x10") {
    std::size_t n = 0;
    for (const cv::Mat& f : frames) {
      n += pipeline.update(f, t += 33.0).tracks.size();
      classifier.classify(f, result);
      n += static_cast<std::size_t>(result.index);
    }
    return n;
  };
}

TEST_CASE("frame encoder per input encoding (shipped model's geometry, 1 thread, 10 frames)") {
  cv::setNumThreads(1);
  const RobotFrames fixture;
  const ModelFile& model = fixture.model;
  const std::vector<cv::Mat>& frames = fixture.frames;
  const cv::Mat empty_skin = segmenter_from(fixture.calibration).empty_skin_model().clone();
  Tensor input;
  for (const InputEncoding e : {InputEncoding::colour, InputEncoding::skin_relative,
                                InputEncoding::darkness_warmth, InputEncoding::masks}) {
    PreprocessParams p = model.preprocess;
    p.input_encoding = e;
    if (light_independent(e)) p.lighting_normalise = false; // it takes none
    FrameEncoder encoder(FrameEncoder::Config{p, ChannelOrder::bgr, empty_skin});
    BENCHMARK(std::string("encode x10, ") + to_string(e)) {
      for (const cv::Mat& f : frames) encoder.run(f, input);
      return input.size();
    };
  }
}

TEST_CASE("the segmenter's reference samples per kernel, frames in and out of the cache") {
  // Every third pixel of every third row of a 635 x 350 frame (the robot rig's size), as the
  // segmenter samples the skin; 60 frames of noise (40 MB, past the last-level cache) read in
  // turn, or one frame over and over. A camera's new frame is not in the cache.
  constexpr int w = 635, h = 350, cold_frames = 60;
  const std::size_t step = 3 * w;
  cv::RNG rng(7);
  std::vector<cv::Mat> frames(cold_frames);
  for (cv::Mat& f : frames) {
    f.create(h, w, CV_8UC3);
    rng.fill(f, cv::RNG::UNIFORM, 0, 256);
  }
  std::vector<std::int32_t> ys, xs;
  for (int y = 1; y < h; y += 3)
    for (int x = 1; x < w; x += 3) {
      ys.push_back(y);
      xs.push_back(x);
    }
  const int n = static_cast<int>(ys.size());
  const std::vector<float> inv(ys.size(), 1.0f);
  std::vector<std::uint16_t> bins(3 * ys.size());
  for (const SegmentKernelKind kind : {SegmentKernelKind::avx512, SegmentKernelKind::avx2,
                                       SegmentKernelKind::neon, SegmentKernelKind::portable}) {
    if (!segment_cpu_has(kind)) continue;
    const auto run = segment_kernels(kind).reference_bins;
    int next = 0;
    auto once = [&](const cv::Mat& f) {
      run(f.ptr<std::uint8_t>(0), step, ys.data(), xs.data(), inv.data(), inv.data(), inv.data(), n,
          bins.data(), bins.data() + n, bins.data() + 2 * n);
      return bins[static_cast<std::size_t>(n) / 2];
    };
    BENCHMARK(std::string("reference_bins, frame not in the cache, ") + segment_kernel_name(kind)) {
      next = (next + 1) % cold_frames;
      return once(frames[static_cast<std::size_t>(next)]);
    };
    BENCHMARK(std::string("reference_bins, frame in the cache, ") + segment_kernel_name(kind)) {
      return once(frames[0]);
    };
  }
}
