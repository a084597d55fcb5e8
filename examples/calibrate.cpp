// ss_calibrate: a calibration file (thresholds + empty-skin model) from a robot's own frames.
//
//   ss_calibrate --empty DIR|VIDEO [--touch DIR [--labels CSV]] --out FILE [--preview PNG]
//
// --empty: frames of the untouched skin (a folder of images sorted by name, or a video; one or
// several light levels). --touch: frames with a hand; --labels: a CSV with the header
//   file,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h
// (file relative to --touch; empty contact fields = no contact, e.g. a hover; empty shadow
// fields = no shadow). Touch frames not in the labels are fitted unlabelled (clustering). The
// fit is calibrate_from_frames (docs/calibration.md); its warnings go to stderr. --preview draws
// the fitted segmentation on up to 8 frames as a montage. Writes are atomic.
// Exit status: 0 written (maybe with warnings), 2 bad command line, input or a refused fit.
#include <shadowsense/sense/calibration.hpp>
#include <shadowsense/sense/calibration_file.hpp>

#include "common/cli.hpp"
#include "common/frame_source.hpp"

#include <opencv2/imgproc.hpp>

#include <charconv>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace shadowsense;

namespace {

constexpr const char* kProgram = "ss_calibrate";

struct Options {
  std::string empty, touch, labels, out, preview;
  long long max_empty = 60; // frames taken from an empty-skin video (evenly spaced)
  double light_group_ratio = 1.25;
  int max_side = 8192;
};

const char* kHelp =
    "usage: ss_calibrate --empty DIR|VIDEO [--touch DIR [--labels CSV]] --out FILE\n"
    "                    [--preview PNG]\n"
    "Fits a segmenter calibration (thresholds and the empty-skin model) from your own frames.\n"
    "\n"
    "  --empty SPEC              frames of the untouched skin: folder of images or video file\n"
    "  --touch DIR               frames with a hand on or over the skin\n"
    "  --labels CSV              boxes for the touch frames, header:\n"
    "      file,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h\n"
    "                            (empty contact fields: no contact; frames not listed are\n"
    "                            fitted unlabelled)\n"
    "  --out FILE                the calibration file to write (atomically)\n"
    "  --preview PNG             the fitted segmentation on up to 8 frames, as a montage\n"
    "  --max-empty N             frames taken from an empty-skin video (default 60)\n"
    "  --light-group-ratio R     luminance step that starts a new light level (default 1.25)\n"
    "  --max-side N              refuse images larger than N px per side (default 8192)\n"
    "  --help, --version\n"
    "Warnings (degenerate fits) go to stderr; see docs/calibration.md.\n";

// Returns the options; throws cli::Exit once --help or --version has been answered.
Options parse(int argc, char** argv) {
  Options o;
  cli::Parser p(kProgram, "Fits a segmenter calibration from your own frames.");
  p.help_text(kHelp);
  p.style(cli::Style::lenient());
  p.option("--empty", "SPEC", "frames of the untouched skin", o.empty);
  p.option("--touch", "DIR", "frames with a hand on or over the skin", o.touch);
  p.option("--labels", "CSV", "boxes for the touch frames", o.labels);
  p.option("--out", "FILE", "the calibration file to write", o.out);
  p.option("--preview", "PNG", "the fitted segmentation as a montage", o.preview);
  p.option("--max-empty", "N", "frames taken from an empty-skin video", o.max_empty)
      .range(1, 100000);
  p.option("--light-group-ratio", "R", "luminance step of a new light level", o.light_group_ratio)
      .range(1.01, 100.0);
  p.option("--max-side", "N", "largest image side", o.max_side).range(16, 65536);
  p.parse(argc, argv);
  if (o.empty.empty()) throw cli::UsageError("--empty is required (frames of the untouched skin)");
  if (o.out.empty()) throw cli::UsageError("--out is required (the calibration file to write)");
  if (!o.labels.empty() && o.touch.empty()) throw cli::UsageError("--labels needs --touch");
  return o;
}

// Frames of the empty skin: every image of a folder, or up to max_empty evenly spaced frames of
// a video.
std::vector<cv::Mat> read_empty(const Options& o) {
  frames::FrameSource src = frames::FrameSource::open(o.empty, o.max_side);
  std::vector<cv::Mat> all;
  cv::Mat f;
  std::string name;
  while (src.next(f, name)) all.push_back(f.clone());
  if (all.empty()) throw IoError("'" + o.empty + "' gave no frame");
  if (src.is_folder() || static_cast<long long>(all.size()) <= o.max_empty) return all;
  std::vector<cv::Mat> picked;
  for (long long k = 0; k < o.max_empty; ++k)
    picked.push_back(
        all[static_cast<std::size_t>(k * static_cast<long long>(all.size()) / o.max_empty)]);
  return picked;
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out(1);
  for (char c : line)
    if (c == ',')
      out.emplace_back();
    else
      out.back() += c;
  return out;
}

// file -> labels, from the --labels CSV.
std::map<std::string, BoxLabelledFrame> read_labels(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw IoError("cannot open labels '" + path + "'");
  std::map<std::string, BoxLabelledFrame> out;
  std::string line;
  int n = 0;
  const std::string header =
      "file,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h";
  while (std::getline(f, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string where = path + ":" + std::to_string(n);
    if (n == 1) {
      if (line != header) throw IoError(where + ": expected the header '" + header + "'");
      continue;
    }
    if (line.empty()) continue;
    const std::vector<std::string> c = split(line);
    if (c.size() != 9)
      throw IoError(where + ": " + std::to_string(c.size()) + " fields; expected 9");
    auto box = [&](std::size_t at, const char* what) -> std::optional<cv::Rect> {
      int empty_fields = 0;
      for (std::size_t k = at; k < at + 4; ++k) empty_fields += c[k].empty() ? 1 : 0;
      const bool all_empty = empty_fields == 4, any_empty = empty_fields > 0;
      if (all_empty) return std::nullopt;
      if (any_empty) throw IoError(where + ": the " + std::string(what) + " box is incomplete");
      int v[4];
      for (std::size_t k = 0; k < 4; ++k) {
        const std::string& t = c[at + k];
        const auto r = std::from_chars(t.data(), t.data() + t.size(), v[k]);
        if (r.ec != std::errc() || r.ptr != t.data() + t.size() || v[k] < 0 || v[k] > 65536)
          throw IoError(where + ": '" + t + "' is not a pixel coordinate (0..65536)");
      }
      if (v[2] == 0 || v[3] == 0)
        throw IoError(where + ": the " + std::string(what) + " box has no area");
      return cv::Rect(v[0], v[1], v[2], v[3]);
    };
    BoxLabelledFrame b;
    b.shadow_box = box(1, "shadow");
    b.contact_box = box(5, "contact");
    if (c[0].empty() || fs::path(c[0]).is_absolute() || c[0].find("..") != std::string::npos)
      throw IoError(where + ": file '" + c[0] + "' must be a name relative to --touch");
    if (!out.emplace(c[0], b).second) throw IoError(where + ": '" + c[0] + "' appears twice");
  }
  if (n == 0)
    throw IoError("labels '" + path + "' are empty; expected the header '" + header + "'");
  return out;
}

// The fitted segmentation on up to 8 frames (touch frames first), 4 per row.
cv::Mat montage(const SegmenterCalibration& cal, const std::vector<cv::Mat>& frames) {
  Segmenter seg({.calibration = cal});
  std::vector<cv::Mat> tiles;
  for (const cv::Mat& f : frames) tiles.push_back(frames::overlay(f, seg.segment(f)));
  const int cols = std::min<int>(4, static_cast<int>(tiles.size()));
  const int rows = (static_cast<int>(tiles.size()) + cols - 1) / cols;
  const cv::Size t = tiles[0].size();
  cv::Mat out(rows * t.height, cols * t.width, CV_8UC3, cv::Scalar::all(0));
  for (std::size_t i = 0; i < tiles.size(); ++i)
    tiles[i].copyTo(out(cv::Rect(static_cast<int>(i % cols) * t.width,
                                 static_cast<int>(i / cols) * t.height, t.width, t.height)));
  return out;
}

int run(const Options& o) {
  frames::limit_decoder(o.max_side);
  const std::vector<cv::Mat> empty = read_empty(o);
  std::vector<BoxLabelledFrame> touch;
  std::size_t labelled = 0;
  if (!o.touch.empty()) {
    std::map<std::string, BoxLabelledFrame> labels;
    if (!o.labels.empty()) labels = read_labels(o.labels);
    const std::vector<fs::path> files = frames::list_images(o.touch);
    if (files.empty()) throw IoError("folder '" + o.touch + "' holds no image");
    for (const fs::path& p : files) {
      BoxLabelledFrame b;
      const auto it = labels.find(p.filename().string());
      if (it != labels.end()) {
        b = it->second;
        labels.erase(it);
        ++labelled;
      } else {
        b.labelled = false;
      }
      b.image = frames::read_image(p, o.max_side);
      touch.push_back(std::move(b));
    }
    if (!labels.empty())
      throw IoError("'" + o.labels + "' labels '" + labels.begin()->first +
                    "', which is not an "
                    "image in '" +
                    o.touch + "'");
  }
  CalibrationOptions co;
  co.light_group_ratio = static_cast<float>(o.light_group_ratio);
  co.base.max_image_side = o.max_side;
  const CalibrationResult r = calibrate_from_frames(empty, touch, co);
  for (const CalibrationWarning& w : r.warnings)
    std::cerr << kProgram << ": warning: " << to_string(w.issue) << ": " << w.message << "\n";
  save_calibration(r.calibration, o.out);
  std::cout << "calibration: " << empty.size() << " empty frames, " << touch.size()
            << " touch frames (" << labelled << " labelled), " << r.groups.size()
            << " light level(s), " << r.warnings.size() << " warning(s) -> " << o.out << "\n";
  for (const LightGroupReport& g : r.groups)
    std::cout << "  luminance " << g.luminance << ": " << g.empty_frames << " empty, "
              << g.touch_frames << " touch; noise " << g.noise_darkness << ", shadow "
              << g.thresholds.shadow_darkness << ", contact darkness "
              << g.thresholds.contact_darkness << " warmth " << g.thresholds.contact_warmth
              << (g.fitted ? "" : " (not fitted here)") << "\n";
  if (!o.preview.empty()) {
    std::vector<cv::Mat> sample;
    const std::size_t n_touch = std::min<std::size_t>(6, touch.size()); // spread over the folder
    for (std::size_t k = 0; k < n_touch; ++k)
      sample.push_back(touch[k * touch.size() / n_touch].image);
    for (std::size_t k = 0; k < empty.size() && sample.size() < 8; ++k) sample.push_back(empty[k]);
    frames::write_png_atomically(o.preview, montage(r.calibration, sample));
    std::cout << "preview: " << sample.size() << " frames -> " << o.preview << "\n";
  }
  return 0;
}

} // namespace

int main(int argc, char** argv) {
  return cli::run(kProgram, [&] { return run(parse(argc, argv)); });
}
