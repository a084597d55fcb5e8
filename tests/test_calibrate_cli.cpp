// ss_calibrate on folders of PNGs with a labels CSV writes exactly the calibration
// calibrate_from_frames makes in memory from the same frames, plus a preview; bad labels and
// arguments are refused with exit status 2 and a message naming the problem.
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/sense/calibration.hpp>
#include <shadowsense/sense/calibration_file.hpp>

#include <doctest/doctest.h>

#include <opencv2/imgcodecs.hpp>

#include "common/run_program.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#ifdef SHADOWSENSE_SS_CALIBRATE

using namespace shadowsense;
namespace fs = std::filesystem;

namespace {

const fs::path kDir = fs::path(SHADOWSENSE_TEST_TMP_DIR) / "calibrate_cli";

using Run = tests::ProgramRun;
using tests::read_file;

Run run(const std::string& args) {
  return tests::run_program(SHADOWSENSE_SS_CALIBRATE, args, kDir);
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
  fs::remove_all(kDir / "empty");
  fs::remove_all(kDir / "touch");
  fs::create_directories(kDir / "empty");
  fs::create_directories(kDir / "touch");
  std::ofstream labels(kDir / "labels.csv");
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
      REQUIRE(cv::imwrite((kDir / (empty ? "empty" : "touch") / name).string(), f.image));
      const cv::Mat back = cv::imread((kDir / (empty ? "empty" : "touch") / name).string());
      if (empty) {
        w.empty.push_back(back);
        continue;
      }
      BoxLabelledFrame b{back, i != 7, std::nullopt, std::nullopt};
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
  const std::string out = (kDir / "skin.calib").string();
  const std::string preview = (kDir / "preview.png").string();
  fs::remove(out);
  fs::remove(preview);
  const Run r = run("--empty '" + (kDir / "empty").string() + "' --touch '" +
                    (kDir / "touch").string() + "' --labels '" + (kDir / "labels.csv").string() +
                    "' --out '" + out + "' --preview '" + preview + "'");
  INFO(r.err);
  REQUIRE(r.status == 0);
  CHECK(r.out.find("6 empty frames, 18 touch frames (15 labelled), 3 light level(s)") !=
        std::string::npos);
  const CalibrationResult expected = calibrate_from_frames(w.empty, w.touch);
  CHECK(load_calibration(out) == expected.calibration);
  CHECK(read_file(out) == calibration_to_string(expected.calibration));
  // Warnings are the same and on stderr.
  for (const CalibrationWarning& x : expected.warnings)
    CHECK(r.err.find(x.message) != std::string::npos);
  const cv::Mat p = cv::imread(preview);
  CHECK(p.size() == cv::Size(4 * 200, 2 * 205)); // 8 tiles, 4 per row
  CHECK_FALSE(fs::exists(out + ".tmp"));
}

TEST_CASE("ss_calibrate: bad labels and arguments exit 2 naming the problem") {
  write_frames();
  const std::string base = "--empty '" + (kDir / "empty").string() + "' --touch '" +
                           (kDir / "touch").string() + "' --out '" + (kDir / "bad.calib").string() +
                           "'";
  auto with_labels = [&](const std::string& text) {
    std::ofstream(kDir / "bad_labels.csv") << text;
    return run(base + " --labels '" + (kDir / "bad_labels.csv").string() + "'");
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
  r = with_labels(header + "nope.png,1,2,3,4,,,,\n");
  CHECK(r.status == 2);
  CHECK(r.err.find("'nope.png', which is not an image") != std::string::npos);
  r = with_labels(header + "t0_2.png,190,0,30,30,,,,\n"); // outside the 200 px wide image
  CHECK(r.status == 2);
  CHECK(r.err.find("reaches outside the image") != std::string::npos);
  CHECK_FALSE(fs::exists(kDir / "bad.calib"));
  r = run("--help");
  CHECK(r.status == 0);
  CHECK(r.out.find("usage: ss_calibrate") == 0);
  r = run("--version");
  CHECK(r.status == 0);
  CHECK(r.out.find("ss_calibrate shadowsense ") == 0);
  r = run("--out x.calib");
  CHECK(r.status == 2);
  CHECK(r.err.find("--empty is required") != std::string::npos);
  r = run(base + " --max-empty 1e3");
  CHECK(r.status == 2);
  CHECK(r.err.find("--max-empty: expected an integer") != std::string::npos);
}

#else
TEST_CASE("ss_calibrate tests need the examples (SHADOWSENSE_BUILD_EXAMPLES)") {
  MESSAGE("skipped: ss_calibrate is not built");
}
#endif
