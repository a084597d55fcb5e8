// CsvSink: touch events as CSV (RFC 4180) on any std::ostream, one row per event.
//
// Columns (header row first unless Config::header is false): the project's event schema,
// version 2 (docs/output.md; JsonLinesSink writes the same fields):
//   schema,source,frame,timestamp_ms,track_id,from,to,direction,x,y,gesture,confidence,gesture_frame
//   schema        2 (event_schema_version)
//   source        Config::source (e.g. the input file or camera name), quoted when it holds a
//                 comma, quote, CR/LF or leading/trailing space
//   frame         OutputFrame::frame_index
//   timestamp_ms  the event's timestamp (shortest round-trip decimal, '.' whatever the locale)
//   track_id      the track the event belongs to
//   from, to      none|appear|touch|move|lift (to=none is the paper's "disappear")
//   direction     none|left|right|front|back (move events), else none
//   x, y          the event's contact position in image pixels, empty when it has none
//   gesture       the frame's hand shape (OutputFrame::gesture.label), empty when the run has no
//                 classifier or it was gated off (no shadow)
//   confidence    its probability, empty with it
//   gesture_frame the frame it was computed on, empty with it
// Lines end with "\n". The header is written by the constructor.
//
// CsvSink(out, config = {})
//   requires: `out` outlives the sink.
//   throws:   IoError if the stream is already failed or writing the header fails.
// write(frame)
//   ensures:  one row per frame.events entry, in order; frames without events write nothing.
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
    prefix_ = std::to_string(event_schema_version) + ','; // schema,source, of every row
    detail::append_csv_field(prefix_, config_.source);
    prefix_ += ',';
    line_.reserve(256);
    if (config_.header) {
      out_ << event_csv_header << '\n';
      check();
    }
  }

  void write(const OutputFrame& frame) {
    if (frame.events.empty()) return;
    for (const OutputEvent& e : frame.events) {
      line_.assign(prefix_);
      detail::append_integer(line_, frame.frame_index);
      line_ += ',';
      detail::append_number(line_, e.event.timestamp_ms);
      line_ += ',';
      detail::append_integer(line_, e.track_id);
      line_ += ',';
      line_ += to_string(e.event.from);
      line_ += ',';
      line_ += to_string(e.event.to);
      line_ += ',';
      line_ += to_string(e.event.direction);
      line_ += ',';
      if (e.event.position && std::isfinite(e.event.position->x) &&
          std::isfinite(e.event.position->y)) {
        detail::append_number(line_, e.event.position->x);
        line_ += ',';
        detail::append_number(line_, e.event.position->y);
      } else {
        line_ += ',';
      }
      line_ += ',';
      const OutputGesture& g = frame.gesture;
      if (g.available && !g.label.empty()) {
        detail::append_csv_field(line_, g.label);
        line_ += ',';
        detail::append_number(line_, g.confidence);
        line_ += ',';
        detail::append_integer(line_, g.frame_index);
      } else {
        line_ += ",,";
      }
      line_ += '\n';
      out_.write(line_.data(), static_cast<std::streamsize>(line_.size()));
    }
    if (config_.flush) out_.flush();
    check();
  }

private:
  void check() {
    detail::require<IoError>(out_.good(), "CsvSink: writing to the output stream failed (closed "
                                          "pipe or full disk?)");
  }

  std::ostream& out_;
  Config config_;
  std::string prefix_;
  std::string line_;
};
static_assert(EventSink<CsvSink>);

SHADOWSENSE_NAMESPACE_END
