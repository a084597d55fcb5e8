// The whole frame of the shipped model (models/default.ssm) on one core, per stage and
// together, on robot-rig generator frames: segmenter, touch pipeline (segmenter + ids + state
// machines), frame encoder, forward pass, classify (encode + forward) and the whole frame
// (pipeline + classify); and the frame encoder alone with each input encoding (the shipped
// model's geometry, the sim calibration's empty skin). One benchmark iteration = every fixture
// frame once (per-frame time = mean / frames). bench/frame_time prints the same stages as a table
// with heap allocations per frame.
#include <shadowsense/backends/densenet/classifier.hpp>
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>
#include <shadowsense/sim.hpp>

#include <catch2/catch.hpp>

#include "common/robot_frames.hpp"

#include <opencv2/core.hpp>

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
