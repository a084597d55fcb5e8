// The on-disk format of temporal gesture sequences (docs/dataset_format.md, "Temporal gesture
// sequences"): per sequence a folder of frames with frames.csv (file, timestamp, the hand-shape
// reading) and gestures.csv (each gesture's label, track, interval, repetitions, direction),
// and one sequences.csv listing the sequences (written last: it marks the dataset complete).
// sim/touch_sequence_writer.hpp renders generated sequences into it; ss_track_eval --temporal
// reads it.
//
// read_temporal_sequences(dir)
//   ensures: the rows of dir/sequences.csv (header exactly temporal_sequence_columns; sequence a
//            relative path without '..', fps in (0, 1000], frames >= 1, gestures >= 0,
//            lighting_level empty (-1: unknown) or in [0, 1], px_per_cm > 0).
//   throws:  DatasetError naming file:line: column and what was wrong (a missing file included).
// read_temporal_sequence(dir, row)
//   ensures: the sequence's frames.csv and gestures.csv, checked: the folder stays inside dir;
//            the row counts equal the sequences.csv row's frames and gestures (a truncated file
//            is refused); frame indices and timestamps strictly increasing; file names relative
//            (the images themselves are read by the caller, e.g. io/dataset.hpp's image reader);
//            shape_confidence given exactly when shape is; gestures with start_ms < end_ms,
//            track_id 0 for hug, punch and two_hands and > 0 for the others, repetitions >= 1.
//   throws:  DatasetError naming file:line: column.
// temporal_*_csv(rows) -> the csv text (header included; numbers in the shortest form that
//   reads back exactly, so rows round-trip and the same rows give the same bytes).
//   write_temporal_*(path, rows, sync): atomically (core/atomic_file.hpp).
// Plain values and functions; no shared state (any thread).
#pragma once

#include <shadowsense/core/atomic_file.hpp>
#include <shadowsense/core/direction.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/io/dataset.hpp>
#include <shadowsense/sense/gesture_event.hpp>

#include <array>
#include <charconv>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

inline constexpr std::array<std::string_view, 7> temporal_sequence_columns{
    "sequence", "fps", "user", "frames", "gestures", "lighting_level", "px_per_cm"};
inline constexpr std::array<std::string_view, 6> temporal_frame_columns{
    "frame", "file_name", "timestamp_ms", "duplicate", "shape", "shape_confidence"};
inline constexpr std::array<std::string_view, 6> temporal_gesture_columns{
    "gesture", "track_id", "start_ms", "end_ms", "repetitions", "direction"};

struct TemporalSequenceRow {
  std::string sequence; // folder, relative to the dataset's
  double fps = 30;      // nominal frame rate
  int user = 0;
  int frames = 0, gestures = 0;
  double lighting_level = -1; // -1: unknown
  double px_per_cm = 7.6;     // image scale at the skin
  int line = 0;               // in sequences.csv (set by the reader)
};

struct TemporalFrameRow {
  std::int64_t frame = 0;  // nominal index: a gap is a dropped frame
  std::string file_name;   // relative to the sequence's folder
  double timestamp_ms = 0; // strictly increasing
  bool duplicate = false;  // the camera repeated an earlier frame's content
  std::string shape;       // the hand-shape reading of the frame ("" none)
  double shape_confidence = 0;
  int line = 0;
};

struct TemporalGestureRow {
  TouchGesture gesture = TouchGesture::tap;
  int track_id = 1; // 0 for hug, punch, two_hands (the whole frame)
  double start_ms = 0, end_ms = 0;
  int repetitions = 1;
  Direction direction = Direction::none; // strokes
  int line = 0;
};

struct TemporalSequence {
  TemporalSequenceRow row;
  std::filesystem::path folder, frames_csv, gestures_csv;
  std::vector<TemporalFrameRow> frames;
  std::vector<TemporalGestureRow> gestures;
  std::filesystem::path image_path(const TemporalFrameRow& f) const { return folder / f.file_name; }
};

namespace detail {

// Rows of a csv with exactly `columns`, each handed to parse_row(FieldParser, line).
template <class Columns, class F>
inline void parse_rows(const std::filesystem::path& path, const Columns& columns, F parse_row) {
  const std::string text = read_csv_text(path);
  const std::vector<std::string> lines = csv_lines(text, path);
  const std::vector<std::string_view> header = split_csv(lines[0]);
  if (!header_is(header, columns))
    SHADOWSENSE_THROW(DatasetError(path.string() + ":1: unexpected header '" + lines[0] +
                                   "'; expected '" + join(columns) + "'"));
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const int line = static_cast<int>(i + 1);
    const std::vector<std::string_view> fields = split_csv(lines[i]);
    check_row_width(path, line, lines[i], fields, columns.size());
    parse_row(FieldParser(path, line, header, fields), line);
  }
}

inline bool whole_frame_gesture(TouchGesture g) {
  return g == TouchGesture::hug || g == TouchGesture::punch || g == TouchGesture::two_hands;
}

inline constexpr double max_timestamp_ms = 1e12;

// The shortest text that reads back as exactly `v` (times: a written dataset's timestamps and
// intervals equal the generator's doubles).
inline std::string exact_number(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

} // namespace detail

inline std::vector<TemporalSequenceRow> read_temporal_sequences(const std::filesystem::path& dir) {
  const std::filesystem::path path = dir / "sequences.csv";
  std::vector<TemporalSequenceRow> rows;
  detail::parse_rows(path, temporal_sequence_columns, [&](const detail::FieldParser& p, int line) {
    TemporalSequenceRow r;
    detail::check_relative(p, 0);
    r.sequence = p.text(0);
    r.fps = p.real(1, 1e-3, 1000);
    r.user = p.integer(2, 0, 2147483647);
    r.frames = p.integer(3, 1, 1 << 30);
    r.gestures = p.integer(4, 0, 1 << 30);
    r.lighting_level = p.empty(5) ? -1 : p.real(5, 0, 1);
    r.px_per_cm = p.real(6, 1e-3, 1e6);
    r.line = line;
    rows.push_back(std::move(r));
  });
  return rows;
}

inline TemporalSequence read_temporal_sequence(const std::filesystem::path& dir,
                                               const TemporalSequenceRow& row) {
  namespace fs = std::filesystem;
  TemporalSequence s;
  s.row = row;
  const fs::path sequences_csv = dir / "sequences.csv";
  s.folder = detail::inside_folder(dir, row.sequence,
                                   detail::where(sequences_csv, row.line, 0, "sequence"));
  s.frames_csv = s.folder / "frames.csv";
  s.gestures_csv = s.folder / "gestures.csv";
  detail::parse_rows(
      s.frames_csv, temporal_frame_columns, [&](const detail::FieldParser& p, int line) {
        TemporalFrameRow f;
        f.frame = p.integer(0, 0, 2147483647);
        detail::check_relative(p, 1);
        f.file_name = p.text(1);
        f.timestamp_ms = p.real(2, -detail::max_timestamp_ms, detail::max_timestamp_ms);
        f.duplicate = p.integer(3, 0, 1) == 1;
        f.shape = p.empty(4) ? std::string() : p.text(4);
        if (f.shape.empty() != p.empty(5))
          p.fail(5, "must be given exactly when the shape column is");
        f.shape_confidence = p.empty(5) ? 0.0 : p.real(5, 0, 1);
        f.line = line;
        if (!s.frames.empty()) {
          const TemporalFrameRow& prev = s.frames.back();
          if (!(f.frame > prev.frame))
            p.fail(0, "frame indices must be strictly increasing (the previous row has " +
                          std::to_string(prev.frame) + ")");
          if (!(f.timestamp_ms > prev.timestamp_ms))
            p.fail(2, "timestamps must be strictly increasing (the previous row has " +
                          detail::format_number(prev.timestamp_ms, 3) + ")");
        }
        s.frames.push_back(std::move(f));
      });
  detail::parse_rows(
      s.gestures_csv, temporal_gesture_columns, [&](const detail::FieldParser& p, int line) {
        TemporalGestureRow g;
        g.gesture = p.choice(0, all_touch_gestures, "gesture");
        g.track_id = p.integer(1, 0, 2147483647);
        if (detail::whole_frame_gesture(g.gesture) != (g.track_id == 0))
          p.fail(1, std::string("expected ") +
                        (g.track_id == 0 ? "a track id > 0 for " : "track id 0 for ") +
                        to_string(g.gesture) +
                        " (hug, punch and two_hands are whole-frame "
                        "gestures on track 0, the others are on a hand's track)");
        g.start_ms = p.real(2, -detail::max_timestamp_ms, detail::max_timestamp_ms);
        g.end_ms = p.real(3, -detail::max_timestamp_ms, detail::max_timestamp_ms);
        if (!(g.end_ms > g.start_ms)) p.fail(3, "must be after start_ms");
        g.repetitions = p.integer(4, 1, 1000000);
        g.direction = p.empty(5) ? Direction::none : p.choice(5, all_directions, "direction");
        g.line = line;
        s.gestures.push_back(g);
      });
  auto count = [&](const fs::path& csv, std::size_t got, int expected, const char* what,
                   std::size_t col) {
    if (got != static_cast<std::size_t>(expected))
      SHADOWSENSE_THROW(DatasetError(
          csv.string() + ": has " + std::to_string(got) + " " + what + " rows; " +
          detail::where(sequences_csv, row.line, col, temporal_sequence_columns[col]) + "expects " +
          std::to_string(expected) + " (a truncated or mismatched file)"));
  };
  count(s.frames_csv, s.frames.size(), row.frames, "frame", 3);
  count(s.gestures_csv, s.gestures.size(), row.gestures, "gesture", 4);
  return s;
}

inline std::string temporal_sequences_csv(const std::vector<TemporalSequenceRow>& rows) {
  std::string s = detail::join(temporal_sequence_columns) + "\n";
  for (const TemporalSequenceRow& r : rows)
    s += r.sequence + "," + detail::exact_number(r.fps) + "," + std::to_string(r.user) + "," +
         std::to_string(r.frames) + "," + std::to_string(r.gestures) + "," +
         (r.lighting_level < 0 ? std::string() : detail::exact_number(r.lighting_level)) + "," +
         detail::exact_number(r.px_per_cm) + "\n";
  return s;
}

inline std::string temporal_frames_csv(const std::vector<TemporalFrameRow>& rows) {
  std::string s = detail::join(temporal_frame_columns) + "\n";
  for (const TemporalFrameRow& r : rows)
    s += std::to_string(r.frame) + "," + r.file_name + "," + detail::exact_number(r.timestamp_ms) +
         "," + (r.duplicate ? "1" : "0") + "," + r.shape + "," +
         (r.shape.empty() ? std::string() : detail::exact_number(r.shape_confidence)) + "\n";
  return s;
}

inline std::string temporal_gestures_csv(const std::vector<TemporalGestureRow>& rows) {
  std::string s = detail::join(temporal_gesture_columns) + "\n";
  for (const TemporalGestureRow& r : rows)
    s += std::string(to_string(r.gesture)) + "," + std::to_string(r.track_id) + "," +
         detail::exact_number(r.start_ms) + "," + detail::exact_number(r.end_ms) + "," +
         std::to_string(r.repetitions) + "," +
         (r.direction == Direction::none ? "" : to_string(r.direction)) + "\n";
  return s;
}

inline void write_temporal_sequences(const std::filesystem::path& path,
                                     const std::vector<TemporalSequenceRow>& rows,
                                     Sync sync = Sync::file) {
  write_file_atomically(path, temporal_sequences_csv(rows), sync);
}
inline void write_temporal_frames(const std::filesystem::path& path,
                                  const std::vector<TemporalFrameRow>& rows,
                                  Sync sync = Sync::file) {
  write_file_atomically(path, temporal_frames_csv(rows), sync);
}
inline void write_temporal_gestures(const std::filesystem::path& path,
                                    const std::vector<TemporalGestureRow>& rows,
                                    Sync sync = Sync::file) {
  write_file_atomically(path, temporal_gestures_csv(rows), sync);
}

SHADOWSENSE_NAMESPACE_END
