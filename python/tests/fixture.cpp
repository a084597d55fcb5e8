// ss_python_fixture: writes the generated frames the Python tests and bench read, and the C++
// run of the same frames the Python run is compared with.
//
//   ss_python_fixture sequence OUT MODEL   the touch sequence (fixture_scenes.hpp) run through
//       Runtime with the DenseNet classifier of MODEL: OUT/skin.calib, OUT/frames.u8 (the frames'
//       bytes, N x H x W x 3), OUT/frames.txt ("N H W" then one timestamp per line),
//       OUT/cpp_results.txt (results.py's format: every frame's tracks, events, gesture with its
//       probabilities, temporal gestures), OUT/cpp_events.csv and OUT/cpp_events.jsonl (the
//       event sinks).
//   ss_python_fixture bench OUT            the bench frames of both rigs: OUT/<rig>/{skin.calib,
//       frames.u8, frames.txt} for rig = tracking_box (200x205) and robot (635x350).
// Every file is written atomically. Errors: a message on stderr, exit 2.
#include "fixture_scenes.hpp"

#include <shadowsense/core/atomic_file.hpp>
#include <shadowsense/output/csv_sink.hpp>
#include <shadowsense/output/json_lines_sink.hpp>
#include <shadowsense/runtime/densenet_runtime.hpp>

#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>

namespace ss = shadowsense;
namespace fs = std::filesystem;

namespace {

void write_scenes(const ss::python_fixture::Scenes& s, const fs::path& dir) {
  fs::create_directories(dir);
  ss::save_calibration(s.calibration, (dir / "skin.calib").string());
  ss::write_file_atomically(dir / "frames.u8", [&](std::ostream& out) {
    for (const cv::Mat& f : s.frames)
      for (int y = 0; y < f.rows; ++y)
        out.write(reinterpret_cast<const char*>(f.ptr(y)),
                  static_cast<std::streamsize>(f.cols) * 3);
  });
  std::ostringstream meta;
  meta.precision(17);
  meta << s.frames.size() << ' ' << s.frames[0].rows << ' ' << s.frames[0].cols << '\n';
  for (double t : s.timestamps_ms) meta << t << '\n';
  ss::write_file_atomically(dir / "frames.txt", meta.str());
}

// One number as results.py reads it ("nan" for none).
std::string num(double v) {
  if (std::isnan(v)) return "nan";
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}
std::string word(const std::string& s) {
  return s.empty() ? "-" : s;
}

// The format of results.py (format_frame): one line per frame, track, event and gesture.
void format_frame(std::ostream& o, const ss::RuntimeFrame& r) {
  const auto idx = std::to_string(r.frame_index);
  o << "frame " << idx << ' ' << num(r.timestamp_ms) << ' ' << int(r.classified) << ' '
    << word(r.gesture.label) << ' ' << num(r.gesture.confidence) << ' ' << r.gesture.frame_index;
  for (float p : r.gesture.probabilities) o << ' ' << num(p);
  o << '\n';
  for (const ss::TouchTrack& t : r.touch.tracks)
    o << "track " << idx << ' ' << t.id << ' ' << int(t.matched) << ' ' << ss::to_string(t.state)
      << ' ' << num(t.contact ? t.contact->x : NAN) << ' ' << num(t.contact ? t.contact->y : NAN)
      << ' ' << num(t.position.x) << ' ' << num(t.position.y) << ' ' << t.shadow_box.x << ' '
      << t.shadow_box.y << ' ' << t.shadow_box.width << ' ' << t.shadow_box.height << ' '
      << num(t.contact_area) << '\n';
  for (const ss::TrackEvent& e : r.touch.events)
    o << "event " << idx << ' ' << e.track_id << ' ' << ss::to_string(e.event.from) << ' '
      << ss::to_string(e.event.to) << ' ' << ss::to_string(e.event.direction) << ' '
      << num(e.event.position ? e.event.position->x : NAN) << ' '
      << num(e.event.position ? e.event.position->y : NAN) << ' ' << num(e.event.timestamp_ms)
      << '\n';
  for (const ss::GestureEvent& g : r.touch_gestures)
    o << "touch_gesture " << idx << ' ' << ss::to_string(g.gesture) << ' ' << ss::to_string(g.phase)
      << ' ' << g.track_id << ' ' << num(g.start_ms) << ' ' << num(g.end_ms) << ' '
      << num(g.decided_ms) << ' ' << num(g.length_px) << ' ' << num(g.speed_px_s) << ' '
      << g.repetitions << ' ' << word(std::string(g.hand_shape.view())) << ' ' << num(g.confidence)
      << '\n';
}

void run_sequence(const fs::path& dir, const std::string& model) {
  const ss::python_fixture::Scenes s = ss::python_fixture::touch_sequence();
  write_scenes(s, dir);
  // As a user would: the calibration from its file, the classifier from the model file.
  ss::Runtime sense{ss::TouchPipeline{ss::Segmenter(
                        {.calibration = ss::load_calibration((dir / "skin.calib").string())})},
                    ss::make_densenet_classifier(ss::ModelFile::load(model))};
  std::ostringstream results, csv_text, json_text;
  ss::CsvSink csv(csv_text);
  ss::JsonLinesSink json(json_text);
  for (std::size_t i = 0; i < s.frames.size(); ++i) {
    format_frame(results, sense.update(s.frames[i], s.timestamps_ms[i]));
    ss::publish(sense.output(), csv, json);
  }
  format_frame(results, sense.flush(s.timestamps_ms.back() + 33.25));
  ss::publish(sense.output(), csv, json);
  ss::write_file_atomically(dir / "cpp_results.txt", results.str());
  ss::write_file_atomically(dir / "cpp_events.csv", csv_text.str());
  ss::write_file_atomically(dir / "cpp_events.jsonl", json_text.str());
}

} // namespace

int main(int argc, char** argv) {
  const std::string usage = "usage: ss_python_fixture sequence OUT MODEL | bench OUT";
  const std::string mode = argc > 1 ? argv[1] : "";
  if (mode == "--help") {
    std::cout << usage << '\n';
    return 0;
  }
  try {
    if (mode == "sequence" && argc == 4) {
      run_sequence(argv[2], argv[3]);
    } else if (mode == "bench" && argc == 3) {
      write_scenes(ss::python_fixture::bench_frames(ss::sim::Rig::tracking_box(), 0xB0),
                   fs::path(argv[2]) / "tracking_box");
      write_scenes(ss::python_fixture::bench_frames(ss::sim::Rig::robot(), 0xB2),
                   fs::path(argv[2]) / "robot");
    } else {
      std::cerr << "ss_python_fixture: " << usage << '\n';
      return 2;
    }
  } catch (const std::exception& e) {
    std::cerr << "ss_python_fixture: " << e.what() << '\n';
    return 2;
  }
  return 0;
}
