// ss_calibrate: a calibration file (thresholds + empty-skin model) from a robot's own frames.
//
//   ss_calibrate --empty DIR|VIDEO [--touch DIR|VIDEO|DATASET [--labels CSV]] --out FILE
//                [--preview PNG] [--px-per-cm X]
//
// --empty: frames of the untouched skin: a folder of images or a video (one or several light
// levels). --touch: frames with a hand, as users have them:
//   * a folder of images (the one rule of shadowsense/io/image_folder.hpp: recursive, sorted by
//     path) with an optional --labels CSV whose header is
//       file,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h
//     and whose `file` is the image's path relative to --touch ('/' separators; the file name
//     for a flat folder);
//   * a video with an optional --labels CSV of the same header whose `file` is the frame index
//     (0 = the first frame);
//   * a dataset folder with a metadata.csv (docs/dataset_format.md): the boxes come from the
//     metadata; no --labels. Rows without a shadow box are labelled "no shadow"; rows whose
//     image is also in the --empty folder (--empty DATASET/nothing) are left out.
// Empty contact fields = no contact (a hover); empty shadow fields = no shadow. Frames not in
// the labels are fitted unlabelled (clustering); from a video at most --max-touch of them,
// evenly spaced. The fit is calibrate_from_frames (docs/calibration.md); its warnings go to
// stderr naming the file (or "VIDEO#k"). --preview draws the fitted segmentation on up to 8
// frames as a montage. The run ends with a summary on stdout: frames used per light level,
// warnings, where the calibration was written. Writes are atomic. Memory: --max-memory-mb plans
// how many frames are held from the frame size (common/calibrate_budget.hpp); fewer than asked
// for at large sizes, evenly spaced, with a warning (docs/calibration.md "Memory").
// --px-per-cm X: the camera's scale (px per cm of skin at the image centre, measured once, e.g.
// a ruler laid on the skin across the middle of a frame), recorded in the calibration (format
// version 3): the gesture classifier brings frames to its network's scale with it
// (docs/input_encodings.md). Not fitted from the frames.
// Exit status: 0 written (maybe with warnings), 2 bad command line, input or a refused fit.
#include <shadowsense/io/dataset.hpp>
#include <shadowsense/io/image_folder.hpp>
#include <shadowsense/sense/calibration.hpp>
#include <shadowsense/sense/calibration_file.hpp>

#include "common/calibrate_budget.hpp"
#include "common/cli.hpp"
#include "common/frame_source.hpp"

#include <opencv2/imgproc.hpp>

#include <charconv>
#include <cmath>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace shadowsense;

namespace {

constexpr const char* kProgram = "ss_calibrate";

struct Options {
  std::string empty, touch, labels, out, preview;
  long long max_empty = 60; // frames taken from an empty-skin video (evenly spaced)
  long long max_touch = 60; // unlabelled frames taken from a touch video (evenly spaced)
  double light_group_ratio = 1.25;
  double px_per_cm = 0; // --px-per-cm: the camera's scale, recorded as measured (0 = none)
  int max_side = 8192;
  long long max_memory_mb = calib_budget::kDefaultMiB; // frames held: see calibrate_budget.hpp
};

const char* kHelp =
    "usage: ss_calibrate --empty DIR|VIDEO [--touch DIR|VIDEO|DATASET [--labels CSV]]\n"
    "                    --out FILE [--preview PNG] [--px-per-cm X]\n"
    "Fits a segmenter calibration (thresholds and the empty-skin model) from your own frames.\n"
    "Options take \"--opt value\" or \"--opt=value\". Folders are searched recursively\n"
    "(.png .jpg .jpeg .bmp .tif .tiff .webp .ppm .pgm; sorted by path).\n"
    "\n"
    "  --empty SPEC              frames of the untouched skin: folder of images or video file\n"
    "  --touch SPEC              frames with a hand on or over the skin: a folder of images, a\n"
    "                            video file, or a dataset folder with metadata.csv (its boxes\n"
    "                            are the labels; docs/dataset_format.md; frames that are also\n"
    "                            in --empty, e.g. --empty DATASET/nothing, are left out)\n"
    "  --labels CSV              boxes for a touch folder or video, header:\n"
    "      file,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h\n"
    "                            file: the image's path relative to --touch, or for a video\n"
    "                            the frame index (0 = first); empty contact fields: no\n"
    "                            contact; frames not listed are fitted unlabelled\n"
    "  --out FILE                the calibration file to write (atomically)\n"
    "  --preview PNG             the fitted segmentation on up to 8 frames, as a montage\n"
    "  --px-per-cm X             the camera's scale, px per cm of skin at the image centre\n"
    "                            (measured with a ruler on the skin), in [0.05, 10000]:\n"
    "                            recorded for the gesture classifier (default: none)\n"
    "  --max-empty N             empty-skin frames used, evenly spaced (default 60)\n"
    "  --max-touch N             unlabelled frames taken from a touch video (default 60)\n"
    "  --light-group-ratio R     luminance step that starts a new light level (default 1.25)\n"
    "  --max-side N              refuse images larger than N px per side (default 8192)\n"
    "  --max-memory-mb N         plan the run to peak within N MiB (default 900): at large\n"
    "                            frame sizes fewer frames are held (evenly spaced; a warning\n"
    "                            says how many were used)\n"
    "  --help, --version\n"
    "Warnings (degenerate fits) go to stderr naming the frame; a summary ends the run.\n"
    "See docs/calibration.md.\n";

// Returns the options; throws cli::Exit once --help or --version has been answered.
Options parse(int argc, char** argv) {
  Options o;
  cli::Parser p(kProgram, "Fits a segmenter calibration from your own frames.");
  p.help_text(kHelp);
  p.option("--empty", "SPEC", "frames of the untouched skin", o.empty);
  p.option("--touch", "SPEC", "frames with a hand on or over the skin", o.touch);
  p.option("--labels", "CSV", "boxes for the touch frames", o.labels);
  p.option("--out", "FILE", "the calibration file to write", o.out);
  p.option("--preview", "PNG", "the fitted segmentation as a montage", o.preview);
  p.option("--px-per-cm", "X", "the camera's scale (px per cm of skin)", o.px_per_cm)
      .range(0.05, 10000.0);
  p.option("--max-empty", "N", "empty-skin frames used, evenly spaced", o.max_empty)
      .range(1, 100000);
  p.option("--max-touch", "N", "unlabelled frames taken from a touch video", o.max_touch)
      .range(1, 100000);
  p.option("--light-group-ratio", "R", "luminance step of a new light level", o.light_group_ratio)
      .range(1.01, 100.0);
  p.option("--max-side", "N", "largest image side", o.max_side).range(16, 65536);
  p.option("--max-memory-mb", "N", "peak memory the run is planned for (MiB)", o.max_memory_mb)
      .range(101, 1048576);
  p.parse(argc, argv);
  if (o.empty.empty()) throw cli::UsageError("--empty is required (frames of the untouched skin)");
  if (o.out.empty()) throw cli::UsageError("--out is required (the calibration file to write)");
  if (!o.labels.empty() && o.touch.empty()) throw cli::UsageError("--labels needs --touch");
  return o;
}

// Indices 0..count-1 to keep when at most `max` of them are wanted, evenly spaced.
std::set<std::size_t> evenly_spaced(std::size_t count, long long max) {
  std::set<std::size_t> keep;
  const auto m = static_cast<std::size_t>(max);
  for (std::size_t k = 0; k < std::min(count, m); ++k) keep.insert(count <= m ? k : k * count / m);
  return keep;
}

// What the memory plan allows: empty frames (at most max_empty of them) and touch frames.
struct Plan {
  long long max_empty = 0;
  std::size_t max_touch_held = 0;
};

// Frames of the empty skin: up to max_empty evenly spaced frames of a folder or a video. Memory
// is bounded by what is kept: only kept frames are decoded (folders) or copied (videos); a video
// that does not tell its length keeps every stride-th frame, doubling the stride (and dropping
// every other kept frame) whenever 2 x max_empty are held, then picks max_empty evenly spaced.
// The first frame (always kept) gives the frame size, and with it the memory plan
// (--max-memory-mb, calibrate_budget.hpp): when the wanted empty frames and `touch_wanted` touch
// frames would not fit, max_empty is lowered (a warning says so) and plan.max_touch_held set.
std::vector<cv::Mat> read_empty(const Options& o, std::size_t touch_wanted, bool labelled,
                                Plan& plan) {
  frames::FrameSource src = frames::FrameSource::open(o.empty, o.max_side);
  if (src.is_camera())
    throw cli::UsageError("--empty: '" + o.empty +
                          "' is a camera; record a video or a folder of frames first");
  std::vector<cv::Mat> all;
  cv::Mat f;
  std::string name;
  if (!src.next(f, name)) throw IoError("'" + o.empty + "' gave no frame");
  all.push_back(f.clone());
  {
    const cv::Size size = f.size();
    const double budget = static_cast<double>(o.max_memory_mb) * calib_budget::kMiB;
    const std::size_t room = calib_budget::frames_within(size, budget, labelled);
    const bool known = src.count().has_value();
    const auto max_empty = static_cast<std::size_t>(o.max_empty);
    // Held at once: the kept frames, or up to 2 x max_empty while a video of unknown length is
    // thinned.
    const std::size_t empty_wanted = known ? std::min(*src.count(), max_empty) : 2 * max_empty;
    const calib_budget::Split s = calib_budget::split(empty_wanted, touch_wanted, room);
    const std::string dims = std::to_string(size.width) + "x" + std::to_string(size.height);
    if (!s.ok)
      throw cli::UsageError("--max-memory-mb " + std::to_string(o.max_memory_mb) +
                            " is too small for " + dims +
                            " frames: the fit and one frame of each kind need about " +
                            std::to_string(static_cast<long long>(std::ceil(
                                calib_budget::estimate(size, (touch_wanted ? 2 : 1), labelled) /
                                calib_budget::kMiB))) +
                            " MiB");
    plan.max_empty = known ? static_cast<long long>(s.empty)
                           : std::max<long long>(1, static_cast<long long>(s.empty / 2));
    plan.max_touch_held = s.touch;
    if (s.empty < empty_wanted || s.touch < touch_wanted)
      std::cerr << kProgram << ": warning: --max-memory-mb " << o.max_memory_mb << ": " << dims
                << " frames leave room for " << room << " frames held at once; using at most "
                << plan.max_empty << " empty frames"
                << (known ? " of " + std::to_string(*src.count()) : std::string())
                << (s.touch < touch_wanted ? " and " + std::to_string(s.touch) + " of " +
                                                 std::to_string(touch_wanted) + " touch frames"
                                           : std::string())
                << " (evenly spaced); raise --max-memory-mb to use more\n";
  }
  std::optional<std::set<std::size_t>> keep;
  if (src.count()) keep = evenly_spaced(*src.count(), plan.max_empty);
  const auto bound = static_cast<std::size_t>(2 * plan.max_empty);
  std::size_t stride = 1;
  for (std::size_t i = 1;; ++i) { // frame 0 is read: every plan keeps it
    const bool wanted = keep ? keep->count(i) > 0 : i % stride == 0;
    if (!(wanted ? src.next(f, name) : src.skip())) break;
    if (!wanted) continue;
    all.push_back(f.clone());
    if (!keep && all.size() >= bound) { // unknown length: thin out, keep every 2*stride-th
      std::vector<cv::Mat> half;
      for (std::size_t k = 0; k < all.size(); k += 2) half.push_back(all[k]);
      all.swap(half);
      stride *= 2;
    }
  }
  if (const std::string short_read = src.ended_early(); !short_read.empty())
    throw IoError("--empty '" + o.empty + "': " + short_read +
                  "; a calibration from part of it would not say so");
  if (static_cast<long long>(all.size()) <= plan.max_empty) return all;
  std::vector<cv::Mat> picked;
  for (std::size_t k : evenly_spaced(all.size(), plan.max_empty)) picked.push_back(all[k]);
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

// file -> labels, from the --labels CSV. video: `file` is a frame index, kept as its decimal
// text (leading zeros dropped).
std::map<std::string, BoxLabelledFrame> read_labels(const std::string& path, bool video) {
  // The library's bounded reader: a regular file of at most 1 GiB (a FIFO or /dev/zero is
  // refused with its name instead of hanging or growing without bound).
  std::istringstream f(detail::read_csv_text(path));
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
    std::string key = c[0];
    if (video) {
      long long index = -1;
      const auto r = std::from_chars(key.data(), key.data() + key.size(), index);
      if (key.empty() || r.ec != std::errc() || r.ptr != key.data() + key.size() || index < 0)
        throw IoError(where + ": file '" + key +
                      "' must be a frame index (0 = the first frame) for a video --touch");
      key = std::to_string(index);
    } else if (key.empty() || fs::path(key).is_absolute() || key.find("..") != std::string::npos) {
      throw IoError(where + ": file '" + key + "' must be a path relative to --touch");
    }
    if (!out.emplace(key, b).second) throw IoError(where + ": '" + c[0] + "' appears twice");
  }
  if (n == 0)
    throw IoError("labels '" + path + "' are empty; expected the header '" + header + "'");
  return out;
}

// The touch frames a run would take, listed before any is decoded (the memory plan needs their
// number): a dataset's rows, or the frame indices of a folder or of a video of known length.
struct TouchInput {
  bool dataset = false, folder = false;
  std::shared_ptr<const Metadata> md;             // dataset
  std::vector<std::size_t> rows;                  // dataset: the rows used
  std::map<std::string, BoxLabelledFrame> labels; // folder or video: --labels
  std::optional<std::vector<std::size_t>> taken;  // folder, video of known length: indices
  std::size_t wanted = 0;                         // frames that would be held at once
  bool labelled = false;                          // some are labelled: the box search runs
};

// Touch frames of a dataset folder: every metadata.csv row, its boxes as labels, except the
// rows whose image is one of the --empty folder's (e.g. --empty DATASET/nothing): those are
// empty frames already.
TouchInput list_dataset_touch(const Options& o) {
  TouchInput t;
  t.dataset = true;
  t.md = std::make_shared<const Metadata>(read_metadata(fs::path(o.touch) / "metadata.csv"));
  const Metadata& md = *t.md;
  if (md.rows.empty()) throw DatasetError(md.csv_path.string() + ": no frames");
  std::set<fs::path> empty_files;
  std::error_code ec;
  if (fs::is_directory(o.empty, ec))
    for (const fs::path& p : find_images(o.empty)) empty_files.insert(fs::weakly_canonical(p, ec));
  for (std::size_t r = 0; r < md.rows.size(); ++r)
    if (!empty_files.count(fs::weakly_canonical(md.image_path(md.rows[r]), ec)))
      t.rows.push_back(r);
  if (t.rows.empty())
    throw DatasetError(md.csv_path.string() + ": every frame is one of --empty's; no touch frame");
  t.wanted = 1; // read from its file whenever the fit needs it (BoxLabelledFrame::load)
  t.labelled = true;
  return t;
}

// Touch frames of a folder of images (all of them) or a video (the labelled frames and at most
// max_touch unlabelled ones, evenly spaced), labelled from --labels where listed.
TouchInput list_touch(const Options& o) {
  TouchInput t;
  std::error_code ec;
  t.folder = fs::is_directory(o.touch, ec);
  if (!o.labels.empty()) t.labels = read_labels(o.labels, !t.folder);
  t.labelled = !t.labels.empty();
  frames::FrameSource src = frames::FrameSource::open(o.touch, o.max_side);
  if (src.is_camera())
    throw cli::UsageError("--touch: '" + o.touch +
                          "' is a camera; record a video or a folder of frames first");
  if (!src.count()) { // a video of unknown length
    t.wanted = t.labels.size() + static_cast<std::size_t>(o.max_touch);
    return t;
  }
  if (t.folder) { // every image, each read from its file whenever the fit needs it
    t.wanted = 1;
    return t;
  }
  t.taken.emplace();
  {
    std::size_t unlabelled = 0;
    for (std::size_t i = 0; i < *src.count(); ++i)
      unlabelled += t.labels.count(std::to_string(i)) ? 0 : 1;
    const std::set<std::size_t> picks = evenly_spaced(unlabelled, o.max_touch);
    for (std::size_t i = 0, u = 0; i < *src.count(); ++i)
      if (t.labels.count(std::to_string(i)) || picks.count(u++)) t.taken->push_back(i);
  }
  t.wanted = t.taken->size();
  return t;
}

void warn_touch_thinned(const std::string& what, std::size_t used, std::size_t of) {
  if (used < of)
    std::cerr << kProgram << ": warning: --max-memory-mb: " << used << " of " << of << " " << what
              << " used (evenly spaced)\n";
}

// The dataset's touch frames, none decoded here: each is read from its file whenever the fit
// needs it (BoxLabelledFrame::load), so one is held at a time.
std::vector<BoxLabelledFrame> read_dataset_touch(const Options& o, const TouchInput& t) {
  ImageLimits limits;
  limits.max_width = limits.max_height = o.max_side;
  std::vector<BoxLabelledFrame> out;
  for (std::size_t r : t.rows) {
    const MetadataRow& row = t.md->rows[r];
    BoxLabelledFrame b;
    b.load = [md = t.md, r, limits] { return read_image(*md, md->rows[r], limits); };
    b.shadow_box = row.shadow_box;
    b.contact_box = row.contact_box;
    b.name = row.file_name;
    out.push_back(std::move(b));
  }
  return out;
}

// The frames of list_touch. A folder's are not decoded here: each is read from its file whenever
// the fit needs it (BoxLabelledFrame::load), one at a time. A video's are held, at most `cap` of
// them (evenly spaced over the frames taken; a video of unknown length: the labelled frames,
// which must fit, then unlabelled ones).
std::vector<BoxLabelledFrame> read_touch(const Options& o, TouchInput t, std::size_t cap) {
  std::map<std::string, BoxLabelledFrame>& labels = t.labels;
  std::vector<BoxLabelledFrame> touch;
  if (t.folder) {
    for (const fs::path& p : shadowsense::require_images(o.touch)) {
      const std::string name = p.lexically_relative(o.touch).generic_string();
      BoxLabelledFrame b;
      const auto it = labels.find(name);
      if (it != labels.end()) {
        b = it->second;
        labels.erase(it);
      } else {
        b.labelled = false;
      }
      b.load = [p, side = o.max_side] { return frames::read_image(p, side); };
      b.name = name;
      touch.push_back(std::move(b));
    }
    if (!labels.empty())
      throw IoError("'" + o.labels + "' labels '" + labels.begin()->first +
                    "', which is not an image in '" + o.touch + "'");
    return touch;
  }
  frames::FrameSource src = frames::FrameSource::open(o.touch, o.max_side);
  std::optional<std::set<std::size_t>> keep;
  std::size_t max_unlabelled = static_cast<std::size_t>(o.max_touch);
  if (t.taken) {
    keep.emplace();
    for (std::size_t k : evenly_spaced(t.taken->size(), static_cast<long long>(cap)))
      keep->insert((*t.taken)[k]);
  } else {
    if (labels.size() > cap)
      throw cli::UsageError("--max-memory-mb " + std::to_string(o.max_memory_mb) +
                            " leaves room for " + std::to_string(cap) +
                            " touch frames, fewer than the " + std::to_string(labels.size()) +
                            " labelled frames of a video of unknown length; raise --max-memory-mb");
    max_unlabelled = std::min(max_unlabelled, cap - labels.size());
  }
  std::size_t unlabelled_taken = 0;
  cv::Mat f;
  std::string name;
  for (std::size_t i = 0;; ++i) {
    if (keep && !keep->count(i)) { // skipped undecoded
      if (!src.skip()) break;
      labels.erase(std::to_string(i));
      continue;
    }
    if (!src.next(f, name)) break;
    BoxLabelledFrame b;
    const auto it = labels.find(std::to_string(i));
    if (it != labels.end()) {
      b = it->second;
      labels.erase(it);
    } else {
      if (!keep && unlabelled_taken >= max_unlabelled) continue;
      b.labelled = false;
      ++unlabelled_taken;
    }
    b.image = f.clone();
    b.name = o.touch + "#" + std::to_string(i);
    touch.push_back(std::move(b));
  }
  if (const std::string short_read = src.ended_early(); !short_read.empty())
    throw IoError("--touch '" + o.touch + "': " + short_read +
                  "; a calibration from part of it would not say so");
  if (!labels.empty())
    throw IoError("'" + o.labels + "' labels '" + labels.begin()->first + "', which is not " +
                  "a frame of '" + o.touch + "' (frames are counted from 0)");
  if (touch.empty()) throw IoError("'" + o.touch + "' gave no frame");
  if (t.taken) warn_touch_thinned("touch frames", touch.size(), t.taken->size());
  return touch;
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
  // The touch frames are listed first (undecoded): the memory plan shares the room between them
  // and the empty frames.
  std::optional<TouchInput> touch_input;
  std::string touch_kind;
  if (!o.touch.empty()) {
    std::error_code ec;
    const bool dataset = fs::is_regular_file(fs::path(o.touch) / "metadata.csv", ec);
    if (dataset && !o.labels.empty())
      throw cli::UsageError("--labels: '" + o.touch +
                            "' is a dataset folder; its metadata.csv gives the boxes");
    touch_input = dataset ? list_dataset_touch(o) : list_touch(o);
    touch_kind = dataset ? "dataset" : fs::is_directory(o.touch, ec) ? "folder" : "video";
  }
  Plan plan;
  const std::vector<cv::Mat> empty = read_empty(o, touch_input ? touch_input->wanted : 0,
                                                touch_input && touch_input->labelled, plan);
  std::vector<BoxLabelledFrame> touch;
  if (touch_input)
    touch = touch_input->dataset ? read_dataset_touch(o, *touch_input)
                                 : read_touch(o, std::move(*touch_input), plan.max_touch_held);
  std::size_t labelled = 0;
  for (const BoxLabelledFrame& b : touch) labelled += b.labelled ? 1 : 0;
  CalibrationOptions co;
  co.light_group_ratio = static_cast<float>(o.light_group_ratio);
  co.base.max_image_side = o.max_side;
  CalibrationResult r = calibrate_from_frames(empty, touch, co);
  r.calibration.px_per_cm = static_cast<float>(o.px_per_cm);
  for (const CalibrationWarning& w : r.warnings)
    std::cerr << kProgram << ": warning: " << to_string(w.issue) << ": " << w.message << "\n";
  std::cerr.flush();
  save_calibration(r.calibration, o.out);
  for (const LightGroupReport& g : r.groups)
    std::cout << "  luminance " << g.luminance << ": " << g.empty_frames << " empty, "
              << g.touch_frames << " touch; noise " << g.noise_darkness << ", shadow "
              << g.thresholds.shadow_darkness << ", contact darkness "
              << g.thresholds.contact_darkness << " warmth " << g.thresholds.contact_warmth
              << (g.fitted ? "" : " (not fitted here)") << "\n";
  if (!o.preview.empty()) {
    std::vector<cv::Mat> sample;
    const std::size_t n_touch = std::min<std::size_t>(6, touch.size()); // spread over the input
    for (std::size_t k = 0; k < n_touch; ++k) {
      const BoxLabelledFrame& b = touch[k * touch.size() / n_touch];
      sample.push_back(b.image.empty() && b.load ? b.load() : b.image);
    }
    for (std::size_t k = 0; k < empty.size() && sample.size() < 8; ++k) sample.push_back(empty[k]);
    frames::write_png_atomically(o.preview, montage(r.calibration, sample));
    std::cout << "preview: " << sample.size() << " frames -> " << o.preview << "\n";
  }
  // The summary: what was used per light level, the warnings, where the result went.
  std::ostringstream levels;
  for (std::size_t g = 0; g < r.groups.size(); ++g)
    levels << (g ? "; " : "") << "luminance " << static_cast<int>(r.groups[g].luminance + 0.5f)
           << ": " << r.groups[g].empty_frames << " empty + " << r.groups[g].touch_frames
           << " touch";
  std::cout << "calibration: " << empty.size() << " empty frames, " << touch.size()
            << " touch frames (" << labelled << " labelled"
            << (touch_kind.empty() ? "" : ", from a " + touch_kind) << "), " << r.groups.size()
            << " light level(s) (" << levels.str() << "), " << r.warnings.size() << " warning(s)"
            << (r.warnings.empty() ? "" : " (on stderr)") << " -> " << o.out << "\n";
  return 0;
}

} // namespace

int main(int argc, char** argv) {
  return cli::run(kProgram, [&] { return run(parse(argc, argv)); });
}
