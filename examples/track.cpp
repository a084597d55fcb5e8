// ss_track: touch events from a folder of images, a video file or a camera.
//
// Runs TouchPipeline (segmenter + multi-touch tracker + one touch state machine per track) with
// a calibration file (thresholds and empty-skin model, from ss_calibrate), flushes pending events
// at the end of the stream, and prints one line per event on stdout (CSV or JSON lines):
//   frame,timestamp_ms,track_id,from,to,direction,x,y
// Timestamps: folders use --fps (frame i at i * 1000 / fps ms) or --timestamps CSV
// (file,timestamp_ms); videos use their declared frame rate (or --fps); cameras the clock.
// Options: --tuio HOST[:PORT] (TUIO 1.1 over UDP as well: /tuio/2Dcur contacts, /tuio/2Dblb
// shadows; output/tuio_sink.hpp), --annotate DIR (one annotated PNG per frame, atomic writes),
// --show (a window, when
// OpenCV highgui is built in), --max-frames N. A progress line goes to stderr for long inputs.
// Exit status: 0 done, 2 bad command line or input (message on stderr).
#include <shadowsense/output/event_sink.hpp>
#include <shadowsense/output/tuio_sink.hpp>
#include <shadowsense/sense/calibration_file.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>

#include "common/cli.hpp"
#include "common/frame_source.hpp"

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
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace shadowsense;

namespace {

constexpr const char* kProgram = "ss_track";

struct Options {
  std::string input, calibration, timestamps, format = "csv";
  std::string tuio_host; // empty: no TUIO output
  std::uint16_t tuio_port = 3333;
  fs::path annotate;
  double fps = 0; // 0 = not given
  long long max_frames = -1;
  int max_side = 8192;
  bool show = false, quiet = false;
};

const char* kHelp =
    "usage: ss_track --input DIR|VIDEO|CAMERA --calibration FILE [options]\n"
    "Touch events (appear, touch, move, lift, disappear) from a folder of images (sorted by\n"
    "name), a video file or a camera index, one line per event on stdout.\n"
    "\n"
    "  --input SPEC         folder of images, video file, or camera index (0, 1, ...)\n"
    "  --calibration FILE   calibration with the empty-skin model (ss_calibrate)\n"
    "  --fps F              frame rate of a folder (default 30) or override for a video\n"
    "  --timestamps CSV     folder timestamps: lines file,timestamp_ms (header optional)\n"
    "  --format csv|json    event lines as CSV (default, with a header) or JSON lines\n"
    "  --tuio HOST[:PORT]   also send TUIO 1.1 over UDP (default port 3333), e.g. 127.0.0.1\n"
    "  --annotate DIR       write an annotated PNG per frame into DIR\n"
    "  --show               show the annotated frames in a window (OpenCV highgui)\n"
    "  --max-frames N       stop after N frames\n"
    "  --max-side N         refuse frames larger than N px per side (default 8192)\n"
    "  --quiet              no progress line on stderr\n"
    "  --help, --version\n"
    "CSV columns: frame,timestamp_ms,track_id,from,to,direction,x,y (x, y empty when the\n"
    "event has no contact position). 'to' = none is a disappear.\n";

// --tuio HOST[:PORT]: the host as given (a name or an IPv4 address), the port 1..65535.
void parse_tuio(const std::string& spec, Options& o) {
  const auto colon = spec.rfind(':');
  o.tuio_host = spec.substr(0, colon);
  if (o.tuio_host.empty())
    throw cli::UsageError("--tuio: expected HOST[:PORT], got '" + spec + "'");
  if (colon == std::string::npos) return;
  const std::string port = spec.substr(colon + 1);
  unsigned value = 0;
  const auto r = std::from_chars(port.data(), port.data() + port.size(), value);
  if (r.ec != std::errc() || r.ptr != port.data() + port.size() || value < 1 || value > 65535)
    throw cli::UsageError("--tuio: expected a port in [1, 65535] after ':', got '" + port + "'");
  o.tuio_port = static_cast<std::uint16_t>(value);
}

// Returns the options; throws cli::Exit once --help or --version has been answered.
Options parse(int argc, char** argv) {
  Options o;
  std::string tuio;
  cli::Parser p(kProgram, "Touch events from a folder of images, a video file or a camera.");
  p.help_text(kHelp);
  p.style(cli::Style::lenient());
  p.option("--input", "SPEC", "folder of images, video file, or camera index", o.input);
  p.option("--calibration", "FILE", "calibration with the empty-skin model", o.calibration);
  p.option("--timestamps", "CSV", "folder timestamps", o.timestamps);
  p.option("--format", "csv|json", "event lines as CSV or JSON lines", o.format)
      .check([](const std::string& f) {
        if (f != "csv" && f != "json")
          throw cli::UsageError("--format: expected csv or json, got '" + f + "'");
      });
  p.option("--tuio", "HOST[:PORT]", "also send TUIO 1.1 over UDP", tuio)
      .check([&o](const std::string& spec) { parse_tuio(spec, o); });
  p.option("--annotate", "DIR", "write an annotated PNG per frame into DIR", o.annotate);
  p.option("--fps", "F", "frame rate of a folder or override for a video", o.fps)
      .range(0.001, 10000.0);
  p.option("--max-frames", "N", "stop after N frames", o.max_frames).range(1, 1'000'000'000);
  p.option("--max-side", "N", "largest frame side", o.max_side).range(16, 65536);
  p.flag("--show", "show the annotated frames in a window", o.show);
  p.flag("--quiet", "no progress line on stderr", o.quiet);
  p.parse(argc, argv);
  if (o.input.empty()) throw cli::UsageError("--input is required (a folder, a video or a camera)");
  if (o.calibration.empty())
    throw cli::UsageError("--calibration is required (make one with ss_calibrate)");
#ifndef SHADOWSENSE_HAVE_HIGHGUI
  if (o.show) throw cli::UsageError("--show: this build has no OpenCV highgui");
#endif
  return o;
}

// file -> timestamp_ms from a CSV (lines "file,timestamp_ms"; a first line that is not a number
// is a header).
std::map<std::string, double> read_timestamps(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw IoError("cannot open timestamps '" + path + "'");
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

std::string position_csv(const std::optional<cv::Point2f>& p) {
  if (!p) return ",";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.2f,%.2f", p->x, p->y);
  return buf;
}

void print_event(const Options& o, long long frame, const TrackEvent& e) {
  char t[32];
  std::snprintf(t, sizeof t, "%.3f", e.event.timestamp_ms);
  if (o.format == "csv") {
    std::cout << frame << ',' << t << ',' << e.track_id << ',' << to_string(e.event.from) << ','
              << to_string(e.event.to) << ',' << to_string(e.event.direction) << ','
              << position_csv(e.event.position) << '\n';
  } else {
    std::cout << "{\"frame\":" << frame << ",\"timestamp_ms\":" << t
              << ",\"track_id\":" << e.track_id << ",\"from\":\"" << to_string(e.event.from)
              << "\",\"to\":\"" << to_string(e.event.to) << "\",\"direction\":\""
              << to_string(e.event.direction) << "\"";
    if (e.event.position) {
      char p[64];
      std::snprintf(p, sizeof p, ",\"x\":%.2f,\"y\":%.2f", e.event.position->x,
                    e.event.position->y);
      std::cout << p;
    } else {
      std::cout << ",\"x\":null,\"y\":null";
    }
    std::cout << "}\n";
  }
}

cv::Mat annotate(const cv::Mat& frame, const TouchPipeline& p, const TouchFrame& r) {
  cv::Mat out = frames::overlay(frame, p.segmentation());
  for (const TouchTrack& t : r.tracks) {
    const std::string label = std::to_string(t.id) + " " + to_string(t.state);
    cv::putText(out, label, t.shadow_box.tl() + cv::Point(2, 12), cv::FONT_HERSHEY_PLAIN, 0.9,
                cv::Scalar(255, 255, 255), 1);
    if (t.contact) cv::circle(out, *t.contact, 3, cv::Scalar(0, 255, 0), cv::FILLED);
  }
  return out;
}

int run(const Options& o) {
  frames::limit_decoder(o.max_side);
  const SegmenterCalibration cal = load_calibration(o.calibration);
  if (cal.empty_skin.empty())
    std::cerr << kProgram << ": warning: '" << o.calibration
              << "' holds no empty-skin model (version 1); the first frames are judged "
                 "without one - make a new calibration with ss_calibrate\n";
  SegmenterConfig sc;
  sc.calibration = cal;
  sc.max_image_side = o.max_side;
  TouchPipeline pipeline{Segmenter(sc)};
  std::optional<TuioSink> tuio;
  if (!o.tuio_host.empty()) tuio.emplace(o.tuio_host, o.tuio_port);
  OutputFrameBuilder tuio_frames; // TouchFrame -> the sinks' per-frame value
  cv::Size frame_size;
  frames::FrameSource src = frames::FrameSource::open(o.input, o.max_side);
  std::optional<std::map<std::string, double>> stamps;
  if (!o.timestamps.empty()) {
    if (!src.is_folder()) throw cli::UsageError("--timestamps needs a folder --input");
    stamps = read_timestamps(o.timestamps);
  }
  const double fps = o.fps > 0 ? o.fps : (src.fps() ? *src.fps() : 30.0);
  if (!src.is_folder() && !src.is_camera() && !src.fps() && o.fps <= 0)
    std::cerr << kProgram << ": warning: the video declares no frame rate; using 30 fps\n";
  if (!o.annotate.empty()) fs::create_directories(o.annotate);
  if (o.format == "csv") std::cout << "frame,timestamp_ms,track_id,from,to,direction,x,y\n";
  const auto start = std::chrono::steady_clock::now();
  auto last_progress = start;
  const bool show_progress = !o.quiet && (!src.count() || *src.count() > 100);
  cv::Mat frame;
  std::string name;
  long long i = 0;
  double t = 0, last_t = 0;
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
      t = static_cast<double>(i) * 1000.0 / fps;
    }
    const TouchFrame* r = nullptr;
    try {
      r = &pipeline.update(frame, t);
    } catch (const InvalidArgument& e) {
      throw InvalidArgument("frame " + std::to_string(i) + " ('" + name + "'): " + e.what());
    }
    for (const TrackEvent& e : r->events) print_event(o, i, e);
    frame_size = frame.size();
    if (tuio) tuio->write(tuio_frames.build(*r, frame_size));
    if (!o.annotate.empty() || o.show) {
      const cv::Mat a = annotate(frame, pipeline, *r);
      if (!o.annotate.empty()) {
        char file[40];
        std::snprintf(file, sizeof file, "frame_%06lld.png", i);
        frames::write_png_atomically(o.annotate / file, a);
      }
#ifdef SHADOWSENSE_HAVE_HIGHGUI
      if (o.show) {
        cv::imshow(kProgram, a);
        if (cv::waitKey(1) == 27) break; // Esc stops
      }
#endif
    }
    last_t = t;
    ++i;
    const auto now = std::chrono::steady_clock::now();
    if (show_progress && now - last_progress > std::chrono::seconds(1)) {
      last_progress = now;
      std::cerr << "\r" << kProgram << ": frame " << i;
      if (src.count()) std::cerr << " of " << *src.count();
      std::cerr << std::flush;
    }
  }
  if (i == 0) throw IoError("'" + o.input + "' gave no frame");
  const double step = stamps || src.is_camera() ? 1.0 : 1000.0 / fps;
  const TouchFrame& last = pipeline.flush(last_t + step);
  for (const TrackEvent& e : last.events) print_event(o, i, e);
  if (tuio) tuio->write(tuio_frames.build(last, frame_size)); // the lifts reach the clients
  std::cout.flush();
  if (show_progress) std::cerr << "\r" << kProgram << ": " << i << " frames\n";
  if (!std::cout) throw IoError("writing the events to stdout failed");
  return 0;
}

} // namespace

int main(int argc, char** argv) {
  return cli::run(kProgram, [&] { return run(parse(argc, argv)); });
}
