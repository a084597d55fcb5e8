// JsonLinesSink: touch events and temporal gestures as JSON Lines (one JSON object per event per
// line) on any std::ostream.
//
// Each line: the fields of CsvSink's columns (the event schema, version 4, docs/output.md), in
// the same order and with the same names:
//   {"schema":4,"kind":"touch","source":"cam0","frame":12,"timestamp_ms":396,"track_id":1,
//    "from":"touch","to":"move","direction":"left","x":101.5,"y":80.25,"gesture":"palm",
//    "confidence":0.97,"gesture_frame":12,"touch_gesture":null,...,"gesture_confidence":null}
//   "source" is Config::source ("" when not set), escaped as a JSON string (RFC 8259, invalid
//   UTF-8 as U+FFFD); x and y are null when the event has no contact position; gesture,
//   confidence and gesture_frame are null when the run has no classifier or it was gated off;
//   from and to are null on gesture lines, the temporal gesture's fields null on touch lines,
//   hand_shape null when the gesture has none. A camera line (kind "camera", track_id 0) has
//   from and to (the fault states, as CsvSink) and every other field null.
//   Numbers are the shortest round-trip decimal, '.' whatever the locale; a non-finite number
//   is written as null.
//
// JsonLinesSink(out, config = {})
//   requires: `out` outlives the sink.
//   throws:   IoError if the stream is already failed.
// write(frame)
//   ensures:  a camera line when frame.camera_changed(), one line per frame.events entry, in
//             order, then one per frame.touch_gestures entry.
//   throws:   IoError when the stream fails.
// Threading: one thread per instance (and per stream). No allocation after warm-up.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/output/event_sink.hpp>
#include <shadowsense/output/text_format.hpp>

#include <cmath>
#include <ostream>
#include <string>

SHADOWSENSE_NAMESPACE_BEGIN

class JsonLinesSink {
public:
  struct Config {
    std::string source; // "source" member of every object
    bool flush = false; // flush the stream after every frame with events (for pipes)
  };

  explicit JsonLinesSink(std::ostream& out) : JsonLinesSink(out, Config{}) {}
  JsonLinesSink(std::ostream& out, Config config) : out_(out), config_(std::move(config)) {
    detail::require<IoError>(out_.good(), "JsonLinesSink: the output stream is not writable");
    prefix_ = "{\"schema\":";
    detail::append_integer(prefix_, event_schema_version);
    prefix_ += ",\"kind\":\"";
    source_ = "\",\"source\":";
    detail::append_json_string(source_, config_.source);
    source_ += ',';
    line_.reserve(256);
  }

  void write(const OutputFrame& frame) {
    if (frame.events.empty() && frame.touch_gestures.empty() && !frame.camera_changed()) return;
    if (frame.camera_changed()) { // track 0: the camera, not a hand
      begin("camera", frame, frame.timestamp_ms, 0);
      line_ += ",\"from\":\"";
      line_ += to_string(frame.camera_before);
      line_ += "\",\"to\":\"";
      line_ += to_string(frame.camera);
      line_ += "\",\"direction\":null,\"x\":null,\"y\":null,\"gesture\":null,\"confidence\":null,"
               "\"gesture_frame\":null,\"touch_gesture\":null,\"phase\":null,\"start_ms\":null,"
               "\"end_ms\":null,\"length_px\":null,\"speed_px_s\":null,\"repetitions\":null,"
               "\"hand_shape\":null,\"gesture_confidence\":null}\n";
      out_.write(line_.data(), static_cast<std::streamsize>(line_.size()));
    }
    for (const OutputEvent& e : frame.events) {
      begin("touch", frame, e.event.timestamp_ms, e.track_id);
      line_ += ",\"from\":\"";
      line_ += to_string(e.event.from);
      line_ += "\",\"to\":\"";
      line_ += to_string(e.event.to);
      line_ += "\",\"direction\":\"";
      line_ += to_string(e.event.direction);
      line_ += "\",\"x\":";
      if (e.event.position) {
        number(e.event.position->x);
        line_ += ",\"y\":";
        number(e.event.position->y);
      } else {
        line_ += "null,\"y\":null";
      }
      gesture(frame.gesture);
      line_ += ",\"touch_gesture\":null,\"phase\":null,\"start_ms\":null,\"end_ms\":null,"
               "\"length_px\":null,\"speed_px_s\":null,\"repetitions\":null,\"hand_shape\":null,"
               "\"gesture_confidence\":null}\n";
      out_.write(line_.data(), static_cast<std::streamsize>(line_.size()));
    }
    for (const GestureEvent& e : frame.touch_gestures) {
      begin("gesture", frame, e.decided_ms, e.track_id);
      line_ += ",\"from\":null,\"to\":null,\"direction\":\"";
      line_ += to_string(e.direction);
      line_ += "\",\"x\":";
      number(e.position.x);
      line_ += ",\"y\":";
      number(e.position.y);
      gesture(frame.gesture);
      line_ += ",\"touch_gesture\":\"";
      line_ += to_string(e.gesture);
      line_ += "\",\"phase\":\"";
      line_ += to_string(e.phase);
      line_ += "\",\"start_ms\":";
      number(e.start_ms);
      line_ += ",\"end_ms\":";
      number(e.end_ms);
      line_ += ",\"length_px\":";
      number(e.length_px);
      line_ += ",\"speed_px_s\":";
      number(e.speed_px_s);
      line_ += ",\"repetitions\":";
      detail::append_integer(line_, e.repetitions);
      line_ += ",\"hand_shape\":";
      if (e.hand_shape.empty())
        line_ += "null";
      else
        detail::append_json_string(line_, e.hand_shape.view());
      line_ += ",\"gesture_confidence\":";
      number(e.confidence);
      line_ += "}\n";
      out_.write(line_.data(), static_cast<std::streamsize>(line_.size()));
    }
    if (config_.flush) out_.flush();
    detail::require<IoError>(out_.good(), "JsonLinesSink: writing to the output stream failed "
                                          "(closed pipe or full disk?)");
  }

private:
  // {"schema":4,"kind":K,"source":S,"frame":F,"timestamp_ms":T,"track_id":I
  void begin(const char* kind, const OutputFrame& frame, double t, int track_id) {
    line_.assign(prefix_);
    line_ += kind;
    line_ += source_;
    line_ += "\"frame\":";
    detail::append_integer(line_, frame.frame_index);
    line_ += ",\"timestamp_ms\":";
    number(t);
    line_ += ",\"track_id\":";
    detail::append_integer(line_, track_id);
  }

  // ,"gesture":..,"confidence":..,"gesture_frame":..
  void gesture(const OutputGesture& g) {
    if (g.available && !g.label.empty()) {
      line_ += ",\"gesture\":";
      detail::append_json_string(line_, g.label);
      line_ += ",\"confidence\":";
      number(g.confidence);
      line_ += ",\"gesture_frame\":";
      detail::append_integer(line_, g.frame_index);
    } else {
      line_ += ",\"gesture\":null,\"confidence\":null,\"gesture_frame\":null";
    }
  }

  template <class T>
  void number(T v) {
    if (std::isfinite(v))
      detail::append_number(line_, v);
    else
      line_ += "null";
  }

  std::ostream& out_;
  Config config_;
  std::string prefix_, source_;
  std::string line_;
};
static_assert(EventSink<JsonLinesSink>);

SHADOWSENSE_NAMESPACE_END
