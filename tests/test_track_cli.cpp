// ss_track on a folder of PNGs and on a video file gives exactly the events TouchPipeline gives
// on the same frames in memory (for the video: the frames decoded back from it); its command
// line follows the programs' convention.
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/output/osc.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>

#include <doctest/doctest.h>

#include <opencv2/imgcodecs.hpp>
#ifdef SHADOWSENSE_HAVE_VIDEOIO
#include <opencv2/videoio.hpp>
#endif

#include "common/local_udp.hpp"
#include "common/run_program.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#ifdef SHADOWSENSE_SS_TRACK

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

// The CSV ss_track prints, made here from TouchPipeline on `frames` at i * 1000 / fps ms.
std::string expected_csv(const std::vector<cv::Mat>& frames, double fps,
                         const std::string& calibration_file) {
  TouchPipeline p{Segmenter({.calibration = load_calibration(calibration_file)})};
  std::ostringstream o;
  o << "frame,timestamp_ms,track_id,from,to,direction,x,y\n";
  auto print = [&](std::size_t frame, const TrackEvent& e) {
    char line[200];
    std::snprintf(line, sizeof line, "%zu,%.3f,%d,%s,%s,%s,", frame, e.event.timestamp_ms,
                  e.track_id, to_string(e.event.from), to_string(e.event.to),
                  std::string(to_string(e.event.direction)).c_str());
    o << line;
    if (e.event.position) {
      std::snprintf(line, sizeof line, "%.2f,%.2f", e.event.position->x, e.event.position->y);
      o << line;
    } else {
      o << ',';
    }
    o << '\n';
  };
  double t = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    t = static_cast<double>(i) * 1000.0 / fps;
    for (const TrackEvent& e : p.update(frames[i], t).events) print(i, e);
  }
  for (const TrackEvent& e : p.flush(t + 1000.0 / fps).events) print(frames.size(), e);
  return o.str();
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
  const std::string expected = expected_csv(frames, 13.0, calibration_path());
  // The script's touch: appear, touch, move right, lift and disappear are all there.
  CHECK(expected.find(",none,appear,") != std::string::npos);
  CHECK(expected.find(",appear,touch,") != std::string::npos);
  CHECK(expected.find(",touch,move,right,") != std::string::npos);
  CHECK(expected.find(",lift,none,") != std::string::npos);
  const Run r = run("--input '" + folder.string() + "' --calibration '" + calibration_path() +
                    "' --fps 13 --quiet");
  INFO(r.err);
  CHECK(r.status == 0);
  CHECK(r.out == expected);
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
  if (!writer.isOpened()) {
    MESSAGE("skipped: no FFV1 or MJPG encoder in this OpenCV build");
    return;
  }
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
  const Run r = run("--input '" + video.string() + "' --calibration '" + cal_path + "' --quiet");
  INFO(used << ": " << r.err);
  CHECK(r.status == 0);
  CHECK(r.out == expected_csv(decoded, fps, cal_path));
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
  const Run r = run("--input '" + folder.string() + "' --calibration '" + calibration_path() +
                    "' --fps 13 --quiet --tuio 127.0.0.1:" + std::to_string(udp.port));
  INFO(r.err);
  REQUIRE(r.status == 0);
  int cur_frames = 0, blb_frames = 0, cursor_sets = 0;
  std::vector<std::int32_t> last_alive{-1};
  while (const auto packet = udp.receive()) {
    std::vector<OscMessage> messages;
    osc_collect_messages(osc_decode(*packet), messages);
    for (const OscMessage& m : messages) {
      REQUIRE(!m.arguments.empty());
      const std::string& command = std::get<std::string>(m.arguments[0]);
      if (m.address == "/tuio/2Dcur" && command == "fseq") ++cur_frames;
      if (m.address == "/tuio/2Dblb" && command == "fseq") ++blb_frames;
      if (m.address == "/tuio/2Dcur" && command == "set") ++cursor_sets;
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
  CHECK(run("--input x --calibration y --tuio :3333").status == 2);
  CHECK(run("--input x --calibration y --tuio 127.0.0.1:0").status == 2);
  CHECK(run("--input x --calibration y --tuio 127.0.0.1:65536").status == 2);
}

#else
TEST_CASE("ss_track tests need the examples (SHADOWSENSE_BUILD_EXAMPLES)") {
  MESSAGE("skipped: ss_track is not built");
}
#endif
