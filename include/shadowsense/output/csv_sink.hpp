// CsvSink: touch events and temporal gestures as CSV (RFC 4180) on any std::ostream, one row per
// event.
//
// Columns (header row first unless Config::header is false): the project's event schema,
// version 4 (docs/output.md; JsonLinesSink writes the same fields):
//   schema,kind,source,frame,timestamp_ms,track_id,from,to,direction,x,y,gesture,confidence,
//   gesture_frame,touch_gesture,phase,start_ms,end_ms,length_px,speed_px_s,repetitions,
//   hand_shape,gesture_confidence
//   schema        4 (event_schema_version)
//   kind          touch (a touch event: from, to), gesture (a temporal gesture: the last nine)
//                 or camera (the camera's fault state changed: from, to are none, dark,
//                 saturated or frozen; track_id 0; sense/camera_health.hpp)
//   source        Config::source (e.g. the input file or camera name), quoted when it holds a
//                 comma, quote, CR/LF or leading/trailing space
//   frame         OutputFrame::frame_index
//   timestamp_ms  the event's timestamp (a gesture: the frame that decided it); numbers are the
//                 shortest round-trip decimal, '.' whatever the locale
//   track_id      the track the event belongs to (0: a whole-frame gesture, hug/punch/two_hands)
//   from, to      none|appear|touch|move|lift (to=none is the paper's "disappear"); empty for
//                 a gesture
//   direction     none|left|right|front|back (move events, strokes), else none
//   x, y          the event's contact position in image pixels (a gesture: where it began),
//                 empty when it has none
//   gesture       the frame's hand shape (OutputFrame::gesture.label), empty when the run has no
//                 classifier or it was gated off (no shadow)
//   confidence    its probability, empty with it
//   gesture_frame the frame it was computed on, empty with it
//   touch_gesture tap|double_tap|pat|stroke|rub|hold|hit|hug|punch|two_hands (gesture rows)
//   phase         complete|began|ended|revised (GesturePhase)
//   start_ms, end_ms, length_px, speed_px_s, repetitions, hand_shape, gesture_confidence
//                 the GestureEvent's fields (sense/gesture_event.hpp); empty on touch rows
// Lines end with "\n". The header is written by the constructor.
//
// CsvSink(out, config = {})
//   requires: `out` outlives the sink.
//   throws:   IoError if the stream is already failed or writing the header fails.
// write(frame)
//   ensures:  a camera row when frame.camera_changed(), then one row per frame.events entry, in
//             order, then one per frame.touch_gestures entry; frames without any write nothing.
//   throws:   IoError when the stream fails (e.g. disk full); the stream's state is left as is.
// Threading: one thread per instance (and per stream). No allocation after warm-up: one line
// buffer is reused.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/output/event_sink.hpp>
#include <shadowsense/output/text_format.hpp>

#include <cmath>
#include <ostream>
#include <string>
#include <string_view>

SHADOWSENSE_NAMESPACE_BEGIN

class CsvSink {
public:
  struct Config {
    std::string source; // value of the `source` column
    bool header = true; // write the header row on construction
    bool flush = false; // flush the stream after every frame with events (for pipes)
  };

  explicit CsvSink(std::ostream& out) : CsvSink(out, Config{}) {}
  CsvSink(std::ostream& out, Config config) : out_(out), config_(std::move(config)) {
    detail::require<IoError>(out_.good(), "CsvSink: the output stream is not writable");
    prefix_ = std::to_string(event_schema_version) + ','; // schema, of every row
    detail::append_csv_field(source_, config_.source);    // source, of every row
    source_ += ',';
    line_.reserve(256);
    if (config_.header) {
      out_ << event_csv_header << '\n';
      check();
    }
  }

  void write(const OutputFrame& frame) {
    if (frame.events.empty() && frame.touch_gestures.empty() && !frame.camera_changed()) return;
    if (frame.camera_changed()) { // track 0: the camera, not a hand
      begin_row("camera,", frame, frame.timestamp_ms, 0);
      line_ += to_string(frame.camera_before);
      line_ += ',';
      line_ += to_string(frame.camera);
      line_ += std::string_view(",,,,,,,,,,,,,,,\n"); // direction .. gesture_confidence: empty
      out_.write(line_.data(), static_cast<std::streamsize>(line_.size()));
    }
    for (const OutputEvent& e : frame.events) {
      begin_row("touch,", frame, e.event.timestamp_ms, e.track_id);
      line_ += to_string(e.event.from);
      line_ += ',';
      line_ += to_string(e.event.to);
      line_ += ',';
      line_ += to_string(e.event.direction);
      line_ += ',';
      if (e.event.position)
        point(*e.event.position);
      else
        line_ += ',';
      gesture(frame.gesture);
      line_ += ",,,,,,,,,\n"; // no temporal gesture
      out_.write(line_.data(), static_cast<std::streamsize>(line_.size()));
    }
    for (const GestureEvent& e : frame.touch_gestures) {
      begin_row("gesture,", frame, e.decided_ms, e.track_id);
      line_ += ",,";
      line_ += to_string(e.direction);
      line_ += ',';
      point(e.position);
      gesture(frame.gesture);
      line_ += ',';
      line_ += to_string(e.gesture);
      line_ += ',';
      line_ += to_string(e.phase);
      line_ += ',';
      detail::append_number(line_, e.start_ms);
      line_ += ',';
      detail::append_number(line_, e.end_ms);
      line_ += ',';
      detail::append_number(line_, e.length_px);
      line_ += ',';
      detail::append_number(line_, e.speed_px_s);
      line_ += ',';
      detail::append_integer(line_, e.repetitions);
      line_ += ',';
      detail::append_csv_field(line_, e.hand_shape.view());
      line_ += ',';
      detail::append_number(line_, e.confidence);
      line_ += '\n';
      out_.write(line_.data(), static_cast<std::streamsize>(line_.size()));
    }
    if (config_.flush) out_.flush();
    check();
  }

private:
  // schema,kind,source,frame,timestamp_ms,track_id,
  void begin_row(const char* kind, const OutputFrame& frame, double t, int track_id) {
    line_.assign(prefix_);
    line_ += kind;
    line_ += source_;
    detail::append_integer(line_, frame.frame_index);
    line_ += ',';
    detail::append_number(line_, t);
    line_ += ',';
    detail::append_integer(line_, track_id);
    line_ += ',';
  }

  // x,y (empty when not finite)
  void point(cv::Point2f p) {
    if (std::isfinite(p.x) && std::isfinite(p.y)) {
      detail::append_number(line_, p.x);
      line_ += ',';
      detail::append_number(line_, p.y);
    } else {
      line_ += ',';
    }
  }

  // ,gesture,confidence,gesture_frame
  void gesture(const OutputGesture& g) {
    line_ += ',';
    if (g.available && !g.label.empty()) {
      detail::append_csv_field(line_, g.label);
      line_ += ',';
      detail::append_number(line_, g.confidence);
      line_ += ',';
      detail::append_integer(line_, g.frame_index);
    } else {
      line_ += ",,";
    }
  }

  void check() {
    detail::require<IoError>(out_.good(), "CsvSink: writing to the output stream failed (closed "
                                          "pipe or full disk?)");
  }

  std::ostream& out_;
  Config config_;
  std::string prefix_, source_;
  std::string line_;
};
static_assert(EventSink<CsvSink>);

SHADOWSENSE_NAMESPACE_END
