// The firmware promise of output/: after warm-up, building an OutputFrame and encoding it as
// TUIO bundles allocates nothing. Counted by replacing the global operator new in this binary
// (bench/common/counting_new.hpp).
#include <shadowsense/output/event_sink.hpp>
#include <shadowsense/output/tuio_sink.hpp>

#include <doctest/doctest.h>

#include "common/counting_new.hpp"

#include <memory>
#include <optional>
#include <vector>

using namespace shadowsense;

// The user's own frame types (OutputFrameBuilder takes any with these members).
namespace {
struct UserTrack {
  int id = 0;
  cv::Rect shadow_box{};
  std::optional<cv::Point2f> contact{};
  TouchState state = TouchState::none;
};
struct UserEvent {
  int track_id = 0;
  TouchEvent event{};
};
struct UserFrame {
  double timestamp_ms = 0;
  std::vector<UserTrack> tracks;
  std::vector<UserEvent> events;
};
} // namespace

TEST_CASE("the counting operator new sees allocations in this binary") {
  const std::size_t before = counting_new::count();
  auto v = std::make_unique<std::vector<int>>(100, 7);
  CHECK((*v)[99] == 7);
  CHECK(counting_new::count() - before >= 2);
}

TEST_CASE("OutputFrameBuilder + TuioEncoder allocate nothing per frame after warm-up") {
  UserFrame f;
  for (int id = 1; id <= 4; ++id)
    f.tracks.push_back(
        {id, cv::Rect(10 * id, 10, 30, 20), cv::Point2f(12.f * id, 15.f), TouchState::touch});
  f.events.push_back({1, TouchEvent{0, TouchState::touch, TouchState::move, Direction::left,
                                    cv::Point2f(12, 15)}});
  OutputFrameBuilder builder;
  TuioEncoder::Config config;
  config.source = "shadowsense@127.0.0.1";
  TuioEncoder encoder(config);
  std::size_t bytes = 0;
  auto count_bytes = [&](std::span<const std::uint8_t> b) { bytes += b.size(); };
  for (int i = 0; i < 3; ++i) { // warm-up
    f.timestamp_ms = 33.0 * i;
    encoder.encode(builder.build(f, {320, 240}), count_bytes);
  }
  const std::size_t before = counting_new::count();
  for (int i = 3; i < 100; ++i) {
    f.timestamp_ms = 33.0 * i;
    for (UserTrack& t : f.tracks) t.contact->x += 1.0f;
    encoder.encode(builder.build(f, {320, 240}), count_bytes);
  }
  CHECK(counting_new::count() - before == 0);
  CHECK(bytes > 0);
}
