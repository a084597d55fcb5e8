// The calibration file: everything a Segmenter needs, the empty-skin model included.
//
// Format versions 2 and 3 (written by save_calibration; docs/calibration.md):
//   UTF-8 text lines "key value...", '#' starts a comment; first non-comment line
//   "shadowsense_segmenter_calibration V"; keys (each once unless noted):
//     mode fixed_ranges|relative
//     shadow_range  B_lo G_lo R_lo B_hi G_hi R_hi      (integers 0..255)
//     contact_range B_lo G_lo R_lo B_hi G_hi R_hi
//     shadow_darkness F  contact_darkness F  contact_warmth F  reference_percentile F
//     light_thresholds LUMINANCE SHADOW_DARKNESS CONTACT_DARKNESS CONTACT_WARMTH  (0 or more,
//                                                           increasing luminance)
//     px_per_cm F       (version 3 only; the camera's scale, in [0.05, 10000]; absent = 0)
//     empty_skin W H f32  (optional) followed, right after its newline, by W*H*3 little-endian
//                       IEEE-754 float32 values (row-major, B G R per pixel: the model exactly,
//                       so a loaded calibration segments exactly like the one saved) and one
//                       newline
//   last line: "end XXXXXXXX" - the CRC-32 (IEEE, as zlib.crc32) in 8 lower-case hex digits of
//   every byte before that line. A file cut anywhere, or changed, is rejected.
// A calibration is written as version 2 unless it records px_per_cm (then version 3), so files
// without a scale stay byte for byte what earlier releases wrote and read. Version 1 (no
// empty_skin, no end line) still loads; a cut version 1 file cannot always be detected, so save
// again to upgrade it.
//
// calibration_to_string(c) / save_calibration(c, path)
//   requires: validate_calibration(c) passes.
//   ensures:  version 2 bytes (3 when c.px_per_cm > 0); save writes them atomically: a temporary
//   file in the same folder,
//             checked writes, flush, rename over `path` (the old file stays intact on failure).
//   throws:   InvalidArgument (bad calibration), IoError naming the path.
// calibration_from_string(bytes, source) / load_calibration(path)
//   ensures:  the calibration (version 1, 2 or 3).
//   throws:   CalibrationFileError (a ModelFileError) naming the source (and line, in the text
//             part) for anything malformed, cut or changed; IoError when the path cannot be read,
//             is not a regular file (a FIFO or device is refused before reading) or is larger than
//             512 MiB.
// Plain functions; no shared state (any thread).
#pragma once

#include <shadowsense/core/atomic_file.hpp>
#include <shadowsense/core/crc32.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/sense/pixel_rule.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

namespace detail {

constexpr std::uintmax_t kMaxCalibrationFileBytes = 512ull << 20;

// The file's CRC-32 (core/crc32.hpp) over text.
inline std::uint32_t calibration_crc32(const char* data, std::size_t n) {
  return crc32(std::span(reinterpret_cast<const std::uint8_t*>(data), n));
}

inline std::string crc_hex(std::uint32_t v) {
  char buf[9];
  std::snprintf(buf, sizeof buf, "%08x", v);
  return buf;
}

} // namespace detail

inline std::string calibration_to_string(const SegmenterCalibration& c) {
  detail::validate_calibration(c, "calibration_to_string");
  std::ostringstream o;
  o.precision(9);
  auto range = [&](const ColourRange& r) {
    o << int(r.lower[0]) << ' ' << int(r.lower[1]) << ' ' << int(r.lower[2]) << ' '
      << int(r.upper[0]) << ' ' << int(r.upper[1]) << ' ' << int(r.upper[2]) << '\n';
  };
  o << "# shadowsense segmenter calibration (see docs/calibration.md)\n";
  o << "shadowsense_segmenter_calibration " << (c.px_per_cm > 0 ? 3 : 2) << '\n';
  o << "mode " << (c.mode == SegmentMode::relative ? "relative" : "fixed_ranges") << '\n';
  o << "shadow_range ";
  range(c.shadow_range);
  o << "contact_range ";
  range(c.contact_range);
  o << "shadow_darkness " << c.shadow_darkness << '\n';
  o << "contact_darkness " << c.contact_darkness << '\n';
  o << "contact_warmth " << c.contact_warmth << '\n';
  o << "reference_percentile " << c.reference_percentile << '\n';
  for (const LightThresholds& t : c.by_light)
    o << "light_thresholds " << t.luminance << ' ' << t.shadow_darkness << ' ' << t.contact_darkness
      << ' ' << t.contact_warmth << '\n';
  if (c.px_per_cm > 0) o << "px_per_cm " << c.px_per_cm << '\n';
  std::string out = o.str();
  if (!c.empty_skin.empty()) {
    const cv::Mat& m = c.empty_skin;
    out += "empty_skin " + std::to_string(m.cols) + " " + std::to_string(m.rows) + " f32\n";
    const std::size_t n = m.total() * 3, at = out.size();
    out.reserve(at + 4 * n + 64); // the block, its newline and the end line: no regrowth copy
    out.resize(at + 4 * n);
    const cv::Mat cont = m.isContinuous() ? m : m.clone();
    const float* v = cont.ptr<float>(0);
    for (std::size_t i = 0; i < n; ++i) {
      const auto u = std::bit_cast<std::uint32_t>(v[i]);
      for (std::size_t k = 0; k < 4; ++k)
        out[at + 4 * i + k] = static_cast<char>((u >> (8 * k)) & 0xFFu);
    }
    out += '\n';
  }
  out += "end " + detail::crc_hex(detail::calibration_crc32(out.data(), out.size())) + "\n";
  return out;
}

namespace detail {

// Parses the text part of a version 1, 2 or 3 file (`text`: up to, not including, the end line).
// Versions 2 and 3 may hold one "empty_skin W H" line followed by its raw block.
inline SegmenterCalibration parse_calibration(const std::string& text, const std::string& source,
                                              int expect_version) {
  SegmenterCalibration c;
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  bool header = false;
  std::vector<std::string> seen;
  auto fail = [&](const std::string& what) {
    SHADOWSENSE_THROW(CalibrationFileError(
        source + (line_no > 0 ? ":" + std::to_string(line_no) : std::string()) + ": " + what));
  };
  while (std::getline(in, line)) {
    ++line_no;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::istringstream ls(line);
    std::string key;
    if (!(ls >> key)) continue;
    if (!header) {
      int version = 0;
      if (key != "shadowsense_segmenter_calibration" || !(ls >> version))
        fail("expected the header 'shadowsense_segmenter_calibration 3' (or 2 or 1)");
      if (version != expect_version)
        fail("format version " + std::to_string(version) + " is not supported; expected 1, 2 or 3");
      header = true;
      continue;
    }
    if (key == "empty_skin") {
      if (expect_version < 2) fail("key 'empty_skin' needs format version 2");
      long long w = 0, h = 0;
      std::string type, extra;
      if (!(ls >> w >> h >> type) || (ls >> extra) || w < 1 || h < 1 || w > 65536 || h > 65536)
        fail("key 'empty_skin' needs a width and a height in 1..65536 and the type f32");
      if (type != "f32") fail("empty_skin type '" + type + "' is unknown; expected f32");
      if (std::find(seen.begin(), seen.end(), key) != seen.end())
        fail("key 'empty_skin' appears twice");
      seen.push_back(key);
      const auto bytes = static_cast<std::size_t>(w * h * 12);
      const auto start = static_cast<std::size_t>(in.tellg());
      if (in.tellg() < 0 || text.size() < start + bytes + 1)
        fail("the empty-skin block of " + std::to_string(bytes) + " bytes is cut short");
      if (text[start + bytes] != '\n') fail("the empty-skin block is not followed by a newline");
      cv::Mat m(static_cast<int>(h), static_cast<int>(w), CV_32FC3);
      const auto* b = reinterpret_cast<const unsigned char*>(text.data() + start);
      float* out = m.ptr<float>(0);
      for (std::size_t i = 0; i < static_cast<std::size_t>(w * h * 3); ++i) {
        const std::uint32_t u = std::uint32_t(b[4 * i]) | (std::uint32_t(b[4 * i + 1]) << 8) |
                                (std::uint32_t(b[4 * i + 2]) << 16) |
                                (std::uint32_t(b[4 * i + 3]) << 24);
        out[i] = std::bit_cast<float>(u);
      }
      c.empty_skin = m;
      in.seekg(static_cast<std::streamoff>(start + bytes + 1));
      line_no = -1; // line numbers are meaningless after the binary block
      continue;
    }
    if (key != "light_thresholds" && key != "empty_skin" &&
        std::find(seen.begin(), seen.end(), key) != seen.end())
      fail("key '" + key + "' appears twice");
    seen.push_back(key);
    auto read_float = [&](float& v) {
      std::string tok;
      if (!(ls >> tok)) fail("key '" + key + "' needs a number");
      const char* end = tok.data() + tok.size();
      const auto r = std::from_chars(tok.data(), end, v);
      if (r.ec != std::errc() || r.ptr != end || !std::isfinite(v))
        fail("key '" + key + "': '" + tok + "' is not a finite number");
    };
    auto read_range = [&](ColourRange& r) {
      int v[6];
      for (int& x : v) {
        if (!(ls >> x)) fail("key '" + key + "' needs six integers (B G R low, B G R high)");
        if (x < 0 || x > 255)
          fail("key '" + key + "': value " + std::to_string(x) + " is outside 0..255");
      }
      r = {cv::Vec3b(uchar(v[0]), uchar(v[1]), uchar(v[2])),
           cv::Vec3b(uchar(v[3]), uchar(v[4]), uchar(v[5]))};
    };
    if (key == "mode") {
      std::string m;
      ls >> m;
      if (m == "relative")
        c.mode = SegmentMode::relative;
      else if (m == "fixed_ranges")
        c.mode = SegmentMode::fixed_ranges;
      else
        fail("mode '" + m + "' is unknown; expected relative or fixed_ranges");
    } else if (key == "shadow_range")
      read_range(c.shadow_range);
    else if (key == "contact_range")
      read_range(c.contact_range);
    else if (key == "shadow_darkness")
      read_float(c.shadow_darkness);
    else if (key == "contact_darkness")
      read_float(c.contact_darkness);
    else if (key == "contact_warmth")
      read_float(c.contact_warmth);
    else if (key == "reference_percentile")
      read_float(c.reference_percentile);
    else if (key == "px_per_cm") {
      if (expect_version < 3) fail("key 'px_per_cm' needs format version 3");
      read_float(c.px_per_cm);
      if (!(c.px_per_cm > 0)) fail("px_per_cm must be > 0 when present (absent = not measured)");
    } else if (key == "light_thresholds") {
      LightThresholds t;
      read_float(t.luminance);
      read_float(t.shadow_darkness);
      read_float(t.contact_darkness);
      read_float(t.contact_warmth);
      c.by_light.push_back(t);
    } else
      fail("unknown key '" + key + "'");
    std::string extra;
    if (ls >> extra) fail("unexpected extra value '" + extra + "' after key '" + key + "'");
  }
  if (!header)
    SHADOWSENSE_THROW(
        CalibrationFileError(source + ": empty; expected a shadowsense segmenter calibration"));
  for (const char* k : {"mode", "shadow_range", "contact_range", "shadow_darkness",
                        "contact_darkness", "contact_warmth", "reference_percentile"})
    if (std::find(seen.begin(), seen.end(), k) == seen.end())
      SHADOWSENSE_THROW(CalibrationFileError(source + ": key '" + k + "' is missing"));
  detail::add_context<InvalidArgument, CalibrationFileError>(
      "", [&] { detail::validate_calibration(c, source); });
  return c;
}

} // namespace detail

// Parses a version 1, 2 or 3 calibration (see above); throws CalibrationFileError naming `source`.
inline SegmenterCalibration calibration_from_string(const std::string& text,
                                                    const std::string& source = "calibration") {
  // The version decides whether the end line is required.
  std::istringstream probe(text);
  std::string line;
  int version = 0;
  while (std::getline(probe, line)) {
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::istringstream ls(line);
    std::string key;
    if (!(ls >> key)) continue;
    if (key == "shadowsense_segmenter_calibration") ls >> version;
    break;
  }
  if (version == 1) return detail::parse_calibration(text, source, 1);
  if (version != 2 && version != 3)
    return detail::parse_calibration(text, source, 3); // names the problem
  // Versions 2 and 3: the last line is "end <crc32 of everything before it>".
  const std::size_t n = text.size();
  const std::size_t start = n >= 2 ? text.rfind('\n', n - 2) : std::string::npos;
  const std::string last = n > 0 && text[n - 1] == '\n' && start != std::string::npos
                               ? text.substr(start + 1, n - start - 2)
                               : std::string();
  if (last.size() != 12 || last.compare(0, 4, "end ") != 0)
    SHADOWSENSE_THROW(CalibrationFileError(
        source + ": truncated or damaged: the last line is not 'end <crc32>'; the file "
                 "was cut short or not written completely - save the calibration again"));
  const std::uint32_t actual = detail::calibration_crc32(text.data(), start + 1);
  if (last.substr(4) != detail::crc_hex(actual))
    SHADOWSENSE_THROW(CalibrationFileError(
        source + ": checksum mismatch (file says " + last.substr(4) + ", contents give " +
        detail::crc_hex(actual) + "): the file is damaged or was edited"));
  return detail::parse_calibration(text.substr(0, start + 1), source, version);
}

// Writes `c` (version 2, or 3 with px_per_cm) atomically; see above.
inline void save_calibration(const SegmenterCalibration& c, const std::string& path) {
  write_file_atomically(path, calibration_to_string(c));
}

inline SegmenterCalibration load_calibration(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (ec || !fs::exists(status))
    SHADOWSENSE_THROW(
        IoError("load_calibration: cannot open '" + path + "' for reading: no such file"));
  if (!fs::is_regular_file(status))
    SHADOWSENSE_THROW(
        IoError("load_calibration: '" + path +
                "' is not a regular file (a folder, FIFO or device); expected a calibration file"));
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec || size > detail::kMaxCalibrationFileBytes)
    SHADOWSENSE_THROW(IoError("load_calibration: '" + path + "' is " + std::to_string(size) +
                              " bytes; a calibration file is at most 512 MiB"));
  std::ifstream f(path, std::ios::binary);
  if (!f) SHADOWSENSE_THROW(IoError("load_calibration: cannot open '" + path + "' for reading"));
  std::string text(static_cast<std::size_t>(size), '\0');
  f.read(text.data(), static_cast<std::streamsize>(size));
  text.resize(static_cast<std::size_t>(f.gcount()));
  return calibration_from_string(text, path);
}

SHADOWSENSE_NAMESPACE_END
