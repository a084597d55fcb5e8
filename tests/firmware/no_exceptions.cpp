// A firmware build without exceptions (-fno-exceptions): every library error goes to the
// program's own handler through SHADOWSENSE_THROW (core/error.hpp), and the runtime umbrella
// compiles and runs with no try, catch or throw of its own. check_no_exceptions.cmake builds it
// with -fno-exceptions and runs it twice: on the shipped model (exit 0, a gesture printed) and
// on a missing model file (the handler's exit status 3 and the library's message).
//   usage: no_exceptions MODEL.ssm
#include <cstdio>
#include <cstdlib>

template <class E>
[[noreturn]] void on_shadowsense_error(const E& e);
#define SHADOWSENSE_THROW(exception) on_shadowsense_error(exception)
#include <shadowsense/shadowsense.hpp>

template <class E>
[[noreturn]] void on_shadowsense_error(const E& e) {
  std::fprintf(stderr, "shadowsense error: %s\n", e.what());
  std::exit(3);
}

int main(int argc, char** argv) {
  namespace ss = shadowsense;
  if (argc != 2) return 2;
  const ss::ModelFile model = ss::ModelFile::load(argv[1]); // the handler exits when missing
  ss::SegmenterConfig config;
  config.calibration.mode = ss::SegmentMode::fixed_ranges; // the paper's ranges: no calibration
  ss::Runtime sense(ss::TouchPipeline(ss::Segmenter(config)), ss::make_densenet_classifier(model));
  cv::Mat frame(350, 635, CV_8UC3, cv::Scalar(200, 200, 200));
  cv::rectangle(frame, cv::Rect(250, 120, 120, 110), cv::Scalar(60, 60, 60), cv::FILLED);
  const ss::RuntimeFrame* r = nullptr;
  for (int i = 1; i <= 3; ++i) r = &sense.update(frame, 33.0 * i);
  std::printf("frame %lld: %zu shadow(s), gesture '%s'\n", static_cast<long long>(r->frame_index),
              r->touch.shadow_boxes.size(), r->gesture.label.c_str());
  return 0;
}
