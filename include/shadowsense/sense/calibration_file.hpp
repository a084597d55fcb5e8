// The calibration file: save_calibration / load_calibration and their string forms.
// Format in docs/calibration.md. Plain functions; no shared state (any thread).
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sense/pixel_rule.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// Calibration file: UTF-8 text, one "key value..." per line, '#' starts a comment. First
// non-comment line: "shadowsense_segmenter_calibration 1". Keys (all required, each once):
//   mode fixed_ranges|relative
//   shadow_range  B_lo G_lo R_lo B_hi G_hi R_hi      (integers 0..255)
//   contact_range B_lo G_lo R_lo B_hi G_hi R_hi
//   shadow_darkness F  contact_darkness F  contact_warmth F  reference_percentile F
// plus zero or more rows, in increasing luminance (SegmenterCalibration::by_light):
//   light_thresholds LUMINANCE SHADOW_DARKNESS CONTACT_DARKNESS CONTACT_WARMTH

inline std::string calibration_to_string(const SegmenterCalibration& c) {
  detail::validate_calibration(c, "calibration_to_string");
  std::ostringstream o;
  o.precision(9);
  auto range = [&](const ColourRange& r) {
    o << int(r.lower[0]) << ' ' << int(r.lower[1]) << ' ' << int(r.lower[2]) << ' '
      << int(r.upper[0]) << ' ' << int(r.upper[1]) << ' ' << int(r.upper[2]) << '\n';
  };
  o << "# shadowsense segmenter calibration (see docs/tracking_eval.md)\n";
  o << "shadowsense_segmenter_calibration 1\n";
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
  return o.str();
}

// Parses the text format above; throws ModelFileError naming the line on any problem.
inline SegmenterCalibration calibration_from_string(const std::string& text,
                                                    const std::string& source = "calibration") {
  SegmenterCalibration c;
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  bool header = false;
  std::vector<std::string> seen;
  auto fail = [&](const std::string& what) {
    throw ModelFileError(source + ":" + std::to_string(line_no) + ": " + what);
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
        fail("expected the header 'shadowsense_segmenter_calibration 1'");
      if (version != 1)
        fail("format version " + std::to_string(version) + " is not supported; expected 1");
      header = true;
      continue;
    }
    if (key != "light_thresholds" && std::find(seen.begin(), seen.end(), key) != seen.end())
      fail("key '" + key + "' appears twice");
    seen.push_back(key);
    auto read_float = [&](float& v) {
      std::string tok;
      if (!(ls >> tok)) fail("key '" + key + "' needs a number");
      try {
        std::size_t used = 0;
        v = std::stof(tok, &used);
        if (used != tok.size() || !std::isfinite(v)) throw std::invalid_argument(tok);
      } catch (const std::exception&) {
        fail("key '" + key + "': '" + tok + "' is not a finite number");
      }
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
    else if (key == "light_thresholds") {
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
    throw ModelFileError(source + ": empty; expected a shadowsense segmenter calibration");
  for (const char* k : {"mode", "shadow_range", "contact_range", "shadow_darkness",
                        "contact_darkness", "contact_warmth", "reference_percentile"})
    if (std::find(seen.begin(), seen.end(), k) == seen.end())
      throw ModelFileError(source + ": key '" + k + "' is missing");
  try {
    detail::validate_calibration(c, source);
  } catch (const InvalidArgument& e) {
    throw ModelFileError(e.what());
  }
  return c;
}

inline void save_calibration(const SegmenterCalibration& c, const std::string& path) {
  const std::string text = calibration_to_string(c);
  std::ofstream f(path, std::ios::binary);
  if (!f) throw IoError("save_calibration: cannot open '" + path + "' for writing");
  f << text;
  if (!f.flush()) throw IoError("save_calibration: writing '" + path + "' failed");
}

inline SegmenterCalibration load_calibration(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw IoError("load_calibration: cannot open '" + path + "' for reading");
  std::ostringstream ss;
  ss << f.rdbuf();
  return calibration_from_string(ss.str(), path);
}

SHADOWSENSE_NAMESPACE_END
