// The temporal gesture recogniser's cost per frame (sense/temporal_gestures.hpp) with 4
// simultaneous tracks: one tapping, one patting with a palm, one stroking back and forth (rubs
// and strokes), one holding, at 30 fps, with the classifier's label changing every second. The
// frames are made before timing; one benchmark run is 3000 frames (100 s of touches), so the
// cost per frame is the reported mean / 3000. Also printed: the events decided over the run.
#include <shadowsense/sense/temporal_gestures.hpp>

#include <catch2/catch.hpp>

#include <opencv2/core.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

using namespace shadowsense;

namespace {

constexpr int kFrames = 3000;

std::vector<TouchFrame> make_frames() {
  std::vector<TouchFrame> frames(kFrames);
  for (int i = 0; i < kFrames; ++i) {
    TouchFrame& f = frames[static_cast<std::size_t>(i)];
    f.timestamp_ms = 1000.0 * i / 30.0;
    const int phase = i % 45; // a 1.5 s cycle
    for (int id = 1; id <= 4; ++id) {
      TouchTrack t;
      t.id = id;
      t.matched = true;
      t.position = cv::Point2f(100.f * id, 100.f);
      bool touching = false;
      cv::Point2f at = t.position;
      switch (id) {
      case 1:
        touching = phase % 10 < 3;
        break; // taps of 100 ms
      case 2:
        touching = phase % 12 < 5;
        break; // pats of 167 ms
      case 3:  // strokes back and forth
        touching = phase < 40;
        at.x += 40.f * std::sin(static_cast<float>(phase) * 0.3f);
        break;
      case 4:
        touching = phase < 44;
        break; // holds of 1.47 s
      }
      if (touching) t.contact = at;
      t.contact_area = id == 2 ? 2000.0 : 300.0;
      f.tracks.push_back(t);
    }
  }
  return frames;
}

} // namespace

TEST_CASE("temporal gesture recogniser: cost per frame with 4 tracks") {
  const std::vector<TouchFrame> frames = make_frames();
  OutputGesture shape;
  shape.available = true;
  shape.label.reserve(16);
  TemporalGestureRecogniser r;
  std::size_t events = 0;
  double t0 = 0;
  // Timestamps must keep growing across runs: shift them by the previous run's span.
  std::vector<TouchFrame> shifted = frames;
  auto run_shifted = [&] {
    events = 0;
    for (int i = 0; i < kFrames; ++i) {
      TouchFrame& f = shifted[static_cast<std::size_t>(i)];
      f.timestamp_ms = t0 + frames[static_cast<std::size_t>(i)].timestamp_ms;
      shape.label = (i / 30) % 3 == 0 ? "point" : ((i / 30) % 3 == 1 ? "palm" : "");
      events += r.update(f, shape).size();
    }
    t0 += frames.back().timestamp_ms + 1000;
    return events;
  };
  run_shifted(); // warm-up
  const auto start = std::chrono::steady_clock::now();
  constexpr int reps = 20;
  for (int k = 0; k < reps; ++k) run_shifted();
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::printf("temporal recogniser, 4 tracks, %d frames x %d runs: %.5f ms per frame; %zu events "
              "per run\n",
              kFrames, reps, ms / (kFrames * reps), events);
  BENCHMARK("temporal recogniser, 4 tracks, 3000 frames (divide by 3000 for one frame)") {
    return run_shifted();
  };
}
