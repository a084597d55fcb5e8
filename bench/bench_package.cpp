// Baseline: the cost of validating a frame, the first thing every per-frame entry point does.
#include <shadowsense/shadowsense.hpp>

#include <catch2/catch.hpp>

TEST_CASE("validate a 635x350 frame", "[package]") {
  const cv::Mat frame(350, 635, CV_8UC3, cv::Scalar(128, 128, 128));
  BENCHMARK("require_colour_image") {
    shadowsense::require_colour_image(frame, "frame");
    return frame.rows;
  };
}
