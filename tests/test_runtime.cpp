// Runtime (runtime/runtime.hpp) on sequences rendered by the scene generator: the touch events
// are the TouchPipeline's, the classifier runs exactly on the frames where a shadow is seen and
// its probabilities are the Classifier's on those frames bit for bit; classify_every carries a
// reading with the frame it was computed on; a user-defined backend plugs in through the
// ClassifierBackend concept; and TouchPipeline refuses an uncalibrated segmenter unless the
// caller opts in by name.
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/output/csv_sink.hpp>
#include <shadowsense/runtime/densenet_runtime.hpp>
#include <shadowsense/sim.hpp>

#include <doctest/doctest.h>

#include "common/files.hpp"
#include "fixture_scenes.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

using namespace shadowsense;

namespace {

sim::Renderer& renderer() {
  static sim::Renderer r(sim::Rig::robot());
  return r;
}

const SimCalibration& calibration() {
  static const SimCalibration c = calibrate_on_sim(renderer(), 0xC0FFEE, 12);
  return c;
}

// 24 frames: empty skin, a palm coming down, touching and sliding, lifted, empty again, a fist
// (the scripted sequence the Python tests compare against: python/tests/fixture_scenes.hpp).
const std::vector<cv::Mat>& sequence() {
  static const std::vector<cv::Mat> frames = python_fixture::touch_sequence().frames;
  return frames;
}

const ModelFile& model() {
  static const ModelFile m = ModelFile::load(SHADOWSENSE_SOURCE_DIR "/models/default.ssm");
  return m;
}

// A backend of the user's own: two classes, logits from the frame's mean brightness, and a
// count of the calls.
struct BrightnessBackend {
  std::vector<std::string> names{"dark", "bright"};
  std::vector<float> out = std::vector<float>(2);
  int calls = 0;
  std::span<const std::string> class_names() const { return names; }
  std::span<const float> logits(const Tensor& x) {
    ++calls;
    double sum = 0;
    for (std::size_t i = 0; i < x.size(); ++i) sum += x.data()[i];
    const double mean = sum / static_cast<double>(x.size());
    out = {static_cast<float>(-mean), static_cast<float>(mean)};
    return out;
  }
};
static_assert(ClassifierBackend<BrightnessBackend>);

} // namespace

TEST_CASE("Runtime: the TouchPipeline's events, the classifier on exactly the shadow frames") {
  const std::vector<cv::Mat> frames = sequence();
  TouchPipeline reference(segmenter_from(calibration()));
  auto classifier = make_densenet_classifier(model());
  Runtime sense(TouchPipeline(segmenter_from(calibration())), make_densenet_classifier(model()));
  CHECK(sense.has_classifier());
  int classified = 0, gated = 0, events = 0;
  double t = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    t = 40.0 * static_cast<double>(i);
    const TouchFrame& want = reference.update(frames[i], t);
    const RuntimeFrame& got = sense.update(frames[i], t);
    INFO("frame " << i + 1);
    CHECK(got.frame_index == static_cast<std::int64_t>(i) + 1);
    CHECK(got.timestamp_ms == t);
    CHECK(got.frame_size == frames[i].size());
    REQUIRE(got.touch.events.size() == want.events.size());
    for (std::size_t k = 0; k < want.events.size(); ++k) {
      CHECK(got.touch.events[k].track_id == want.events[k].track_id);
      CHECK(got.touch.events[k].event.to == want.events[k].event.to);
      CHECK(got.touch.events[k].event.timestamp_ms == want.events[k].event.timestamp_ms);
    }
    events += static_cast<int>(want.events.size());
    CHECK(got.gesture.available);
    if (!want.shadow_boxes.empty()) {
      ++classified;
      const Classification c = classifier.classify(frames[i]);
      CHECK(got.classified);
      CHECK(got.gesture.label == c.label);
      CHECK(got.gesture.frame_index == got.frame_index);
      CHECK(got.gesture.probabilities == c.probabilities); // bit for bit
      CHECK(got.gesture.confidence == c.probabilities[static_cast<std::size_t>(c.index)]);
    } else {
      ++gated;
      CHECK_FALSE(got.classified);
      CHECK(got.gesture.label.empty());
      CHECK(got.gesture.probabilities.empty());
    }
    // The sinks' frame is this frame, with its gesture.
    const OutputFrame& out = sense.output();
    CHECK(out.frame_index == got.frame_index);
    CHECK(out.events.size() == got.touch.events.size());
    CHECK(out.gesture.label == got.gesture.label);
    CHECK(out.gesture.class_names.size() == 6);
  }
  CHECK(classified >= 12); // the palm and the fist
  CHECK(gated >= 4);       // the empty skin before, between and after
  CHECK(events >= 6);
  // The end of the stream: one more frame with the pending lifts and no gesture.
  const TouchFrame& want_end = reference.flush(t + 40);
  const RuntimeFrame& end = sense.flush(t + 40);
  CHECK(end.frame_index == static_cast<std::int64_t>(frames.size()) + 1);
  CHECK(end.touch.events.size() == want_end.events.size());
  CHECK(end.gesture.label.empty());
  CHECK_FALSE(end.classified);
}

TEST_CASE("Runtime: classify_every carries the reading with the frame it was computed on") {
  const std::vector<cv::Mat> frames = sequence();
  Runtime every3(TouchPipeline(segmenter_from(calibration())), make_densenet_classifier(model()),
                 {.classify_every = 3});
  Runtime every1(TouchPipeline(segmenter_from(calibration())), make_densenet_classifier(model()));
  std::int64_t reading_from = 0;
  int runs = 0, shadow_frames = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const double t = 40.0 * static_cast<double>(i);
    const RuntimeFrame& a = every3.update(frames[i], t);
    const RuntimeFrame& b = every1.update(frames[i], t);
    INFO("frame " << i + 1);
    if (b.gesture.label.empty()) { // no shadow: both gated off, the count starts again
      CHECK(a.gesture.label.empty());
      reading_from = 0;
      continue;
    }
    ++shadow_frames;
    const bool due = reading_from == 0 || a.frame_index - reading_from >= 3;
    CHECK(a.classified == due);
    if (due) {
      reading_from = a.frame_index;
      ++runs;
      CHECK(a.gesture.probabilities == b.gesture.probabilities);
    }
    CHECK(a.gesture.frame_index == reading_from);
  }
  CHECK(runs < shadow_frames);
  CHECK(runs >= shadow_frames / 3);
  CHECK_THROWS_WITH_AS(
      Runtime(TouchPipeline(segmenter_from(calibration())), std::nullopt, {.classify_every = 0}),
      doctest::Contains("classify_every is 0"), InvalidArgument);
}

TEST_CASE("Runtime with a user-defined backend and without a classifier") {
  const std::vector<cv::Mat> frames = sequence();
  BasicRuntime<CalibratedRule, BrightnessBackend> user(
      TouchPipeline(segmenter_from(calibration())),
      Classifier<BrightnessBackend>(BrightnessBackend{}, {model().preprocess}));
  BasicRuntime<CalibratedRule, BrightnessBackend> none(TouchPipeline(segmenter_from(calibration())),
                                                       std::nullopt);
  CHECK_FALSE(none.has_classifier());
  CHECK(none.classifier() == nullptr);
  int shadow_frames = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const RuntimeFrame& r = user.update(frames[i], 40.0 * static_cast<double>(i));
    const RuntimeFrame& n = none.update(frames[i], 40.0 * static_cast<double>(i));
    shadow_frames += !r.touch.shadow_boxes.empty();
    if (!r.touch.shadow_boxes.empty())
      CHECK((r.gesture.label == "dark" || r.gesture.label == "bright"));
    CHECK_FALSE(n.gesture.available);
    CHECK(n.touch.events.size() == r.touch.events.size());
  }
  CHECK(user.classifier()->backend().calls == shadow_frames); // the gate, for any backend
  // Without a classifier the sinks write no gesture.
  std::ostringstream csv;
  CsvSink sink(csv, {.source = "", .header = false});
  const RuntimeFrame& end = none.flush(40.0 * static_cast<double>(frames.size()));
  sink.write(none.output());
  CHECK(end.touch.events.size() >= 1);
  CHECK(csv.str().find(",,,\n") != std::string::npos);
}

namespace {
// A recogniser of the user's own: one "tap" per frame with a contact, on that track.
struct EveryContactRecogniser {
  std::vector<GestureEvent> out;
  const std::vector<GestureEvent>& update(const TouchFrame& f, const OutputGesture&) {
    out.clear();
    for (const TouchTrack& t : f.tracks)
      if (t.contact) {
        GestureEvent& e = out.emplace_back();
        e.track_id = t.id;
        e.start_ms = e.end_ms = e.decided_ms = f.timestamp_ms;
      }
    return out;
  }
  const std::vector<GestureEvent>& flush(double) {
    out.clear();
    return out;
  }
};
static_assert(TemporalRecogniser<EveryContactRecogniser>);

bool same(const GestureEvent& a, const GestureEvent& b) {
  return a.gesture == b.gesture && a.phase == b.phase && a.track_id == b.track_id &&
         a.start_ms == b.start_ms && a.end_ms == b.end_ms && a.decided_ms == b.decided_ms &&
         a.position == b.position && a.direction == b.direction && a.length_px == b.length_px &&
         a.speed_px_s == b.speed_px_s && a.repetitions == b.repetitions &&
         a.hand_shape.view() == b.hand_shape.view() && a.confidence == b.confidence;
}
} // namespace

TEST_CASE("Runtime: the temporal gestures of the recogniser fed its frames; off by config; the "
          "user's own recogniser") {
  const std::vector<cv::Mat> frames = sequence();
  using UserRuntime = BasicRuntime<CalibratedRule, BrightnessBackend>;
  auto clf = [] {
    return Classifier<BrightnessBackend>(BrightnessBackend{}, {model().preprocess});
  };
  UserRuntime on(TouchPipeline(segmenter_from(calibration())), clf());
  RuntimeConfig off_config;
  off_config.temporal_gestures = false;
  UserRuntime off(TouchPipeline(segmenter_from(calibration())), clf(), off_config);
  BasicRuntime<CalibratedRule, BrightnessBackend, EveryContactRecogniser> mine(
      TouchPipeline(segmenter_from(calibration())), clf());
  TemporalGestureRecogniser reference;
  int strokes = 0, total = 0, contacts = 0, mine_events = 0;
  double t = 0;
  auto compare = [&](const RuntimeFrame& r, const std::vector<GestureEvent>& want) {
    REQUIRE(r.touch_gestures.size() == want.size());
    for (std::size_t k = 0; k < want.size(); ++k) CHECK(same(r.touch_gestures[k], want[k]));
    const OutputFrame& out = on.output();
    REQUIRE(out.touch_gestures.size() == want.size());
    for (std::size_t k = 0; k < want.size(); ++k) CHECK(same(out.touch_gestures[k], want[k]));
    for (const GestureEvent& e : want) strokes += e.gesture == TouchGesture::stroke, ++total;
  };
  for (std::size_t i = 0; i < frames.size(); ++i) {
    t = 40.0 * static_cast<double>(i);
    INFO("frame " << i + 1);
    const RuntimeFrame& r = on.update(frames[i], t);
    compare(r, reference.update(r.touch, r.gesture));
    CHECK(off.update(frames[i], t).touch_gestures.empty());
    CHECK(off.output().touch_gestures.empty());
    const RuntimeFrame& m = mine.update(frames[i], t);
    for (const TouchTrack& tr : m.touch.tracks) contacts += tr.contact.has_value();
    mine_events += static_cast<int>(m.touch_gestures.size());
  }
  const RuntimeFrame& end = on.flush(t + 40);
  compare(end, reference.flush(t + 40));
  CHECK(strokes == 1); // the palm's slide
  CHECK(total >= 1);
  CHECK(contacts >= 6);
  CHECK(mine_events == contacts);
}

TEST_CASE("TouchPipeline refuses an uncalibrated segmenter unless the caller opts in by name") {
  CHECK_THROWS_WITH_AS(TouchPipeline{Segmenter(SegmenterConfig{})},
                       doctest::Contains("not calibrated (no empty-skin model)"), InvalidArgument);
  CHECK_THROWS_WITH_AS(TouchPipeline{Segmenter(SegmenterConfig{})},
                       doctest::Contains("TouchPipeline(uncalibrated, segmenter)"),
                       InvalidArgument);
  // Opting in: by name, the paper's fixed colour ranges, the adaptive model, or a calibration.
  CHECK_NOTHROW(TouchPipeline(uncalibrated, Segmenter(SegmenterConfig{})));
  SegmenterConfig fixed;
  fixed.calibration.mode = SegmentMode::fixed_ranges;
  CHECK_NOTHROW(TouchPipeline{Segmenter(fixed)});
  SegmenterConfig adaptive;
  adaptive.adaptive = true;
  CHECK_NOTHROW(TouchPipeline{Segmenter(adaptive)});
  CHECK_NOTHROW(TouchPipeline{segmenter_from(calibration())});
  // Why it matters: on the empty skin an uncalibrated pipeline reports phantom shadows the
  // calibrated one does not.
  std::vector<cv::Mat> empty;
  for (int k = 0; k < 6; ++k)
    empty.push_back(renderer()
                        .render(sim::Scene{}, sim::light_from_level(0.2 * k, 30),
                                700 + static_cast<std::uint64_t>(k))
                        .image);
  TouchPipeline raw(uncalibrated, Segmenter(SegmenterConfig{}));
  TouchPipeline calibrated(segmenter_from(calibration()));
  std::size_t raw_shadows = 0, calibrated_shadows = 0;
  for (std::size_t i = 0; i < empty.size(); ++i) {
    raw_shadows += raw.update(empty[i], 40.0 * static_cast<double>(i)).shadow_boxes.size();
    calibrated_shadows +=
        calibrated.update(empty[i], 40.0 * static_cast<double>(i)).shadow_boxes.size();
  }
  CHECK(calibrated_shadows == 0);
  CHECK(raw_shadows > 0);
}

namespace {

namespace ss = shadowsense;

// The README's Runtime loop, verbatim between the markers (the test below compares the text).
template <class Camera, class React>
void readme_runtime_loop(const Camera& camera, React&& react) {
  // clang-format off
  // README-BEGIN
  ss::Runtime sense{ss::TouchPipeline{ss::Segmenter({.calibration = ss::load_calibration("skin.calib")})},
                    ss::make_densenet_classifier(ss::ModelFile::load("default.ssm"))};
  ss::CsvSink csv(std::cout); // the event schema (docs/output.md); add a TuioSink or your own sink
  double t_end = 0;
  for (const auto& [frame, t_ms] : camera) {
    const ss::RuntimeFrame& r = sense.update(frame, t_ms); // r.touch.events, r.gesture.label
    for (const ss::GestureEvent& g : r.touch_gestures) react(g); // a tap, a pat, a stroke...
    ss::publish(sense.output(), csv);
    t_end = t_ms;
  }
  sense.flush(t_end + 33); // the stream ended: pending lifts and disappears
  ss::publish(sense.output(), csv); // the lifts reach the sinks
  // README-END
  // clang-format on
}

} // namespace

TEST_CASE("the README's Runtime loop is this compiled code, and it prints events with gestures") {
  const auto snippet = tests::readme_snippet("tests/test_runtime.cpp", "ss::Runtime sense{",
                                             "the lifts reach the sinks");
  REQUIRE(snippet.readme.size() == 12);
  CHECK(snippet.readme == snippet.here);
  const tests::WorkingFolder folder("readme_runtime");
  std::filesystem::copy_file(SHADOWSENSE_SOURCE_DIR "/models/default.ssm", "default.ssm");
  save_calibration(calibration().config.calibration, "skin.calib");
  const std::vector<cv::Mat> frames = sequence();
  std::vector<std::pair<cv::Mat, double>> camera;
  for (std::size_t i = 0; i < frames.size(); ++i)
    camera.emplace_back(frames[i], 40.0 * static_cast<double>(i));
  std::ostringstream printed;
  std::streambuf* const cout_buf = std::cout.rdbuf(printed.rdbuf());
  std::vector<GestureEvent> reacted;
  readme_runtime_loop(camera, [&](const GestureEvent& g) { reacted.push_back(g); });
  std::cout.rdbuf(cout_buf);
  const std::string text = printed.str();
  CHECK(text.rfind(std::string(event_csv_header) + "\n", 0) == 0);
  CHECK(text.find(",appear,touch,") != std::string::npos);
  CHECK(text.find(",lift,none,") != std::string::npos);
  CHECK(text.find(",palm,") != std::string::npos); // the palm's touch, with its hand shape
  // The palm's slide is a stroke, given to the loop's reaction and printed as a gesture row.
  CHECK(std::count_if(reacted.begin(), reacted.end(), [](const GestureEvent& g) {
          return g.gesture == TouchGesture::stroke;
        }) == 1);
  CHECK(text.find(",gesture,") != std::string::npos);
  CHECK(text.find(",stroke,complete,") != std::string::npos);
}

TEST_CASE("Runtime: a lens cap is a camera fault - no shadow, no classification, no hug") {
  // Before the camera check, the black frames were one whole-skin shadow: appear, and the
  // shipped model read them as hug with p close to 1.
  const cv::Mat sample = sequence().front();
  Runtime sense(TouchPipeline(segmenter_from(calibration())), make_densenet_classifier(model()));
  std::ostringstream csv_text;
  CsvSink csv(csv_text, {.source = "", .header = false});
  for (int i = 0; i < 8; ++i) {
    const cv::Mat frame = i < 2 ? sample : cv::Mat(sample.size(), CV_8UC3, cv::Scalar::all(0));
    const RuntimeFrame& r = sense.update(frame, 40.0 * (i + 1));
    INFO("frame " << i + 1);
    CHECK(r.touch.camera == (i < 2 ? CameraFault::none : CameraFault::dark));
    if (i >= 2) {
      CHECK_FALSE(r.classified);
      CHECK(r.gesture.label.empty());
      CHECK(r.touch.events.empty());
      CHECK(r.touch_gestures.empty());
    }
    csv.write(sense.output());
  }
  CHECK(csv_text.str() == "4,camera,,3,120,0,none,dark,,,,,,,,,,,,,,,\n");
}
