// TouchPipeline on sequences rendered by the scene generator: the events, their frames and their
// tracks are known from the script of the sequence (the generator's ground truth). Calibration
// frames use another seed.
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>

#include "common/sim_box.hpp"

#include <doctest/doctest.h>

#include "common/files.hpp"
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace shadowsense;

namespace {

sim::HandPose finger(double x_cm, double y_cm, double height_cm, double rotation_deg = -90) {
  sim::HandPose p;
  p.shape = sim::HandShape::point;
  p.position_cm = {x_cm, y_cm};
  p.rotation_deg = rotation_deg;
  p.height_cm = height_cm;
  p.arm_elevation_deg = 40;
  return p;
}

sim::Frame render(const std::vector<sim::HandPose>& hands, std::uint64_t seed) {
  sim::Scene scene;
  sim::User user;
  for (const auto& h : hands) sim::add_hand(scene.parts, user, h);
  return test::box_renderer().render(scene, sim::preset(sim::Lighting::dusk), seed);
}

struct Expected {
  int frame;
  int track;
  TouchState from, to;
  Direction direction = Direction::none;
};

std::string describe(const TrackEvent& e) {
  return "track " + std::to_string(e.track_id) + " " + to_string(e.event.from) + "->" +
         to_string(e.event.to) + " " + std::string(to_string(e.event.direction)) + " at " +
         std::to_string(e.event.timestamp_ms);
}

} // namespace

TEST_CASE("one finger: appear, touch, slide right, lift, disappear - on the scripted frames") {
  // The script, one frame every 77 ms: 0-1 empty skin, 2-3 hovering 1.5 cm above (0, 0), 4-5
  // touching (0, 0), 6-8 sliding right 1.2 cm per frame, 9-10 hovering again, 11-13 empty.
  std::vector<std::vector<sim::HandPose>> script;
  script.push_back({});
  script.push_back({});
  script.push_back({finger(0, 0, 1.5)});
  script.push_back({finger(0, 0, 1.5)});
  script.push_back({finger(0, 0, 0)});
  script.push_back({finger(0, 0, 0)});
  for (int k = 1; k <= 3; ++k) script.push_back({finger(1.2 * k, 0, 0)});
  script.push_back({finger(3.6, 0, 1.5)});
  script.push_back({finger(3.6, 0, 1.5)});
  for (int k = 0; k < 3; ++k) script.push_back({});
  // Expected from the script and the machine's rules (hysteresis 150 ms = two frames).
  const std::vector<Expected> expected{
      {2, 1, TouchState::none, TouchState::appear},
      {4, 1, TouchState::appear, TouchState::touch},
      {6, 1, TouchState::touch, TouchState::move, Direction::right},
      {11, 1, TouchState::move, TouchState::lift}, // contact lost at 9: 154 ms later
      {13, 1, TouchState::lift, TouchState::none}, // shadow lost at 11: 154 ms later
  };
  TouchPipeline pipeline(segmenter_from(test::box_calibration()), {.max_distance_px = 60});
  std::vector<TrackEvent> events;
  std::vector<int> frame_of;
  for (std::size_t i = 0; i < script.size(); ++i) {
    const sim::Frame f = render(script[i], 500 + i);
    const TouchFrame& r = pipeline.update(f.image, 77.0 * static_cast<double>(i));
    CHECK(r.timestamp_ms == 77.0 * static_cast<double>(i));
    CHECK(r.shadow_boxes.size() == (f.gt.shadow_box ? 1u : 0u));
    CHECK(r.contact_points.size() == (f.gt.contact_box ? 1u : 0u));
    for (const TouchTrack& t : r.tracks) {
      CHECK(t.id == 1);
      CHECK(t.contact.has_value() == (t.matched && f.gt.contact_box.has_value()));
      if (t.contact) { // the contact point is the true contact region's centroid
        const cv::Moments m = cv::moments(f.gt.contact_mask, true);
        CHECK(std::hypot(t.contact->x - m.m10 / m.m00, t.contact->y - m.m01 / m.m00) < 1.0);
      }
    }
    for (const TrackEvent& e : r.events) {
      events.push_back(e);
      frame_of.push_back(static_cast<int>(i));
    }
  }
  CHECK(pipeline.flush(77.0 * 14).events.empty()); // everything had ended
  std::string got;
  for (const TrackEvent& e : events) got += describe(e) + "\n";
  INFO(got);
  REQUIRE(events.size() == expected.size());
  for (std::size_t k = 0; k < expected.size(); ++k) {
    CHECK(frame_of[k] == expected[k].frame);
    CHECK(events[k].track_id == expected[k].track);
    CHECK(events[k].event.from == expected[k].from);
    CHECK(events[k].event.to == expected[k].to);
    CHECK(events[k].event.direction == expected[k].direction);
    CHECK(events[k].event.timestamp_ms == 77.0 * expected[k].frame);
  }
}

TEST_CASE("two hands touching at once: two tracks, two touches; flush ends both") {
  TouchPipeline pipeline(segmenter_from(test::box_calibration()));
  const std::vector<sim::HandPose> hands{finger(-3, 0, 0, 0), finger(3, 0, 0, 180)}; // arms apart
  for (int i = 0; i < 3; ++i) {
    const sim::Frame f = render(hands, 900 + static_cast<std::uint64_t>(i));
    const TouchFrame& r = pipeline.update(f.image, 50.0 * i);
    REQUIRE(r.tracks.size() == 2);
    CHECK(r.tracks[0].id == 1);
    CHECK(r.tracks[1].id == 2);
    CHECK(r.tracks[0].contact.has_value());
    CHECK(r.tracks[1].contact.has_value());
    CHECK(r.tracks[0].state == TouchState::touch);
    CHECK(r.tracks[1].state == TouchState::touch);
    if (i == 0) {
      REQUIRE(r.events.size() == 4); // appear + touch per track
      CHECK(r.events[0].track_id == 1);
      CHECK(r.events[1].track_id == 1);
      CHECK(r.events[2].track_id == 2);
      CHECK(r.events[1].event.to == TouchState::touch);
      CHECK(r.events[3].event.to == TouchState::touch);
    } else {
      CHECK(r.events.empty());
    }
  }
  // The stream ends while both touch: lift at the flush time, disappear one hysteresis later.
  const TouchFrame& end = pipeline.flush(200);
  REQUIRE(end.events.size() == 4);
  for (int k = 0; k < 2; ++k) {
    const TrackEvent& lift = end.events[static_cast<std::size_t>(2 * k)];
    const TrackEvent& gone = end.events[static_cast<std::size_t>(2 * k + 1)];
    CHECK(lift.track_id == k + 1);
    CHECK(lift.event.to == TouchState::lift);
    CHECK(lift.event.timestamp_ms == 350); // 200 + hysteresis 150: loss starts at the flush
    CHECK(gone.event.to == TouchState::none);
    CHECK(gone.event.timestamp_ms == 350);
  }
  // A new stream after the flush: ids keep growing.
  const sim::Frame f = render({hands[0]}, 999);
  const TouchFrame& r = pipeline.update(f.image, 201);
  REQUIRE(r.tracks.size() == 1);
  CHECK(r.tracks[0].id == 3);
}

TEST_CASE("bad timestamps and frames are refused with the pipeline unchanged") {
  TouchPipeline pipeline(segmenter_from(test::box_calibration()));
  const sim::Frame f = render({}, 1);
  pipeline.update(f.image, 10);
  CHECK_THROWS_WITH_AS(pipeline.update(f.image, 10), doctest::Contains("strictly increasing"),
                       InvalidArgument);
  CHECK_THROWS_AS(pipeline.update(f.image, std::nan("")), InvalidArgument);
  CHECK_THROWS_AS(pipeline.update(cv::Mat(10, 10, CV_8UC3), 20), InvalidArgument);
  CHECK_THROWS_AS(pipeline.flush(5), InvalidArgument);
  CHECK(pipeline.update(f.image, 30).events.empty());
}

namespace {

namespace ss = shadowsense;

// The README's tracking loop, verbatim between the markers (a test below compares the text).
template <class Camera, class Log>
void readme_tracking_loop(const Camera& camera, Log log) {
  // README-BEGIN
  ss::TouchPipeline touch{ss::Segmenter({.calibration = ss::load_calibration("skin.calib")})};
  double t_end = 0;
  for (const auto& [frame, t_ms] : camera) { // cv::Mat BGR, timestamp in ms
    for (const ss::TrackEvent& e : touch.update(frame, t_ms).events) log(e); // e.track_id, e.event
    t_end = t_ms;
  }
  for (const ss::TrackEvent& e : touch.flush(t_end + 33).events) log(e); // the stream ended
  // README-END
}

} // namespace

TEST_CASE("the README's tracking loop is this compiled code, and it reports the touch") {
  const auto snippet = tests::readme_snippet("tests/test_touch_pipeline.cpp",
                                             "ss::TouchPipeline touch", "the stream ended");
  REQUIRE(snippet.readme.size() == 7);
  CHECK(snippet.readme == snippet.here);
  // Run it: a calibration file in the working folder, a short touch.
  const tests::WorkingFolder folder("readme_loop");
  save_calibration(test::box_calibration().config.calibration, "skin.calib");
  std::vector<std::pair<cv::Mat, double>> camera;
  camera.emplace_back(render({}, 1).image, 0.0);
  camera.emplace_back(render({finger(0, 0, 0)}, 2).image, 33.0);
  camera.emplace_back(render({finger(0, 0, 0)}, 3).image, 66.0);
  std::vector<TrackEvent> logged;
  readme_tracking_loop(camera, [&](const TrackEvent& e) { logged.push_back(e); });
  REQUIRE(logged.size() == 4); // appear + touch at 33 ms; lift + disappear at the flush
  CHECK(logged[1].event.to == TouchState::touch);
  CHECK(logged[1].event.timestamp_ms == 33.0);
  CHECK(logged[2].event.to == TouchState::lift);
  CHECK(logged[3].event.to == TouchState::none);
}

// ---------------------------------------------------------------------------------------------
// Camera faults (sense/camera_health.hpp): a lens cap, lights off, a clipped or a frozen camera
// is a fault, never a touch. Before the check, a black frame was one whole-skin shadow: appear
// on the first black frame, and the classifier read it as a hug.

namespace {

cv::Mat filled(cv::Size size, std::uint8_t v) {
  return cv::Mat(size, CV_8UC3, cv::Scalar(v, v, v));
}

// The frame's events as "track from->to", in order.
std::vector<std::string> events_of(const TouchFrame& f) {
  std::vector<std::string> out;
  for (const TrackEvent& e : f.events)
    out.push_back(std::to_string(e.track_id) + " " + to_string(e.event.from) + "->" +
                  to_string(e.event.to));
  return out;
}

} // namespace

TEST_CASE("CameraHealth: one sampled byte changed anywhere ends a repeat; unsampled bytes do not") {
  // 27 x 9 with sample_step 4: 7 samples a row (the last one in the row's last 64-byte block),
  // 3 sampled rows; 1 and 3 channels, 4 (alpha not looked at).
  for (const int channels : {1, 3, 4}) {
    CAPTURE(channels);
    cv::Mat base(9, 27, CV_8UC(channels));
    cv::randu(base, 60, 200);
    int sampled_changes = 0, unsampled_changes = 0;
    for (int y = 0; y < base.rows; ++y)
      for (int x = 0; x < base.cols; ++x)
        for (int c = 0; c < channels; ++c) {
          const bool sampled = y % 4 == 0 && x % 4 == 0 && c < 3;
          cv::Mat changed = base.clone();
          changed.ptr<std::uint8_t>(y)[x * channels + c] ^= 1;
          CameraHealth h;
          h.update(base);
          h.update(base);
          REQUIRE(h.repeated_frames() == 1);
          h.update(changed);
          if (sampled) {
            sampled_changes += h.repeated_frames() == 0;
          } else {
            unsampled_changes += h.repeated_frames() == 2;
          }
        }
    CHECK(sampled_changes == 3 * 7 * std::min(channels, 3));
    CHECK(unsampled_changes == 9 * 27 * channels - 3 * 7 * std::min(channels, 3));
  }
}

// The camera check's scan (sense/camera_scan.hpp) against its definition written out here: the
// sampled rows read as 32-bit words, the bytes not looked at zeroed, every word holding a
// looked-at byte through lane (index mod 16) of 16 FNV-style lanes; the AVX-512 kernel must give
// the portable loop's result bit for bit.
namespace {
detail::CameraScan scan_by_definition(const cv::Mat& frame, int step, int dark, int saturated) {
  const int channels = frame.channels(), colour = channels == 1 ? 1 : 3;
  const std::size_t row_bytes = static_cast<std::size_t>(frame.cols * channels);
  std::uint32_t h[16];
  for (std::uint32_t j = 0; j < 16; ++j) h[j] = 2166136261u ^ j;
  detail::CameraScan out;
  for (int y = 0; y < frame.rows; y += step) {
    const std::uint8_t* row = frame.ptr<std::uint8_t>(y);
    std::vector<std::uint8_t> looked((row_bytes + 3) / 4 * 4, 0), is_looked(looked.size(), 0);
    for (int x = 0; x < frame.cols; x += step) {
      int lo = 255, hi = 0;
      for (int c = 0; c < colour; ++c) {
        const std::size_t at = static_cast<std::size_t>(x * channels + c);
        looked[at] = row[at];
        is_looked[at] = 1;
        lo = std::min<int>(lo, row[at]);
        hi = std::max<int>(hi, row[at]);
      }
      ++out.samples;
      out.dark += hi <= dark;
      out.saturated += lo >= saturated;
    }
    for (std::size_t w = 0; w < looked.size() / 4; ++w) {
      const std::size_t at = 4 * w; // the word holds a looked-at byte: it takes a step
      if (!(is_looked[at] || is_looked[at + 1] || is_looked[at + 2] || is_looked[at + 3])) continue;
      const std::uint8_t* b = &looked[at];
      const std::uint32_t word = b[0] | b[1] << 8 | b[2] << 16 | std::uint32_t{b[3]} << 24;
      h[w % 16] = (h[w % 16] ^ word) * 16777619u;
    }
  }
  out.hash = 1469598103934665603ull;
  for (const std::uint32_t v : h) out.hash = (out.hash ^ v) * 1099511628211ull;
  return out;
}
} // namespace

TEST_CASE("camera scan: the portable loop is the signature's definition and the AVX-512 kernel "
          "equals it, on every width's last block, every step and a frame cut from a larger one") {
  cv::RNG rng(11);
  int compared = 0, compared_avx512 = 0;
  for (const int channels : {1, 3, 4})
    for (const int step : {1, 2, 3, 4, 5, 7, 16, 21, 64})
      for (const int cols : {1, 5, 21, 22, 27, 63, 64, 65, 86, 130, 635}) {
        const int rows = 1 + (cols + step) % 13;
        cv::Mat big(rows + 3, cols + 9, CV_8UC(channels));
        rng.fill(big, cv::RNG::UNIFORM, 0, 256);
        // Extremes often, so both counts are neither 0 nor everything.
        std::uint8_t* p = big.data;
        for (std::size_t i = 0; i < big.total() * big.elemSize(); ++i)
          if (p[i] % 3 == 0) p[i] = p[i] % 2 ? 255 : 3;
        for (const bool cut : {false, true}) {
          const cv::Mat frame =
              cut ? big(cv::Rect(4, 2, cols, rows)) : big(cv::Rect(0, 0, cols, rows)).clone();
          CAPTURE(channels);
          CAPTURE(step);
          CAPTURE(cols);
          CAPTURE(cut);
          CameraHealthConfig config;
          config.sample_step = step;
          config.dark_level = 40;
          config.saturated_level = 230;
          const detail::CameraScanGrid g = detail::camera_scan_grid(frame, config);
          const detail::CameraScan want = scan_by_definition(frame, step, 40, 230);
          const detail::CameraScan portable = detail::camera_scan_portable(g);
          CAPTURE(want.samples);
          CAPTURE(want.dark);
          CAPTURE(want.saturated);
          REQUIRE(portable == want);
          ++compared;
#if SHADOWSENSE_CAMERA_SCAN_X86
          if (detail::camera_scan_cpu_has_avx512()) {
            REQUIRE(detail::camera_scan_avx512(g) == want);
            ++compared_avx512;
          }
#endif
        }
      }
  CHECK(compared == 3 * 9 * 11 * 2);
  MESSAGE("AVX-512 scans compared: " << compared_avx512);
}

TEST_CASE("CameraHealth: black, black with one bright pixel, white, frozen; a live camera none") {
  const sim::Frame f = render({}, 7);
  const cv::Size size = f.image.size();
  CameraHealth health;
  CHECK(health.update(filled(size, 0)) == CameraFault::dark);
  cv::Mat speck = filled(size, 0);
  speck.at<cv::Vec3b>(0, 0) = cv::Vec3b(255, 255, 255); // a sampled pixel
  CHECK(health.update(speck) == CameraFault::dark);
  CHECK(health.update(filled(size, 10)) == CameraFault::dark); // lights off, some offset
  CHECK(health.update(filled(size, 255)) == CameraFault::saturated);
  CHECK(health.update(filled(size, 128)) == CameraFault::none); // flat grey is not a fault...
  // ...until it repeats: the 30th identical frame in a row is frozen (frozen_frames = 30).
  CameraHealth frozen;
  for (int i = 1; i <= 29; ++i) REQUIRE(frozen.update(f.image) == CameraFault::none);
  CHECK(frozen.update(f.image) == CameraFault::frozen);
  CHECK(frozen.repeated_frames() == 29);
  CHECK(frozen.update(render({}, 8).image) == CameraFault::none); // noise changed: alive again
  // A live camera (a new noise draw every frame), empty and with hands, dusk light: never.
  CameraHealth live;
  for (std::uint64_t i = 0; i < 40; ++i) {
    const std::vector<sim::HandPose> hands =
        i % 2 ? std::vector<sim::HandPose>{finger(0, 0, 0)} : std::vector<sim::HandPose>{};
    REQUIRE(live.update(render(hands, 100 + i).image) == CameraFault::none);
  }
  // Frames it cannot judge are not faults (the segmenter refuses them).
  CHECK(live.update(cv::Mat()) == CameraFault::none);
  CHECK(live.update(cv::Mat(8, 8, CV_32FC3, cv::Scalar(0, 0, 0))) == CameraFault::none);
  CHECK_THROWS_WITH_AS(CameraHealth(CameraHealthConfig{.fault_fraction = 0.3}),
                       doctest::Contains("fault_fraction is 0.3"), InvalidArgument);
  CHECK_THROWS_WITH_AS(CameraHealth(CameraHealthConfig{.frozen_frames = 1}),
                       doctest::Contains("frozen_frames is 1"), InvalidArgument);
  CHECK_THROWS_WITH_AS(CameraHealth(CameraHealthConfig{.dark_level = 200, .saturated_level = 100}),
                       doctest::Contains("saturated_level is 100"), InvalidArgument);
}

TEST_CASE("a bad frame is refused with the segmenter's message and is not judged by the camera "
          "check") {
  const cv::Mat good = render({}, 1).image;
  const std::string model =
      std::to_string(good.cols) + "x" + std::to_string(good.rows) + "; expected the same size";
  TouchPipeline pipeline(segmenter_from(test::box_calibration()));
  double t = 0;
  for (int i = 0; i < 28; ++i) pipeline.update(good, t += 33); // 27 repeats: frozen at the 30th
  REQUIRE(pipeline.camera_health().repeated_frames() == 27);
  // Each bad frame: the segmenter's exact message; a black one (dark to the camera check) and a
  // noisy one alike, the camera check untouched (no fault, the repeat count kept).
  const cv::Mat noisy_small = render({}, 2).image(cv::Rect(0, 0, 10, 10)).clone();
  const std::vector<std::pair<cv::Mat, std::string>> bad = {
      {cv::Mat(), "Segmenter::segment: image: image is empty; expected an 8-bit 3-channel image"},
      {filled({10, 10}, 0),
       "Segmenter::segment: image is 10x10 but the empty-skin model is " + model},
      {noisy_small, "Segmenter::segment: image is 10x10 but the empty-skin model is " + model},
      {cv::Mat(good.size(), CV_8UC1, cv::Scalar(0)),
       "Segmenter::segment: image: image type is CV_8UC1; expected CV_8UC3 (8-bit, 3 channels)"},
  };
  for (const auto& [frame, message] : bad) {
    CAPTURE(message);
    CHECK_THROWS_WITH_AS(pipeline.update(frame, t + 1), message.c_str(), InvalidArgument);
    CHECK(pipeline.camera_health().fault() == CameraFault::none);
    CHECK(pipeline.camera_health().repeated_frames() == 27);
  }
  CHECK(pipeline.update(good, t += 33).camera == CameraFault::none);
  CHECK(pipeline.update(good, t += 33).camera == CameraFault::frozen); // the 30th, as without them
}

TEST_CASE("a dead camera is a camera fault, not a touch: black, white and frozen sequences") {
  const cv::Size size = render({}, 1).image.size();
  // From the first frame on: no appear, no track, the fault on every frame, the change once.
  for (const std::uint8_t level : {std::uint8_t(0), std::uint8_t(255)}) {
    CAPTURE(int(level));
    TouchPipeline pipeline(segmenter_from(test::box_calibration()));
    for (int i = 0; i < 10; ++i) {
      const TouchFrame& r = pipeline.update(filled(size, level), 33.0 * (i + 1));
      CHECK(r.events.empty());
      CHECK(r.tracks.empty());
      CHECK(r.shadow_boxes.empty());
      CHECK(r.camera == (level == 0 ? CameraFault::dark : CameraFault::saturated));
      CHECK(r.camera_before == (i == 0 ? CameraFault::none : r.camera));
      CHECK(cv::countNonZero(pipeline.segmentation().shadow_mask) == 0);
    }
  }
  // A touch, then the lens cap: the touch ends as when the hand leaves (lift, then disappear
  // after the hysteresis), and nothing appears while the camera is dark.
  {
    TouchPipeline pipeline(segmenter_from(test::box_calibration()));
    std::vector<std::string> seen;
    double t = 0;
    for (int i = 0; i < 4; ++i) {
      const TouchFrame& r = pipeline.update(render({finger(0, 0, 0)}, 300 + i).image, t += 77);
      CHECK(r.camera == CameraFault::none);
      for (const std::string& e : events_of(r)) seen.push_back(e);
    }
    CHECK(seen == std::vector<std::string>{"1 none->appear", "1 appear->touch"});
    seen.clear();
    for (int i = 0; i < 6; ++i) {
      const TouchFrame& r = pipeline.update(filled(size, 0), t += 77);
      CHECK(r.camera == CameraFault::dark);
      for (const std::string& e : events_of(r)) seen.push_back(e);
    }
    CHECK(seen == std::vector<std::string>{"1 touch->lift", "1 lift->none"});
  }
  // A driver that repeats its last buffer while a finger touches: frozen after 30 frames, then
  // the touch ends; with the check off (enabled = false) the stale touch would go on for ever.
  {
    const sim::Frame touching = render({finger(0, 0, 0)}, 400);
    TouchPipeline pipeline(segmenter_from(test::box_calibration()));
    std::vector<std::string> seen;
    int first_frozen = 0;
    for (int i = 1; i <= 50; ++i) {
      const TouchFrame& r = pipeline.update(touching.image, 33.0 * i);
      if (r.camera == CameraFault::frozen && !first_frozen) first_frozen = i;
      for (const std::string& e : events_of(r)) seen.push_back(e);
    }
    CHECK(first_frozen == 30);
    CHECK(seen == std::vector<std::string>{"1 none->appear", "1 appear->touch", "1 touch->lift",
                                           "1 lift->none"});
    TouchPipeline unchecked(segmenter_from(test::box_calibration()), {}, {},
                            CameraHealthConfig{.enabled = false});
    std::vector<std::string> stale;
    for (int i = 1; i <= 50; ++i)
      for (const std::string& e : events_of(unchecked.update(touching.image, 33.0 * i)))
        stale.push_back(e);
    CHECK(stale == std::vector<std::string>{"1 none->appear", "1 appear->touch"});
  }
}
