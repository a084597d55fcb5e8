// ss_studio: the skin seen and set up in a browser - live view, event log, recording, box
// labelling, calibration - served over HTTP by one program (cpp-httplib, Debian's
// libcpp-httplib-dev) with one plain HTML/JS/CSS page (examples/studio/web, installed under
// share/shadowsense/studio; no build step, nothing downloaded at run time).
//
//   ss_studio --input DIR|VIDEO|CAMERA [--calibration FILE] [--model FILE|none] [--out DIR]
//             [--bind ADDR] [--port N]
//
// Live view: a runner thread reads the input (common/frame_source.hpp; files paced to their
// frame rate and looped, pause/step for files), runs the library's Runtime (the same as
// ss_track: segmenter, tracker, touch state machines, classifier gated by the shadow, temporal
// gestures), draws the masks (common/runner.hpp annotate) into a JPEG and publishes it with the
// tracks (id, state, box, contact point, contact area, hover opacity and height), the gesture
// and its probabilities, per-stage milliseconds (read, segment, blobs+track+touch, classify,
// draw, encode; timed by the studio around the library's rule and backend, see StageClock) and
// the frame rate. The page long-polls GET /api/frame: the frame's JPEG bytes after a small JSON
// (its metadata, the server's read and publish times, the new event lines), one request per
// frame, no base64. Events are the JSON lines of the library's JsonLinesSink (the ss_track
// schema, docs/output.md). Without a calibration the frames are shown bare until one is made in
// the page.
// Calibration: the page records the current frame as an empty-skin or a touch frame (at most
// kMaxRecorded of each), labels the touch frames with two boxes, runs calibrate_from_frames
// with ss_calibrate's defaults (so the file equals ss_calibrate's on the same frames and boxes),
// shows the warnings by frame and a preview, and saves the file atomically as OUT/NAME (NAME one
// plain file name: letters, digits, '.', '_', '-'; no folder, no "..") with the frames and a
// labels CSV under OUT/NAME.frames/ (ss_calibrate --empty .../empty --touch .../touch --labels
// .../labels.csv reproduces it: recorded from a video or a camera, these are the only copy of
// the frames, written atomically); the live view then switches to it.
//
// Safety: binds 127.0.0.1 unless --bind; a bind to any other address requires a random token
// (printed at start) on every request (query "token", header X-Studio-Token, or the cookie the
// page gets with ?token=), else 401. On a
// loopback bind the Host header must name the loopback (a DNS-rebinding page is refused, 403).
// Requests that change state are POSTs with the header "X-Studio: 1" (a cross-site form cannot
// send it; 403 without). Bodies are limited to kMaxBody bytes (413), the URL by cpp-httplib.
// No request names a file: the page's files are read at start into memory, frames are named by
// number, and the one written name is checked as above.
// Threading: the runner thread owns the FrameSource and the Runtime; cpp-httplib's worker
// threads (at most kWorkers) serve requests; every piece of state they share is in Studio,
// guarded by Studio::m (one mutex). A calibration runs on copies outside the lock, one at a
// time (a second request while one runs gets 409), so the live view keeps going. A second tab
// sees the same Studio.
// Exit status: 0 after SIGINT/SIGTERM, 2 bad command line or input (message on stderr).
#include <shadowsense/output/json_lines_sink.hpp>
#include <shadowsense/runtime/densenet_runtime.hpp>
#include <shadowsense/sense/calibration.hpp>
#include <shadowsense/sense/calibration_file.hpp>

#include "common/cli.hpp"
#include "common/frame_source.hpp"
#include "common/json.hpp"
#include "common/runner.hpp"

#include <httplib.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <pthread.h>
#include <signal.h>

#include <atomic>
#include <charconv>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#ifndef SHADOWSENSE_STUDIO_INSTALLED_WEB
#define SHADOWSENSE_STUDIO_INSTALLED_WEB "../share/shadowsense/studio"
#endif

namespace fs = std::filesystem;
using namespace shadowsense;

namespace {

constexpr const char* kProgram = "ss_studio";
constexpr std::size_t kMaxRecorded = 240; // empty frames and touch frames, each
constexpr std::size_t kMaxEvents = 2000;  // event lines kept for the log
constexpr std::size_t kRecentFrames = 8;  // frames kept for recording the one the page shows
constexpr std::size_t kMaxBody = 4096;    // request bodies (the page sends none larger)
constexpr std::size_t kWorkers = 16;      // HTTP worker threads (keep-alive connections hold one)
constexpr int kLongPollMs = 2000;         // /api/live waits this long for a new frame
constexpr const char* kWebFiles[] = {"index.html", "app.js", "style.css"};

struct Options {
  std::string input, calibration, model, out, bind = "127.0.0.1", web;
  int port = 8080, max_side = 8192, threads = 1, jpeg_quality = 80;
  double fps = 0;
  std::vector<double> hover; // intercept, per_edge_px, per_opacity
  const char* argv0 = kProgram;
};

Options parse(int argc, char** argv) {
  Options o;
  o.argv0 = argv[0];
  cli::Parser p(kProgram, "The skin in a browser: live view with the detection drawn on it, the "
                          "event log, recording, box labelling and calibration.");
  p.usage("ss_studio --input DIR|VIDEO|CAMERA [--calibration FILE] [--model FILE|none] "
          "[--out DIR] [--bind ADDR] [--port N]");
  p.option("--input", "SPEC", "folder of images, video file, or camera index", o.input).required();
  p.option("--calibration", "FILE", "calibration to start with (else: make one in the page)",
           o.calibration);
  p.option("--model", "FILE|none",
           "gesture model (default: " + runner::default_model_text(argv[0]) +
               "); none: touch events only",
           o.model);
  p.option("--out", "DIR",
           "the one folder the page may write into (calibration files and their frames); "
           "without it nothing can be saved",
           o.out);
  p.option("--bind", "ADDR",
           "address to listen on; any but the loopback requires the token printed at start",
           o.bind);
  p.option("--port", "N", "port to listen on (0: any free port, printed at start)", o.port)
      .range(0, 65535);
  p.option("--web", "DIR", "the page's files (default: installed, else the source tree's)", o.web);
  p.option("--fps", "F", "frame rate of a folder (default 30) or override for a video", o.fps)
      .range(0.001, 1000.0);
  p.option("--threads", "N", "classifier worker threads", o.threads).range(1, 256);
  p.option("--jpeg-quality", "Q", "quality of the frames sent to the page", o.jpeg_quality)
      .range(10, 100);
  p.list("--hover-model", "A,B,C",
         "hover height in cm = A + B * edge width (px) + C * opacity (sense/hover_height.hpp); "
         "without it the page shows the shadow's opacity only",
         o.hover);
  p.option("--max-side", "N", "refuse frames larger than N px per side", o.max_side)
      .range(16, 65536);
  p.parse(argc, argv);
  if (!o.hover.empty() && o.hover.size() != 3)
    throw cli::UsageError("--hover-model: expected three numbers A,B,C, got " +
                          std::to_string(o.hover.size()));
  if (o.bind.empty()) throw cli::UsageError("--bind: expected an address, got ''");
  return o;
}

bool is_loopback(const std::string& addr) {
  return addr == "localhost" || addr == "::1" || addr.rfind("127.", 0) == 0;
}

std::string random_token() {
  std::random_device rd;
  std::string t;
  static const char* hex = "0123456789abcdef";
  for (int i = 0; i < 32; ++i) t += hex[rd() & 15u];
  return t;
}

bool same_text(const std::string& a, const std::string& b) { // constant time for equal sizes
  if (a.size() != b.size()) return false;
  unsigned char d = 0;
  for (std::size_t i = 0; i < a.size(); ++i) d |= static_cast<unsigned char>(a[i] ^ b[i]);
  return d == 0;
}

std::string base64(const std::vector<uchar>& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const unsigned v = (unsigned(in[i]) << 16) | (unsigned(in[i + 1]) << 8) | in[i + 2];
    out += {t[v >> 18], t[(v >> 12) & 63], t[(v >> 6) & 63], t[v & 63]};
  }
  if (i + 1 == in.size()) {
    const unsigned v = unsigned(in[i]) << 16;
    out += {t[v >> 18], t[(v >> 12) & 63], '=', '='};
  } else if (i + 2 == in.size()) {
    const unsigned v = (unsigned(in[i]) << 16) | (unsigned(in[i + 1]) << 8);
    out += {t[v >> 18], t[(v >> 12) & 63], t[(v >> 6) & 63], '='};
  }
  return out;
}

std::vector<uchar> encode(const cv::Mat& image, const char* ext, int quality) {
  std::vector<uchar> bytes;
  const std::vector<int> params = std::string(ext) == ".jpg"
                                      ? std::vector<int>{cv::IMWRITE_JPEG_QUALITY, quality}
                                      : std::vector<int>{};
  if (!cv::imencode(ext, image, bytes, params))
    throw IoError(std::string("cannot encode a frame as ") + ext);
  return bytes;
}

double epoch_ms() {
  return std::chrono::duration<double, std::milli>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Stage clocks of the live view, kept by the studio (the library has no clock in its hot path):
// the pixel rule and the classifier backend are the library's extension points
// (sense/pixel_rule.hpp, classify/backend.hpp), so wrapping the calibrated rule and DenseNet
// times the segmentation's per-pixel work and the network's inference without an edit of the
// library. The rest of Runtime::update (mask clean-up, blobs, tracker, touch machines, the
// classifier's input encoding, temporal gestures) is the update's time minus these two.
// Owned by the runner thread; the rule and backend below write it from inside update().
struct StageClock {
  using clock = std::chrono::steady_clock;
  clock::time_point rule_end{};
  double classify_ms = 0;
};

class TimedRule {
public:
  TimedRule(const SegmenterCalibration& cal, StageClock* clock) : rule_(cal), clock_(clock) {}
  bool uses_reference() const { return rule_.uses_reference(); }
  void classify(const PixelRuleInput& in, PixelRuleOutput& out) const {
    rule_.classify(in, out);
    clock_->rule_end = StageClock::clock::now();
  }

private:
  CalibratedRule rule_;
  StageClock* clock_;
};
static_assert(PixelRule<TimedRule>);

class TimedBackend {
public:
  TimedBackend(DenseNet net, StageClock* clock) : net_(std::move(net)), clock_(clock) {}
  std::span<const std::string> class_names() const { return net_.class_names(); }
  std::span<const float> logits(const Tensor& input) {
    const auto t0 = StageClock::clock::now();
    const std::span<const float> out = net_.logits(input);
    clock_->classify_ms +=
        std::chrono::duration<double, std::milli>(StageClock::clock::now() - t0).count();
    return out;
  }

private:
  DenseNet net_;
  StageClock* clock_;
};
static_assert(ClassifierBackend<TimedBackend>);

using StudioRuntime = BasicRuntime<TimedRule, TimedBackend>;

// One recorded frame of the calibration workflow.
struct Recorded {
  long long id = 0;
  cv::Mat image;           // never changed after recording (shared by cv::Mat's refcount)
  std::string source_name; // the input's name for it (folder path or frame_NNNNNN)
  bool labelled = false;   // boxes given (shadow box, contact box or "no contact")
  std::optional<cv::Rect> shadow, contact;
};

// Everything the runner thread and the request handlers share. Guarded by m.
struct Studio {
  std::mutex m;
  std::condition_variable changed; // a new frame, a control request, stop
  bool stop = false;
  // live view
  long long seq = 0;          // frames published
  std::string frame_json;     // the last frame's metadata (tracks, gesture, stage times)
  std::string frame_jpeg;     // and its picture, as JPEG bytes
  double published_epoch = 0; // when it was published (ms since the epoch)
  // The last frames as read, by their seq (never written after publishing): the page records
  // the one it shows, also when newer ones were published since.
  struct Raw {
    long long seq;
    cv::Mat image;
    std::string name;
  };
  std::deque<Raw> recent;
  bool file_input = true;
  bool paused = false;
  int steps = 0;            // frames to run while paused
  std::string runner_error; // the runner stopped on this error
  std::deque<std::string> events;
  long long events_total = 0; // event lines ever published (the last one's number)
  // calibration
  long long next_id = 1;
  std::vector<Recorded> empty, touch;
  bool calibrating = false;
  std::optional<CalibrationResult> result;
  std::string result_json;
  std::optional<SegmenterCalibration> switch_to; // the runner takes it before its next frame
  std::string calibration_name;                  // what the live view runs with
};

// ---------------------------------------------------------------- runner thread

struct Runner {
  const Options& o;
  Studio& s;
  fs::path model_path;

  StageClock stage_clock; // the runtime's rule and backend write it (runner thread only)

  // The library's Runtime with the studio's timed rule and backend (ss_track's Runtime
  // otherwise: the same rule, network, pipeline and configuration).
  std::optional<StudioRuntime> make_runtime(const SegmenterCalibration& cal) {
    SegmenterConfig sc;
    sc.calibration = cal;
    sc.max_image_side = o.max_side;
    if (o.hover.size() == 3) sc.hover_model = HoverHeightModel{o.hover[0], o.hover[1], o.hover[2]};
    std::optional<Classifier<TimedBackend>> classifier;
    if (!model_path.empty()) {
      const ModelFile model = ModelFile::load(model_path);
      classifier.emplace(TimedBackend(DenseNet(model, {.threads = o.threads}), &stage_clock),
                         Classifier<TimedBackend>::Config{model.preprocess, ChannelOrder::bgr});
    }
    return std::optional<StudioRuntime>(
        std::in_place,
        BasicTouchPipeline<TimedRule>{BasicSegmenter<TimedRule>(sc, TimedRule(cal, &stage_clock))},
        std::move(classifier), RuntimeConfig{});
  }

  static void track_json(cli::JsonWriter& j, const TouchTrack& t, const Segmentation& seg) {
    j.begin_object(cli::JsonWriter::compact);
    j.field("id", t.id).field("state", std::string(to_string(t.state)));
    j.field("matched", t.matched);
    j.key("box").begin_array().value(t.shadow_box.x).value(t.shadow_box.y);
    j.value(t.shadow_box.width).value(t.shadow_box.height).end_array();
    j.key("contact");
    if (t.contact)
      j.begin_array().value(t.contact->x).value(t.contact->y).end_array();
    else
      j.value(nullptr);
    j.field("contact_area", t.contact_area);
    // The hover cues of its shadow blob (the blob whose box is the track's, when seen).
    const Blob* blob = nullptr;
    for (const Blob& b : seg.shadows)
      if (t.matched && b.box == t.shadow_box) blob = &b;
    j.key("opacity");
    if (blob && !blob->touching)
      j.value(blob->opacity);
    else
      j.value(nullptr);
    j.key("hover_cm");
    if (blob && blob->hover_height_cm)
      j.value(*blob->hover_height_cm);
    else
      j.value(nullptr);
    j.end_object();
  }

  void run() {
    try {
      loop();
    } catch (const std::exception& e) {
      std::cerr << kProgram << ": error: the live view stopped: " << e.what() << "\n";
      std::lock_guard lock(s.m);
      s.runner_error = e.what();
      s.changed.notify_all();
    }
  }

  void loop() {
    std::optional<StudioRuntime> sense;
    if (!o.calibration.empty()) sense = make_runtime(load_calibration(o.calibration));
    std::optional<frames::FrameSource> src = frames::FrameSource::open(o.input, o.max_side);
    const bool camera = src->is_camera();
    const double fps = o.fps > 0 ? o.fps : (src->fps() ? *src->fps() : 30.0);
    using clock = std::chrono::steady_clock;
    const auto start = clock::now();
    auto pace_origin = start;
    double pace_t0 = 0, t = 0, t_offset = 0;
    long long i = 0;
    std::deque<clock::time_point> done; // when the frames of the last 2 s were published
    std::stringstream event_text;
    std::optional<JsonLinesSink> sink;
    sink.emplace(event_text, JsonLinesSink::Config{.source = o.input, .flush = false});
    cv::Mat frame;
    std::string name;
    for (;;) {
      bool stepping = false;
      {
        std::unique_lock lock(s.m);
        s.changed.wait(
            lock, [&] { return s.stop || !s.paused || s.steps > 0 || s.switch_to.has_value(); });
        if (s.stop) return;
        if (s.switch_to) {
          const SegmenterCalibration cal = std::move(*s.switch_to);
          s.switch_to.reset();
          lock.unlock();
          sense.reset();
          sense = make_runtime(cal);
          continue;
        }
        if (s.paused) {
          --s.steps;
          stepping = true;
        }
      }
      const auto t_read = clock::now();
      const double read_epoch = epoch_ms();
      if (!src->next(frame, name)) {
        if (i == 0) throw IoError("'" + o.input + "' gave no frame");
        if (camera) throw IoError("camera " + o.input + " gave no more frames");
        // The end of a file: start it again; the timestamps go on increasing.
        t_offset = t + 1000.0 / fps;
        src.reset();
        src = frames::FrameSource::open(o.input, o.max_side);
        i = 0;
        pace_origin = clock::now();
        pace_t0 = t_offset;
        if (!src->next(frame, name)) throw IoError("'" + o.input + "' gave no frame");
      }
      const auto t_update = clock::now();
      t = camera ? std::chrono::duration<double, std::milli>(t_read - start).count()
                 : t_offset + runner::frame_time_ms(i, fps);
      ++i;
      std::string source_name = name;
      cv::Mat shown;
      const RuntimeFrame* r = nullptr;
      stage_clock.rule_end = t_update;
      stage_clock.classify_ms = 0;
      if (sense) {
        r = &sense->update(frame, t);
        sink->write(sense->output());
      }
      const auto t_draw = clock::now();
      shown = r ? runner::annotate(frame, sense->segmentation(), *r) : frame;
      const auto t_encode = clock::now();
      const std::vector<uchar> jpeg = encode(shown, ".jpg", o.jpeg_quality);
      const auto t_done = clock::now();
      const auto ms = [](clock::time_point a, clock::time_point b) {
        return std::chrono::duration<double, std::milli>(b - a).count();
      };
      // Frames processed per second: those of the last 2 s over their span.
      done.push_back(t_done);
      while (ms(done.front(), t_done) > 2000) done.pop_front();
      const double rate =
          done.size() > 1 ? 1000.0 * static_cast<double>(done.size() - 1) / ms(done.front(), t_done)
                          : 0;

      cli::JsonWriter j;
      j.begin_object(cli::JsonWriter::compact);
      j.field("frame", r ? r->frame_index : static_cast<std::int64_t>(i));
      j.field("name", source_name).field("t_ms", t).field("read_epoch_ms", read_epoch);
      j.field("width", frame.cols).field("height", frame.rows);
      j.field("calibrated", sense.has_value()).field("classifier", !model_path.empty());
      j.field("file", !camera).field("input_fps", fps).field("processed_fps", rate);
      // segment: up to the pixel rule's end (camera check, blur, reference, rule); track: the
      // rest of the update but the network's inference (mask clean-up, blobs, tracker, touch
      // machines, the classifier's input, temporal gestures, the event line).
      const double segment = sense ? ms(t_update, stage_clock.rule_end) : 0;
      j.key("stage_ms").begin_object();
      j.field("read", ms(t_read, t_update)).field("segment", segment);
      j.field("track", std::max(0.0, ms(t_update, t_draw) - segment - stage_clock.classify_ms));
      j.field("classify", stage_clock.classify_ms).field("runtime", ms(t_update, t_draw));
      j.field("draw", ms(t_draw, t_encode)).field("encode", ms(t_encode, t_done)).end_object();
      j.key("tracks").begin_array();
      if (r)
        for (const TouchTrack& tr : r->touch.tracks) track_json(j, tr, sense->segmentation());
      j.end_array();
      j.key("gesture").begin_object();
      if (r && !r->gesture.label.empty()) {
        j.field("label", r->gesture.label).field("confidence", r->gesture.confidence);
        j.key("classes").begin_array();
        for (const std::string& c : r->gesture.class_names) j.value(c);
        j.end_array().key("probabilities").begin_array();
        for (float p : r->gesture.probabilities) j.value(p);
        j.end_array();
      }
      j.end_object();
      j.key("touch_gestures").begin_array();
      if (r)
        for (const GestureEvent& g : r->touch_gestures) j.value(std::string(to_string(g.gesture)));
      j.end_array();
      j.end_object();

      std::vector<std::string> lines;
      for (std::string line; std::getline(event_text, line);)
        if (!line.empty()) lines.push_back(line);
      event_text.str({});
      event_text.clear();
      {
        std::lock_guard lock(s.m);
        s.frame_json = j.str();
        s.frame_jpeg.assign(jpeg.begin(), jpeg.end());
        s.published_epoch = epoch_ms();
        s.recent.push_back({s.seq + 1, frame.clone(), source_name});
        if (s.recent.size() > kRecentFrames) s.recent.pop_front();
        s.file_input = !camera;
        ++s.seq;
        for (std::string& line : lines) {
          s.events.push_back(std::move(line));
          ++s.events_total;
          if (s.events.size() > kMaxEvents) s.events.pop_front();
        }
        s.changed.notify_all();
      }
      if (camera || stepping) continue;
      // Files play at their frame rate (a slower runtime plays them slower, never skipping).
      const auto due = pace_origin + std::chrono::duration_cast<clock::duration>(
                                         std::chrono::duration<double, std::milli>(t - pace_t0));
      std::unique_lock lock(s.m);
      s.changed.wait_until(lock, due, [&] { return s.stop || s.paused; });
      if (clock::now() > due + std::chrono::milliseconds(250) || s.paused) {
        pace_origin = clock::now(); // behind or paused: the clock starts again from this frame
        pace_t0 = t;
      }
    }
  }
};

// ---------------------------------------------------------------- calibration

// Touch and empty frames are named by position, as ss_calibrate names the files of the folders
// the save writes: the warnings then read the same.
std::string frame_file(std::size_t k) {
  char b[32];
  std::snprintf(b, sizeof b, "%04zu.png", k);
  return b;
}

cv::Mat preview(const SegmenterCalibration& cal, const std::vector<cv::Mat>& touch,
                const std::vector<cv::Mat>& empty) {
  std::vector<cv::Mat> sample;
  const std::size_t n_touch = std::min<std::size_t>(6, touch.size());
  for (std::size_t k = 0; k < n_touch; ++k) sample.push_back(touch[k * touch.size() / n_touch]);
  for (std::size_t k = 0; k < empty.size() && sample.size() < 8; ++k) sample.push_back(empty[k]);
  Segmenter seg({.calibration = cal});
  const cv::Size t = sample[0].size();
  const int cols = std::min<int>(4, static_cast<int>(sample.size()));
  const int rows = (static_cast<int>(sample.size()) + cols - 1) / cols;
  cv::Mat out(rows * t.height, cols * t.width, CV_8UC3, cv::Scalar::all(0));
  for (std::size_t i = 0; i < sample.size(); ++i) {
    if (sample[i].size() != t) continue; // frames of another size are left out
    frames::overlay(sample[i], seg.segment(sample[i]))
        .copyTo(out(cv::Rect(static_cast<int>(i % cols) * t.width,
                             static_cast<int>(i / cols) * t.height, t.width, t.height)));
  }
  return out;
}

std::string recorded_json(const Studio& s) {
  cli::JsonWriter j;
  j.begin_object(cli::JsonWriter::compact);
  const auto list = [&](const char* key, const std::vector<Recorded>& v) {
    j.key(key).begin_array();
    for (const Recorded& r : v) {
      j.begin_object().field("id", r.id).field("source", r.source_name);
      j.field("width", r.image.cols).field("height", r.image.rows);
      j.field("labelled", r.labelled);
      const auto box = [&](const char* k, const std::optional<cv::Rect>& b) {
        j.key(k);
        if (!b) return void(j.value(nullptr));
        j.begin_array().value(b->x).value(b->y).value(b->width).value(b->height).end_array();
      };
      box("shadow", r.shadow);
      box("contact", r.contact);
      j.end_object();
    }
    j.end_array();
  };
  list("empty", s.empty);
  list("touch", s.touch);
  j.field("max_recorded", kMaxRecorded).field("calibrating", s.calibrating);
  j.field("calibration", s.calibration_name);
  j.key("result");
  if (s.result_json.empty())
    j.value(nullptr);
  else
    j.value(std::string("see /api/calib/result"));
  j.end_object();
  return j.str();
}

// "x,y,w,h" (non-negative integers, positive size) or "none".
std::optional<cv::Rect> parse_box(const std::string& text, const char* what) {
  if (text == "none") return std::nullopt;
  int v[4];
  const char* p = text.data();
  const char* end = text.data() + text.size();
  for (int k = 0; k < 4; ++k) {
    const auto r = std::from_chars(p, end, v[k]);
    if (r.ec != std::errc() || v[k] < 0 || v[k] > 65536)
      throw InvalidArgument(std::string(what) + ": expected x,y,w,h or none, got '" + text + "'");
    p = r.ptr;
    if (k < 3) {
      if (p == end || *p != ',')
        throw InvalidArgument(std::string(what) + ": expected x,y,w,h or none, got '" + text + "'");
      ++p;
    }
  }
  if (p != end || v[2] == 0 || v[3] == 0)
    throw InvalidArgument(std::string(what) + ": expected x,y,w,h with w, h > 0, got '" + text +
                          "'");
  return cv::Rect(v[0], v[1], v[2], v[3]);
}

// The one file name the page may give: a plain name in the output folder.
fs::path checked_out_path(const std::string& out, const std::string& name) {
  const bool plain = !name.empty() && name.size() <= 64 && name[0] != '.' &&
                     std::all_of(name.begin(), name.end(),
                                 [](char c) {
                                   return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                                          (c >= '0' && c <= '9') || c == '.' || c == '_' ||
                                          c == '-';
                                 }) &&
                     name.find("..") == std::string::npos;
  if (!plain)
    throw InvalidArgument("name '" + name +
                          "' refused: expected a plain file name of at most 64 letters, digits, "
                          "'.', '_', '-' (no folder, not starting with '.')");
  const fs::path p = fs::path(out) / name;
  if (p.parent_path() != fs::path(out)) throw InvalidArgument("name '" + name + "' refused");
  return p;
}

std::string error_json(const std::string& message) {
  cli::JsonWriter j;
  j.begin_object(cli::JsonWriter::compact).field("error", message).end_object();
  return j.str();
}

// ---------------------------------------------------------------- server

struct Server {
  const Options& o;
  Studio& s;
  std::map<std::string, std::string> web; // file name -> bytes, read at start
  std::string token;                      // empty: none required (loopback bind)
  int port = 0;
  httplib::Server http;

  static void reply(httplib::Response& res, int status, const std::string& json) {
    res.status = status;
    res.set_content(json, "application/json");
  }

  void load_web() {
    fs::path dir = o.web;
    if (dir.empty()) {
      const fs::path installed = cli::program_folder(o.argv0) / SHADOWSENSE_STUDIO_INSTALLED_WEB;
      std::error_code ec;
      dir = fs::is_regular_file(installed / "index.html", ec)
                ? installed
                : fs::path(SHADOWSENSE_STUDIO_SOURCE_WEB);
    }
    for (const char* f : kWebFiles) {
      std::ifstream in(dir / f, std::ios::binary);
      std::ostringstream text;
      text << in.rdbuf();
      if (!in || text.str().empty())
        throw IoError("cannot read the page's file '" + (dir / f).string() +
                      "' (give the folder with --web DIR)");
      web[f] = text.str();
    }
  }

  // The value of cookie `name` in the request, or "".
  static std::string cookie(const httplib::Request& req, const std::string& name) {
    const std::string all = "; " + req.get_header_value("Cookie");
    const std::size_t at = all.find("; " + name + "=");
    if (at == std::string::npos) return {};
    const std::size_t start = at + name.size() + 3;
    return all.substr(start, all.find(';', start) - start);
  }

  // Refuses a request before routing: token, Host header, POST header.
  httplib::Server::HandlerResponse check(const httplib::Request& req, httplib::Response& res) {
    using H = httplib::Server::HandlerResponse;
    if (!token.empty()) {
      const std::string given = req.has_header("X-Studio-Token")
                                    ? req.get_header_value("X-Studio-Token")
                                : req.has_param("token") ? req.get_param_value("token")
                                                         : cookie(req, "ss_studio_token");
      if (!same_text(given, token)) {
        reply(res, 401, error_json("a token is required (printed by ss_studio at start)"));
        return H::Handled;
      }
    } else {
      std::string host = req.get_header_value("Host");
      const std::size_t colon = host.rfind(':');
      if (colon != std::string::npos && host.find(']', colon) == std::string::npos)
        host = host.substr(0, colon);
      if (host != "127.0.0.1" && host != "localhost" && host != "[::1]" && !is_loopback(host)) {
        reply(res, 403, error_json("Host '" + host + "' is not this computer's loopback"));
        return H::Handled;
      }
    }
    // The page's own files (app.js, style.css) are fetched without the query: the cookie set
    // with the page carries the token (HttpOnly, sent to this origin only).
    if (!token.empty() && req.has_param("token"))
      res.set_header("Set-Cookie",
                     "ss_studio_token=" + token + "; Path=/; HttpOnly; SameSite=Strict");
    if (req.method == "POST" && req.get_header_value("X-Studio") != "1") {
      reply(res, 403, error_json("requests that change state need the header X-Studio: 1"));
      return H::Handled;
    }
    if (req.method != "GET" && req.method != "POST") {
      reply(res, 405, error_json("only GET and POST"));
      return H::Handled;
    }
    return H::Unhandled;
  }

  // Runs a handler, turning a shadowsense error into 400 with its message.
  template <class F>
  auto guarded(F f) {
    return [f](const httplib::Request& req, httplib::Response& res) {
      try {
        f(req, res);
      } catch (const InvalidArgument& e) {
        reply(res, 400, error_json(e.what()));
      } catch (const std::exception& e) {
        reply(res, 500, error_json(e.what()));
      }
    };
  }

  static long long int_param(const httplib::Request& req, const char* name) {
    const std::string v = req.get_param_value(name);
    long long x = 0;
    const auto r = std::from_chars(v.data(), v.data() + v.size(), x);
    if (v.empty() || r.ec != std::errc() || r.ptr != v.data() + v.size())
      throw InvalidArgument(std::string(name) + ": expected an integer, got '" + v + "'");
    return x;
  }

  // The /api/live reply for the request's `after` and `events_after`, waiting up to kLongPollMs
  // for a frame after `after`; with `jpeg`, that frame's JPEG goes there (else nothing).
  std::string live(const httplib::Request& req, std::string* jpeg) {
    const long long after = req.has_param("after") ? int_param(req, "after") : 0;
    const long long ev = req.has_param("events_after") ? int_param(req, "events_after") : 0;
    std::unique_lock lock(s.m);
    s.changed.wait_for(lock, std::chrono::milliseconds(kLongPollMs),
                       [&] { return s.stop || s.seq > after || !s.runner_error.empty(); });
    const bool fresh = s.seq > after && !s.frame_json.empty();
    std::string out = "{\"seq\":" + std::to_string(s.seq) +
                      ",\"paused\":" + (s.paused ? "true" : "false") +
                      ",\"calibration\":" + cli_string(s.calibration_name) +
                      ",\"error\":" + cli_string(s.runner_error) +
                      ",\"frame\":" + (fresh ? s.frame_json : "null");
    out += ",\"published_epoch_ms\":" + std::to_string(s.published_epoch);
    out += ",\"events_total\":" + std::to_string(s.events_total) + ",\"events\":[";
    const long long first = s.events_total - static_cast<long long>(s.events.size());
    bool comma = false;
    for (long long k = std::max(ev, first); k < s.events_total; ++k) {
      out += (comma ? "," : "") + s.events[static_cast<std::size_t>(k - first)];
      comma = true;
    }
    out += "]}";
    if (jpeg && fresh) *jpeg = s.frame_jpeg;
    return out;
  }

  void routes() {
    for (const char* f : kWebFiles) {
      const std::string name = f;
      const std::string type = name.ends_with(".html") ? "text/html; charset=utf-8"
                               : name.ends_with(".js") ? "text/javascript; charset=utf-8"
                                                       : "text/css; charset=utf-8";
      http.Get(name == "index.html" ? "/" : "/" + name,
               [this, name, type](const httplib::Request&, httplib::Response& res) {
                 res.set_header("Cache-Control", "no-store");
                 res.set_header("X-Content-Type-Options", "nosniff");
                 res.set_content(web.at(name), type.c_str());
               });
    }
    http.Get("/api/info", [this](const httplib::Request&, httplib::Response& res) {
      cli::JsonWriter j;
      j.begin_object(cli::JsonWriter::compact);
      j.field("program", std::string(kProgram)).field("version", std::string(version_string));
      j.field("input", o.input).field("can_save", !o.out.empty());
      j.field("token_required", !token.empty()).field("max_recorded", kMaxRecorded);
      j.end_object();
      reply(res, 200, j.str());
    });
    // The next frame after `after` (waits up to kLongPollMs) and the event lines after
    // `events_after`: /api/live as JSON (the frame's metadata, no picture), /api/frame as
    // binary - a 4-byte big-endian length, that JSON, then the frame's JPEG (absent when no
    // newer frame came). The page uses /api/frame: no base64, one request per frame.
    http.Get("/api/live", guarded([this](const httplib::Request& req, httplib::Response& res) {
               reply(res, 200, live(req, nullptr));
             }));
    http.Get("/api/frame", guarded([this](const httplib::Request& req, httplib::Response& res) {
               std::string jpeg;
               const std::string json = live(req, &jpeg);
               std::string body(4, '\0');
               for (int k = 0; k < 4; ++k)
                 body[static_cast<std::size_t>(k)] =
                     static_cast<char>((json.size() >> (24 - 8 * k)) & 255u);
               body += json;
               body += jpeg;
               res.set_header("Cache-Control", "no-store");
               res.set_content(std::move(body), "application/octet-stream");
             }));
    http.Post("/api/control", guarded([this](const httplib::Request& req, httplib::Response& res) {
                const std::string a = req.get_param_value("action");
                std::lock_guard lock(s.m);
                if (!s.file_input && a != "play")
                  throw InvalidArgument("a camera cannot be paused or stepped");
                if (a == "pause")
                  s.paused = true;
                else if (a == "play")
                  s.paused = false, s.steps = 0;
                else if (a == "step")
                  s.paused = true, s.steps = std::min(s.steps + 1, 100);
                else
                  throw InvalidArgument("action: expected pause, play or step, got '" + a + "'");
                s.changed.notify_all();
                reply(res, 200, std::string("{\"paused\":") + (s.paused ? "true" : "false") + "}");
              }));
    http.Post("/api/record", guarded([this](const httplib::Request& req, httplib::Response& res) {
                const std::string kind = req.get_param_value("kind");
                if (kind != "empty" && kind != "touch")
                  throw InvalidArgument("kind: expected empty or touch, got '" + kind + "'");
                std::lock_guard lock(s.m);
                if (s.recent.empty()) throw InvalidArgument("no frame yet");
                const Studio::Raw* raw = &s.recent.back();
                if (req.has_param("seq")) {
                  const long long seq = int_param(req, "seq");
                  raw = nullptr;
                  for (const Studio::Raw& f : s.recent)
                    if (f.seq == seq) raw = &f;
                  if (!raw) {
                    reply(res, 409,
                          error_json("frame " + std::to_string(seq) +
                                     " is no longer kept; record again"));
                    return;
                  }
                }
                std::vector<Recorded>& v = kind == "empty" ? s.empty : s.touch;
                if (v.size() >= kMaxRecorded) {
                  reply(res, 409,
                        error_json("at most " + std::to_string(kMaxRecorded) + " " + kind +
                                   " frames; delete some first"));
                  return;
                }
                Recorded r;
                r.id = s.next_id++;
                r.image = raw->image; // the runner never writes a published frame
                r.source_name = raw->name;
                v.push_back(std::move(r));
                reply(res, 200, recorded_json(s));
              }));
    http.Get("/api/calib", [this](const httplib::Request&, httplib::Response& res) {
      std::lock_guard lock(s.m);
      reply(res, 200, recorded_json(s));
    });
    http.Get("/api/calib/result", [this](const httplib::Request&, httplib::Response& res) {
      std::lock_guard lock(s.m);
      reply(res, 200, s.result_json.empty() ? "null" : s.result_json);
    });
    http.Get("/api/calib/image",
             guarded([this](const httplib::Request& req, httplib::Response& res) {
               const long long id = int_param(req, "id");
               cv::Mat image;
               {
                 std::lock_guard lock(s.m);
                 for (const auto* v : {&s.empty, &s.touch})
                   for (const Recorded& r : *v)
                     if (r.id == id) image = r.image;
               }
               if (image.empty()) {
                 reply(res, 404, error_json("no recorded frame " + std::to_string(id)));
                 return;
               }
               const std::vector<uchar> png = encode(image, ".png", 0);
               res.set_content(std::string(png.begin(), png.end()), "image/png");
             }));
    http.Post("/api/calib/label",
              guarded([this](const httplib::Request& req, httplib::Response& res) {
                const long long id = int_param(req, "id");
                const bool labelled = req.get_param_value("labelled") != "0";
                const std::optional<cv::Rect> shadow =
                    labelled ? parse_box(req.get_param_value("shadow"), "shadow") : std::nullopt;
                const std::optional<cv::Rect> contact =
                    labelled ? parse_box(req.get_param_value("contact"), "contact") : std::nullopt;
                if (labelled && contact && !shadow)
                  throw InvalidArgument("a contact box needs a shadow box");
                std::lock_guard lock(s.m);
                for (Recorded& r : s.touch)
                  if (r.id == id) {
                    const cv::Rect whole(0, 0, r.image.cols, r.image.rows);
                    for (const auto& b : {shadow, contact})
                      if (b && (*b & whole) != *b)
                        throw InvalidArgument("box outside the " + std::to_string(whole.width) +
                                              "x" + std::to_string(whole.height) + " frame");
                    r.labelled = labelled;
                    r.shadow = shadow;
                    r.contact = contact;
                    reply(res, 200, recorded_json(s));
                    return;
                  }
                reply(res, 404, error_json("no touch frame " + std::to_string(id)));
              }));
    http.Post("/api/calib/delete",
              guarded([this](const httplib::Request& req, httplib::Response& res) {
                const long long id = int_param(req, "id");
                std::lock_guard lock(s.m);
                for (auto* v : {&s.empty, &s.touch})
                  std::erase_if(*v, [&](const Recorded& r) { return r.id == id; });
                reply(res, 200, recorded_json(s));
              }));
    http.Post("/api/calib/run",
              guarded([this](const httplib::Request&, httplib::Response& res) { calibrate(res); }));
    http.Post("/api/calib/save",
              guarded([this](const httplib::Request& req, httplib::Response& res) {
                save(req.get_param_value("name"), res);
              }));
  }

  static std::string cli_string(const std::string& v) {
    std::string out;
    detail::append_json_string(out, v);
    return out;
  }

  void calibrate(httplib::Response& res) {
    std::vector<cv::Mat> empty;
    std::vector<BoxLabelledFrame> touch;
    {
      std::lock_guard lock(s.m);
      if (s.calibrating) {
        reply(res, 409, error_json("a calibration is running already"));
        return;
      }
      if (s.empty.empty())
        throw InvalidArgument("no empty-skin frame recorded; record the untouched skin first");
      for (const Recorded& r : s.empty) empty.push_back(r.image);
      for (std::size_t k = 0; k < s.touch.size(); ++k) {
        const Recorded& r = s.touch[k];
        BoxLabelledFrame b;
        b.image = r.image;
        b.labelled = r.labelled;
        b.shadow_box = r.shadow;
        b.contact_box = r.contact;
        b.name = frame_file(k);
        touch.push_back(std::move(b));
      }
      s.calibrating = true;
    }
    std::string json;
    std::optional<CalibrationResult> result;
    try {
      // ss_calibrate's options: its defaults, with the same image size limit.
      CalibrationOptions co;
      co.light_group_ratio = 1.25f;
      co.base.max_image_side = o.max_side;
      result = calibrate_from_frames(empty, touch, co);
      std::vector<cv::Mat> touch_images;
      for (const BoxLabelledFrame& b : touch) touch_images.push_back(b.image);
      const std::vector<uchar> jpg =
          encode(preview(result->calibration, touch_images, empty), ".jpg", 85);
      cli::JsonWriter j;
      j.begin_object(cli::JsonWriter::compact);
      j.field("empty_frames", empty.size()).field("touch_frames", touch.size());
      // Warnings by frame: the touch frame a warning names ('NNNN.png'), else "all".
      j.key("warnings").begin_array();
      for (const CalibrationWarning& w : result->warnings) {
        std::string frame = "all";
        for (std::size_t k = 0; k < touch.size(); ++k)
          if (w.message.find("'" + touch[k].name + "'") != std::string::npos) frame = touch[k].name;
        j.begin_object().field("frame", frame).field("issue", std::string(to_string(w.issue)));
        j.field("message", w.message).end_object();
      }
      j.end_array();
      j.key("groups").begin_array();
      for (const LightGroupReport& g : result->groups) {
        j.begin_object().field("luminance", g.luminance).field("empty_frames", g.empty_frames);
        j.field("touch_frames", g.touch_frames).field("noise_darkness", g.noise_darkness);
        j.field("shadow_darkness", g.thresholds.shadow_darkness);
        j.field("contact_darkness", g.thresholds.contact_darkness);
        j.field("contact_warmth", g.thresholds.contact_warmth).field("fitted", g.fitted);
        j.end_object();
      }
      j.end_array();
      j.field("preview", "data:image/jpeg;base64," + base64(jpg));
      j.end_object();
      json = j.str();
    } catch (...) {
      std::lock_guard lock(s.m);
      s.calibrating = false;
      throw;
    }
    std::lock_guard lock(s.m);
    s.calibrating = false;
    s.result = std::move(result);
    s.result_json = json;
    reply(res, 200, json);
  }

  void save(const std::string& name, httplib::Response& res) {
    if (o.out.empty())
      throw InvalidArgument("ss_studio was started without --out DIR; nothing can be saved");
    const fs::path path = checked_out_path(o.out, name);
    std::optional<CalibrationResult> result;
    std::vector<Recorded> empty, touch;
    {
      std::lock_guard lock(s.m);
      if (!s.result) throw InvalidArgument("no calibration to save; run the calibration first");
      result = s.result;
      empty = s.empty;
      touch = s.touch;
    }
    fs::create_directories(o.out);
    // The frames and boxes it came from, as ss_calibrate reads them.
    const fs::path frames_dir = fs::path(o.out) / (name + ".frames");
    fs::create_directories(frames_dir / "empty");
    fs::create_directories(frames_dir / "touch");
    for (std::size_t k = 0; k < empty.size(); ++k)
      frames::write_png_atomically(frames_dir / "empty" / frame_file(k), empty[k].image);
    std::string labels =
        "file,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h\n";
    for (std::size_t k = 0; k < touch.size(); ++k) {
      frames::write_png_atomically(frames_dir / "touch" / frame_file(k), touch[k].image);
      if (!touch[k].labelled) continue;
      const auto box = [](const std::optional<cv::Rect>& b) {
        return b ? std::to_string(b->x) + "," + std::to_string(b->y) + "," +
                       std::to_string(b->width) + "," + std::to_string(b->height)
                 : std::string(",,,");
      };
      labels += frame_file(k) + "," + box(touch[k].shadow) + "," + box(touch[k].contact) + "\n";
    }
    write_file_atomically(frames_dir / "labels.csv", labels);
    save_calibration(result->calibration, path.string());
    {
      std::lock_guard lock(s.m);
      s.switch_to = result->calibration;
      s.calibration_name = name;
      s.changed.notify_all();
    }
    std::cerr << kProgram << ": saved " << path.string() << "; the live view uses it now\n";
    cli::JsonWriter j;
    j.begin_object(cli::JsonWriter::compact).field("saved", path.string());
    j.field("frames", frames_dir.string()).end_object();
    reply(res, 200, j.str());
  }
};

int run(const Options& o) {
  frames::limit_decoder(o.max_side);
  // The signals go to one thread that stops the server (the others block them).
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  Studio studio;
  Server server{o, studio, {}, {}, 0, {}};
  server.load_web();
  if (!o.calibration.empty()) {
    (void)load_calibration(o.calibration); // a bad file is a start-up error, not a runner one
    studio.calibration_name = fs::path(o.calibration).filename().string();
  }
  Runner runner{o, studio, {}, {}};
  if (o.model != "none")
    runner.model_path = o.model.empty() ? runner::find_default_model(o.argv0) : fs::path(o.model);
  if (!runner.model_path.empty()) (void)ModelFile::load(runner.model_path);
  (void)frames::FrameSource::open(o.input, o.max_side); // a bad input is a start-up error
  if (!o.out.empty()) {
    std::error_code ec;
    if (fs::exists(o.out, ec) && !fs::is_directory(o.out, ec))
      throw cli::UsageError("--out: '" + o.out + "' exists and is not a folder");
  }
  if (!is_loopback(o.bind)) server.token = random_token();

  httplib::Server& http = server.http;
  http.new_task_queue = [] { return new httplib::ThreadPool(kWorkers); };
  http.set_payload_max_length(kMaxBody);
  // A frame is a small header write then the body: with Nagle's algorithm the body waits for
  // the browser's delayed ACK (tens of ms per frame).
  http.set_tcp_nodelay(true);
  http.set_keep_alive_timeout(3);
  http.set_read_timeout(5);
  http.set_write_timeout(5);
  http.set_pre_routing_handler([&server](const httplib::Request& req, httplib::Response& res) {
    return server.check(req, res);
  });
  server.routes();
  const int port = o.port == 0 ? http.bind_to_any_port(o.bind) : o.port;
  if (port <= 0 || (o.port != 0 && !http.bind_to_port(o.bind, o.port)))
    throw IoError("cannot listen on " + o.bind + ":" + std::to_string(o.port) +
                  " (address not on this computer, or the port is taken)");
  const std::string host = o.bind.find(':') != std::string::npos ? "[" + o.bind + "]" : o.bind;
  std::cout << kProgram << ": serving " << o.input << " at http://" << host << ":" << port << "/"
            << (server.token.empty() ? "" : "?token=" + server.token) << "\n";
  if (!server.token.empty())
    std::cout << kProgram << ": token " << server.token
              << " (required on every request: bound to a non-loopback address)\n";
  std::cout << std::flush;

  std::thread live([&runner] { runner.run(); });
  std::thread stopper([&] {
    int sig = 0;
    sigwait(&signals, &sig);
    {
      std::lock_guard lock(studio.m);
      studio.stop = true;
      studio.changed.notify_all();
    }
    http.stop();
  });
  const bool ok = http.listen_after_bind();
  {
    std::lock_guard lock(studio.m);
    studio.stop = true;
    studio.changed.notify_all();
  }
  live.join();
  if (!ok) {
    pthread_kill(stopper.native_handle(), SIGTERM);
    stopper.join();
    throw IoError("the server stopped listening");
  }
  stopper.join();
  return 0;
}

} // namespace

int main(int argc, char** argv) {
  return cli::run(kProgram, [&] { return run(parse(argc, argv)); });
}
