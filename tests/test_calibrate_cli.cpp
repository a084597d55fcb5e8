// ss_calibrate on folders of PNGs with a labels CSV, on a dataset folder with metadata.csv and
// on videos writes exactly the calibration calibrate_from_frames makes in memory from the same
// frames (warnings naming the files), plus a preview and a closing summary; bad labels and
// arguments are refused with exit status 2 and a message naming the problem.
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/io/dataset.hpp>
#include <shadowsense/io/image_folder.hpp>
#include <shadowsense/sense/calibration.hpp>
#include <shadowsense/sense/calibration_file.hpp>
#include <shadowsense/sim/dataset_writer.hpp>

#include <doctest/doctest.h>

#include <opencv2/imgcodecs.hpp>
#ifdef SHADOWSENSE_HAVE_VIDEOIO
#include <opencv2/videoio.hpp>
#endif

#include "common/run_program.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#ifdef SHADOWSENSE_SS_CALIBRATE

using namespace shadowsense;
namespace fs = std::filesystem;

namespace {

const fs::path kCalibrateDir = fs::path(SHADOWSENSE_TEST_TMP_DIR) / "calibrate_cli";

using Run = tests::ProgramRun;
using tests::read_file;

Run run_calibrate(const std::string& args) {
  return tests::run_program(SHADOWSENSE_SS_CALIBRATE, args, kCalibrateDir);
}

std::string box_fields(const std::optional<cv::Rect>& r) {
  if (!r) return ",,,";
  return std::to_string(r->x) + "," + std::to_string(r->y) + "," + std::to_string(r->width) + "," +
         std::to_string(r->height);
}

// Generator frames written as PNGs: 2 empty and 6 touch frames per lighting preset, the touch
// frames labelled by their true boxes except the last one per preset (unlabelled).
struct Written {
  std::vector<cv::Mat> empty;
  std::vector<BoxLabelledFrame> touch; // in file-name order, as the program reads them
};

Written write_frames() {
  static sim::Renderer renderer(sim::Rig::tracking_box());
  fs::remove_all(kCalibrateDir / "empty");
  fs::remove_all(kCalibrateDir / "touch");
  fs::create_directories(kCalibrateDir / "empty");
  fs::create_directories(kCalibrateDir / "touch");
  std::ofstream labels(kCalibrateDir / "labels.csv");
  labels << "file,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h\n";
  Written w;
  for (int light = 0; light < 3; ++light) {
    sim::TrackingSampleConfig variety;
    variety.lighting_weights = {0, 0, 0};
    variety.lighting_weights[static_cast<std::size_t>(light)] = 1;
    for (int i = 0; i < 8; ++i) {
      const bool empty = i < 2;
      const auto category =
          empty ? sim::TrackCategory::nothing : static_cast<sim::TrackCategory>(1 + i % 4);
      const sim::Frame f = sim::render_random_tracking_frame(
          renderer, category, sim::derive_seed(0xC11, static_cast<std::uint64_t>(10 * light + i)),
          variety);
      char name[32];
      std::snprintf(name, sizeof name, "%s%d_%d.png", empty ? "e" : "t", light, i);
      REQUIRE(cv::imwrite((kCalibrateDir / (empty ? "empty" : "touch") / name).string(), f.image));
      const cv::Mat back =
          cv::imread((kCalibrateDir / (empty ? "empty" : "touch") / name).string());
      if (empty) {
        w.empty.push_back(back);
        continue;
      }
      BoxLabelledFrame b{back, i != 7, std::nullopt, std::nullopt, name};
      if (b.labelled) {
        b.shadow_box = f.gt.shadow_box;
        b.contact_box = f.gt.contact_box;
        labels << name << ',' << box_fields(b.shadow_box) << ',' << box_fields(b.contact_box)
               << '\n';
      }
      w.touch.push_back(b);
    }
  }
  return w;
}

} // namespace

TEST_CASE("ss_calibrate writes the calibration calibrate_from_frames makes from the same frames") {
  const Written w = write_frames();
  const std::string out = (kCalibrateDir / "skin.calib").string();
  const std::string preview = (kCalibrateDir / "preview.png").string();
  fs::remove(out);
  fs::remove(preview);
  const Run r = run_calibrate("--empty '" + (kCalibrateDir / "empty").string() + "' --touch '" +
                              (kCalibrateDir / "touch").string() + "' --labels '" +
                              (kCalibrateDir / "labels.csv").string() + "' --out '" + out +
                              "' --preview '" + preview + "'");
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(r.out.find("6 empty frames, 18 touch frames (15 labelled, from a folder), 3 light "
                   "level(s) (luminance ") != std::string::npos);
  // The summary is the last line and says where the calibration went.
  CHECK(r.out.rfind("calibration: ") > r.out.rfind("preview: "));
  CHECK(r.out.ends_with(" -> " + out + "\n"));
  const CalibrationResult expected = calibrate_from_frames(w.empty, w.touch);
  CHECK(load_calibration(out) == expected.calibration);
  CHECK(r.out.find(std::to_string(expected.warnings.size()) + " warning(s)") != std::string::npos);
  CHECK(read_file(out) == calibration_to_string(expected.calibration));
  // Warnings are the same and on stderr.
  for (const CalibrationWarning& x : expected.warnings)
    CHECK(r.err.find(x.message) != std::string::npos);
  const cv::Mat p = cv::imread(preview);
  CHECK(p.size() == cv::Size(4 * 200, 2 * 205)); // 8 tiles, 4 per row
  CHECK_FALSE(fs::exists(out + ".tmp"));
}

TEST_CASE("ss_calibrate --px-per-cm records the camera's scale (version 3), as measured") {
  write_frames();
  const std::string out = (kCalibrateDir / "scaled.calib").string();
  const std::string empty = " --empty '" + (kCalibrateDir / "empty").string() + "'";
  fs::remove(out);
  const Run r = run_calibrate(empty + " --px-per-cm 10.99 --out '" + out + "'");
  INFO(r.err);
  REQUIRE(r.status == 0);
  const SegmenterCalibration c = load_calibration(out);
  CHECK(c.px_per_cm == 10.99f);
  CHECK(read_file(out).find("shadowsense_segmenter_calibration 3\n") != std::string::npos);
  // Everything else is the fit without the option.
  const Run plain = run_calibrate(empty + " --out '" + out + ".plain'");
  REQUIRE(plain.status == 0);
  SegmenterCalibration p = load_calibration(out + ".plain");
  CHECK(p.px_per_cm == 0);
  p.px_per_cm = c.px_per_cm;
  CHECK(p == c);
  for (const char* bad : {"0", "-2", "0.01", "abc", "20000"}) {
    CAPTURE(bad);
    const Run b = run_calibrate(empty + " --px-per-cm " + bad + " --out '" + out + ".bad'");
    CHECK(b.status == 2);
    CHECK(b.err.find("--px-per-cm") != std::string::npos);
    CHECK_FALSE(fs::exists(out + ".bad"));
  }
}

// --max-memory-mb 104 on these 200x205 frames (41,000 px): 4 MiB over the program's 100 MiB,
// less the fit's 80 bytes a pixel (3.28 MB), leaves room for 7 frames of 123 kB held at once
// (examples/common/calibrate_budget.hpp). The touch folder's frames are read from their files
// when the fit needs them (one held at a time), so of 12 empty frames (each frame written twice,
// "a" and "b") 6 are used, evenly spaced: the "a" copies, i.e. the frames of the first test. The
// calibration is calibrate_from_frames's on exactly those, with every touch frame, and a warning
// says how many were used.
TEST_CASE("ss_calibrate --max-memory-mb holds fewer frames, evenly spaced, and says so") {
  const Written w = write_frames();
  const fs::path twice = kCalibrateDir / "empty_twice";
  fs::remove_all(twice);
  fs::create_directories(twice);
  for (const fs::path& p : shadowsense::find_images(kCalibrateDir / "empty"))
    for (const char* copy : {"a", "b"})
      fs::copy_file(p, twice / (p.stem().string() + copy + ".png"));
  const std::string out = (kCalibrateDir / "budget.calib").string();
  fs::remove(out);
  const std::string touch = " --touch '" + (kCalibrateDir / "touch").string() + "' --labels '" +
                            (kCalibrateDir / "labels.csv").string() + "'";
  const Run r = run_calibrate("--empty '" + twice.string() + "'" + touch + " --out '" + out +
                              "' --max-memory-mb 104");
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(r.err.find("ss_calibrate: warning: --max-memory-mb 104: 200x205 frames leave room for 7 "
                   "frames held at once; using at most 6 empty frames of 12 (evenly spaced)") !=
        std::string::npos);
  CHECK(r.out.find("calibration: 6 empty frames, 18 touch frames (15 labelled, from a folder)") !=
        std::string::npos);
  const CalibrationResult expected = calibrate_from_frames(w.empty, w.touch);
  CHECK(read_file(out) == calibration_to_string(expected.calibration));
  // A budget too small for the fit and one frame of each kind is refused, naming what it needs.
  const Run tiny = run_calibrate("--empty '" + twice.string() + "'" + touch + " --out '" + out +
                                 "x' --max-memory-mb 101");
  CHECK(tiny.status == 2);
  CHECK(tiny.err.find("--max-memory-mb 101 is too small for 200x205 frames: the fit and one "
                      "frame of each kind need about 104 MiB") != std::string::npos);
  CHECK_FALSE(fs::exists(out + "x"));
}

TEST_CASE("ss_calibrate: bad labels and arguments exit 2 naming the problem") {
  write_frames();
  const std::string base = "--empty '" + (kCalibrateDir / "empty").string() + "' --touch '" +
                           (kCalibrateDir / "touch").string() + "' --out '" +
                           (kCalibrateDir / "bad.calib").string() + "'";
  auto with_labels = [&](const std::string& text) {
    std::ofstream(kCalibrateDir / "bad_labels.csv") << text;
    return run_calibrate(base + " --labels '" + (kCalibrateDir / "bad_labels.csv").string() + "'");
  };
  const std::string header =
      "file,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h\n";
  Run r = with_labels("name,x\n");
  CHECK(r.status == 2);
  CHECK(r.err.find("bad_labels.csv:1: expected the header") != std::string::npos);
  r = with_labels(header + "t0_2.png,1,2,3\n");
  CHECK(r.status == 2);
  CHECK(r.err.find("bad_labels.csv:2: 4 fields; expected 9") != std::string::npos);
  r = with_labels(header + "t0_2.png,1,2,abc,4,,,,\n");
  CHECK(r.status == 2);
  CHECK(r.err.find("'abc' is not a pixel coordinate") != std::string::npos);
  r = with_labels(header + "t0_2.png,1,2,3,,,,,\n");
  CHECK(r.status == 2);
  CHECK(r.err.find("shadow box is incomplete") != std::string::npos);
  r = with_labels(header + "../t0_2.png,1,2,3,4,,,,\n");
  CHECK(r.status == 2);
  CHECK(r.err.find("must be a path relative to --touch") != std::string::npos);
  r = with_labels(header + "nope.png,1,2,3,4,,,,\n");
  CHECK(r.status == 2);
  CHECK(r.err.find("'nope.png', which is not an image") != std::string::npos);
  r = with_labels(header + "t0_2.png,190,0,30,30,,,,\n"); // outside the 200 px wide image
  CHECK(r.status == 2);
  CHECK(r.err.find("reaches outside the image") != std::string::npos);
  CHECK_FALSE(fs::exists(kCalibrateDir / "bad.calib"));
  r = run_calibrate("--help");
  CHECK(r.status == 0);
  CHECK(r.out.find("usage: ss_calibrate") == 0);
  r = run_calibrate("--version");
  CHECK(r.status == 0);
  CHECK(r.out.find("ss_calibrate shadowsense ") == 0);
  r = run_calibrate("--out x.calib");
  CHECK(r.status == 2);
  CHECK(r.err.find("--empty is required") != std::string::npos);
  r = run_calibrate(base + " --max-empty 1e3");
  CHECK(r.status == 2);
  CHECK(r.err.find("--max-empty: expected an integer") != std::string::npos);
  r = run_calibrate(base + " --max-empty=0");
  CHECK(r.status == 2);
  CHECK(r.err.find("--max-empty: expected an integer in [1, 100000], got '0'") !=
        std::string::npos);
}

namespace {

// The frames and boxes of a dataset folder as ss_calibrate reads them, named by file_name.
std::vector<BoxLabelledFrame> dataset_frames(const fs::path& dir) {
  const Metadata md = read_metadata(dir / "metadata.csv");
  std::vector<BoxLabelledFrame> out;
  for (const MetadataRow& row : md.rows)
    out.push_back({read_image(md, row), true, row.shadow_box, row.contact_box, row.file_name});
  return out;
}

// Empty-skin generator frames of the test box at one lighting preset.
std::vector<cv::Mat> empty_frames(int light, int n, std::uint64_t seed) {
  static sim::Renderer renderer(sim::Rig::tracking_box());
  sim::TrackingSampleConfig variety;
  variety.lighting_weights = {0, 0, 0};
  variety.lighting_weights[static_cast<std::size_t>(light)] = 1;
  std::vector<cv::Mat> out;
  for (int i = 0; i < n; ++i)
    out.push_back(sim::render_random_tracking_frame(renderer, sim::TrackCategory::nothing,
                                                    sim::derive_seed(seed, i), variety)
                      .image);
  return out;
}

} // namespace

TEST_CASE("ss_calibrate --touch on a dataset folder takes the boxes from its metadata.csv") {
  // The generator's tracking dataset (all three light presets) and empty frames in daylight
  // only: touch frames in dusk and night light are far from every empty light level, and the
  // warnings must name their files.
  const fs::path data = kCalibrateDir / "dataset";
  fs::remove_all(data);
  sim::TrackingDatasetConfig config;
  config.frames_per_category = 3;
  sim::write_tracking_dataset(data, 7, config);
  fs::remove_all(kCalibrateDir / "day_empty");
  fs::create_directories(kCalibrateDir / "day_empty");
  std::vector<cv::Mat> empty;
  for (const cv::Mat& f : empty_frames(0, 3, 0xE3)) {
    const fs::path p = kCalibrateDir / "day_empty" / ("e" + std::to_string(empty.size()) + ".png");
    REQUIRE(cv::imwrite(p.string(), f));
    empty.push_back(cv::imread(p.string()));
  }
  const std::vector<BoxLabelledFrame> touch = dataset_frames(data);
  REQUIRE(touch.size() == 15);
  const CalibrationResult expected = calibrate_from_frames(empty, touch);
  std::size_t naming_a_file = 0;
  for (const CalibrationWarning& x : expected.warnings)
    naming_a_file += x.message.find(".png'") != std::string::npos ? 1 : 0;
  REQUIRE(naming_a_file > 0); // the case tests what it claims

  const std::string out = (kCalibrateDir / "dataset.calib").string();
  fs::remove(out);
  const Run r = run_calibrate(
      "--empty=" + tests::shell_quote((kCalibrateDir / "day_empty").string()) +
      " --touch=" + tests::shell_quote(data.string()) + " --out=" + tests::shell_quote(out));
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(load_calibration(out) == expected.calibration);
  for (const CalibrationWarning& x : expected.warnings)
    CHECK(r.err.find("ss_calibrate: warning: " + std::string(to_string(x.issue)) + ": " +
                     x.message + "\n") != std::string::npos);
  // e.g. "touch frame 'point/point_0002.png' has reference luminance ..."
  CHECK(r.err.find("touch frame '") != std::string::npos);
  CHECK(r.err.find("touch frame 0") == std::string::npos);
  CHECK(r.out.find("3 empty frames, 15 touch frames (15 labelled, from a dataset), 1 light "
                   "level(s) (luminance ") != std::string::npos);
  CHECK(r.out.ends_with(std::to_string(expected.warnings.size()) + " warning(s) (on stderr) -> " +
                        out + "\n"));

  // --empty DATASET/nothing: those frames are the empty skin and left out of the touch frames.
  std::vector<cv::Mat> nothing;
  for (const fs::path& p : find_images(data / "nothing")) nothing.push_back(cv::imread(p.string()));
  REQUIRE(nothing.size() == 3);
  std::vector<BoxLabelledFrame> touching;
  for (const BoxLabelledFrame& b : touch)
    if (!b.name.starts_with("nothing/")) touching.push_back(b);
  REQUIRE(touching.size() == 12);
  const CalibrationResult split = calibrate_from_frames(nothing, touching);
  const Run own = run_calibrate("--empty '" + (data / "nothing").string() + "' --touch '" +
                                data.string() + "' --out '" + out + "'");
  INFO(own.err);
  REQUIRE(own.status == 0);
  CHECK(load_calibration(out) == split.calibration);
  CHECK(own.out.find("3 empty frames, 12 touch frames (12 labelled, from a dataset)") !=
        std::string::npos);

  // The metadata gives the boxes: a labels CSV as well is refused.
  std::ofstream(kCalibrateDir / "extra_labels.csv")
      << "file,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h\n";
  const Run both = run_calibrate(
      "--empty '" + (kCalibrateDir / "day_empty").string() + "' --touch '" + data.string() +
      "' --labels '" + (kCalibrateDir / "extra_labels.csv").string() + "' --out '" + out + "'");
  CHECK(both.status == 2);
  CHECK(both.err.find("is a dataset folder; its metadata.csv gives the boxes") !=
        std::string::npos);
}

#ifdef SHADOWSENSE_HAVE_VIDEOIO
namespace {

// Writes frames as a video (a lossless codec when there is one) and returns them as decoded;
// empty when this OpenCV has no encoder for either codec.
std::vector<cv::Mat> write_video(const fs::path& path, const std::vector<cv::Mat>& frames) {
  fs::remove(path);
  cv::VideoWriter writer;
  for (const char* codec : {"FFV1", "MJPG"}) {
    writer.open(path.string(), cv::VideoWriter::fourcc(codec[0], codec[1], codec[2], codec[3]),
                10.0, frames[0].size());
    if (writer.isOpened()) break;
  }
  if (!writer.isOpened()) return {};
  for (const cv::Mat& f : frames) writer.write(f);
  writer.release();
  cv::VideoCapture cap(path.string());
  std::vector<cv::Mat> decoded;
  for (cv::Mat f; cap.read(f) && !f.empty();) decoded.push_back(f.clone());
  return decoded;
}

} // namespace

TEST_CASE("ss_calibrate on videos: --empty and --touch, labels keyed by frame index") {
  static sim::Renderer renderer(sim::Rig::tracking_box());
  std::vector<cv::Mat> touch_images;
  std::vector<sim::GroundTruth> truth;
  for (int i = 0; i < 6; ++i) {
    sim::TrackingSampleConfig variety;
    variety.lighting_weights = {1, 0, 0};
    const sim::Frame f = sim::render_random_tracking_frame(
        renderer, static_cast<sim::TrackCategory>(1 + i % 4), sim::derive_seed(0xF1D, i), variety);
    touch_images.push_back(f.image);
    truth.push_back(f.gt);
  }
  const std::vector<cv::Mat> empty =
      write_video(kCalibrateDir / "empty.avi", empty_frames(0, 4, 0xE4));
  const std::vector<cv::Mat> decoded = write_video(kCalibrateDir / "touch.avi", touch_images);
  // OpenCV's videoio is built (SHADOWSENSE_HAVE_VIDEOIO): Debian's has both encoders, so a
  // missing one is a broken install, not a reason to pass without testing.
  REQUIRE_MESSAGE(!(empty.empty() || decoded.empty()),
                  "no FFV1 or MJPG encoder in this OpenCV build");
  REQUIRE(empty.size() == 4);
  REQUIRE(decoded.size() == 6);
  // Frames 0, 2 and 3 labelled (by index, one with leading zeros), the others unlabelled.
  std::ofstream labels(kCalibrateDir / "video_labels.csv");
  labels << "file,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h\n";
  std::vector<BoxLabelledFrame> touch;
  const std::string video = (kCalibrateDir / "touch.avi").string();
  for (int i = 0; i < 6; ++i) {
    const bool labelled = i == 0 || i == 2 || i == 3;
    BoxLabelledFrame b{decoded[static_cast<std::size_t>(i)], labelled, std::nullopt, std::nullopt,
                       video + "#" + std::to_string(i)};
    if (labelled) {
      b.shadow_box = truth[static_cast<std::size_t>(i)].shadow_box;
      b.contact_box = truth[static_cast<std::size_t>(i)].contact_box;
      labels << (i == 3 ? "003" : std::to_string(i)) << ',' << box_fields(b.shadow_box) << ','
             << box_fields(b.contact_box) << '\n';
    }
    touch.push_back(b);
  }
  labels.close();
  const CalibrationResult expected = calibrate_from_frames(empty, touch);
  const std::string out = (kCalibrateDir / "video.calib").string();
  fs::remove(out);
  const std::string args = "--empty '" + (kCalibrateDir / "empty.avi").string() + "' --touch '" +
                           video + "' --out '" + out + "'";
  const Run r =
      run_calibrate(args + " --labels '" + (kCalibrateDir / "video_labels.csv").string() + "'");
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(load_calibration(out) == expected.calibration);
  for (const CalibrationWarning& x : expected.warnings)
    CHECK(r.err.find(x.message) != std::string::npos);
  CHECK(r.out.find("4 empty frames, 6 touch frames (3 labelled, from a video), 1 light level(s)") !=
        std::string::npos);

  // --max-touch bounds the unlabelled frames taken from a video (labelled ones are all kept).
  const Run capped = run_calibrate(
      args + " --labels '" + (kCalibrateDir / "video_labels.csv").string() + "' --max-touch 1");
  INFO(capped.err);
  CHECK(capped.status == 0);
  CHECK(capped.out.find("4 touch frames (3 labelled, from a video)") != std::string::npos);

  // A label for a frame the video does not have, and a file name instead of an index.
  std::ofstream(kCalibrateDir / "bad_video_labels.csv")
      << "file,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h\n"
      << "99,1,2,3,4,,,,\n";
  Run bad =
      run_calibrate(args + " --labels '" + (kCalibrateDir / "bad_video_labels.csv").string() + "'");
  CHECK(bad.status == 2);
  CHECK(bad.err.find("labels '99', which is not a frame of") != std::string::npos);
  std::ofstream(kCalibrateDir / "bad_video_labels.csv")
      << "file,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h\n"
      << "f.png,1,2,3,4,,,,\n";
  bad =
      run_calibrate(args + " --labels '" + (kCalibrateDir / "bad_video_labels.csv").string() + "'");
  CHECK(bad.status == 2);
  CHECK(bad.err.find("must be a frame index (0 = the first frame)") != std::string::npos);

  // A damaged video (its last two thirds cut off) that still declares its 60 frames: an error,
  // not a calibration from the 20 it gave (before: exit 0 and a calibration file).
  REQUIRE(write_video(kCalibrateDir / "long_empty.avi", empty_frames(0, 60, 0xE5)).size() == 60);
  {
    std::ifstream in(kCalibrateDir / "long_empty.avi", std::ios::binary);
    const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    std::ofstream(kCalibrateDir / "cut_empty.avi", std::ios::binary)
        << bytes.substr(0, bytes.size() / 3);
  }
  fs::remove(out);
  const Run cut = run_calibrate("--empty '" + (kCalibrateDir / "cut_empty.avi").string() +
                                "' --touch '" + video + "' --out '" + out + "'");
  CHECK(cut.status == 2);
  CHECK(cut.err.find("ended after") != std::string::npos);
  CHECK(cut.err.find("of the 60 frames it declares") != std::string::npos);
  CHECK_FALSE(fs::exists(out));
}
#endif

#else
// Reported as skipped (not passed): the program is not built.
TEST_CASE("ss_calibrate is not built (SHADOWSENSE_BUILD_EXAMPLES=OFF)" * doctest::skip()) {}
#endif
