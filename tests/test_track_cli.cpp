// ss_track on a folder of PNGs and on a video file gives exactly the events TouchPipeline gives
// on the same frames in memory (for the video: the frames decoded back from it); its command
// line follows the programs' convention.
#include <shadowsense/backends/densenet/classifier.hpp>
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/output/osc.hpp>
#include <shadowsense/output/text_format.hpp>
#include <shadowsense/sense/temporal_gestures.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>

#include <doctest/doctest.h>

#include <opencv2/imgcodecs.hpp>
#ifdef SHADOWSENSE_HAVE_VIDEOIO
#include <opencv2/videoio.hpp>
#endif

#include "common/local_udp.hpp"
#include "common/run_program.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#ifdef SHADOWSENSE_SS_TRACK

// Its own namespace: the file is compiled in one translation unit with the other tests of
// tests_runtime (tests/CMakeLists.txt), whose helpers have the same names.
namespace track_cli_tests {

using namespace shadowsense;
namespace fs = std::filesystem;

namespace {

const fs::path kDir = fs::path(SHADOWSENSE_TEST_TMP_DIR) / "track_cli";

sim::Renderer& renderer() {
  static sim::Renderer r(sim::Rig::tracking_box());
  return r;
}

sim::HandPose finger(double x_cm, double height_cm) {
  sim::HandPose p;
  p.shape = sim::HandShape::point;
  p.position_cm = {x_cm, 0};
  p.height_cm = height_cm;
  p.arm_elevation_deg = 40;
  return p;
}

// 16 frames: empty, hover, touch, slide right, hover, empty.
std::vector<cv::Mat> render_sequence() {
  std::vector<std::vector<sim::HandPose>> script{{}, {}, {finger(0, 1.5)}, {finger(0, 0)}};
  for (int k = 1; k <= 6; ++k) script.push_back({finger(0.8 * k, 0)});
  script.push_back({finger(4.8, 1.5)});
  for (int k = 0; k < 5; ++k) script.push_back({});
  std::vector<cv::Mat> out;
  for (std::size_t i = 0; i < script.size(); ++i) {
    sim::Scene scene;
    sim::User user;
    for (const auto& h : script[i]) sim::add_hand(scene.parts, user, h);
    out.push_back(renderer().render(scene, sim::preset(sim::Lighting::dusk), 40 + i).image);
  }
  return out;
}

const SegmenterCalibration& calibration() {
  static const SegmenterCalibration c =
      calibrate_on_sim(renderer(), 0xCA11B, 40).config.calibration;
  return c;
}

const std::string& calibration_path() {
  static const std::string path = [] {
    fs::create_directories(kDir);
    const std::string p = (kDir / "skin.calib").string();
    save_calibration(calibration(), p);
    return p;
  }();
  return path;
}

const std::string kModel = std::string(SHADOWSENSE_SOURCE_DIR) + "/models/default.ssm";

// The CSV ss_track prints (the event schema, docs/output.md), made here from TouchPipeline and,
// with a model, the classifier run on every frame where a shadow blob is seen, on `frames` at
// i * 1000 / fps ms; frames counted from 1, the flush as one more frame; after each frame's touch
// rows, the rows of the temporal gestures a TemporalGestureRecogniser (default config) decides
// from the pipeline's frame and the hand shape.
std::string expected_csv(const std::vector<cv::Mat>& frames, double fps,
                         const std::string& calibration_file, const std::string& source,
                         const std::string& model = "", bool scale_to_network = false) {
  const SegmenterCalibration cal = load_calibration(calibration_file);
  TouchPipeline p{Segmenter({.calibration = cal})};
  std::optional<Classifier<DenseNet>> clf;
  // The calibration's camera scale is the touch gestures' distance scale, and with
  // --scale-to-network the classifier's too.
  if (!model.empty())
    clf.emplace(make_densenet_classifier(ModelFile::load(model), {}, ChannelOrder::bgr,
                                         cal.empty_skin, scale_to_network ? cal.px_per_cm : 0));
  TemporalGestureConfig tc;
  if (cal.px_per_cm > 0) tc.px_per_cm = cal.px_per_cm;
  TemporalGestureRecogniser temporal(tc);
  std::string o = "schema,kind,source,frame,timestamp_ms,track_id,from,to,direction,x,y,gesture,"
                  "confidence,gesture_frame,touch_gesture,phase,start_ms,end_ms,length_px,"
                  "speed_px_s,repetitions,hand_shape,gesture_confidence\n";
  std::string gesture = ",,"; // label,confidence,frame of the current frame
  auto print = [&](std::size_t frame, const TrackEvent& e) {
    o += "4,touch," + source + "," + std::to_string(frame) + ",";
    detail::append_number(o, e.event.timestamp_ms);
    o += "," + std::to_string(e.track_id) + "," + to_string(e.event.from) + "," +
         to_string(e.event.to) + "," + to_string(e.event.direction) + ",";
    if (e.event.position) {
      detail::append_number(o, e.event.position->x);
      o += ',';
      detail::append_number(o, e.event.position->y);
    } else {
      o += ',';
    }
    o += "," + gesture + ",,,,,,,,,\n";
  };
  auto print_gesture = [&](std::size_t frame, const GestureEvent& e) {
    o += "4,gesture," + source + "," + std::to_string(frame) + ",";
    detail::append_number(o, e.decided_ms);
    o += "," + std::to_string(e.track_id) + ",,," + to_string(e.direction) + ",";
    detail::append_number(o, e.position.x);
    o += ',';
    detail::append_number(o, e.position.y);
    o += "," + gesture + "," + to_string(e.gesture) + "," + to_string(e.phase) + ",";
    for (double v : {e.start_ms, e.end_ms}) {
      detail::append_number(o, v);
      o += ',';
    }
    for (float v : {e.length_px, e.speed_px_s}) {
      detail::append_number(o, v);
      o += ',';
    }
    o += std::to_string(e.repetitions) + "," + std::string(e.hand_shape.view()) + ",";
    detail::append_number(o, e.confidence);
    o += "\n";
  };
  double t = 0;
  OutputGesture reading;
  reading.available = clf.has_value();
  for (std::size_t i = 0; i < frames.size(); ++i) {
    t = static_cast<double>(i) * 1000.0 / fps;
    const TouchFrame& r = p.update(frames[i], t);
    gesture = ",,";
    reading.label.clear();
    reading.confidence = 0;
    if (clf && !r.shadow_boxes.empty()) {
      const Classification c = clf->classify(frames[i]);
      reading.label = c.label;
      reading.confidence = c.probabilities[static_cast<std::size_t>(c.index)];
      gesture = c.label + ",";
      detail::append_number(gesture, reading.confidence);
      gesture += "," + std::to_string(i + 1);
    }
    for (const TrackEvent& e : r.events) print(i + 1, e);
    for (const GestureEvent& e : temporal.update(r, reading)) print_gesture(i + 1, e);
  }
  gesture = ",,";
  const double t_end = t + 1000.0 / fps;
  for (const TrackEvent& e : p.flush(t_end).events) print(frames.size() + 1, e);
  for (const GestureEvent& e : temporal.flush(t_end)) print_gesture(frames.size() + 1, e);
  return o;
}

// The rows of `csv` (header first) split into fields (no quoted fields in these tests).
std::vector<std::vector<std::string>> csv_rows(const std::string& csv) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream lines(csv);
  for (std::string line; std::getline(lines, line);) {
    std::vector<std::string> v;
    for (std::size_t a = 0, b; a <= line.size(); a = b + 1) {
      b = line.find(',', a);
      if (b == std::string::npos) b = line.size();
      v.push_back(line.substr(a, b - a));
    }
    rows.push_back(v);
  }
  return rows;
}

using Run = tests::ProgramRun;

Run run(const std::string& args) {
  return tests::run_program(SHADOWSENSE_SS_TRACK, args, kDir);
}

// `frames` as f000.png, f001.png, ... in `folder` (emptied first).
void write_pngs(const std::vector<cv::Mat>& frames, const fs::path& folder) {
  fs::remove_all(folder);
  fs::create_directories(folder);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "f%03zu.png", i);
    REQUIRE(cv::imwrite((folder / name).string(), frames[i]));
  }
}

} // namespace

TEST_CASE("ss_track on a folder of PNGs: the events of TouchPipeline on the same frames") {
  const std::vector<cv::Mat> frames = render_sequence();
  const fs::path folder = kDir / "frames";
  write_pngs(frames, folder);
  const std::string expected = expected_csv(frames, 13.0, calibration_path(), "cam0", kModel);
  // The script's touch: appear, touch, move right, lift and disappear are all there.
  CHECK(expected.find(",none,appear,") != std::string::npos);
  CHECK(expected.find(",appear,touch,") != std::string::npos);
  CHECK(expected.find(",touch,move,right,") != std::string::npos);
  CHECK(expected.find(",lift,none,") != std::string::npos);
  // The gesture is there on events while the finger's shadow is seen (the appear, the touch).
  int with_gesture = 0;
  for (const auto& row : csv_rows(expected)) with_gesture += row.size() == 23 && !row[11].empty();
  CHECK(with_gesture >= 3); // the header, the appear and the touch at least
  // The script's touch is a slide: the recogniser reports it as a stroke to the right.
  CHECK(expected.find(",stroke,complete,") != std::string::npos);
  const Run r = run("--input '" + folder.string() + "' --calibration '" + calibration_path() +
                    "' --fps 13 --quiet --source cam0 --model '" + kModel + "'");
  INFO(r.err);
  CHECK(r.status == 0);
  CHECK(r.out == expected);
  // --model none: touch events only, the same events without the gesture; --opt=value.
  const Run t = run("--input='" + folder.string() + "' --calibration='" + calibration_path() +
                    "' --fps=13 --quiet --source=cam0 --model=none");
  CHECK(t.status == 0);
  CHECK(t.out == expected_csv(frames, 13.0, calibration_path(), "cam0"));
  // --no-temporal: the same touch rows, no gesture rows.
  const Run n = run("--input='" + folder.string() + "' --calibration='" + calibration_path() +
                    "' --fps=13 --quiet --source=cam0 --model=none --no-temporal");
  CHECK(n.status == 0);
  std::string touch_only;
  std::istringstream all(t.out);
  for (std::string line; std::getline(all, line);)
    if (line.rfind("4,gesture,", 0) != 0) touch_only += line + "\n";
  CHECK(touch_only != t.out); // the slide's stroke was there
  CHECK(n.out == touch_only);
}

TEST_CASE("ss_track: a calibration's camera scale is the touch gestures' and, with "
          "--scale-to-network, the classifier's") {
  const std::vector<cv::Mat> frames = render_sequence();
  const fs::path folder = kDir / "frames_scaled";
  write_pngs(frames, folder);
  SegmenterCalibration cal = load_calibration(calibration_path());
  REQUIRE(cal.px_per_cm == 0);
  cal.px_per_cm = 2 * 7.578125f; // a camera that sees hands twice the network's size
  const std::string scaled = (kDir / "scaled.calib").string();
  save_calibration(cal, scaled);
  const std::string expected = expected_csv(frames, 13.0, scaled, "cam0", kModel, true);
  CHECK(expected != expected_csv(frames, 13.0, scaled, "cam0", kModel));
  const std::string args = "--input '" + folder.string() + "' --calibration '" + scaled +
                           "' --fps 13 --quiet --source cam0 --model '" + kModel + "'";
  const Run r = run(args + " --scale-to-network");
  INFO(r.err);
  CHECK(r.status == 0);
  CHECK(r.out == expected);
  const Run d = run(args); // the default: the classifier sees the frames as they are
  CHECK(d.status == 0);
  CHECK(d.out == expected_csv(frames, 13.0, scaled, "cam0", kModel));
  // Without a scale in the calibration the option is refused, naming it.
  const Run no = run("--input '" + folder.string() + "' --calibration '" + calibration_path() +
                     "' --fps 13 --quiet --scale-to-network");
  CHECK(no.status == 2);
  CHECK(no.err.find("--scale-to-network") != std::string::npos);
  // ... and with no classifier to scale for, too (the flag would do nothing).
  for (const std::string& calib : {calibration_path(), scaled}) {
    const Run none = run("--input '" + folder.string() + "' --calibration '" + calib +
                         "' --fps 13 --quiet --model none --scale-to-network");
    CHECK(none.status == 2);
    CHECK(none.err.find("--scale-to-network") != std::string::npos);
    CHECK(none.out.empty());
  }
  // --px-per-cm overrides the calibration's for the touch gestures (not for the classifier).
  const Run o = run("--input '" + folder.string() + "' --calibration '" + scaled +
                    "' --fps 13 --quiet --source cam0 --model none --px-per-cm 7.6");
  CHECK(o.status == 0);
  CHECK(o.out == expected_csv(frames, 13.0, calibration_path(), "cam0"));
}

TEST_CASE("ss_track --format json: the same events as JSON lines, one valid object per line") {
  const std::vector<cv::Mat> frames = render_sequence();
  const fs::path folder = kDir / "frames_json";
  write_pngs(frames, folder);
  const Run csv = run("--input '" + folder.string() + "' --calibration '" + calibration_path() +
                      "' --fps 13 --quiet --model '" + kModel + "'");
  const Run json = run("--input '" + folder.string() + "' --calibration '" + calibration_path() +
                       "' --fps 13 --quiet --format json --model '" + kModel + "'");
  REQUIRE(csv.status == 0);
  REQUIRE(json.status == 0);
  // Line k of the JSON output holds the values of row k + 1 of the CSV, field by field.
  std::istringstream c(csv.out), j(json.out);
  std::string cl, jl;
  std::getline(c, cl);
  std::vector<std::string> names;
  for (std::size_t a = 0, b; a <= cl.size(); a = b + 1) {
    b = cl.find(',', a);
    if (b == std::string::npos) b = cl.size();
    names.push_back(cl.substr(a, b - a));
  }
  int lines = 0;
  while (std::getline(c, cl)) {
    REQUIRE(std::getline(j, jl));
    std::vector<std::string> v;
    for (std::size_t a = 0, b; a <= cl.size(); a = b + 1) {
      b = cl.find(',', a);
      if (b == std::string::npos) b = cl.size();
      v.push_back(cl.substr(a, b - a));
    }
    REQUIRE(v.size() == names.size());
    std::string expected = "{";
    for (std::size_t k = 0; k < v.size(); ++k) {
      const bool text = names[k] == "source" || names[k] == "from" || names[k] == "to" ||
                        names[k] == "direction" || names[k] == "gesture" || names[k] == "kind" ||
                        names[k] == "touch_gesture" || names[k] == "phase" ||
                        names[k] == "hand_shape";
      if (k) expected += ',';
      expected += "\"" + names[k] + "\":";
      if (v[k].empty() && names[k] != "source")
        expected += "null";
      else
        expected += text ? "\"" + v[k] + "\"" : v[k];
    }
    CHECK(jl == expected + "}");
    ++lines;
  }
  CHECK(lines >= 5);
  CHECK(!std::getline(j, jl));
}

#ifdef SHADOWSENSE_HAVE_VIDEOIO
TEST_CASE("ss_track on a video file: the events of TouchPipeline on the decoded frames") {
  // Even sizes for every codec: the frames and the empty-skin model lose their last row.
  const cv::Rect even(0, 0, 200, 204);
  std::vector<cv::Mat> frames = render_sequence();
  for (cv::Mat& f : frames) f = f(even).clone();
  SegmenterCalibration cal = calibration();
  cal.empty_skin = cal.empty_skin(even).clone();
  const std::string cal_path = (kDir / "skin_even.calib").string();
  save_calibration(cal, cal_path);
  const fs::path video = kDir / "sequence.avi";
  fs::remove(video);
  cv::VideoWriter writer;
  std::string used;
  for (const char* codec : {"FFV1", "MJPG"}) {
    writer.open(video.string(), cv::VideoWriter::fourcc(codec[0], codec[1], codec[2], codec[3]),
                13.0, frames[0].size());
    if (writer.isOpened()) {
      used = codec;
      break;
    }
  }
  // OpenCV's videoio is built (SHADOWSENSE_HAVE_VIDEOIO): Debian's has both encoders, so a
  // missing one is a broken install, not a reason to pass without testing.
  REQUIRE_MESSAGE(writer.isOpened(), "no FFV1 or MJPG encoder in this OpenCV build");
  for (const cv::Mat& f : frames) writer.write(f);
  writer.release();
  cv::VideoCapture cap(video.string());
  REQUIRE(cap.isOpened());
  const double fps = cap.get(cv::CAP_PROP_FPS);
  CHECK(fps == doctest::Approx(13.0));
  std::vector<cv::Mat> decoded;
  cv::Mat f;
  while (cap.read(f)) decoded.push_back(f.clone());
  REQUIRE(decoded.size() == frames.size());
  const Run r =
      run("--input '" + video.string() + "' --calibration '" + cal_path + "' --quiet --model none");
  INFO(used << ": " << r.err);
  CHECK(r.status == 0);
  CHECK(r.out == expected_csv(decoded, fps, cal_path, video.string()));
  CHECK(r.out.find(",touch,move,right,") != std::string::npos);
}
#endif

TEST_CASE("ss_track command line: help, version, missing and bad arguments") {
  Run r = run("--help");
  CHECK(r.status == 0);
  CHECK(r.out.find("usage: ss_track") == 0);
  CHECK(r.err.empty());
  r = run("--version");
  CHECK(r.status == 0);
  CHECK(r.out.find("ss_track shadowsense ") == 0);
  r = run("");
  CHECK(r.status == 2);
  CHECK(r.out.empty());
  CHECK(r.err.find("--input is required") != std::string::npos);
  r = run("--input . --calibration '" + calibration_path() + "' --fps abc");
  CHECK(r.status == 2);
  CHECK(r.err.find("--fps: expected a number") != std::string::npos);
  r = run("--input . --calibration '" + (kDir / "missing.calib").string() + "'");
  CHECK(r.status == 2);
  CHECK(r.err.find("missing.calib") != std::string::npos);
  r = run("--input '" + (kDir / "no_such_input").string() + "' --calibration '" +
          calibration_path() + "'");
  CHECK(r.status == 2);
  CHECK(r.err.find("no_such_input") != std::string::npos);
  r = run("--bogus");
  CHECK(r.status == 2);
  CHECK(r.err.find("unknown option '--bogus'") != std::string::npos);
}

TEST_CASE("ss_track --tuio: one /tuio/2Dcur and one /tuio/2Dblb bundle per frame, the touch as a "
          "cursor") {
  const std::vector<cv::Mat> frames = render_sequence();
  const fs::path folder = kDir / "frames_tuio";
  write_pngs(frames, folder);
  const tests::LocalUdp udp(std::chrono::seconds(1));
  // TUIO from a folder is paced to the frames' timestamps by default: 17 frames at 13 fps take
  // at least 16 / 13 s.
  const auto start = std::chrono::steady_clock::now();
  const Run r = run("--input '" + folder.string() + "' --calibration '" + calibration_path() +
                    "' --fps 13 --quiet --model '" + kModel +
                    "' --tuio 127.0.0.1:" + std::to_string(udp.port));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(seconds >= 16.0 / 13.0);
  int cur_frames = 0, blb_frames = 0, cursor_sets = 0, gestures = 0, classified = 0;
  std::vector<std::int32_t> last_alive{-1};
  std::vector<std::string> touch_gestures; // /shadowsense/touch_gesture names, in order
  while (const auto packet = udp.receive()) {
    std::vector<OscMessage> messages;
    osc_collect_messages(osc_decode(*packet), messages);
    for (const OscMessage& m : messages) {
      REQUIRE(!m.arguments.empty());
      if (m.address == "/shadowsense/touch_gesture") { // s_id gesture phase ...
        REQUIRE(m.arguments.size() == 14);
        touch_gestures.push_back(std::get<std::string>(m.arguments[1]));
        continue;
      }
      const std::string& command = std::get<std::string>(m.arguments[0]);
      if (m.address == "/tuio/2Dcur" && command == "fseq") ++cur_frames;
      if (m.address == "/tuio/2Dblb" && command == "fseq") ++blb_frames;
      if (m.address == "/tuio/2Dcur" && command == "set") ++cursor_sets;
      if (m.address == "/shadowsense/gesture") { // label confidence frame [class p]...
        ++gestures;
        if (command.empty()) continue; // gated off: no shadow
        ++classified;
        REQUIRE(m.arguments.size() == 3 + 2 * 6); // the shipped model's six classes
        const float confidence = std::get<float>(m.arguments[1]);
        float sum = 0, best = -1;
        std::string best_class;
        for (std::size_t k = 3; k < m.arguments.size(); k += 2) {
          const float p = std::get<float>(m.arguments[k + 1]);
          sum += p;
          if (p > best) best = p, best_class = std::get<std::string>(m.arguments[k]);
        }
        CHECK(sum == doctest::Approx(1.0).epsilon(1e-5));
        CHECK(confidence == best); // the label is the most probable class
        CHECK(command == best_class);
      }
      if (m.address == "/tuio/2Dcur" && command == "alive") {
        last_alive.clear();
        for (std::size_t k = 1; k < m.arguments.size(); ++k)
          last_alive.push_back(std::get<std::int32_t>(m.arguments[k]));
      }
    }
  }
  // Every frame plus the end-of-stream flush, on both profiles.
  CHECK(cur_frames == static_cast<int>(frames.size()) + 1);
  CHECK(blb_frames == static_cast<int>(frames.size()) + 1);
  CHECK(cursor_sets >= 6);   // the finger touches and slides for at least 6 frames
  CHECK(last_alive.empty()); // the lift removed the cursor by the end
  CHECK(gestures == static_cast<int>(frames.size()) + 1); // one per bundle set, in the last
  // Classified exactly on the frames where the pipeline sees a shadow (the gate).
  TouchPipeline p{Segmenter({.calibration = load_calibration(calibration_path())})};
  int with_shadow = 0;
  for (std::size_t i = 0; i < frames.size(); ++i)
    with_shadow += !p.update(frames[i], static_cast<double>(i) * 1000.0 / 13).shadow_boxes.empty();
  CHECK(with_shadow >= 9); // hover, touch, six slide frames, hover
  CHECK(classified == with_shadow);
  // The touch gestures of the CSV on the same frames, in order (the slide is a stroke).
  std::vector<std::string> csv_gestures;
  for (const auto& row : csv_rows(expected_csv(frames, 13.0, calibration_path(), "cam0", kModel)))
    if (row[1] == "gesture") csv_gestures.push_back(row[14]);
  CHECK(touch_gestures == csv_gestures);
  CHECK(std::count(touch_gestures.begin(), touch_gestures.end(), "stroke") == 1);
  CHECK(run("--input x --calibration y --tuio :3333").status == 2);
  CHECK(run("--input x --calibration y --tuio 127.0.0.1:0").status == 2);
  CHECK(run("--input x --calibration y --tuio 127.0.0.1:65536").status == 2);
}

TEST_CASE("ss_track --tuio takes [IPv6]:PORT, [IPv6], HOST and HOST:PORT") {
  const tests::LocalUdp udp(std::chrono::seconds(1));
  const std::vector<cv::Mat> frames = render_sequence();
  const fs::path folder = kDir / "frames_v6";
  write_pngs({frames.begin(), frames.begin() + 3}, folder);
  const std::string base = "--input '" + folder.string() + "' --calibration '" +
                           calibration_path() + "' --quiet --model none --no-realtime --tuio ";
  Run r = run(base + "'[::1]:" + std::to_string(udp.port) + "'");
  // A machine without IPv6 on loopback refuses the socket with a clear error, never a crash.
  CHECK((r.status == 0 || r.err.find("::1") != std::string::npos));
  for (const char* bad : {"'[::1'", "'[::1]:0'", "host:port", "''"}) {
    r = run(base + bad);
    INFO(bad << ": " << r.err);
    CHECK(r.status == 2);
    CHECK(r.err.find("--tuio: ") != std::string::npos);
  }
}

TEST_CASE("ss_track keeps tracking when no TUIO frame can be sent (item 4 of the audit)") {
  // A broadcast address without SO_BROADCAST: every sendto fails (EACCES), like a lost route.
  // Before: exit 2 at the first frame, the track left without its lift.
  const std::vector<cv::Mat> frames = render_sequence();
  const fs::path folder = kDir / "frames_tuio_fail";
  write_pngs(frames, folder);
  const std::string base = "--input '" + folder.string() + "' --calibration '" +
                           calibration_path() + "' --fps 13 --quiet --source cam0 --model none";
  const Run plain = run(base);
  const Run lost = run(base + " --no-realtime --tuio 255.255.255.255:3333");
  INFO(lost.err);
  REQUIRE(plain.status == 0);
  CHECK(lost.status == 0);
  CHECK(lost.out == plain.out); // every event, the lift included
  CHECK(plain.out.find(",lift,none,") != std::string::npos);
  CHECK(lost.err.find("warning: TUIO frame 1 not sent, tracking goes on") != std::string::npos);
  CHECK(lost.err.find(std::to_string(frames.size() + 1) + " of " +
                      std::to_string(frames.size() + 1) + " TUIO frames could not be sent") !=
        std::string::npos);
}

TEST_CASE("ss_track refuses --show without a display, in one line with exit status 2") {
  const Run r = tests::run_program(
      "/usr/bin/env",
      "-u DISPLAY -u WAYLAND_DISPLAY " + tests::shell_quote(SHADOWSENSE_SS_TRACK) +
          " --input . --calibration '" + calibration_path() + "' --show",
      kDir);
  CHECK(r.status == 2);
  CHECK(r.err.find("--show") != std::string::npos);
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
}

#ifdef SHADOWSENSE_SS_DEMO
TEST_CASE("ss_demo's events and ss_track's on the demo's frames and calibration are the same "
          "lines") {
  const fs::path out = kDir / "demo";
  fs::remove_all(out);
  const Run demo = tests::run_program(
      SHADOWSENSE_SS_DEMO,
      "--out '" + out.string() + "' --save-frames --source demo --model '" + kModel + "'", kDir);
  INFO(demo.err);
  REQUIRE(demo.status == 0);
  const Run track = run("--input '" + (out / "frames").string() + "' --calibration '" +
                        (out / "skin.calib").string() +
                        "' --fps 10 --source demo --quiet --model '" + kModel + "'");
  INFO(track.err);
  REQUIRE(track.status == 0);
  std::ifstream f(out / "events.csv");
  const std::string events((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  CHECK(track.out == events);
  // The scripted palm touch, slide and punch are all in it, with their gestures.
  CHECK(events.find(",appear,touch,none,") != std::string::npos);
  CHECK(events.find(",touch,move,right,") != std::string::npos);
  CHECK(events.find(",palm,") != std::string::npos);
  CHECK(events.find(",punch,") != std::string::npos);
  CHECK(events.find(",hug,") != std::string::npos);
  // The temporal gestures of the script: the palm's hold, its stroke to the right and its two
  // pats (a pat, then revised to two), the punch and the hug.
  CHECK(events.find(",hold,began,") != std::string::npos);
  CHECK(events.find(",right,") != std::string::npos);
  CHECK(events.find(",stroke,complete,") != std::string::npos);
  CHECK(events.find(",pat,complete,") != std::string::npos);
  CHECK(events.find(",pat,revised,") != std::string::npos);
  CHECK(events.find(",punch,began,") != std::string::npos);
  CHECK(events.find(",hug,ended,") != std::string::npos);
}
#endif

} // namespace track_cli_tests

#else
// Reported as skipped (not passed): the program is not built.
TEST_CASE("ss_track is not built (SHADOWSENSE_BUILD_EXAMPLES=OFF)" * doctest::skip()) {}
#endif
