// ss_classify: classify every frame of a folder of images or of a video file with a model
// file, the frame encoding (lighting normalisation, dark-frame rule, preprocessing) taken from
// the model file itself.
//
//   ss_classify --input INPUT [--model FILE] [--format csv|json] [--truth] [--threads N]
//               [--lighting-normalise] [--calibration FILE] [--quiet]
//
// INPUT (--input, or as the last word): a folder (images found by the one rule of
// shadowsense/io/image_folder.hpp: recursively, .png .jpg .jpeg .bmp .tif .tiff .webp .ppm .pgm,
// sorted by path, names starting with '.' skipped) or a video file (when built with OpenCV
// videoio). --model defaults to the shipped model, found by common/model_path.hpp (installed,
// $SHADOWSENSE_MODEL, or the source tree's when run from the build folder). Options take
// "--opt value" or "--opt=value".
// stdout: one line per frame.
//   csv (default): header "frame,source,dark,label,<class 1>,...,<class n>", then the frame
//                  number (from 0), the image path or "VIDEO#k", whether the dark-frame rule
//                  applied the brightness factor (0/1), the label and one probability per class.
//   json: one JSON object per line: {"frame":0,"source":"...","dark":false,"label":"palm",
//         "index":2,"probabilities":{"nothing":0.01,...}}.
// --truth (folders only): the true class of an image is the name of the first folder below
//   INPUT on its path (INPUT/<class>/.../x.png; an image directly in INPUT takes INPUT's own
//   name). Every true class must be one of the model's. After the frames, the accuracy and the
//   confusion matrix (rows: true class, columns: predicted) go to stderr, so stdout stays
//   machine-readable.
// --lighting-normalise: switch lighting normalisation on for version-1 model files, which do
//   not record it (version-2 files apply what they record).
// --calibration FILE: the robot's calibration (ss_calibrate); its empty-skin model is what a
//   model with a calibrated input encoding (docs/input_encodings.md) divides frames by. Such a
//   model refuses to run without it (exit 2); a colour model does not use it.
// --scale-to-network: bring every frame to the network's scale with the calibration's camera
//   scale (px_per_cm, ss_calibrate --px-per-cm; any model). Off by default: on the shipped model
//   it lowers accuracy (docs/input_encodings.md, "The camera's scale").
// stderr: "ss_classify: frame i of n" at most once a second and "ss_classify: n frames" at the
//   end, when the input is a video of unknown length or has more than 100 frames (--quiet: none).
// Exit status: 0 on success; 2 on any error (message on stderr); --help (stdout) and
// --version exit 0.
#include <shadowsense/io/image_folder.hpp>
#include <shadowsense/shadowsense.hpp>
#include <shadowsense/train/gesture_samples.hpp>

#include "common/cli.hpp"
#include "common/model_calibration.hpp"
#include "common/model_path.hpp"

#include <opencv2/imgcodecs.hpp>
#ifdef SHADOWSENSE_HAVE_VIDEOIO
#include <opencv2/videoio.hpp>
#endif

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace ss = shadowsense;
namespace fs = std::filesystem;

namespace {

constexpr const char* usage =
    "usage: ss_classify --input INPUT [--model FILE] [--format csv|json] [--truth]\n"
    "                   [--threads N] [--lighting-normalise] [--calibration FILE]\n"
    "                   [--quiet]\n"
    "\n"
    "Classifies every frame of INPUT (a folder of images, searched recursively and sorted by\n"
    "path, or a video file) with a shadowsense model file and prints one line per frame.\n"
    "Options take \"--opt value\" or \"--opt=value\".\n"
    "\n"
    "  --input INPUT         a folder of images (.png .jpg .jpeg .bmp .tif .tiff .webp .ppm\n"
    "                        .pgm, in sub-folders too) or a video file; may also be given as\n"
    "                        the last word without --input\n"
    "  --model FILE          model file (default: @DEFAULT_MODEL@)\n"
    "  --format csv|json     csv (default): frame,source,dark,label,<one column per class>;\n"
    "                        json: one object per line with frame, source, dark, label,\n"
    "                        index and probabilities {class: p}\n"
    "  --truth               folders only: the true class is the first folder below INPUT\n"
    "                        (INPUT/<class>/...); accuracy and confusion matrix (rows true,\n"
    "                        columns predicted) are printed to stderr after the frames\n"
    "  --threads N           inference threads, an integer in [1, 256] (default 1)\n"
    "  --lighting-normalise  normalise lighting for version-1 model files, which do not\n"
    "                        record it (version-2 files apply what they record)\n"
    "  --calibration FILE    the robot's calibration (ss_calibrate): its empty-skin model,\n"
    "                        needed by a model with a calibrated input encoding (such a model\n"
    "                        refuses to run without it); a colour model does not use it\n"
    "  --scale-to-network    bring frames to the network's scale with the calibration's\n"
    "                        camera scale (ss_calibrate --px-per-cm); off by default: it\n"
    "                        lowers the shipped model's accuracy (docs/input_encodings.md)\n"
    "  --quiet               no progress line on stderr (shown once a second for inputs\n"
    "                        over 100 frames or of unknown length)\n"
    "  --help                this text;  --version  the library version\n"
    "\n"
    "Exit status 0 on success, 2 on an error (message on stderr).\n";

struct Options {
  std::string model;      // empty: cli::find_default_model
  std::string model_note; // where the default model was found (said once the input opened)
  std::string input;
  std::string calibration;
  bool json = false, truth = false, force_normalise = false, quiet = false;
  bool scale_to_network = false;
  int threads = 1;
};

// Returns the options; throws cli::Exit once --help or --version has been answered.
Options parse(int argc, char** argv) {
  Options o;
  std::string format = "csv";
  cli::Parser p("ss_classify", "Classifies every frame of INPUT with a shadowsense model file.");
  std::string help = usage;
  const std::string marker = "@DEFAULT_MODEL@";
  help.replace(help.find(marker), marker.size(), cli::default_model_help(argv[0]));
  p.help_text(help);
  p.option("--input", "INPUT", "a folder of images or a video file", o.input)
      .check([&o](const std::string& arg) {
        if (!o.input.empty())
          throw cli::UsageError("more than one INPUT ('" + o.input + "' and '" + arg + "')");
      });
  p.option("--model", "FILE", "model file", o.model);
  p.option("--format", "csv|json", "output format", format).choices({"csv", "json"});
  p.flag("--truth", "the true class is the first folder below INPUT", o.truth);
  p.option("--threads", "N", "inference threads", o.threads).range(1, 256);
  p.flag("--lighting-normalise", "normalise lighting for version-1 model files", o.force_normalise);
  p.option("--calibration", "FILE", "calibration file (empty-skin model)", o.calibration);
  p.flag("--scale-to-network", "bring frames to the network's scale (calibration's px_per_cm)",
         o.scale_to_network);
  p.flag("--quiet", "no progress line on stderr", o.quiet);
  // INPUT as the last word stays accepted (the command line ss_classify documented first).
  p.positional("INPUT", "a folder of images or a video file", [&o](std::string_view arg) {
    if (!o.input.empty())
      throw cli::UsageError("more than one INPUT ('" + o.input + "' and '" + std::string(arg) +
                            "')");
    o.input = arg;
  });
  p.parse(argc, argv);
  o.json = format == "json";
  if (o.input.empty())
    throw cli::UsageError("--input is required: a folder of images or a video file");
  if (o.model.empty()) { // say which file the default is, as --help does
    std::string what;
    o.model = cli::find_default_model(argv[0], &what).string();
    o.model_note = "ss_classify: model " + o.model + " (" + what + ")\n";
  }
  return o;
}

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += ch;
    } else if (c < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string out = "\"";
  for (const char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string number(float v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", static_cast<double>(v));
  return buf;
}

// Frames from a folder (sorted images) or a video file.
class FrameSource {
public:
  explicit FrameSource(const std::string& input) : input_(input) {
    std::error_code ec;
    if (fs::is_directory(input, ec)) {
      images_ = ss::find_images(input);
      if (images_.empty())
        throw ss::IoError(input + ": no images found (looked for " + ss::image_extensions_text() +
                          ", recursively)");
      return;
    }
    if (!fs::is_regular_file(input, ec))
      throw ss::IoError(input + ": no such folder or file, expected a folder of images or a "
                                "video file");
#ifdef SHADOWSENSE_HAVE_VIDEOIO
    if (!video_.open(input) || !video_.isOpened())
      throw ss::IoError(input + ": cannot open as a video (not a format OpenCV videoio reads)");
    is_video_ = true;
    const double n = video_.get(cv::CAP_PROP_FRAME_COUNT);
    if (std::isfinite(n) && n > 0 && n < 1e9) count_ = static_cast<std::size_t>(n);
#else
    throw ss::IoError(input + ": is a file; reading video needs OpenCV videoio, which this "
                              "build lacks (pass a folder of images)");
#endif
  }
  bool is_video() const {
    return is_video_;
  }
  const std::vector<fs::path>& images() const {
    return images_;
  }
  // Number of frames when known (folders, most video files).
  std::optional<std::size_t> count() const {
    if (!is_video_) return images_.size();
    return count_;
  }

  // Next frame (BGR) and its source name; false at the end.
  bool next(cv::Mat& frame, std::string& source) {
    if (!is_video_) {
      if (index_ >= images_.size()) return false;
      const auto& p = images_[index_++];
      frame = ss::read_colour_image(p);
      source = p.string();
      return true;
    }
#ifdef SHADOWSENSE_HAVE_VIDEOIO
    if (!video_.read(frame) || frame.empty()) return false;
    source = input_ + "#" + std::to_string(index_++);
    if (frame.type() == CV_8UC1) cv::cvtColor(frame, frame, cv::COLOR_GRAY2BGR);
    if (frame.type() == CV_8UC4) cv::cvtColor(frame, frame, cv::COLOR_BGRA2BGR);
    return true;
#else
    return false;
#endif
  }

private:
  std::string input_;
  std::vector<fs::path> images_;
  std::size_t index_ = 0;
  bool is_video_ = false;
  std::optional<std::size_t> count_;
#ifdef SHADOWSENSE_HAVE_VIDEOIO
  cv::VideoCapture video_;
#endif
};

// The true class index of every image (--truth), checked before anything is classified.
std::vector<int> truth_labels(const FrameSource& src, const fs::path& root,
                              const std::vector<std::string>& classes) {
  if (src.is_video()) throw cli::UsageError("--truth needs a folder of images, not a video");
  std::vector<int> out;
  for (const auto& p : src.images()) {
    const auto rel = fs::relative(p, root);
    const std::string cls = std::distance(rel.begin(), rel.end()) >= 2
                                ? rel.begin()->string()
                                : fs::absolute(root).lexically_normal().filename().string();
    const auto it = std::find(classes.begin(), classes.end(), cls);
    if (it == classes.end())
      throw ss::DatasetError(p.string() + ": true class '" + cls +
                             "' (its folder) is not one of the model's classes");
    out.push_back(static_cast<int>(it - classes.begin()));
  }
  return out;
}

void print_header(const Options& o, const std::vector<std::string>& classes) {
  if (o.json) return;
  std::string line = "frame,source,dark,label";
  for (const auto& c : classes) line += "," + csv_field(c);
  std::cout << line << "\n";
}

void print_frame(const Options& o, std::size_t frame, const std::string& source, bool dark,
                 const ss::Classification& r, const std::vector<std::string>& classes) {
  std::string line;
  if (o.json) {
    line = "{\"frame\":" + std::to_string(frame) + ",\"source\":" + json_string(source) +
           ",\"dark\":" + (dark ? "true" : "false") + ",\"label\":" + json_string(r.label) +
           ",\"index\":" + std::to_string(r.index) + ",\"probabilities\":{";
    for (std::size_t k = 0; k < classes.size(); ++k)
      line += (k ? "," : "") + json_string(classes[k]) + ":" + number(r.probabilities[k]);
    line += "}}";
  } else {
    line = std::to_string(frame) + "," + csv_field(source) + "," + (dark ? "1" : "0") + "," +
           csv_field(r.label);
    for (float p : r.probabilities) line += "," + number(p);
  }
  std::cout << line << "\n";
}

void print_confusion(const std::vector<std::vector<int>>& m,
                     const std::vector<std::string>& classes) {
  long long total = 0, correct = 0;
  std::size_t width = 9;
  for (const auto& c : classes) width = std::max(width, c.size() + 1);
  for (std::size_t t = 0; t < m.size(); ++t)
    for (std::size_t p = 0; p < m.size(); ++p) {
      total += m[t][p];
      if (t == p) correct += m[t][p];
    }
  std::fprintf(stderr, "accuracy %.2f%% (%lld of %lld frames)\n",
               total ? 100.0 * double(correct) / double(total) : 0.0, correct, total);
  std::fprintf(stderr, "confusion matrix (rows: true class, columns: predicted)\n%*s", int(width),
               "");
  for (const auto& c : classes) std::fprintf(stderr, "%*s", int(width), c.c_str());
  std::fprintf(stderr, "\n");
  for (std::size_t t = 0; t < m.size(); ++t) {
    std::fprintf(stderr, "%*s", int(width), classes[t].c_str());
    for (std::size_t p = 0; p < m.size(); ++p) std::fprintf(stderr, "%*d", int(width), m[t][p]);
    std::fprintf(stderr, "\n");
  }
}

int run(const Options& o) {
  auto model = cli::load_model(o.model, o.force_normalise);
  if (model.format_version < ss::model_file_float_version)
    std::cerr << "ss_classify: note: " << o.model << " is model format version "
              << model.format_version
              << " (no recorded lighting normalisation or dark-frame rule); upgrade it with\n"
                 "  /usr/bin/python3 tools/densenet_to_model.py --upgrade "
              << o.model << " -o NEW.ssm [--lighting-normalise] [--dark-threshold X]\n";
  const cli::EncoderCalibration cal =
      cli::encoder_calibration_for(model, o.model, o.calibration, o.scale_to_network);
  auto clf = ss::make_densenet_classifier(model, {.threads = o.threads}, ss::ChannelOrder::bgr,
                                          cal.empty_skin, cal.camera_px_per_cm);
  const auto& classes = model.class_names;

  FrameSource src(o.input);
  if (!o.model_note.empty()) std::cerr << o.model_note; // after the input's errors, if any
  std::vector<int> truth;
  if (o.truth) truth = truth_labels(src, o.input, classes);
  std::vector<std::vector<int>> confusion(classes.size(), std::vector<int>(classes.size(), 0));

  cli::Progress progress("ss_classify", src.count(), cli::Progress::wanted(o.quiet, src.count()));
  print_header(o, classes);
  cv::Mat frame;
  std::string source;
  std::size_t n = 0;
  for (; src.next(frame, source); ++n) {
    const bool dark = !clf.encoder().lighting_normalise() && clf.encoder().is_dark(frame);
    ss::Classification r;
    try {
      r = clf.classify(frame);
    } catch (const ss::InvalidArgument& e) {
      throw ss::Error(source + ": " + e.what());
    }
    print_frame(o, n, source, dark, r, classes);
    if (o.truth) ++confusion[static_cast<std::size_t>(truth[n])][static_cast<std::size_t>(r.index)];
    progress.update(n + 1);
  }
  std::cout.flush();
  progress.finish(n);
  if (!std::cout) throw ss::IoError("writing to stdout failed");
  if (n == 0) throw ss::IoError(o.input + ": no frames could be read");
  if (o.truth) print_confusion(confusion, classes);
  return 0;
}

} // namespace

int main(int argc, char** argv) {
  return cli::run("ss_classify", [&] { return run(parse(argc, argv)); });
}
