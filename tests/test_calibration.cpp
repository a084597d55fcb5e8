// Calibration from a robot's own frames (calibrate_from_frames) and the calibration file with the
// empty-skin model: fitted on generator frames labelled only by boxes, the segmenter meets the
// accuracy of the mask-fitted one on other generator frames; a cut or changed file is rejected
// naming the file; degenerate input gives warnings or a refusal.
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/sense/calibration.hpp>
#include <shadowsense/sense/calibration_file.hpp>

#include <doctest/doctest.h>

#include "common/sim_box.hpp"
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace shadowsense;

namespace {

// Generator frames of every lighting preset: `empty` of the empty skin per preset, and touch
// frames (hover, palm, fist, finger in turn) labelled by their true boxes with each side moved
// by a random -2..2 px (a hand-drawn, coarse box).
struct Frames {
  std::vector<cv::Mat> empty;
  std::vector<BoxLabelledFrame> touch;
};

Frames render_frames(std::uint64_t seed, int empty_per_light, int touch_per_light) {
  Frames out;
  const cv::Rect image({}, cv::Size(200, 205));
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  auto coarse = [&](const cv::Rect& r) {
    const int l = rng.uniform(-2, 3), t = rng.uniform(-2, 3), rr = rng.uniform(-2, 3),
              b = rng.uniform(-2, 3);
    return cv::Rect(r.x - l, r.y - t, r.width + l + rr, r.height + t + b) & image;
  };
  for (int light = 0; light < 3; ++light) {
    sim::TrackingSampleConfig variety;
    variety.lighting_weights = {0, 0, 0};
    variety.lighting_weights[static_cast<std::size_t>(light)] = 1;
    for (int i = 0; i < empty_per_light + touch_per_light; ++i) {
      const bool empty = i < empty_per_light;
      const auto category =
          empty ? sim::TrackCategory::nothing : static_cast<sim::TrackCategory>(1 + i % 4);
      const sim::Frame f = sim::render_random_tracking_frame(
          test::box_renderer(), category,
          sim::derive_seed(seed, static_cast<std::uint64_t>(100 * light + i)), variety);
      if (empty) {
        out.empty.push_back(f.image);
        continue;
      }
      BoxLabelledFrame b;
      b.image = f.image;
      if (f.gt.shadow_box) b.shadow_box = coarse(*f.gt.shadow_box);
      if (f.gt.contact_box) b.contact_box = coarse(*f.gt.contact_box);
      out.touch.push_back(b);
    }
  }
  return out;
}

const CalibrationResult& fitted() {
  static const CalibrationResult r = [] {
    const Frames f = render_frames(0xB0C5, 4, 16);
    return calibrate_from_frames(f.empty, f.touch);
  }();
  return r;
}

std::string read_all(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}

void write_all(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f << bytes;
}

} // namespace

TEST_CASE("box-labelled generator frames: three light groups, model included, no warnings") {
  const CalibrationResult& r = fitted();
  std::string warnings;
  for (const CalibrationWarning& w : r.warnings) warnings += w.message + "\n";
  INFO(warnings);
  CHECK(r.warnings.empty());
  REQUIRE(r.groups.size() == 3);
  for (const LightGroupReport& g : r.groups) {
    CHECK(g.empty_frames == 4);
    CHECK(g.touch_frames == 16);
    CHECK(g.fitted);
    CHECK(g.thresholds.shadow_darkness > g.noise_darkness);
  }
  CHECK(r.calibration.by_light.size() == 3);
  CHECK(r.calibration.empty_skin.size() == cv::Size(200, 205));
}

TEST_CASE("touch frames given by load: the same calibration, each frame loaded a few times") {
  Frames f = render_frames(0xB0C5, 4, 16);
  f.touch[5].labelled = false; // one unlabelled frame and one labelled "no shadow" too
  f.touch[5].shadow_box.reset();
  f.touch[5].contact_box.reset();
  f.touch[6].shadow_box.reset();
  f.touch[6].contact_box.reset();
  const CalibrationResult held = calibrate_from_frames(f.empty, f.touch);
  std::vector<int> loads(f.touch.size(), 0);
  std::vector<BoxLabelledFrame> lazy = f.touch;
  for (std::size_t i = 0; i < lazy.size(); ++i) {
    lazy[i].image.release();
    lazy[i].load = [&f, &loads, i] {
      ++loads[i];
      return f.touch[i].image.clone();
    };
  }
  const CalibrationResult r = calibrate_from_frames(f.empty, lazy);
  CHECK(calibration_to_string(r.calibration) == calibration_to_string(held.calibration));
  REQUIRE(r.warnings.size() == held.warnings.size());
  for (std::size_t k = 0; k < r.warnings.size(); ++k)
    CHECK(r.warnings[k].message == held.warnings[k].message);
  // Sampling, the box search's coarse and fine passes, the surely-contact samples (frames with
  // a shadow box); an unlabelled frame only its sampling. Never held between them.
  for (std::size_t i = 0; i < lazy.size(); ++i) {
    INFO(i);
    CHECK(loads[i] == (i == 5 ? 1 : i == 6 ? 3 : 4));
  }
  // A loaded frame is checked as a given one is.
  lazy[3].load = [] { return cv::Mat(10, 12, CV_8UC3, cv::Scalar::all(90)); };
  try {
    calibrate_from_frames(f.empty, lazy);
    FAIL("a 12x10 touch frame was accepted");
  } catch (const InvalidArgument& e) {
    CHECK(std::string(e.what()).find("touch frame 3 is 12x10; expected the empty frames' size") !=
          std::string::npos);
  }
}

TEST_CASE("the segmenter from box labels meets the mask-fitted accuracy on other frames") {
  Segmenter seg({.calibration = fitted().calibration}); // the model comes with the calibration
  REQUIRE(seg.has_empty_skin());
  test::check_random_tracking_frames(seg);
}

TEST_CASE("the calibration file holds the empty-skin model; the loaded segmenter is the same") {
  const std::string dir = std::string(SHADOWSENSE_TEST_TMP_DIR) + "/calibration";
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/skin.calib";
  save_calibration(fitted().calibration, path);
  CHECK_FALSE(std::filesystem::exists(path + ".tmp"));
  const SegmenterCalibration loaded = load_calibration(path);
  // Exactly, the model included.
  CHECK(loaded == fitted().calibration);
  // Saved again, the loaded calibration gives the same bytes.
  CHECK(calibration_to_string(loaded) == read_all(path));
  Segmenter a({.calibration = fitted().calibration}), b({.calibration = loaded});
  sim::TrackingSampleConfig variety;
  for (int i = 0; i < 6; ++i) {
    const sim::Frame f = sim::render_random_tracking_frame(
        test::box_renderer(), static_cast<sim::TrackCategory>(i % 5), 0x5A4E + i, variety);
    const Segmentation sa = a.segment(f.image), sb = b.segment(f.image);
    CHECK(sa.shadow_box == sb.shadow_box);
    CHECK(sa.contact_box == sb.contact_box);
    CHECK(cv::countNonZero(sa.shadow_mask != sb.shadow_mask) == 0);
  }
}

TEST_CASE("a cut or changed calibration file is rejected with an error naming the file") {
  const std::string dir = std::string(SHADOWSENSE_TEST_TMP_DIR) + "/calibration";
  std::filesystem::create_directories(dir);
  const std::string good = calibration_to_string(fitted().calibration);
  const std::string path = dir + "/cut.calib";
  const std::size_t text_end = good.find("empty_skin");
  for (std::size_t cut : {std::size_t{0}, std::size_t{1}, std::size_t{40}, text_end - 3, text_end,
                          text_end + 20, good.size() / 2, good.size() - 14, good.size() - 1}) {
    CAPTURE(cut);
    write_all(path, good.substr(0, cut));
    CHECK_THROWS_WITH_AS(load_calibration(path), doctest::Contains(path.c_str()),
                         CalibrationFileError);
  }
  std::string flipped = good;
  flipped[good.size() / 2] ^= 0x10;
  write_all(path, flipped);
  CHECK_THROWS_WITH_AS(load_calibration(path), doctest::Contains("checksum mismatch"),
                       CalibrationFileError);
  // A folder is refused before reading, as is a missing file.
  CHECK_THROWS_WITH_AS(load_calibration(dir), doctest::Contains("not a regular file"), IoError);
  CHECK_THROWS_AS(load_calibration(dir + "/missing.calib"), IoError);
  // A failed save leaves the old file intact: the folder does not exist.
  CHECK_THROWS_AS(save_calibration(fitted().calibration, dir + "/no/such/dir/x.calib"), IoError);
}

TEST_CASE("degenerate input: warnings for what can still be used, refusal for the hopeless") {
  const Frames f = render_frames(0xDE6E, 3, 0);
  SUBCASE("empty frames only: the defaults for contact, a warning") {
    const CalibrationResult r = calibrate_from_frames(f.empty, {});
    REQUIRE(r.warnings.size() == 1);
    CHECK(r.warnings[0].issue == CalibrationIssue::no_touch_frames);
    CHECK(r.groups.size() == 3);
    CHECK_FALSE(r.calibration.empty_skin.empty());
  }
  SUBCASE("one light level: one group, no per-light rows") {
    const std::vector<cv::Mat> night(f.empty.begin() + 6, f.empty.end());
    const CalibrationResult r = calibrate_from_frames(night, {});
    CHECK(r.groups.size() == 1);
    CHECK(r.calibration.by_light.empty());
  }
  SUBCASE("touch boxes drawn on the empty skin: no shadow anywhere, refused") {
    std::vector<BoxLabelledFrame> fake;
    for (const cv::Mat& e : f.empty)
      fake.push_back({e, true, cv::Rect(50, 50, 80, 80), cv::Rect(80, 80, 20, 20)});
    CHECK_THROWS_WITH_AS(calibrate_from_frames(f.empty, fake),
                         doctest::Contains("no touch frame shows a shadow"), InvalidArgument);
  }
  SUBCASE("a light group without touch frames and too few contact pixels: warnings") {
    const Frames t = render_frames(0xDE6F, 0, 2); // hover + palm per light
    std::vector<BoxLabelledFrame> day(t.touch.begin(), t.touch.begin() + 2);
    day[1].contact_box = cv::Rect(day[1].contact_box->x, day[1].contact_box->y, 3, 3);
    const CalibrationResult r = calibrate_from_frames(f.empty, day);
    bool group_without = false, too_few = false;
    for (const CalibrationWarning& w : r.warnings) {
      group_without = group_without || w.issue == CalibrationIssue::light_group_without_touch;
      too_few = too_few || w.issue == CalibrationIssue::too_few_pixels;
    }
    CHECK(group_without);
    CHECK(too_few);
  }
  SUBCASE("bad input is refused naming the frame") {
    CHECK_THROWS_AS(calibrate_from_frames({}, {}), InvalidArgument);
    CHECK_THROWS_WITH_AS(
        calibrate_from_frames({cv::Mat(205, 200, CV_8UC3, cv::Scalar::all(0))}, {}),
        doctest::Contains("black"), InvalidArgument);
    std::vector<BoxLabelledFrame> outside{{f.empty[0], true, cv::Rect(190, 0, 20, 20), {}}};
    CHECK_THROWS_WITH_AS(calibrate_from_frames(f.empty, outside),
                         doctest::Contains("touch frame 0"), InvalidArgument);
    outside[0].name = "day/0001.png"; // a name replaces the index in messages
    CHECK_THROWS_WITH_AS(calibrate_from_frames(f.empty, outside),
                         "calibrate_from_frames: touch frame 'day/0001.png': a label box is empty "
                         "or reaches outside the image",
                         InvalidArgument);
  }
}

TEST_CASE(
    "unlabelled touch frames: clustering finds contact; the empty skin and hovers stay clear") {
  Frames f = render_frames(0xB0C5, 4, 16);
  for (BoxLabelledFrame& b : f.touch) b = {b.image, false, std::nullopt, std::nullopt};
  const CalibrationResult r = calibrate_from_frames(f.empty, f.touch);
  bool hover_taken = false;
  for (const CalibrationWarning& w : r.warnings)
    hover_taken = hover_taken || w.issue == CalibrationIssue::contact_not_separated;
  CHECK(hover_taken); // the hover frames (and some others) give no contact cluster
  Segmenter seg({.calibration = r.calibration});
  sim::TrackingSampleConfig variety;
  for (int c : {0, 1, 2, 4}) { // nothing, hover, palm, finger
    RunningStats contact_iou;
    int shadow_fp = 0, contact_fp = 0, contact_miss = 0;
    for (int i = 0; i < 12; ++i) {
      const sim::Frame fr = sim::render_random_tracking_frame(
          test::box_renderer(), static_cast<sim::TrackCategory>(c), 0x7E57 + 1000 * c + i, variety);
      const Segmentation s = seg.segment(fr.image);
      if (!fr.gt.shadow_box && s.shadow_box) ++shadow_fp;
      if (!fr.gt.contact_box && s.contact_box) ++contact_fp;
      if (fr.gt.contact_box) {
        if (s.contact_box)
          contact_iou.add(box_iou(*s.contact_box, *fr.gt.contact_box));
        else
          ++contact_miss;
      }
    }
    CAPTURE(c);
    CHECK(shadow_fp == 0);
    CHECK(contact_fp == 0);
    CHECK(contact_miss == 0);
    if (c >= 2) CHECK(contact_iou.mean() >= 0.9);
  }
}

TEST_CASE("load_calibration refuses devices and FIFOs before reading") {
  CHECK_THROWS_WITH_AS(load_calibration("/dev/zero"), doctest::Contains("not a regular file"),
                       IoError);
  const std::string fifo = std::string(SHADOWSENSE_TEST_TMP_DIR) + "/calibration/fifo";
  std::filesystem::create_directories(std::string(SHADOWSENSE_TEST_TMP_DIR) + "/calibration");
  std::filesystem::remove(fifo);
  if (std::system(("mkfifo '" + fifo + "'").c_str()) == 0)
    CHECK_THROWS_WITH_AS(load_calibration(fifo), doctest::Contains("not a regular file"),
                         IoError); // would hang if it were opened
}

TEST_CASE("a light level at the top of the reference range (luminance up to 256) is valid") {
  // Frame references are quarter-unit bins up to 256: a very bright skin reaches 255.875.
  SegmenterCalibration c;
  c.by_light = {{50.f, 0.3f, 0.5f, 0.f}, {255.875f, 0.4f, 0.45f, 0.f}};
  CHECK(calibration_from_string(calibration_to_string(c)) == c);
  c.by_light[1].luminance = 256.5f;
  CHECK_THROWS_AS(calibration_to_string(c), InvalidArgument);
}

TEST_CASE("the camera's scale is recorded as version 3; without one the file stays version 2") {
  SegmenterCalibration c = fitted().calibration;
  const std::string v2 = calibration_to_string(c);
  CHECK(v2.find("shadowsense_segmenter_calibration 2\n") != std::string::npos);
  CHECK(v2.find("px_per_cm") == std::string::npos);
  c.px_per_cm = 10.9921875f;
  const std::string v3 = calibration_to_string(c);
  CHECK(v3.find("shadowsense_segmenter_calibration 3\n") != std::string::npos);
  CHECK(v3.find("\npx_per_cm 10.9921875\n") != std::string::npos);
  const SegmenterCalibration back = calibration_from_string(v3, "v3");
  CHECK(back.px_per_cm == c.px_per_cm);
  CHECK(back == c);
  CHECK_FALSE(back == fitted().calibration); // the scale takes part in equality
  CHECK(calibration_from_string(v2, "v2").px_per_cm == 0);
  // The key needs version 3; a bad value is refused naming it (the checksum made right, so
  // the parser, not the checksum, decides).
  auto with_crc = [](std::string text) {
    text = text.substr(0, text.rfind("end "));
    return text + "end " + detail::crc_hex(detail::calibration_crc32(text.data(), text.size())) +
           "\n";
  };
  const std::size_t header = v3.find("calibration 3\n") + 12;
  std::string as_v2 = v3;
  as_v2[header] = '2';
  CHECK_THROWS_WITH_AS(calibration_from_string(with_crc(as_v2), "x"),
                       doctest::Contains("'px_per_cm' needs format version 3"),
                       CalibrationFileError);
  for (const char* bad : {"0", "-3", "0.01", "nan", "20000", "7 8", "abc"}) {
    CAPTURE(bad);
    std::string t = v3;
    const std::size_t at = t.find("px_per_cm 10.9921875");
    t.replace(at, std::string("px_per_cm 10.9921875").size(), std::string("px_per_cm ") + bad);
    CHECK_THROWS_WITH_AS(calibration_from_string(with_crc(t), "bad.calib"),
                         doctest::Contains("bad.calib"), CalibrationFileError);
  }
  c.px_per_cm = -1;
  CHECK_THROWS_WITH_AS(calibration_to_string(c), doctest::Contains("px_per_cm"), InvalidArgument);
}
