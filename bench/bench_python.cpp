// The C++ side of the Python overhead measurement (bench/python_overhead.py runs this and the
// same loops through the Python module on the same frames): TouchPipeline::update over the 40
// bench frames and Classifier::classify over 10 of them, at 200x205 (tracking rig) and 635x350
// (robot rig), one thread. The frames are python/tests/fixture_scenes.hpp's, the ones
// ss_python_fixture writes for the Python loop.
#include "fixture_scenes.hpp"

#include <shadowsense/runtime/densenet_runtime.hpp>

#include <catch2/catch.hpp>

#include <opencv2/core.hpp>

#include <string>

using namespace shadowsense;

namespace {

void bench_rig(const std::string& name, const python_fixture::Scenes& s) {
  TouchPipeline pipeline{Segmenter({.calibration = s.calibration})};
  Classifier<DenseNet> classifier =
      make_densenet_classifier(ModelFile::load(SHADOWSENSE_SOURCE_DIR "/models/default.ssm"));
  Classification reading;
  double t = 0;
  BENCHMARK("TouchPipeline.update " + name + ", 40 frames") {
    std::size_t n = 0;
    for (const cv::Mat& f : s.frames) n += pipeline.update(f, t += 10).tracks.size();
    return n;
  };
  BENCHMARK("Classifier.classify " + name + ", 10 frames") {
    int sum = 0;
    for (std::size_t i = 0; i < 10; ++i) {
      classifier.classify(s.frames[i], reading);
      sum += reading.index;
    }
    return sum;
  };
}

} // namespace

TEST_CASE("TouchPipeline and Classifier per frame, the C++ side of python_overhead.py") {
  cv::setNumThreads(1);
  bench_rig("200x205", python_fixture::bench_frames(sim::Rig::tracking_box(), 0xB0));
  bench_rig("635x350", python_fixture::bench_frames(sim::Rig::robot(), 0xB2));
}
