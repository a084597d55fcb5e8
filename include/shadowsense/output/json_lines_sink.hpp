// JsonLinesSink: touch events as JSON Lines (one JSON object per event per line) on any
// std::ostream.
//
// Each line: the fields of CsvSink's columns (the event schema, version 2, docs/output.md), in
// the same order and with the same names:
//   {"schema":2,"source":"cam0","frame":12,"timestamp_ms":396,"track_id":1,"from":"touch",
//    "to":"move","direction":"left","x":101.5,"y":80.25,"gesture":"palm","confidence":0.97,
//    "gesture_frame":12}
//   "source" is Config::source ("" when not set), escaped as a JSON string (RFC 8259, invalid
//   UTF-8 as U+FFFD); x and y are null when the event has no contact position; gesture,
//   confidence and gesture_frame are null when the run has no classifier or it was gated off.
//   Numbers are the shortest round-trip decimal, '.' whatever the locale; a non-finite number
//   is written as null.
//
// JsonLinesSink(out, config = {})
//   requires: `out` outlives the sink.
//   throws:   IoError if the stream is already failed.
// write(frame)
//   ensures:  one line per frame.events entry, in order.
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
    prefix_ = "\"schema\":";
    detail::append_integer(prefix_, event_schema_version);
    prefix_ += ",\"source\":";
    detail::append_json_string(prefix_, config_.source);
    prefix_ += ',';
    line_.reserve(256);
  }

  void write(const OutputFrame& frame) {
    if (frame.events.empty()) return;
    for (const OutputEvent& e : frame.events) {
      line_.assign(1, '{');
      line_ += prefix_;
      line_ += "\"frame\":";
      detail::append_integer(line_, frame.frame_index);
      line_ += ",\"timestamp_ms\":";
      number(e.event.timestamp_ms);
      line_ += ",\"track_id\":";
      detail::append_integer(line_, e.track_id);
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
      const OutputGesture& g = frame.gesture;
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
      line_ += "}\n";
      out_.write(line_.data(), static_cast<std::streamsize>(line_.size()));
    }
    if (config_.flush) out_.flush();
    detail::require<IoError>(out_.good(), "JsonLinesSink: writing to the output stream failed "
                                          "(closed pipe or full disk?)");
  }

private:
  template <class T>
  void number(T v) {
    if (std::isfinite(v))
      detail::append_number(line_, v);
    else
      line_ += "null";
  }

  std::ostream& out_;
  Config config_;
  std::string prefix_;
  std::string line_;
};
static_assert(EventSink<JsonLinesSink>);

SHADOWSENSE_NAMESPACE_END
