// The firmware promise of output/: after warm-up, building an OutputFrame and encoding it as
// TUIO bundles allocates nothing. Counted by replacing the global operator new in this binary.
#include <shadowsense/output/event_sink.hpp>
#include <shadowsense/output/tuio_sink.hpp>

#include <doctest/doctest.h>

#include <cstdlib>
#include <new>
#include <optional>
#include <vector>

namespace {
std::size_t allocations = 0;
}

// The replacements pair malloc with free; GCC cannot see that once they are inlined.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif

void* operator new(std::size_t n) {
  ++allocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}

using namespace shadowsense;

namespace {
struct Track {
  int id = 0;
  cv::Rect shadow_box{};
  std::optional<cv::Point2f> contact{};
  TouchState state = TouchState::none;
};
struct Event {
  int track_id = 0;
  TouchEvent event{};
};
struct Frame {
  double timestamp_ms = 0;
  std::vector<Track> tracks;
  std::vector<Event> events;
};
} // namespace

TEST_CASE("OutputFrameBuilder + TuioEncoder allocate nothing per frame after warm-up") {
  Frame f;
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
  const std::size_t before = allocations;
  for (int i = 3; i < 100; ++i) {
    f.timestamp_ms = 33.0 * i;
    for (Track& t : f.tracks) t.contact->x += 1.0f;
    encoder.encode(builder.build(f, {320, 240}), count_bytes);
  }
  CHECK(allocations - before == 0);
  CHECK(bytes > 0);
}
