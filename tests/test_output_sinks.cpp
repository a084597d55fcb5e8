// Event sinks: the CSV and JSON-lines text exactly, quoting and escaping, stream failures, a
// user-defined sink through publish(), and OutputFrameBuilder on a TouchPipeline-shaped frame.
#include <shadowsense/output/csv_sink.hpp>
#include <shadowsense/output/event_sink.hpp>
#include <shadowsense/output/json_lines_sink.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

using namespace shadowsense;

namespace {
// Two events of one frame: track 3 starts touching (no position on appear), track 4 moves left.
OutputFrame sample_frame() {
  OutputFrame f;
  f.frame_index = 12;
  f.timestamp_ms = 396.5;
  f.frame_size = {200, 100};
  f.events.push_back(
      {3, TouchEvent{396.5, TouchState::none, TouchState::appear, Direction::none, std::nullopt}});
  f.events.push_back({4, TouchEvent{396.5, TouchState::touch, TouchState::move, Direction::left,
                                    cv::Point2f(101.5f, 0.1f)}});
  return f;
}

// The TouchPipeline's per-frame result has this shape (sense/touch_pipeline.hpp).
struct PipelineTrack {
  int id = 0;
  bool matched = false;
  cv::Rect shadow_box{};
  cv::Point2f position{};
  std::optional<cv::Point2f> contact{};
  TouchState state = TouchState::none;
};
struct PipelineEvent {
  int track_id = 0;
  TouchEvent event{};
};
struct PipelineFrame {
  double timestamp_ms = 0;
  std::vector<PipelineTrack> tracks;
  std::vector<PipelineEvent> events;
};
static_assert(TouchFrameLike<PipelineFrame>);

// A user's own sink: counts events per frame.
struct CountingSink {
  std::vector<std::size_t> events_per_frame;
  void write(const OutputFrame& f) { events_per_frame.push_back(f.events.size()); }
};
static_assert(EventSink<CountingSink>);
static_assert(!EventSink<int>);
} // namespace

TEST_CASE("CsvSink writes a header and one row per event, exactly") {
  std::ostringstream out;
  CsvSink sink(out);
  sink.write(sample_frame());
  sink.write(OutputFrame{}); // no events: nothing
  CHECK(out.str() == "schema,kind,source,frame,timestamp_ms,track_id,from,to,direction,x,y,"
                     "gesture,confidence,gesture_frame,touch_gesture,phase,start_ms,end_ms,"
                     "length_px,speed_px_s,repetitions,hand_shape,gesture_confidence\n"
                     "4,touch,,12,396.5,3,none,appear,none,,,,,,,,,,,,,,\n"
                     "4,touch,,12,396.5,4,touch,move,left,101.5,0.1,,,,,,,,,,,,\n");
  CHECK(std::string(event_csv_header) + "\n" == out.str().substr(0, out.str().find('\n') + 1));
}

// A frame whose classifier reading is "palm" at 0.75, computed on frame 11.
OutputFrame frame_with_gesture() {
  OutputFrame f = sample_frame();
  f.gesture.available = true;
  f.gesture.label = "palm";
  f.gesture.confidence = 0.75f;
  f.gesture.frame_index = 11;
  f.gesture.class_names = {"nothing", "palm"};
  f.gesture.probabilities = {0.25f, 0.75f};
  return f;
}

TEST_CASE("CsvSink and JsonLinesSink write the frame's gesture, and nothing while gated off") {
  std::ostringstream csv_out, json_out;
  CsvSink csv(csv_out, {.source = "cam", .header = false});
  JsonLinesSink json(json_out, {.source = "cam"});
  OutputFrame f = frame_with_gesture();
  f.events.resize(1);
  csv.write(f);
  json.write(f);
  f.gesture.label.clear(); // gated off: available, no reading
  csv.write(f);
  json.write(f);
  CHECK(csv_out.str() == "4,touch,cam,12,396.5,3,none,appear,none,,,palm,0.75,11,,,,,,,,,\n"
                         "4,touch,cam,12,396.5,3,none,appear,none,,,,,,,,,,,,,,\n");
  CHECK(json_out.str() ==
        "{\"schema\":4,\"kind\":\"touch\",\"source\":\"cam\",\"frame\":12,\"timestamp_ms\":396.5,"
        "\"track_id\":3,"
        "\"from\":\"none\",\"to\":\"appear\",\"direction\":\"none\",\"x\":null,\"y\":null,"
        "\"gesture\":\"palm\",\"confidence\":0.75,\"gesture_frame\":11,"
        "\"touch_gesture\":null,\"phase\":null,\"start_ms\":null,\"end_ms\":null,"
        "\"length_px\":null,\"speed_px_s\":null,\"repetitions\":null,\"hand_shape\":null,"
        "\"gesture_confidence\":null}\n"
        "{\"schema\":4,\"kind\":\"touch\",\"source\":\"cam\",\"frame\":12,\"timestamp_ms\":396.5,"
        "\"track_id\":3,"
        "\"from\":\"none\",\"to\":\"appear\",\"direction\":\"none\",\"x\":null,\"y\":null,"
        "\"gesture\":null,\"confidence\":null,\"gesture_frame\":null,"
        "\"touch_gesture\":null,\"phase\":null,\"start_ms\":null,\"end_ms\":null,"
        "\"length_px\":null,\"speed_px_s\":null,\"repetitions\":null,\"hand_shape\":null,"
        "\"gesture_confidence\":null}\n");
}

TEST_CASE("the one JSON escaper: invalid UTF-8 becomes U+FFFD, valid UTF-8 and DEL as expected") {
  std::string out;
  detail::append_json_string(out, "caf\xc3\xa9 \xff \xed\xa0\x80 \xc0\xaf \x7f \xf0\x9f\x91\x8b");
  // \xed\xa0\x80 is a surrogate, \xc0\xaf an overlong '/': each byte is one U+FFFD.
  CHECK(out == "\"caf\xc3\xa9 \\ufffd \\ufffd\\ufffd\\ufffd \\ufffd\\ufffd \\u007f "
               "\xf0\x9f\x91\x8b\"");
  std::ostringstream json_out;
  JsonLinesSink json(json_out, {.source = "bad\xfe"});
  json.write(sample_frame());
  CHECK(json_out.str().rfind("{\"schema\":4,\"kind\":\"touch\",\"source\":\"bad\\ufffd\",", 0) ==
        0);
}

TEST_CASE("CsvSink quotes a source that needs it and can leave out the header") {
  std::ostringstream out;
  CsvSink::Config config;
  config.source = "run \"7\", cam,0";
  config.header = false;
  CsvSink sink(out, config);
  OutputFrame f = sample_frame();
  f.events.resize(1);
  sink.write(f);
  CHECK(out.str() ==
        "4,touch,\"run \"\"7\"\", cam,0\",12,396.5,3,none,appear,none,,,,,,,,,,,,,,\n");
  std::string field;
  detail::append_csv_field(field, " lead");
  CHECK(field == "\" lead\"");
  field.clear();
  detail::append_csv_field(field, "two\nlines");
  CHECK(field == "\"two\nlines\"");
  field.clear();
  detail::append_csv_field(field, "plain");
  CHECK(field == "plain");
}

TEST_CASE("JsonLinesSink writes one object per event per line, strings escaped") {
  std::ostringstream out;
  JsonLinesSink::Config config;
  config.source = "a\"b\\c\n\x01";
  JsonLinesSink sink(out, config);
  sink.write(sample_frame());
  const std::string no_gesture =
      ",\"gesture\":null,\"confidence\":null,\"gesture_frame\":null,\"touch_gesture\":null,"
      "\"phase\":null,\"start_ms\":null,\"end_ms\":null,\"length_px\":null,\"speed_px_s\":null,"
      "\"repetitions\":null,\"hand_shape\":null,\"gesture_confidence\":null}\n";
  CHECK(out.str() ==
        "{\"schema\":4,\"kind\":\"touch\",\"source\":\"a\\\"b\\\\c\\n\\u0001\",\"frame\":12,"
        "\"timestamp_ms\":396.5,\"track_id\":3,\"from\":\"none\",\"to\":\"appear\","
        "\"direction\":\"none\",\"x\":null,\"y\":null" +
            no_gesture +
            "{\"schema\":4,\"kind\":\"touch\",\"source\":\"a\\\"b\\\\c\\n\\u0001\",\"frame\":12,"
            "\"timestamp_ms\":396.5,\"track_id\":4,\"from\":\"touch\",\"to\":\"move\","
            "\"direction\":\"left\",\"x\":101.5,\"y\":0.1" +
            no_gesture);
  std::ostringstream plain;
  JsonLinesSink no_source(plain);
  OutputFrame f = sample_frame();
  f.events.resize(1);
  f.events[0].event.timestamp_ms = std::numeric_limits<double>::quiet_NaN();
  no_source.write(f);
  CHECK(plain.str() ==
        "{\"schema\":4,\"kind\":\"touch\",\"source\":\"\",\"frame\":12,\"timestamp_ms\":null,"
        "\"track_id\":3,\"from\":\"none\",\"to\":\"appear\",\"direction\":\"none\","
        "\"x\":null,\"y\":null" +
            no_gesture);
}

TEST_CASE("a failed stream is an IoError, at construction and on write") {
  std::ostringstream bad;
  bad.setstate(std::ios::badbit);
  CHECK_THROWS_AS(CsvSink{bad}, IoError);
  CHECK_THROWS_AS(JsonLinesSink{bad}, IoError);
  std::ostringstream out;
  CsvSink csv(out);
  JsonLinesSink json(out);
  out.setstate(std::ios::failbit);
  CHECK_THROWS_WITH_AS(csv.write(sample_frame()), doctest::Contains("CsvSink: writing"), IoError);
  CHECK_THROWS_WITH_AS(json.write(sample_frame()), doctest::Contains("JsonLinesSink: writing"),
                       IoError);
}

TEST_CASE("publish() writes one frame to a user-defined sink and the library's sinks in order") {
  CountingSink counter;
  EventSinkArchetype archetype;
  std::ostringstream out;
  CsvSink::Config no_header;
  no_header.header = false;
  CsvSink csv(out, no_header);
  publish(sample_frame(), counter, archetype, csv);
  publish(OutputFrame{}, counter, csv);
  CHECK(counter.events_per_frame == std::vector<std::size_t>{2, 0});
  const std::string text = out.str();
  CHECK(std::count(text.begin(), text.end(), '\n') == 2);
  CHECK(text.rfind("4,touch,,12,396.5,4,touch,move,left,101.5,0.1,,,,,,,,,,,,\n") ==
        text.find('\n') + 1);
}

TEST_CASE("OutputFrameBuilder: contacts while touching (last point during the hysteresis), "
          "shadows for every track, events copied, frame index counting from 1") {
  OutputFrameBuilder builder;
  PipelineFrame f;
  f.timestamp_ms = 0;
  f.tracks.push_back(
      {1, true, cv::Rect(10, 10, 40, 30), {30, 25}, cv::Point2f(20, 15), TouchState::touch});
  f.tracks.push_back(
      {2, true, cv::Rect(100, 10, 20, 20), {110, 20}, std::nullopt, TouchState::appear});
  f.events.push_back(
      {1, TouchEvent{0, TouchState::none, TouchState::appear, Direction::none, std::nullopt}});
  f.events.push_back({1, TouchEvent{0, TouchState::appear, TouchState::touch, Direction::none,
                                    cv::Point2f(20, 15)}});
  const OutputFrame& a = builder.build(f, {200, 100});
  CHECK(a.frame_index == 1);
  CHECK(a.frame_size == cv::Size(200, 100));
  REQUIRE(a.contacts.size() == 1);
  CHECK(a.contacts[0].id == 1);
  CHECK(a.contacts[0].position == cv::Point2f(20, 15));
  REQUIRE(a.shadows.size() == 2);
  CHECK(a.shadows[1].id == 2);
  CHECK(a.shadows[1].box == cv::Rect(100, 10, 20, 20));
  REQUIRE(a.events.size() == 2);
  CHECK(a.events[1].event.to == TouchState::touch);

  // Contact lost for a frame but the machine still touches (hysteresis): the last point stays.
  f.timestamp_ms = 33;
  f.events.clear();
  f.tracks[0].contact.reset();
  const OutputFrame& b = builder.build(f, {200, 100});
  CHECK(b.frame_index == 2);
  REQUIRE(b.contacts.size() == 1);
  CHECK(b.contacts[0].position == cv::Point2f(20, 15));
  CHECK(b.events.empty());

  // Lifted: no contact any more.
  f.timestamp_ms = 200;
  f.tracks[0].state = TouchState::lift;
  const OutputFrame& c = builder.build(f, {200, 100});
  CHECK(c.contacts.empty());
  CHECK(c.shadows.size() == 2);
  CHECK_THROWS_AS(builder.build(f, {0, 100}), InvalidArgument);
}

namespace {
// Two temporal gestures: a double tap (a revision) and a stroke to the right.
OutputFrame frame_with_touch_gestures() {
  OutputFrame f;
  f.frame_index = 30;
  f.timestamp_ms = 920;
  f.frame_size = {200, 100};
  GestureEvent tap;
  tap.gesture = TouchGesture::double_tap;
  tap.phase = GesturePhase::revised;
  tap.track_id = 3;
  tap.start_ms = 400;
  tap.end_ms = 900;
  tap.decided_ms = 900;
  tap.position = {100, 50};
  tap.repetitions = 2;
  tap.hand_shape.assign("point");
  tap.confidence = 1;
  GestureEvent stroke;
  stroke.gesture = TouchGesture::stroke;
  stroke.track_id = 4;
  stroke.start_ms = 500;
  stroke.end_ms = 920;
  stroke.decided_ms = 920;
  stroke.position = {100.5f, 80.25f};
  stroke.direction = Direction::right;
  stroke.length_px = 200;
  stroke.speed_px_s = 476.5f;
  stroke.hand_shape.assign("pa,lm");
  stroke.confidence = 0.5f;
  f.touch_gestures = {tap, stroke};
  return f;
}
} // namespace

TEST_CASE("CsvSink and JsonLinesSink write temporal gestures as rows of kind gesture, exactly") {
  std::ostringstream csv_out, json_out;
  CsvSink csv(csv_out, {.source = "cam", .header = false});
  JsonLinesSink json(json_out, {.source = "cam"});
  OutputFrame f = frame_with_touch_gestures();
  csv.write(f);
  json.write(f);
  CHECK(csv_out.str() ==
        "4,gesture,cam,30,900,3,,,none,100,50,,,,double_tap,revised,400,900,0,0,2,point,1\n"
        "4,gesture,cam,30,920,4,,,right,100.5,80.25,,,,stroke,complete,500,920,200,476.5,1,"
        "\"pa,lm\",0.5\n");
  CHECK(json_out.str() ==
        "{\"schema\":4,\"kind\":\"gesture\",\"source\":\"cam\",\"frame\":30,\"timestamp_ms\":900,"
        "\"track_id\":3,\"from\":null,\"to\":null,\"direction\":\"none\",\"x\":100,\"y\":50,"
        "\"gesture\":null,\"confidence\":null,\"gesture_frame\":null,\"touch_gesture\":"
        "\"double_tap\",\"phase\":\"revised\",\"start_ms\":400,\"end_ms\":900,\"length_px\":0,"
        "\"speed_px_s\":0,\"repetitions\":2,\"hand_shape\":\"point\",\"gesture_confidence\":1}\n"
        "{\"schema\":4,\"kind\":\"gesture\",\"source\":\"cam\",\"frame\":30,\"timestamp_ms\":920,"
        "\"track_id\":4,\"from\":null,\"to\":null,\"direction\":\"right\",\"x\":100.5,"
        "\"y\":80.25,\"gesture\":null,\"confidence\":null,\"gesture_frame\":null,"
        "\"touch_gesture\":\"stroke\",\"phase\":\"complete\",\"start_ms\":500,\"end_ms\":920,"
        "\"length_px\":200,\"speed_px_s\":476.5,\"repetitions\":1,\"hand_shape\":\"pa,lm\","
        "\"gesture_confidence\":0.5}\n");
  // touch rows first, then gesture rows, with the frame's hand shape on both
  std::ostringstream both;
  CsvSink csv2(both, {.source = "", .header = false});
  OutputFrame g = frame_with_gesture();
  g.events.resize(1);
  g.touch_gestures = {frame_with_touch_gestures().touch_gestures[0]};
  csv2.write(g);
  CHECK(both.str() == "4,touch,,12,396.5,3,none,appear,none,,,palm,0.75,11,,,,,,,,,\n"
                      "4,gesture,,12,900,3,,,none,100,50,palm,0.75,11,double_tap,revised,400,"
                      "900,0,0,2,point,1\n");
}

TEST_CASE("OutputFrameBuilder carries the temporal gestures and clears them with a plain build") {
  OutputFrameBuilder builder;
  PipelineFrame pf;
  pf.timestamp_ms = 5;
  const std::vector<GestureEvent> events = frame_with_touch_gestures().touch_gestures;
  const OutputFrame& a = builder.build(pf, {10, 10}, OutputGesture{}, events);
  REQUIRE(a.touch_gestures.size() == 2);
  CHECK(a.touch_gestures[1].gesture == TouchGesture::stroke);
  CHECK(a.touch_gestures[1].hand_shape.view() == "pa,lm");
  const OutputFrame& b = builder.build(pf, {10, 10});
  CHECK(b.touch_gestures.empty());
}

TEST_CASE("a camera fault change is one row of kind camera, before the frame's touch rows") {
  std::ostringstream csv_out, json_out;
  CsvSink csv(csv_out, {.source = "cam", .header = false});
  JsonLinesSink json(json_out, {.source = "cam"});
  OutputFrame f = sample_frame();
  f.events.resize(1);
  f.camera_before = CameraFault::none;
  f.camera = CameraFault::dark;
  csv.write(f);
  json.write(f);
  f.camera_before = CameraFault::dark; // still dark: no row; no events either: nothing at all
  f.events.clear();
  csv.write(f);
  json.write(f);
  CHECK(csv_out.str() == "4,camera,cam,12,396.5,0,none,dark,,,,,,,,,,,,,,,\n"
                         "4,touch,cam,12,396.5,3,none,appear,none,,,,,,,,,,,,,,\n");
  CHECK(json_out.str().substr(0, json_out.str().find('\n')) ==
        "{\"schema\":4,\"kind\":\"camera\",\"source\":\"cam\",\"frame\":12,\"timestamp_ms\":396.5,"
        "\"track_id\":0,\"from\":\"none\",\"to\":\"dark\",\"direction\":null,\"x\":null,"
        "\"y\":null,\"gesture\":null,\"confidence\":null,\"gesture_frame\":null,"
        "\"touch_gesture\":null,\"phase\":null,\"start_ms\":null,\"end_ms\":null,"
        "\"length_px\":null,\"speed_px_s\":null,\"repetitions\":null,\"hand_shape\":null,"
        "\"gesture_confidence\":null}");
  const std::string json_text = json_out.str();
  CHECK(std::count(json_text.begin(), json_text.end(), '\n') == 2);
  // Every CSV row has the header's 23 fields.
  std::istringstream rows(csv_out.str());
  for (std::string row; std::getline(rows, row);)
    CHECK(std::count(row.begin(), row.end(), ',') ==
          std::count(event_csv_header, event_csv_header + std::strlen(event_csv_header), ','));
  // The builder copies the state from a TouchPipeline frame, and leaves none without one.
  OutputFrameBuilder builder;
  TouchFrame tf;
  tf.camera = CameraFault::frozen;
  tf.camera_before = CameraFault::none;
  CHECK(builder.build(tf, {10, 10}).camera == CameraFault::frozen);
  CHECK(builder.build(PipelineFrame{}, {10, 10}).camera == CameraFault::none);
}
