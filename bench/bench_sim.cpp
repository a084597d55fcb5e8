// Frames rendered per second by the scene generator, per rig (one thread: OpenCV's own
// threading is switched off so the number is per core).
#include <shadowsense/sim.hpp>

#include <catch2/catch.hpp>

#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

using namespace shadowsense::sim;

namespace {
// A fixed mix of scenes, cycled through so caches and blur sizes vary like in a dataset.
std::vector<TrackingSample> tracking_mix() {
  std::vector<TrackingSample> v;
  for (std::uint64_t i = 0; i < 20; ++i)
    v.push_back(random_tracking_sample(all_track_categories[i % 5], 1000 + i));
  return v;
}
} // namespace

TEST_CASE("scene generator frames per second") {
  cv::setNumThreads(1);
  const auto mix = tracking_mix();
  Renderer tracking(Rig::tracking_box());
  Renderer robot(Rig::robot());
  Frame frame;
  std::uint64_t i = 0;
  BENCHMARK("tracking rig 200x205, one frame (mixed categories)") {
    const TrackingSample& s = mix[i++ % mix.size()];
    tracking.render(s.scene, s.light, i, frame);
    return frame.image.data[0];
  };
  BENCHMARK("robot rig 635x350, one frame (mixed hand poses)") {
    const TrackingSample& s = mix[i++ % mix.size()];
    robot.render(s.scene, s.light, i, frame);
    return frame.image.data[0];
  };
  const SlidePlan plan = plan_slide(3, SlideGesture::palm, Direction::right);
  BENCHMARK("tracking rig, one slide frame") {
    render_slide_frame(tracking, plan,
                       static_cast<int>(i++ % static_cast<std::uint64_t>(plan.num_frames())),
                       frame);
    return frame.image.data[0];
  };
}
