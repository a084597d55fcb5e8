// ss_track: the runner - touch events and the hand-shape gesture from a folder of images, a
// video file or a camera.
//
// Runs the library's Runtime (runtime/runtime.hpp: segmenter + multi-touch tracker + one touch
// state machine per track + the classifier, gated by the shadow) with a calibration file
// (ss_calibrate) and a model file (the installed default unless --model is given; --model none
// for touch events only), flushes pending events at the end of the stream, and writes every
// event through the library's sinks: CSV or JSON lines on stdout in the project's one event
// schema (docs/output.md), and TUIO 1.1 over UDP with the gesture as an OSC message in the same
// bundle (--tuio). The temporal touch gestures (tap, double tap, pat, stroke, rub, hold, hit;
// hug, punch, two hands; docs/temporal_gestures.md) are rows of kind `gesture` in the same
// stream and /shadowsense/touch_gesture messages after the TUIO bundles (--no-temporal leaves
// them out). Frames are counted from 1.
// Timestamps: folders use --fps (frame i, from 0, at i * 1000 / fps ms) or --timestamps CSV
// (file,timestamp_ms); videos use their declared frame rate (or --fps); cameras the clock.
// --realtime paces a folder or video to its timestamps (the default when sending TUIO from a
// file, so clients see the recording's speed). Progress on stderr once a second.
// Exit status: 0 done, 2 bad command line or input (message on stderr).
#include <shadowsense/output/csv_sink.hpp>
#include <shadowsense/output/json_lines_sink.hpp>
#include <shadowsense/output/tuio_sink.hpp>
#include <shadowsense/runtime/densenet_runtime.hpp>
#include <shadowsense/sense/calibration_file.hpp>

#include <shadowsense/io/dataset.hpp>

#include "common/cli.hpp"
#include "common/frame_source.hpp"
#include "common/model_calibration.hpp"
#include "common/runner.hpp"

#include <opencv2/imgproc.hpp>
#ifdef SHADOWSENSE_HAVE_HIGHGUI
#include <opencv2/highgui.hpp>
#endif

#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace fs = std::filesystem;
using namespace shadowsense;

namespace {

constexpr const char* kProgram = "ss_track";

struct Options {
  std::string input, calibration, model, timestamps, format = "csv", source;
  std::string tuio_host; // empty: no TUIO output
  std::uint16_t tuio_port = 3333;
  fs::path annotate;
  double fps = 0; // 0 = not given
  long long max_frames = -1;
  int max_side = 8192, threads = 1, classify_every = 1;
  bool show = false, quiet = false, realtime = false, no_realtime = false, no_temporal = false;
  double px_per_cm = 0;          // --px-per-cm; 0 = the calibration's, else the generated rigs' 7.6
  bool scale_to_network = false; // --scale-to-network: the classifier gets the camera scale
  const char* argv0 = "ss_track"; // finds the installed model beside the program
};

const char* kHelp =
    "usage: ss_track --input DIR|VIDEO|CAMERA --calibration FILE [options]\n"
    "Touch events (appear, touch, move, lift, disappear) with the hand-shape gesture, and the\n"
    "touch gestures over time (tap, double_tap, pat, stroke, rub, hold, hit, hug, punch,\n"
    "two_hands), from a folder of images (sorted by name), a video file or a camera index, one\n"
    "line per event on stdout in the project's event schema (docs/output.md).\n"
    "\n"
    "  --input SPEC         folder of images, video file, or camera index (0, 1, ...)\n"
    "  --calibration FILE   calibration with the empty-skin model (ss_calibrate)\n"
    "  --model FILE|none    gesture model (default: the installed model, see below); none:\n"
    "                       touch events only\n"
    "  --threads N          classifier worker threads (default 1)\n"
    "  --classify-every N   while a shadow is seen, classify every N-th frame (default 1)\n"
    "  --fps F              frame rate of a folder (default 30) or override for a video\n"
    "  --timestamps CSV     folder timestamps: lines file,timestamp_ms (header optional)\n"
    "  --format csv|json    event lines as CSV (default, with a header) or JSON lines\n"
    "  --source NAME        the events' source field (default: --input as given)\n"
    "  --tuio HOST[:PORT]   also send TUIO 1.1 over UDP (default port 3333), e.g. 127.0.0.1,\n"
    "                       with the gesture as /shadowsense/gesture in the same bundle\n"
    "                       and the touch gestures as /shadowsense/touch_gesture after it\n"
    "  --no-temporal        no touch gestures over time (touch events and hand shape only)\n"
    "  --px-per-cm F        image scale at the skin for the touch gestures' distances\n"
    "                       (default: the calibration's px_per_cm (ss_calibrate --px-per-cm),\n"
    "                       else 7.6, the generated rigs' scale at the centre)\n"
    "  --scale-to-network   bring frames to the classifier network's scale with the\n"
    "                       calibration's px_per_cm (off by default: it lowers the shipped\n"
    "                       model's accuracy; docs/input_encodings.md)\n"
    "  --realtime           pace a folder or video to its timestamps (the default with --tuio)\n"
    "  --no-realtime        as fast as possible, also with --tuio\n"
    "  --annotate DIR       write an annotated PNG per frame into DIR\n"
    "  --show               show the annotated frames in a window (needs a display)\n"
    "  --max-frames N       stop after N frames\n"
    "  --max-side N         refuse frames larger than N px per side (default 8192)\n"
    "  --quiet              no progress line on stderr\n"
    "  --help, --version\n"
    "CSV columns: schema,kind,source,frame,timestamp_ms,track_id,from,to,direction,x,y,gesture,\n"
    "confidence,gesture_frame,touch_gesture,phase,start_ms,end_ms,length_px,speed_px_s,\n"
    "repetitions,hand_shape,gesture_confidence (kind touch: a touch event, kind gesture: a touch\n"
    "gesture; frames from 1; x, y in pixels, empty without a contact position; gesture fields\n"
    "empty while no shadow is seen). 'to' = none is a disappear.\n";

// Returns the options; throws cli::Exit once --help or --version has been answered.
Options parse(int argc, char** argv) {
  Options o;
  o.argv0 = argv[0];
  std::string tuio;
  cli::Parser p(kProgram, "Touch events and gestures from a folder, a video or a camera.");
  p.help_text(std::string(kHelp) + "Default model: " + runner::default_model_text(argv[0]) + "\n");
  p.option("--input", "SPEC", "folder of images, video file, or camera index", o.input);
  p.option("--calibration", "FILE", "calibration with the empty-skin model", o.calibration);
  p.option("--model", "FILE|none", "gesture model", o.model);
  p.option("--threads", "N", "classifier worker threads", o.threads).range(1, 256);
  p.option("--classify-every", "N", "classify every N-th frame", o.classify_every)
      .range(1, 1'000'000);
  p.option("--timestamps", "CSV", "folder timestamps", o.timestamps);
  p.option("--format", "csv|json", "event lines as CSV or JSON lines", o.format)
      .check([](const std::string& f) {
        if (f != "csv" && f != "json")
          throw cli::UsageError("--format: expected csv or json, got '" + f + "'");
      });
  p.option("--source", "NAME", "the events' source field", o.source);
  p.option("--tuio", "HOST[:PORT]", "also send TUIO 1.1 over UDP", tuio)
      .check([&o](const std::string& spec) {
        const cli::TuioTarget target = cli::parse_tuio_target(spec, "--tuio");
        o.tuio_host = target.host;
        o.tuio_port = target.port;
      });
  p.option("--annotate", "DIR", "write an annotated PNG per frame into DIR", o.annotate);
  p.option("--fps", "F", "frame rate of a folder or override for a video", o.fps)
      .range(0.001, 10000.0);
  p.option("--max-frames", "N", "stop after N frames", o.max_frames).range(1, 1'000'000'000);
  p.option("--max-side", "N", "largest frame side", o.max_side).range(16, 65536);
  p.flag("--no-temporal", "no touch gestures over time", o.no_temporal);
  p.flag("--scale-to-network", "bring frames to the classifier network's scale",
         o.scale_to_network);
  p.option("--px-per-cm", "F", "image scale at the skin", o.px_per_cm)
      .range(0.01, 10000.0)
      .default_text("the calibration's, else 7.6");
  p.flag("--realtime", "pace a file to its timestamps", o.realtime);
  p.flag("--no-realtime", "as fast as possible", o.no_realtime);
  p.flag("--show", "show the annotated frames in a window", o.show);
  p.flag("--quiet", "no progress line on stderr", o.quiet);
  p.parse(argc, argv);
  if (o.show) cli::require_display("--show"); // before the other checks: `--show` alone says why
  if (o.input.empty()) throw cli::UsageError("--input is required (a folder, a video or a camera)");
  if (o.calibration.empty())
    throw cli::UsageError("--calibration is required (make one with ss_calibrate)");
  if (o.scale_to_network && o.model == "none")
    throw cli::UsageError("--scale-to-network scales the classifier's input, and --model none "
                          "runs no classifier; give one of them");
  if (o.realtime && o.no_realtime)
    throw cli::UsageError("--realtime and --no-realtime contradict each other; give one");
  if (o.source.empty()) o.source = o.input;
  return o;
}

// file -> timestamp_ms from a CSV (lines "file,timestamp_ms"; a first line that is not a number
// is a header).
std::map<std::string, double> read_timestamps(const std::string& path) {
  // The library's bounded reader: a regular file of at most 1 GiB (a FIFO or /dev/zero is
  // refused with its name instead of hanging or growing without bound).
  std::istringstream f(detail::read_csv_text(path));
  std::map<std::string, double> out;
  std::string line;
  int n = 0;
  while (std::getline(f, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    const auto comma = line.rfind(',');
    const std::string where = path + ":" + std::to_string(n);
    if (comma == std::string::npos) throw IoError(where + ": expected file,timestamp_ms");
    const std::string file = line.substr(0, comma), t = line.substr(comma + 1);
    double v = 0;
    const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (t.empty() || r.ec != std::errc() || r.ptr != t.data() + t.size() || !std::isfinite(v)) {
      if (n == 1) continue; // header
      throw IoError(where + ": '" + t + "' is not a finite timestamp");
    }
    if (!out.emplace(file, v).second) throw IoError(where + ": '" + file + "' appears twice");
  }
  return out;
}

// The events of one frame (or the flush) through every sink. stdout is the run's result: a
// failure there ends the run. TUIO is a live view for other programs: a frame it cannot send (a
// lost route) is counted, the first reason said
// once, and tracking goes on.
struct Sinks {
  std::optional<CsvSink> csv;
  std::optional<JsonLinesSink> json;
  std::optional<TuioSink> tuio;
  long long tuio_frames = 0, tuio_failed = 0;
  void write(const OutputFrame& f) {
    if (csv) csv->write(f);
    if (json) json->write(f);
    if (!tuio) return;
    ++tuio_frames;
    try {
      tuio->write(f);
    } catch (const Error& e) { // IoError (socket)
      if (tuio_failed++ == 0)
        std::cerr << kProgram << ": warning: TUIO frame " << f.frame_index
                  << " not sent, tracking goes on: " << e.what() << '\n';
    }
  }
};

int run(const Options& o) {
  frames::limit_decoder(o.max_side);
  const SegmenterCalibration cal = load_calibration(o.calibration);
  if (cal.empty_skin.empty() && cal.mode == SegmentMode::relative)
    throw IoError("'" + o.calibration +
                  "' holds no empty-skin model (a version-1 calibration); without one the "
                  "segmenter reports phantom shadows - make a new calibration with ss_calibrate");
  SegmenterConfig sc;
  sc.calibration = cal;
  sc.max_image_side = o.max_side;
  std::optional<Classifier<DenseNet>> classifier;
  fs::path model_path;
  if (o.model != "none") {
    model_path = o.model.empty() ? runner::find_default_model(o.argv0) : fs::path(o.model);
    // The calibration's empty-skin model (a calibrated input encoding needs it) and, with
    // --scale-to-network, its camera scale (frames brought to the network's scale) go to the
    // classifier too.
    const ModelFile model = ModelFile::load(model_path);
    const cli::EncoderCalibration ec = cli::encoder_calibration_from(
        model, model_path.string(), cal, o.calibration, o.scale_to_network);
    classifier.emplace(make_densenet_classifier(model, {.threads = o.threads}, ChannelOrder::bgr,
                                                ec.empty_skin,
                                                static_cast<float>(ec.camera_px_per_cm)));
  }
  RuntimeConfig rc;
  rc.classify_every = o.classify_every;
  rc.temporal_gestures = !o.no_temporal;
  rc.temporal.px_per_cm = o.px_per_cm > 0     ? o.px_per_cm
                          : cal.px_per_cm > 0 ? cal.px_per_cm
                                              : TemporalGestureConfig{}.px_per_cm;
  Runtime sense(TouchPipeline{Segmenter(sc)}, std::move(classifier), rc);
  frames::FrameSource src = frames::FrameSource::open(o.input, o.max_side);
  std::optional<std::map<std::string, double>> stamps;
  if (!o.timestamps.empty()) {
    if (!src.is_folder()) throw cli::UsageError("--timestamps needs a folder --input");
    stamps = read_timestamps(o.timestamps);
  }
  const double fps = o.fps > 0 ? o.fps : (src.fps() ? *src.fps() : 30.0);
  if (!src.is_folder() && !src.is_camera() && !src.fps() && o.fps <= 0)
    std::cerr << kProgram << ": warning: the video declares no frame rate; using 30 fps\n";
  const bool realtime =
      !src.is_camera() && (o.realtime || (!o.tuio_host.empty() && !o.no_realtime));
  Sinks sinks;
  if (o.format == "csv")
    sinks.csv.emplace(std::cout, CsvSink::Config{.source = o.source, .flush = true});
  else
    sinks.json.emplace(std::cout, JsonLinesSink::Config{.source = o.source, .flush = true});
  if (!o.tuio_host.empty()) sinks.tuio.emplace(o.tuio_host, o.tuio_port);
  if (!o.quiet) {
    std::cerr << kProgram << ": " << o.input << "; model "
              << (model_path.empty() ? std::string("none (touch events only)")
                                     : model_path.string())
              << (sinks.tuio ? "; TUIO to " + sinks.tuio->destination() : std::string())
              << (realtime ? "; paced to the timestamps" : "") << '\n';
  }
  if (!o.annotate.empty()) fs::create_directories(o.annotate);
  cli::Progress progress(kProgram, src.count(), cli::Progress::wanted(o.quiet, src.count()));
  const auto start = std::chrono::steady_clock::now();
  std::optional<double> first_t;
  cv::Mat frame;
  std::string name;
  long long i = 0;
  double t = 0, last_t = 0;
  bool stopped = false; // by the user (Esc): the input was not read to its end on purpose
  while ((o.max_frames < 0 || i < o.max_frames) && src.next(frame, name)) {
    if (stamps) {
      const auto it = stamps->find(name);
      if (it == stamps->end())
        throw IoError("'" + o.timestamps + "' has no timestamp for '" + name + "'");
      t = it->second;
    } else if (src.is_camera()) {
      t = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();
    } else {
      t = runner::frame_time_ms(i, fps);
    }
    if (realtime) { // frame i goes out at its time after the first frame's
      if (!first_t) first_t = t;
      std::this_thread::sleep_until(start +
                                    std::chrono::duration<double, std::milli>(t - *first_t));
    }
    const RuntimeFrame* r = nullptr;
    try {
      r = &sense.update(frame, t);
    } catch (const InvalidArgument& e) {
      throw InvalidArgument("frame " + std::to_string(i + 1) + " ('" + name + "'): " + e.what());
    }
    sinks.write(sense.output());
    if (!o.annotate.empty() || o.show) {
      const cv::Mat a = runner::annotate(frame, sense.segmentation(), *r);
      if (!o.annotate.empty()) {
        char file[40];
        std::snprintf(file, sizeof file, "frame_%06lld.png",
                      static_cast<long long>(r->frame_index));
        frames::write_png_atomically(o.annotate / file, a);
      }
#ifdef SHADOWSENSE_HAVE_HIGHGUI
      if (o.show) {
        cv::imshow(kProgram, a);
        if (cv::waitKey(1) == 27) { // Esc stops
          stopped = true;
          break;
        }
      }
#endif
    }
    last_t = t;
    ++i;
    progress.update(static_cast<std::size_t>(i));
  }
  if (i == 0) throw IoError("'" + o.input + "' gave no frame");
  const double step = stamps || src.is_camera() ? 1.0 : 1000.0 / fps;
  sense.flush(last_t + step);
  sinks.write(sense.output()); // the lifts reach the clients
  std::cout.flush();
  progress.finish(static_cast<std::size_t>(i));
  if (sinks.tuio && sinks.tuio->ids_left_out())
    std::cerr << kProgram << ": warning: " << sinks.tuio->ids_left_out()
              << " TUIO ids were left out of alive lists too long for one packet (the oldest "
                 "tracks were sent)\n";
  if (sinks.tuio_failed)
    std::cerr << kProgram << ": warning: " << sinks.tuio_failed << " of " << sinks.tuio_frames
              << " TUIO frames could not be sent to " << sinks.tuio->destination() << '\n';
  if (!std::cout) throw IoError("writing the events to stdout failed");
  // The events so far are out (and end with their lifts), but the run did not see the input.
  if (const std::string short_read = src.ended_early();
      !short_read.empty() && o.max_frames < 0 && !stopped)
    throw IoError("'" + o.input + "': " + short_read + "; the events above cover frames 1 to " +
                  std::to_string(i));
  return 0;
}

} // namespace

int main(int argc, char** argv) {
  return cli::run(kProgram, [&] { return run(parse(argc, argv)); });
}
