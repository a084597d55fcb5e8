// Shadow/contact segmentation on hand-built frames whose truth is known by construction:
// fabric with noise, a blurred neutral shadow and sharp warm contact discs.
#include <shadowsense/sense/calibration.hpp>
#include <shadowsense/sense/segmenter.hpp>

#include <doctest/doctest.h>

#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

using namespace shadowsense;

namespace {

struct Scene {
  cv::Mat image;   // BGR
  cv::Mat shadow;  // GT: opacity >= 0.5 (incl. contact)
  cv::Mat contact; // GT: contact pixels
};

// Fabric lit at `level`, a shadow of the given opacity map (neutral, 55 % darkening at full
// opacity), and contact discs (warm, dark).
Scene make_scene(cv::Size size, double level, const cv::Mat& opacity, const cv::Mat& contact,
                 unsigned seed = 1) {
  cv::Mat noise(size, CV_32FC3);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 2.5);
  Scene s;
  s.image.create(size, CV_8UC3);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const cv::Vec3f fabric(200, 206, 212);
      const float a = opacity.at<float>(y, x);
      cv::Vec3f p = fabric * static_cast<float>(level) * (1.f - 0.55f * a);
      if (contact.at<uchar>(y, x))
        p = cv::Vec3f(0.16f, 0.22f, 0.38f).mul(fabric) * static_cast<float>(level);
      p += noise.at<cv::Vec3f>(y, x) * static_cast<float>(level);
      s.image.at<cv::Vec3b>(y, x) =
          cv::Vec3b(cv::saturate_cast<uchar>(p[0]), cv::saturate_cast<uchar>(p[1]),
                    cv::saturate_cast<uchar>(p[2]));
    }
  s.shadow = opacity >= 0.5f;
  s.shadow.setTo(255, contact);
  s.contact = contact.clone();
  return s;
}

// Opacity of a blurred filled shape (drawn by `draw` on a 0/1 float canvas).
template <class Draw>
cv::Mat blurred_shape(cv::Size size, double sigma, Draw draw) {
  cv::Mat m = cv::Mat::zeros(size, CV_32F);
  draw(m);
  if (sigma > 0) cv::GaussianBlur(m, m, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
  return m;
}

cv::Rect box_of(const cv::Mat& mask) {
  return cv::boundingRect(mask);
}

Segmenter::Config test_config() {
  Segmenter::Config c;
  c.calibration.shadow_darkness = 0.25f;
  c.calibration.contact_darkness = 0.45f;
  c.calibration.contact_warmth = 0.08f;
  return c;
}

} // namespace

TEST_CASE("one contact inside a hand shadow: boxes and centroid match the construction") {
  const cv::Size size(200, 205);
  cv::Mat opacity = blurred_shape(size, 3.0, [](cv::Mat& m) {
    cv::ellipse(m, cv::Point(100, 110), cv::Size(35, 45), 0, 0, 360, 1.0, cv::FILLED);
  });
  cv::Mat contact = cv::Mat::zeros(size, CV_8UC1);
  cv::circle(contact, cv::Point(95, 100), 12, 255, cv::FILLED);
  const Scene s = make_scene(size, 1.0, opacity, contact);
  Segmenter seg(test_config());
  const Segmentation r = seg.segment(s.image);
  REQUIRE(r.shadow_box);
  REQUIRE(r.contact_box);
  REQUIRE(r.contact_point);
  const cv::Rect gs = box_of(s.shadow), gc = box_of(s.contact);
  CHECK(std::abs(r.shadow_box->x - gs.x) <= 1);
  CHECK(std::abs(r.shadow_box->y - gs.y) <= 1);
  CHECK(std::abs(r.shadow_box->br().x - gs.br().x) <= 1);
  CHECK(std::abs(r.shadow_box->br().y - gs.br().y) <= 1);
  CHECK(std::abs(r.contact_box->x - gc.x) <= 1);
  CHECK(std::abs(r.contact_box->br().x - gc.br().x) <= 1);
  CHECK(std::abs(r.contact_box->y - gc.y) <= 1);
  CHECK(std::abs(r.contact_box->br().y - gc.br().y) <= 1);
  CHECK(r.contact_point->x == doctest::Approx(95.0).epsilon(0.005));
  CHECK(r.contact_point->y == doctest::Approx(100.0).epsilon(0.005));
  REQUIRE(r.shadows.size() == 1);
  CHECK(r.shadows[0].touching);
  REQUIRE(r.contacts.size() == 1);
}

TEST_CASE("two simultaneous touches are two contact blobs") {
  const cv::Size size(200, 205);
  cv::Mat opacity = blurred_shape(size, 3.0, [](cv::Mat& m) {
    cv::ellipse(m, cv::Point(60, 100), cv::Size(30, 40), 0, 0, 360, 1.0, cv::FILLED);
    cv::ellipse(m, cv::Point(145, 100), cv::Size(30, 40), 0, 0, 360, 1.0, cv::FILLED);
  });
  cv::Mat contact = cv::Mat::zeros(size, CV_8UC1);
  cv::circle(contact, cv::Point(60, 95), 8, 255, cv::FILLED);
  cv::circle(contact, cv::Point(145, 105), 10, 255, cv::FILLED);
  const Scene s = make_scene(size, 0.8, opacity, contact, 7);
  Segmenter seg(test_config());
  const Segmentation r = seg.segment(s.image);
  REQUIRE(r.contacts.size() == 2);
  REQUIRE(r.shadows.size() == 2);
  // Sorted by area: the larger (r = 10) first.
  CHECK(r.contacts[0].centroid.x == doctest::Approx(145).epsilon(0.005));
  CHECK(r.contacts[0].centroid.y == doctest::Approx(105).epsilon(0.005));
  CHECK(r.contacts[1].centroid.x == doctest::Approx(60).epsilon(0.005));
  CHECK(r.contacts[1].centroid.y == doctest::Approx(95).epsilon(0.005));
  CHECK(r.shadows[0].touching);
  CHECK(r.shadows[1].touching);
  // The overall contact box spans both.
  CHECK(r.contact_box->x <= 53);
  CHECK(r.contact_box->br().x >= 155);
}

TEST_CASE("a touch at the image border and a shadow entering from outside the frame") {
  const cv::Size size(200, 205);
  // An arm from the left edge to a hand whose contact is cut by the top edge.
  cv::Mat opacity = blurred_shape(size, 2.0, [](cv::Mat& m) {
    cv::rectangle(m, cv::Rect(-10, 20, 110, 30), 1.0, cv::FILLED);
    cv::circle(m, cv::Point(110, 10), 30, 1.0, cv::FILLED);
  });
  cv::Mat contact = cv::Mat::zeros(size, CV_8UC1);
  cv::circle(contact, cv::Point(112, 2), 10, 255, cv::FILLED);
  const Scene s = make_scene(size, 1.0, opacity, contact, 3);
  Segmenter seg(test_config());
  const Segmentation r = seg.segment(s.image);
  REQUIRE(r.shadow_box);
  REQUIRE(r.contact_box);
  CHECK(r.shadow_box->x == 0);
  CHECK(r.shadow_box->y == 0);
  CHECK(r.contact_box->y == 0);
  const cv::Rect gc = box_of(s.contact);
  CHECK(std::abs(r.contact_box->x - gc.x) <= 1);
  CHECK(std::abs(r.contact_box->br().x - gc.br().x) <= 1);
  CHECK(std::abs(r.contact_box->br().y - gc.br().y) <= 1);
  const cv::Rect gs = box_of(s.shadow);
  CHECK(std::abs(r.shadow_box->br().x - gs.br().x) <= 1);
  CHECK(std::abs(r.shadow_box->br().y - gs.br().y) <= 1);
}

TEST_CASE("the empty skin gives nothing at any light level; hover gives a shadow but no contact") {
  const cv::Size size(120, 100);
  const cv::Mat none = cv::Mat::zeros(size, CV_32F);
  const cv::Mat no_contact = cv::Mat::zeros(size, CV_8UC1);
  Segmenter seg(test_config());
  for (double level : {1.0, 0.5, 0.15}) {
    const Segmentation r = seg.segment(make_scene(size, level, none, no_contact, 11).image);
    CHECK(r.shadows.empty());
    CHECK(r.contacts.empty());
    CHECK_FALSE(r.shadow_box);
    CHECK_FALSE(r.contact_point);
  }
  cv::Mat hover = blurred_shape(
      size, 5.0, [](cv::Mat& m) { cv::circle(m, cv::Point(60, 50), 25, 0.9, cv::FILLED); });
  const Segmentation h = seg.segment(make_scene(size, 0.6, hover, no_contact, 12).image);
  REQUIRE(h.shadows.size() == 1);
  CHECK_FALSE(h.shadows[0].touching);
  CHECK(h.contacts.empty());
}

TEST_CASE("relative mode keeps working when the light changes; the paper's fixed ranges do not") {
  const cv::Size size(160, 160);
  cv::Mat opacity = blurred_shape(
      size, 3.0, [](cv::Mat& m) { cv::circle(m, cv::Point(80, 80), 40, 1.0, cv::FILLED); });
  cv::Mat contact = cv::Mat::zeros(size, CV_8UC1);
  cv::circle(contact, cv::Point(80, 80), 12, 255, cv::FILLED);
  const Scene bright = make_scene(size, 1.0, opacity, contact, 5);
  const Scene dim = make_scene(size, 0.3, opacity, contact, 6);
  const cv::Mat empty_bright =
      make_scene(size, 1.0, cv::Mat::zeros(size, CV_32F), cv::Mat::zeros(size, CV_8UC1), 8).image;
  // Calibrate on the bright light only.
  const SegmenterCalibration cal =
      fit_calibration({empty_bright}, {LabelledFrame{bright.image, bright.shadow, bright.contact}});
  Segmenter::Config rel;
  rel.calibration = cal;
  Segmenter::Config fixed = rel;
  fixed.calibration.mode = SegmentMode::fixed_ranges;
  const cv::Rect gc = box_of(contact);
  for (const Scene* s : {&bright, &dim}) {
    const Segmentation r = Segmenter(rel).segment(s->image);
    REQUIRE(r.contact_box);
    CHECK(std::abs(r.contact_box->x - gc.x) <= 1);
    CHECK(std::abs(r.contact_box->width - gc.width) <= 2);
    REQUIRE(r.shadow_box);
    CHECK(std::abs(r.shadow_box->width - box_of(s->shadow).width) <= 2);
  }
  const Segmentation fb = Segmenter(fixed).segment(bright.image);
  REQUIRE(fb.contact_box);
  CHECK(std::abs(fb.contact_box->x - gc.x) <= 1);
  // In dim light the bright-light colour ranges miss the (now much darker) contact entirely.
  const Segmentation fd = Segmenter(fixed).segment(dim.image);
  CHECK_FALSE(fd.contact_box);
}

TEST_CASE("the adaptive mode follows a slow light change and a vignette") {
  const cv::Size size(120, 120);
  // A strong vignette: the corners get 45 % of the centre's light. A per-frame reference alone
  // would call the corners shadow; the per-pixel model does not.
  cv::Mat vignette(size, CV_32F);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const double r2 = ((x - 60.0) * (x - 60.0) + (y - 60.0) * (y - 60.0)) / (60.0 * 60.0 * 2);
      vignette.at<float>(y, x) = static_cast<float>(1.0 - 0.55 * r2);
    }
  auto frame = [&](double level, bool touch, unsigned seed) {
    cv::Mat op = cv::Mat::zeros(size, CV_32F);
    cv::Mat ct = cv::Mat::zeros(size, CV_8UC1);
    if (touch) {
      op = blurred_shape(size, 2.0,
                         [](cv::Mat& m) { cv::circle(m, cv::Point(60, 60), 20, 1.0, cv::FILLED); });
      cv::circle(ct, cv::Point(60, 60), 8, 255, cv::FILLED);
    }
    Scene s = make_scene(size, level, op, ct, seed);
    cv::Mat f;
    s.image.convertTo(f, CV_32FC3);
    cv::Mat v3;
    cv::merge(std::vector<cv::Mat>{vignette, vignette, vignette}, v3);
    f = f.mul(v3);
    f.convertTo(s.image, CV_8UC3);
    return s;
  };
  Segmenter::Config cfg = test_config();
  Segmenter plain(cfg);
  CHECK_FALSE(plain.segment(frame(1.0, false, 20).image).shadows.empty()); // corners look dark
  cfg.adaptive = true;
  Segmenter adaptive(cfg);
  adaptive.set_background(frame(1.0, false, 21).image);
  // The light falls by 1 % per frame to 70 %; the model keeps up and reports nothing.
  double level = 1.0;
  for (int i = 0; i < 30; ++i, level -= 0.01) {
    const Segmentation r =
        adaptive.segment(frame(level, false, 30 + static_cast<unsigned>(i)).image);
    CHECK(r.shadows.empty());
  }
  const Segmentation t = adaptive.segment(frame(level, true, 99).image);
  REQUIRE(t.contact_point);
  CHECK(t.contact_point->x == doctest::Approx(60).epsilon(0.01));
  CHECK(t.contact_point->y == doctest::Approx(60).epsilon(0.01));
  REQUIRE(t.shadows.size() == 1);
}

TEST_CASE("calibration text round-trips exactly and malformed files are rejected by line") {
  SegmenterCalibration c;
  c.mode = SegmentMode::fixed_ranges;
  c.shadow_range = {{1, 2, 3}, {100, 110, 120}};
  c.contact_range = {{4, 5, 6}, {90, 91, 92}};
  c.shadow_darkness = 0.123456f;
  c.contact_darkness = 0.5f;
  c.contact_warmth = -0.0625f;
  c.reference_percentile = 0.85f;
  CHECK(calibration_from_string(calibration_to_string(c)) == c);
  // Per-light thresholds: interpolated by the frame's reference luminance, clamped at the ends.
  c.by_light = {{50.f, 0.25f, 0.5f, 0.0f}, {150.f, 0.35f, 0.4f, 0.1f}};
  CHECK(c.thresholds_at(100.f).shadow_darkness == doctest::Approx(0.30));
  CHECK(c.thresholds_at(100.f).contact_darkness == doctest::Approx(0.45));
  CHECK(c.thresholds_at(125.f).contact_warmth == doctest::Approx(0.075));
  CHECK(c.thresholds_at(10.f) == c.by_light[0]);
  CHECK(c.thresholds_at(250.f) == c.by_light[1]);
  CHECK(calibration_from_string(calibration_to_string(c)) == c);
  // Line checks on the version-1 form (no end line, so edits are not caught by the checksum).
  auto version1 = [](std::string v2) {
    v2.replace(v2.find("calibration 2"), 13, "calibration 1");
    v2.erase(v2.rfind("end "));
    return v2;
  };
  CHECK(calibration_from_string(version1(calibration_to_string(c))) == c);
  CHECK_THROWS_WITH_AS(calibration_from_string(version1(calibration_to_string(c)) +
                                               "light_thresholds 100 0.3 0.4 0.1\n"),
                       doctest::Contains("greater than the previous row"), CalibrationFileError);
  c.by_light.clear();
  const std::string path = std::string(SHADOWSENSE_TEST_TMP_DIR) + "/calibration_roundtrip.txt";
  std::filesystem::create_directories(SHADOWSENSE_TEST_TMP_DIR);
  save_calibration(c, path);
  CHECK(load_calibration(path) == c);
  CHECK_THROWS_AS(load_calibration(path + ".missing"), IoError);

  const std::string good = version1(calibration_to_string(c));
  auto replace = [&](const std::string& from, const std::string& to) {
    std::string s = good;
    s.replace(s.find(from), from.size(), to);
    return s;
  };
  CHECK_THROWS_WITH_AS(calibration_from_string(""), doctest::Contains("empty"),
                       CalibrationFileError);
  CHECK_THROWS_WITH_AS(calibration_from_string(replace("calibration 1", "calibration 4")),
                       doctest::Contains("version 4"), CalibrationFileError);
  CHECK_THROWS_WITH_AS(calibration_from_string(replace("mode fixed_ranges", "mode magic")),
                       doctest::Contains("calibration:3: mode 'magic'"), CalibrationFileError);
  CHECK_THROWS_WITH_AS(calibration_from_string(replace("100 110 120", "100 110 320")),
                       doctest::Contains("outside 0..255"), CalibrationFileError);
  CHECK_THROWS_WITH_AS(calibration_from_string(replace("0.5\n", "0.5x\n")),
                       doctest::Contains("not a finite number"), CalibrationFileError);
  CHECK_THROWS_WITH_AS(calibration_from_string(replace("contact_warmth -0.0625\n", "")),
                       doctest::Contains("'contact_warmth' is missing"), CalibrationFileError);
  CHECK_THROWS_WITH_AS(
      calibration_from_string(replace("shadow_darkness 0.123456001", "shadow_darkness 1.5")),
      doctest::Contains("shadow_darkness must be in [0, 1]"), CalibrationFileError);
  CHECK_THROWS_WITH_AS(calibration_from_string(good + "reference_percentile 0.5\n"),
                       doctest::Contains("appears twice"), CalibrationFileError);
  CHECK_THROWS_WITH_AS(calibration_from_string(replace("1 2 3 100", "100 2 3 1")),
                       doctest::Contains("lower exceeds upper"), CalibrationFileError);
}

TEST_CASE("empty and wrong-type images, bad masks and bad configs are rejected") {
  Segmenter seg;
  CHECK_THROWS_WITH_AS(seg.segment(cv::Mat()), doctest::Contains("image is empty"),
                       InvalidArgument);
  CHECK_THROWS_WITH_AS(seg.segment(cv::Mat(10, 10, CV_8UC1, cv::Scalar(0))),
                       doctest::Contains("CV_8UC3"), InvalidArgument);
  CHECK_THROWS_AS(seg.segment(cv::Mat(10, 10, CV_32FC3, cv::Scalar(0))), InvalidArgument);
  CHECK_THROWS_AS(seg.set_background(cv::Mat()), InvalidArgument);
  const cv::Mat img(10, 10, CV_8UC3, cv::Scalar(100, 100, 100));
  CHECK_THROWS_AS(fit_calibration({}, {}), InvalidArgument);
  CHECK_THROWS_WITH_AS(
      fit_calibration({}, {LabelledFrame{img, cv::Mat(9, 10, CV_8UC1), cv::Mat(10, 10, CV_8UC1)}}),
      doctest::Contains("shadow_mask must be a CV_8UC1 mask"), InvalidArgument);
  CHECK_THROWS_AS(Segmenter({.mask_blur = 4}), InvalidArgument);
  Segmenter::Config bad;
  bad.calibration.contact_darkness = -0.1f;
  CHECK_THROWS_AS(Segmenter{bad}, InvalidArgument);
}

TEST_CASE("hover height from penumbra width and darkness: fit on some heights, predict others") {
  const cv::Size size(220, 220); // penumbra narrow against the shadow: the model's range
  // Constructed physics: the penumbra widens and the shadow fades as the hand rises.
  auto hover_blob = [&](double height_cm, unsigned seed) {
    const double sigma = 1.0 + 0.8 * height_cm, amplitude = 0.95 - 0.035 * height_cm;
    cv::Mat op = blurred_shape(size, sigma, [&](cv::Mat& m) {
      cv::circle(m, cv::Point(110, 110), 60, amplitude, cv::FILLED);
    });
    Segmenter::Config cfg = test_config();
    cfg.calibration.shadow_darkness = 0.1f;
    Segmenter seg(cfg);
    const Segmentation r =
        seg.segment(make_scene(size, 0.9, op, cv::Mat::zeros(size, CV_8UC1), seed).image);
    REQUIRE(r.shadows.size() == 1);
    CHECK_FALSE(r.shadows[0].touching);
    return r.shadows[0];
  };
  std::vector<HoverSample> samples;
  float last_width = 0;
  for (double h : {2.0, 5.0, 8.0, 11.0, 14.0}) {
    const Blob b = hover_blob(h, static_cast<unsigned>(h * 10));
    CHECK(b.edge_width > last_width); // monotone in height
    last_width = b.edge_width;
    samples.push_back({b.edge_width, b.opacity, h});
  }
  const HoverHeightModel model = fit_hover_height(samples);
  for (double h : {3.5, 9.5, 12.5}) {
    const Blob b = hover_blob(h, 500 + static_cast<unsigned>(h));
    CHECK(model.estimate(b.edge_width, b.opacity) == doctest::Approx(h).epsilon(0.1));
  }
  // With the model in the config, non-touching shadows carry the estimate.
  Segmenter::Config cfg = test_config();
  cfg.calibration.shadow_darkness = 0.1f;
  cfg.hover_model = model;
  cv::Mat op = blurred_shape(size, 1.0 + 0.8 * 6, [&](cv::Mat& m) {
    cv::circle(m, cv::Point(110, 110), 60, 0.95 - 0.035 * 6, cv::FILLED);
  });
  const Segmentation r =
      Segmenter(cfg).segment(make_scene(size, 0.9, op, cv::Mat::zeros(size, CV_8UC1), 77).image);
  REQUIRE(r.shadows.size() == 1);
  REQUIRE(r.shadows[0].hover_height_cm);
  CHECK(*r.shadows[0].hover_height_cm == doctest::Approx(6.0).epsilon(0.15));
  CHECK_THROWS_AS(fit_hover_height({samples[0], samples[1]}), InvalidArgument);
  CHECK_THROWS_AS(fit_hover_height({samples[0], samples[0], samples[0]}), InvalidArgument);
}
