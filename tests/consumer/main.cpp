// A program built against shadowsense the way a user's project would: it includes only the
// runtime umbrella and runs the touch pipeline (OpenCV core + imgproc) on an empty frame, with
// no calibration: opted in by name (ss::uncalibrated), as the library requires.
#include <shadowsense/shadowsense.hpp>

#include <iostream>

int main() {
  namespace ss = shadowsense;
  ss::TouchPipeline touch{ss::uncalibrated, ss::Segmenter{}};
  const cv::Mat bright(120, 160, CV_8UC3, cv::Scalar::all(230)); // an empty, lit skin
  const std::size_t events = touch.update(bright, 0).events.size();
  std::cout << "shadowsense " << ss::version_string << ", " << events << " events\n";
  return ss::version_major == 0 && events == 0 ? 0 : 1;
}
