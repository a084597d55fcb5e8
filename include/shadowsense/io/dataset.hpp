// The on-disk dataset format (docs/dataset_format.md): ImageFolder-style folders of PNG
// frames with one metadata.csv per dataset (per sequence for slides) and a sequences.csv
// for slide datasets. A strict reader (malformed rows are rejected with a DatasetError naming
// file, line and column; images are checked from their headers: inside the folder, bounded,
// boxes inside) and atomic writers. Depends on core/ and io/ only (its enums: io/labels.hpp).
#pragma once

#include <shadowsense/core/atomic_file.hpp>
#include <shadowsense/core/direction.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/io/image_file.hpp>
#include <shadowsense/io/labels.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// Columns of every metadata.csv, in order. Slide sequences append slide_columns.
inline constexpr std::array<std::string_view, 19> metadata_columns{
    "file_name", "class",       "user",         "lighting",  "lighting_level",
    "session",   "frame_index", "timestamp_ms", "shadow_x",  "shadow_y",
    "shadow_w",  "shadow_h",    "contact_x",    "contact_y", "contact_w",
    "contact_h", "contact_cx",  "contact_cy",   "px_per_cm"};
inline constexpr std::array<std::string_view, 2> slide_columns{"gesture", "direction"};
inline constexpr std::array<std::string_view, 9> sequence_columns{
    "sequence", "gesture", "direction", "num_frames",    "distance_cm",
    "fps",      "user",    "lighting",  "lighting_level"};

// One frame's row of a metadata.csv.
struct MetadataRow {
  std::string file_name; // relative to the csv's folder
  std::string label;     // the "class" column
  int user = 0;
  Lighting lighting = Lighting::daylight;
  double lighting_level = 1.0;
  std::string session;
  int frame_index = 0;
  double timestamp_ms = 0;
  std::optional<cv::Rect> shadow_box;
  std::optional<cv::Rect> contact_box;
  std::optional<cv::Point2f> contact_point;
  double px_per_cm = 0;
  // Slide sequences only.
  std::optional<SlideGesture> gesture;
  std::optional<Direction> direction;
  int line = 0; // line in the csv (1 = header), for messages
};

struct Metadata {
  std::filesystem::path csv_path;
  bool slide_columns = false;
  std::vector<MetadataRow> rows;

  std::filesystem::path folder() const { return csv_path.parent_path(); }
  std::filesystem::path image_path(const MetadataRow& row) const {
    return folder() / row.file_name;
  }
};

// One row of slides/sequences.csv.
struct SequenceRow {
  std::string sequence; // folder relative to sequences.csv, holding frames + metadata.csv
  SlideGesture gesture = SlideGesture::palm;
  Direction direction = Direction::right;
  int num_frames = 0;
  double distance_cm = 0;
  double fps = 0;
  int user = 0;
  Lighting lighting = Lighting::daylight;
  double lighting_level = 1.0;
  int line = 0;
};

namespace detail {

// Splits one csv line (no quoting: the format never needs it, and quotes are rejected).
inline std::vector<std::string_view> split_csv(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    if (comma == std::string_view::npos) {
      out.push_back(line.substr(start));
      return out;
    }
    out.push_back(line.substr(start, comma - start));
    start = comma + 1;
  }
}

// Parses fields of one csv row, naming file, line and column on failure.
class FieldParser {
public:
  FieldParser(const std::filesystem::path& file, int line,
              const std::vector<std::string_view>& header,
              const std::vector<std::string_view>& fields)
      : file_(file), line_(line), header_(header), fields_(fields) {}

  [[noreturn]] void fail(std::size_t col, const std::string& what) const {
    SHADOWSENSE_THROW(DatasetError(file_.string() + ":" + std::to_string(line_) + ": column " +
                                   std::to_string(col + 1) + " '" + std::string(header_[col]) +
                                   "': " + what + "; got '" + std::string(fields_[col]) + "'"));
  }
  std::string_view raw(std::size_t col) const { return fields_[col]; }
  bool empty(std::size_t col) const { return fields_[col].empty(); }

  // Text fields hold exactly what the writers can write back: not empty, no quote or line
  // break (fields are never quoted in this format).
  std::string text(std::size_t col) const {
    if (fields_[col].empty()) fail(col, "must not be empty");
    if (fields_[col].find_first_of("\"\n\r") != std::string_view::npos)
      fail(col, "holds a quote or a line break; fields are never quoted in this format");
    return std::string(fields_[col]);
  }
  int integer(std::size_t col, int lo, int hi) const {
    const std::string_view s = fields_[col];
    int v = 0;
    const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (s.empty() || ec != std::errc() || p != s.data() + s.size())
      fail(col, "expected an integer");
    if (v < lo || v > hi)
      fail(col, "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return v;
  }
  double real(std::size_t col, double lo, double hi) const {
    const std::string_view s = fields_[col];
    double v = 0;
    const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (s.empty() || ec != std::errc() || p != s.data() + s.size() || !std::isfinite(v))
      fail(col, "expected a finite number");
    if (v < lo || v > hi) {
      std::ostringstream m;
      m << "expected a number in [" << lo << ", " << hi << "]";
      fail(col, m.str());
    }
    return v;
  }
  // One of `values` by its to_string name (no exceptions to translate: a user-defined
  // SHADOWSENSE_THROW would skip a catch).
  template <class E, std::size_t N>
  E choice(std::size_t col, const std::array<E, N>& values, const char* what) const {
    std::string expected;
    for (std::size_t i = 0; i < N; ++i) {
      if (fields_[col] == std::string_view(to_string(values[i]))) return values[i];
      expected.append(i == 0 ? "" : i + 1 == N ? " or " : ", ").append(to_string(values[i]));
    }
    fail(col, std::string("unknown ") + what + " '" + std::string(fields_[col]) + "'; expected " +
                  expected);
  }
  // Four columns x, y, w, h: all empty (absent) or all integers with w, h > 0.
  std::optional<cv::Rect> box(std::size_t col) const {
    int empties = 0;
    for (std::size_t i = col; i < col + 4; ++i) empties += fields_[i].empty() ? 1 : 0;
    if (empties == 4) return std::nullopt;
    for (std::size_t i = col; i < col + 4; ++i)
      if (fields_[i].empty()) fail(i, "a box needs all of x, y, w, h or none");
    return cv::Rect(integer(col, 0, 1 << 20), integer(col + 1, 0, 1 << 20),
                    integer(col + 2, 1, 1 << 20), integer(col + 3, 1, 1 << 20));
  }

private:
  const std::filesystem::path& file_;
  int line_;
  const std::vector<std::string_view>& header_;
  const std::vector<std::string_view>& fields_;
};

// Splits csv text into lines (a trailing '\r' dropped, trailing empty lines ignored).
inline std::vector<std::string> csv_lines(std::string_view text,
                                          const std::filesystem::path& path) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(start, end - start);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    lines.emplace_back(line);
    start = end + 1;
  }
  while (!lines.empty() && lines.back().empty()) lines.pop_back();
  if (lines.empty())
    SHADOWSENSE_THROW(
        DatasetError(path.string() + ":1: the csv file is empty; expected a header row"));
  return lines;
}

// A csv file's text: a regular file of at most max_csv_bytes (no FIFO hang, no /dev/zero).
inline constexpr std::uint64_t max_csv_bytes = 1ull << 30;
inline std::string read_csv_text(const std::filesystem::path& path) {
  ImageLimits limits;
  limits.max_file_bytes = max_csv_bytes;
  const BoundedFile f(path, limits, "csv file", {}, true);
  const std::vector<unsigned char> b = f.read_at(0, static_cast<std::size_t>(f.size()));
  return std::string(b.begin(), b.end());
}

template <class Columns>
inline bool header_is(const std::vector<std::string_view>& header, const Columns& a,
                      std::size_t extra_count = 0, const std::string_view* extra = nullptr) {
  if (header.size() != a.size() + extra_count) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (header[i] != a[i]) return false;
  for (std::size_t i = 0; i < extra_count; ++i)
    if (header[a.size() + i] != extra[i]) return false;
  return true;
}

template <class Columns>
inline std::string join(const Columns& c) {
  std::string s;
  for (const auto& x : c) {
    if (!s.empty()) s.push_back(',');
    s.append(x.data(), x.size());
  }
  return s;
}

inline void check_row_width(const std::filesystem::path& path, int line, std::string_view text,
                            const std::vector<std::string_view>& fields, std::size_t expected) {
  if (text.find('"') != std::string_view::npos)
    SHADOWSENSE_THROW(DatasetError(path.string() + ":" + std::to_string(line) +
                                   ": quoted fields are not supported"));
  if (fields.size() != expected)
    SHADOWSENSE_THROW(DatasetError(path.string() + ":" + std::to_string(line) + ": row has " +
                                   std::to_string(fields.size()) + " columns; expected " +
                                   std::to_string(expected) + " (as in the header)"));
}

inline void check_relative(const FieldParser& p, std::size_t col) {
  const std::string s = p.text(col);
  const std::filesystem::path fp(s);
  if (fp.is_absolute() || s.find('\\') != std::string::npos)
    p.fail(col, "expected a path relative to the csv's folder");
  for (const auto& part : fp)
    if (part == "..") p.fail(col, "the path must not leave the dataset folder ('..')");
}

inline void check_lighting_level(const FieldParser& p, std::size_t col, Lighting l, double level) {
  if (l != Lighting::custom && level != lighting_level(l))
    p.fail(col, "does not match the lighting preset '" + std::string(to_string(l)) + "' (level " +
                    std::to_string(lighting_level(l)) + ")");
}

inline std::string format_number(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

} // namespace detail

// parse_metadata(text, csv_path): validates the text of a metadata.csv (gestures, tracking, or
// one slide sequence); csv_path names it in messages and anchors the rows' relative paths.
// throws DatasetError naming csv_path:line: column. read_metadata(csv_path) reads the file
// (a regular file of at most max_csv_bytes) and parses it.
inline Metadata parse_metadata(std::string_view text, const std::filesystem::path& csv_path) {
  const std::vector<std::string> lines = detail::csv_lines(text, csv_path);
  Metadata md;
  md.csv_path = csv_path;
  const std::vector<std::string_view> header = detail::split_csv(lines[0]);
  if (detail::header_is(header, metadata_columns)) {
    md.slide_columns = false;
  } else if (detail::header_is(header, metadata_columns, slide_columns.size(),
                               slide_columns.data())) {
    md.slide_columns = true;
  } else {
    SHADOWSENSE_THROW(DatasetError(csv_path.string() + ":1: unexpected header '" + lines[0] +
                                   "'; expected '" + detail::join(metadata_columns) +
                                   "' (slide sequences add '," + detail::join(slide_columns) +
                                   "')"));
  }
  std::map<std::string, int> first_line; // file_name -> line, for duplicates
  for (std::size_t li = 1; li < lines.size(); ++li) {
    const int line = static_cast<int>(li) + 1;
    const std::vector<std::string_view> f = detail::split_csv(lines[li]);
    detail::check_row_width(csv_path, line, lines[li], f, header.size());
    const detail::FieldParser p(csv_path, line, header, f);
    MetadataRow r;
    r.line = line;
    detail::check_relative(p, 0);
    r.file_name = p.text(0);
    r.label = p.text(1);
    r.user = p.integer(2, 0, 1000000);
    r.lighting = p.choice(3, all_lightings, "lighting");
    r.lighting_level = p.real(4, 0.0, 1.0);
    detail::check_lighting_level(p, 4, r.lighting, r.lighting_level);
    r.session = p.text(5);
    r.frame_index = p.integer(6, 0, 1 << 30);
    r.timestamp_ms = p.real(7, 0.0, 1e15);
    r.shadow_box = p.box(8);
    r.contact_box = p.box(12);
    if (p.empty(16) != p.empty(17))
      p.fail(p.empty(16) ? 16 : 17, "contact_cx and contact_cy must both be set or both empty");
    if (!p.empty(16))
      r.contact_point = cv::Point2f(static_cast<float>(p.real(16, -1.0, 1 << 20)),
                                    static_cast<float>(p.real(17, -1.0, 1 << 20)));
    if (r.contact_point.has_value() != r.contact_box.has_value())
      p.fail(16, "the contact point must be present exactly when the contact box is");
    if (r.contact_box && !r.shadow_box)
      p.fail(8, "a frame with a contact box must have a shadow box");
    r.px_per_cm = p.real(18, 1e-6, 1e6);
    if (md.slide_columns) {
      r.gesture = p.choice(19, all_slide_gestures, "slide gesture");
      r.direction = p.choice(20, all_directions, "direction");
    }
    if (const auto [it, fresh] = first_line.emplace(r.file_name, line); !fresh)
      p.fail(0, "duplicate row: the same file is already listed on line " +
                    std::to_string(it->second));
    md.rows.push_back(std::move(r));
  }
  if (md.rows.empty())
    SHADOWSENSE_THROW(DatasetError(csv_path.string() +
                                   ":2: no data rows; expected at least one row after the header"));
  return md;
}

inline Metadata read_metadata(const std::filesystem::path& csv_path) {
  return parse_metadata(detail::read_csv_text(csv_path), csv_path);
}

// parse_sequences(text, csv_path) / read_sequences(csv_path): the same for sequences.csv.
inline std::vector<SequenceRow> parse_sequences(std::string_view text,
                                                const std::filesystem::path& csv_path) {
  const std::vector<std::string> lines = detail::csv_lines(text, csv_path);
  const std::vector<std::string_view> header = detail::split_csv(lines[0]);
  if (!detail::header_is(header, sequence_columns))
    SHADOWSENSE_THROW(DatasetError(csv_path.string() + ":1: unexpected header '" + lines[0] +
                                   "'; expected '" + detail::join(sequence_columns) + "'"));
  std::vector<SequenceRow> rows;
  std::map<std::string, int> first_line; // sequence -> line, for duplicates
  for (std::size_t li = 1; li < lines.size(); ++li) {
    const int line = static_cast<int>(li) + 1;
    const std::vector<std::string_view> f = detail::split_csv(lines[li]);
    detail::check_row_width(csv_path, line, lines[li], f, header.size());
    const detail::FieldParser p(csv_path, line, header, f);
    SequenceRow r;
    r.line = line;
    detail::check_relative(p, 0);
    r.sequence = p.text(0);
    r.gesture = p.choice(1, all_slide_gestures, "slide gesture");
    r.direction = p.choice(2, all_directions, "direction");
    r.num_frames = p.integer(3, 1, 1 << 24);
    r.distance_cm = p.real(4, 0.0, 1e4);
    r.fps = p.real(5, 1e-3, 1e4);
    r.user = p.integer(6, 0, 1000000);
    r.lighting = p.choice(7, all_lightings, "lighting");
    r.lighting_level = p.real(8, 0.0, 1.0);
    detail::check_lighting_level(p, 8, r.lighting, r.lighting_level);
    if (const auto [it, fresh] = first_line.emplace(r.sequence, line); !fresh)
      p.fail(0, "duplicate row: the same sequence is already listed on line " +
                    std::to_string(it->second));
    rows.push_back(std::move(r));
  }
  if (rows.empty())
    SHADOWSENSE_THROW(
        DatasetError(csv_path.string() + ":2: no data rows; expected at least one sequence"));
  return rows;
}

inline std::vector<SequenceRow> read_sequences(const std::filesystem::path& csv_path) {
  return parse_sequences(detail::read_csv_text(csv_path), csv_path);
}

// The csv text of metadata rows (header included). Numbers use fixed decimals so the same
// rows always give the same bytes.
inline std::string metadata_csv(const std::vector<MetadataRow>& rows, bool with_slide_columns) {
  std::string s = detail::join(metadata_columns);
  if (with_slide_columns) {
    s += ',';
    s += detail::join(slide_columns);
  }
  s += '\n';
  // Appends fields separated by commas (append() only: GCC 12 warns falsely on operator+ chains).
  bool first = true;
  auto add = [&](std::string_view v) {
    if (!first) s += ',';
    first = false;
    s.append(v.data(), v.size());
  };
  auto add_box = [&](const std::optional<cv::Rect>& b) {
    for (int v : {b ? b->x : 0, b ? b->y : 0, b ? b->width : 0, b ? b->height : 0})
      add(b ? std::to_string(v) : std::string());
  };
  for (const MetadataRow& r : rows) {
    detail::require(!r.file_name.empty() && !r.label.empty() && !r.session.empty(),
                    "metadata_csv: file_name, class and session must not be empty");
    for (const std::string* t : {&r.file_name, &r.label, &r.session})
      detail::require(t->find_first_of(",\"\n\r") == std::string::npos,
                      "metadata_csv: '" + *t + "' contains a comma, quote or line break");
    detail::require(with_slide_columns == (r.gesture.has_value() && r.direction.has_value()),
                    "metadata_csv: gesture and direction must be set exactly for slide rows");
    first = true;
    add(r.file_name);
    add(r.label);
    add(std::to_string(r.user));
    add(to_string(r.lighting));
    add(detail::format_number(r.lighting_level, 4));
    add(r.session);
    add(std::to_string(r.frame_index));
    add(detail::format_number(r.timestamp_ms, 1));
    add_box(r.shadow_box);
    add_box(r.contact_box);
    add(r.contact_point ? detail::format_number(r.contact_point->x, 3) : std::string());
    add(r.contact_point ? detail::format_number(r.contact_point->y, 3) : std::string());
    add(detail::format_number(r.px_per_cm, 5));
    if (with_slide_columns) {
      add(to_string(*r.gesture));
      add(to_string(*r.direction));
    }
    s += '\n';
  }
  return s;
}

inline std::string sequences_csv(const std::vector<SequenceRow>& rows) {
  std::string s = detail::join(sequence_columns);
  s += '\n';
  bool first = true;
  auto add = [&](std::string_view v) {
    if (!first) s += ',';
    first = false;
    s.append(v.data(), v.size());
  };
  for (const SequenceRow& r : rows) {
    detail::require(!r.sequence.empty() && r.sequence.find_first_of(",\"\n\r") == std::string::npos,
                    "sequences_csv: sequence folder must be non-empty without commas or quotes");
    first = true;
    add(r.sequence);
    add(to_string(r.gesture));
    add(to_string(r.direction));
    add(std::to_string(r.num_frames));
    add(detail::format_number(r.distance_cm, 3));
    add(detail::format_number(r.fps, 3));
    add(std::to_string(r.user));
    add(to_string(r.lighting));
    add(detail::format_number(r.lighting_level, 4));
    s += '\n';
  }
  return s;
}

// Writes a metadata.csv atomically (core/atomic_file.hpp: temporary file, checked writes,
// fsync, rename).
inline void write_metadata(const std::filesystem::path& csv_path,
                           const std::vector<MetadataRow>& rows, bool with_slide_columns,
                           Sync sync = Sync::file) {
  write_file_atomically(csv_path, metadata_csv(rows, with_slide_columns), sync);
}
inline void write_sequences(const std::filesystem::path& csv_path,
                            const std::vector<SequenceRow>& rows) {
  write_file_atomically(csv_path, sequences_csv(rows));
}

namespace detail {

// "file:line: column N 'name': " for messages about a row's column.
inline std::string where(const std::filesystem::path& csv, int line, std::size_t col,
                         std::string_view name) {
  return csv.string() + ":" + std::to_string(line) + ": column " + std::to_string(col + 1) + " '" +
         std::string(name) + "': ";
}

// `relative` (already free of '..' and absolute parts) resolved inside `folder`, refusing a
// path that leaves the folder through a symlink.
inline std::filesystem::path inside_folder(const std::filesystem::path& folder,
                                           const std::string& relative, const std::string& at) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path base = fs::weakly_canonical(folder, ec);
  const fs::path full = fs::weakly_canonical(folder / relative, ec);
  if (ec)
    SHADOWSENSE_THROW(DatasetError(at + "cannot resolve '" + relative + "': " + ec.message()));
  const fs::path rel = full.lexically_relative(base);
  if (rel.empty() || *rel.begin() == "..")
    SHADOWSENSE_THROW(DatasetError(at + "'" + relative + "' resolves to '" + full.string() +
                                   "', outside the dataset folder '" + base.string() +
                                   "' (a symlink leaves it)"));
  return folder / relative;
}

inline void check_box_inside(const std::optional<cv::Rect>& box, cv::Size size,
                             const std::string& at, const char* what) {
  if (!box) return;
  if ((*box & cv::Rect(cv::Point(), size)) != *box)
    SHADOWSENSE_THROW(DatasetError(
        at + what + " (" + std::to_string(box->x) + ", " + std::to_string(box->y) + ", " +
        std::to_string(box->width) + ", " + std::to_string(box->height) + ") is not inside the " +
        std::to_string(size.width) + "x" + std::to_string(size.height) + " image"));
}

} // namespace detail

// check_image(md, row, limits)
//   ensures: the row's image lies inside the dataset folder (no symlink leaves it), is a
//            regular PNG/JPEG/BMP file within `limits` (read from its header, no decoding), and
//            the row's boxes and contact point lie inside it. Returns the image size.
//   throws:  DatasetError naming csv:line: column and the problem.
inline cv::Size check_image(const Metadata& md, const MetadataRow& row,
                            const ImageLimits& limits = {}) {
  const std::string at = detail::where(md.csv_path, row.line, 0, "file_name");
  const std::filesystem::path p = detail::inside_folder(md.folder(), row.file_name, at);
  const ImageHeader h = detail::image_header(p, limits, at, true);
  const cv::Size size(h.width, h.height);
  detail::check_box_inside(row.shadow_box, size,
                           detail::where(md.csv_path, row.line, 8, "shadow_x"), "the shadow box");
  detail::check_box_inside(row.contact_box, size,
                           detail::where(md.csv_path, row.line, 12, "contact_x"),
                           "the contact box");
  if (row.contact_point &&
      !cv::Rect2f(0.f, 0.f, static_cast<float>(size.width), static_cast<float>(size.height))
           .contains(*row.contact_point))
    SHADOWSENSE_THROW(DatasetError(detail::where(md.csv_path, row.line, 16, "contact_cx") +
                                   "the contact point is not inside the " +
                                   std::to_string(size.width) + "x" + std::to_string(size.height) +
                                   " image"));
  return size;
}

// check_images(md, limits): check_image for every row (reads only the headers).
inline void check_images(const Metadata& md, const ImageLimits& limits = {}) {
  for (const MetadataRow& row : md.rows) (void)check_image(md, row, limits);
}

// Loads a row's image as 8-bit BGR after check_image (bounded: the header is checked before
// any pixel is decoded). Throws DatasetError naming csv:line.
inline cv::Mat read_image(const Metadata& md, const MetadataRow& row,
                          const ImageLimits& limits = {}) {
  (void)check_image(md, row, limits);
  return detail::image_file(
      md.image_path(row), cv::IMREAD_COLOR, limits,
      md.csv_path.string() + ":" + std::to_string(row.line) + ": cannot read image: ", true);
}

// read_sequence_metadata(sequences_csv, row)
//   ensures: the metadata.csv of one slide sequence listed in sequences.csv, read and checked
//            against its row there: the folder stays inside the dataset, the csv has slide
//            columns, num_frames equals its row count, and every row's gesture, direction,
//            user, lighting and lighting_level equal the sequence's.
//   throws:  DatasetError naming the file:line: column that disagrees (and the other file).
inline Metadata read_sequence_metadata(const std::filesystem::path& sequences_csv,
                                       const SequenceRow& seq) {
  const std::filesystem::path folder =
      detail::inside_folder(sequences_csv.parent_path(), seq.sequence,
                            detail::where(sequences_csv, seq.line, 0, "sequence"));
  Metadata md = read_metadata(folder / "metadata.csv");
  const std::string other =
      " disagrees with " + sequences_csv.string() + ":" + std::to_string(seq.line);
  if (!md.slide_columns)
    SHADOWSENSE_THROW(DatasetError(md.csv_path.string() +
                                   ":1: a slide sequence's csv needs the gesture and direction "
                                   "columns;" +
                                   other));
  if (static_cast<int>(md.rows.size()) != seq.num_frames)
    SHADOWSENSE_THROW(DatasetError(detail::where(sequences_csv, seq.line, 3, "num_frames") +
                                   std::to_string(seq.num_frames) + " frames, but " +
                                   md.csv_path.string() + " has " + std::to_string(md.rows.size()) +
                                   " rows"));
  for (const MetadataRow& r : md.rows) {
    auto check = [&](bool ok, std::size_t col, std::string_view name) {
      if (!ok)
        SHADOWSENSE_THROW(DatasetError(detail::where(md.csv_path, r.line, col, name) + "the value" +
                                       other + " (column '" + std::string(name) + "')"));
    };
    check(r.gesture == seq.gesture, 19, "gesture");
    check(r.direction == seq.direction, 20, "direction");
    check(r.user == seq.user, 2, "user");
    check(r.lighting == seq.lighting, 3, "lighting");
    check(std::abs(r.lighting_level - seq.lighting_level) < 1e-9, 4, "lighting_level");
  }
  return md;
}

SHADOWSENSE_NAMESPACE_END
