// FrameEncoder: the one frame -> tensor path (lighting normalisation, the dark-frame rule,
// preprocessing), checked against the stages it is made of.
#include <shadowsense/classify/frame_encoder.hpp>
#include <shadowsense/sense/calibration_file.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

using namespace shadowsense;

namespace {
Tensor encode(FrameEncoder& enc, const cv::Mat& frame) {
  Tensor t;
  enc.run(frame, t);
  return t;
}
Tensor encode(FrameEncoder& enc, const cv::Mat& frame, bool dark) {
  Tensor t;
  enc.run(frame, dark, t);
  return t;
}
bool same(const Tensor& a, const Tensor& b) {
  return a.n() == b.n() && a.c() == b.c() && a.h() == b.h() && a.w() == b.w() &&
         std::equal(a.values().begin(), a.values().end(), b.values().begin());
}
} // namespace

TEST_CASE("mean luminance: 0.2989 R + 0.587 G + 0.114 B over the frame, in the input order") {
  PreprocessParams p;
  cv::Mat bgr(4, 6, CV_8UC3, cv::Scalar(255, 0, 0)); // pure blue in BGR
  FrameEncoder enc_bgr({p, ChannelOrder::bgr}), enc_rgb({p, ChannelOrder::rgb});
  CHECK(enc_bgr.mean_luminance(bgr) == doctest::Approx(0.114).epsilon(1e-9));
  CHECK(enc_rgb.mean_luminance(bgr) == doctest::Approx(0.2989).epsilon(1e-9)); // read as red
  cv::Mat half(4, 6, CV_8UC3, cv::Scalar::all(0));
  half(cv::Rect(0, 0, 3, 4)).setTo(cv::Scalar::all(255));
  CHECK(enc_bgr.mean_luminance(half) == doctest::Approx(0.5 * (0.2989 + 0.587 + 0.114)));
  cv::Mat f;
  half.convertTo(f, CV_32FC3, 1.0 / 255.0);
  CHECK(enc_bgr.mean_luminance(f) == doctest::Approx(enc_bgr.mean_luminance(half)));
  CHECK_THROWS_AS(enc_bgr.mean_luminance(cv::Mat(4, 4, CV_8UC1)), InvalidArgument);
}

TEST_CASE("the dark-frame rule: brightness factor exactly below the threshold") {
  PreprocessParams p;
  p.resize_width = p.resize_height = p.crop_width = p.crop_height = 0;
  p.dark_luminance_threshold = 0.2f;
  FrameEncoder enc({p, ChannelOrder::bgr});
  Preprocessor pre({p, ChannelOrder::bgr});
  cv::Mat dark(8, 8, CV_8UC3, cv::Scalar::all(40)); // 40/255 = 0.157 < 0.2
  cv::randu(dark(cv::Rect(0, 0, 4, 4)), cv::Scalar::all(30), cv::Scalar::all(50));
  cv::Mat bright(8, 8, CV_8UC3, cv::Scalar::all(60)); // 0.235 >= 0.2
  CHECK(enc.is_dark(dark));
  CHECK_FALSE(enc.is_dark(bright));
  CHECK(same(encode(enc, dark), pre(dark, true)));
  CHECK_FALSE(same(encode(enc, dark), pre(dark, false)));
  CHECK(same(encode(enc, bright), pre(bright, false)));
  CHECK(same(encode(enc, bright, true), pre(bright, true))); // the caller's flag wins
  p.dark_luminance_threshold = 0.0f;                         // rule off: never dark
  FrameEncoder never({p, ChannelOrder::bgr});
  CHECK_FALSE(never.is_dark(cv::Mat(8, 8, CV_8UC3, cv::Scalar::all(0))));
  CHECK(same(encode(never, dark), pre(dark, false)));
}

TEST_CASE("lighting normalisation from the params, or forced by the caller; never brightened") {
  PreprocessParams p;
  p.resize_width = p.resize_height = p.crop_width = p.crop_height = 0;
  p.dark_luminance_threshold = 1.0f; // every frame would be dark without normalisation
  cv::Mat frame(10, 12, CV_8UC3);
  cv::randu(frame, cv::Scalar::all(0), cv::Scalar::all(80));
  cv::Mat normalised;
  LightingNormaliser({.target = 0.3f}).run(frame, normalised);
  Preprocessor pre({p, ChannelOrder::bgr});
  const Tensor expected = pre(normalised, false);
  p.lighting_target = 0.3f;
  FrameEncoder off(p, false);
  CHECK_FALSE(off.lighting_normalise());
  CHECK(same(encode(off, frame), pre(frame, true)));
  FrameEncoder forced(p, true);
  CHECK(forced.lighting_normalise());
  CHECK(same(encode(forced, frame), expected));
  CHECK(same(encode(forced, frame, true), expected));
  p.lighting_normalise = true;
  FrameEncoder recorded(p, false); // false keeps the params' own setting
  CHECK(same(encode(recorded, frame), expected));
}

TEST_CASE("bad frames and parameters are rejected with the field named") {
  PreprocessParams p;
  p.dark_luminance_threshold = -0.1f;
  CHECK_THROWS_WITH_AS(FrameEncoder({p, ChannelOrder::bgr}),
                       doctest::Contains("dark luminance threshold"), InvalidArgument);
  p = {};
  p.resize_width = p.resize_height = 65536;
  CHECK_THROWS_WITH_AS(FrameEncoder({p, ChannelOrder::bgr}), doctest::Contains("1..4096"),
                       InvalidArgument);
  FrameEncoder enc;
  Tensor t;
  CHECK_THROWS_WITH_AS(enc.run(cv::Mat(), t), doctest::Contains("empty"), InvalidArgument);
  cv::Mat f(300, 400, CV_32FC3, cv::Scalar::all(128.0f));
  CHECK_THROWS_WITH_AS(enc.run(f, t), doctest::Contains("expected 0..1"), InvalidArgument);
}

TEST_CASE("LightingNormaliser::channel_sums: exact per-channel sums of 8-bit images") {
  // Against cv::sum (integer sums for 8-bit images): odd widths (a tail after the 16-pixel
  // steps), an ROI whose rows are not contiguous, rows of more than 256 steps of saturated
  // values (a 16-bit lane would overflow without its flush), and a tiny image.
  cv::Mat big(3, 5000, CV_8UC3, cv::Scalar(255, 254, 253));
  cv::Mat noise(37, 101, CV_8UC3);
  cv::theRNG().state = 11;
  cv::randu(noise, cv::Scalar::all(0), cv::Scalar::all(256));
  const cv::Mat roi = noise(cv::Rect(3, 2, 61, 30));
  REQUIRE_FALSE(roi.isContinuous());
  for (const cv::Mat& m : {big, noise, roi, cv::Mat(1, 1, CV_8UC3, cv::Scalar(1, 2, 3))}) {
    const auto got = LightingNormaliser::channel_sums(m);
    const cv::Scalar want = cv::sum(m);
    for (std::size_t c = 0; c < 3; ++c) CHECK(double(got[c]) == want[int(c)]);
  }
  CHECK(LightingNormaliser::channel_sums(big)[0] == 255ull * 3 * 5000);
}

TEST_CASE("8-bit frames: the table path (normalise while resizing) equals the float path bit for "
          "bit") {
  // The float path, written out: ToTensor, per-channel means (the exact mean of v / 255: the
  // integer sum over 255 n), gain, clamp; then the Preprocessor's float-image path (resize,
  // crop, contrast, Normalize).
  auto reference_normalise = [](const cv::Mat& bgr, float target) {
    cv::Mat out(bgr.rows, bgr.cols, CV_32FC3);
    std::uint64_t sum[3] = {0, 0, 0};
    for (int y = 0; y < bgr.rows; ++y)
      for (int x = 0; x < bgr.cols; ++x)
        for (int c = 0; c < 3; ++c) {
          const unsigned char v = bgr.ptr<unsigned char>(y)[3 * x + c];
          out.ptr<float>(y)[3 * x + c] = static_cast<float>(v) / 255.0f;
          sum[c] += v;
        }
    const double n = double(bgr.rows) * bgr.cols;
    for (int c = 0; c < 3; ++c) {
      const double mean = double(sum[c]) / (255.0 * n);
      const float gain = target / std::max(static_cast<float>(mean), 1e-3f);
      for (int y = 0; y < bgr.rows; ++y)
        for (int x = 0; x < bgr.cols; ++x) {
          float& v = out.ptr<float>(y)[3 * x + c];
          v = std::clamp(v * gain, 0.0f, 1.0f);
        }
    }
    return out;
  };
  PreprocessParams p;
  p.resize_width = 41;
  p.resize_height = 29;
  p.crop_width = 36;
  p.crop_height = 24;
  p.lighting_target = 0.4f;
  for (const int seed : {1, 2, 3}) {
    cv::Mat frame(57, 83, CV_8UC3);
    cv::theRNG().state = static_cast<std::uint64_t>(seed);
    cv::randu(frame, cv::Scalar::all(0), cv::Scalar::all(seed == 3 ? 40 : 256));
    Preprocessor pre({p, ChannelOrder::bgr});
    cv::Mat unit;
    frame.convertTo(unit, CV_32FC3, 1.0 / 255.0); // differs from x / 255.0f: rebuilt below
    for (int y = 0; y < frame.rows; ++y)
      for (int x = 0; x < frame.cols * 3; ++x)
        unit.ptr<float>(y)[x] = static_cast<float>(frame.ptr<unsigned char>(y)[x]) / 255.0f;
    CHECK(same(pre(frame, seed == 2), pre(unit, seed == 2))); // ToTensor through the table
    FrameEncoder enc(p, true);
    CHECK(same(encode(enc, frame), pre(reference_normalise(frame, 0.4f), false)));
    cv::Mat normalised;
    LightingNormaliser({.target = 0.4f}).run(frame, normalised);
    const cv::Mat ref = reference_normalise(frame, 0.4f);
    CHECK(cv::countNonZero(normalised.reshape(1) != ref.reshape(1)) == 0);
  }
}

namespace {
// An identity Preprocessor (no resize or crop, contrast 1, mean 0, std 1, no dark rule): the
// tensor then holds the encoded image itself, in RGB planes.
PreprocessParams identity_params(InputEncoding e) {
  PreprocessParams p;
  p.resize_width = p.resize_height = p.crop_width = p.crop_height = 0;
  p.contrast_factor = 1.0f;
  p.mean = {0, 0, 0};
  p.std = {1, 1, 1};
  p.dark_luminance_threshold = 0.0f;
  p.input_encoding = e;
  return p;
}
} // namespace

TEST_CASE("skin_relative: the frame over the empty-skin model, 0 off the skin, clipped at 1") {
  const PreprocessParams p = identity_params(InputEncoding::skin_relative);
  cv::Mat model(2, 3, CV_32FC3, cv::Scalar(0.8, 0.8, 0.8)); // BGR
  model.at<cv::Vec3f>(0, 1) = {0.2f, 0.2f, 0.2f};           // not skin: sum 0.6 < 1.5
  model.at<cv::Vec3f>(0, 2) = {0.05f, 0.7f, 0.75f};         // skin (sum 1.5), B under the floor
  model.at<cv::Vec3f>(1, 0) = {0.5f, 0.5f, 0.5f};           // skin exactly at the test
  cv::Mat frame(2, 3, CV_8UC3, cv::Scalar(128, 64, 255));
  FrameEncoder enc({p, ChannelOrder::bgr, model});
  const Tensor t = encode(enc, frame);
  REQUIRE(t.h() == 2);
  REQUIRE(t.w() == 3);
  const float b = 128.0f / 255.0f, g = 64.0f / 255.0f, r = 255.0f / 255.0f;
  // (0, 0): plain division; R clipped (1 / 0.8 > 1). Planes are R, G, B.
  CHECK(t(0, 0, 0, 0) == 1.0f);
  CHECK(r / 0.8f > 1.0f);
  CHECK(t(0, 1, 0, 0) == g / 0.8f);
  CHECK(t(0, 2, 0, 0) == b / 0.8f);
  for (int c = 0; c < 3; ++c) CHECK(t(0, c, 0, 1) == 0.0f); // off the skin
  CHECK(t(0, 2, 0, 2) == std::min(b / 0.125f, 1.0f));       // the floor 0.125
  CHECK(t(0, 1, 0, 2) == g / 0.7f);
  CHECK(t(0, 0, 0, 2) == 1.0f);
  CHECK(t(0, 1, 1, 0) == g / 0.5f);
  CHECK(t(0, 2, 1, 0) == std::min(b / 0.5f, 1.0f));
  // encode_input is stage 0 alone, in the input order.
  cv::Mat e;
  enc.encode_input(frame, e);
  CHECK(e.at<cv::Vec3f>(0, 0)[1] == g / 0.8f);
  CHECK(e.at<cv::Vec3f>(0, 1) == cv::Vec3f(0, 0, 0));
  // A float frame in 0..1 gives the same values as its 8-bit original.
  cv::Mat unit(frame.size(), CV_32FC3);
  for (int y = 0; y < frame.rows; ++y)
    for (int x = 0; x < frame.cols * 3; ++x)
      unit.ptr<float>(y)[x] = static_cast<float>(frame.ptr<unsigned char>(y)[x]) / 255.0f;
  CHECK(same(encode(enc, unit), t));
  // RGB input: the same numbers on the channel-swapped frame (the model stays BGR).
  cv::Mat rgb;
  cv::cvtColor(frame, rgb, cv::COLOR_BGR2RGB);
  FrameEncoder enc_rgb({p, ChannelOrder::rgb, model});
  CHECK(same(encode(enc_rgb, rgb), t));
}

TEST_CASE("skin_relative: the model is resized to the frame; then the Preprocessor as usual") {
  PreprocessParams p; // the paper's geometry and photometrics
  p.resize_width = 41;
  p.resize_height = 29;
  p.crop_width = 36;
  p.crop_height = 24;
  p.input_encoding = InputEncoding::skin_relative;
  cv::Mat model(20, 30, CV_32FC3);
  cv::theRNG().state = 5;
  cv::randu(model, cv::Scalar::all(0.3), cv::Scalar::all(1.2));
  cv::Mat frame(57, 83, CV_8UC3);
  cv::randu(frame, cv::Scalar::all(0), cv::Scalar::all(256));
  cv::Mat big;
  cv::resize(model, big, frame.size(), 0, 0, cv::INTER_LINEAR);
  FrameEncoder small({p, ChannelOrder::bgr, model}), sized({p, ChannelOrder::bgr, big});
  CHECK(same(encode(small, frame), encode(sized, frame)));
  // The stages: encode_input, then the Preprocessor on the float image with the frame's own
  // dark flag (the rule reads the frame, not the encoded image).
  cv::Mat e;
  sized.encode_input(frame, e);
  Preprocessor pre({p, ChannelOrder::bgr});
  for (const bool dark : {false, true}) CHECK(same(encode(sized, frame, dark), pre(e, dark)));
  cv::Mat night = frame / 8; // dark by the rule
  REQUIRE(sized.is_dark(night));
  sized.encode_input(night, e);
  CHECK(same(encode(sized, night), pre(e, true)));
  // With lighting normalisation: the encoded image is normalised, never brightened.
  p.lighting_normalise = true;
  FrameEncoder norm({p, ChannelOrder::bgr, big});
  norm.encode_input(night, e);
  cv::Mat n;
  LightingNormaliser({.target = p.lighting_target}).run(e, n);
  CHECK(same(encode(norm, night, true), pre(n, false)));
}

TEST_CASE("skin_relative without a calibration is refused; colour ignores one") {
  const PreprocessParams p = identity_params(InputEncoding::skin_relative);
  CHECK_THROWS_WITH_AS(FrameEncoder({p, ChannelOrder::bgr}),
                       doctest::Contains("input encoding is skin_relative, which needs a "
                                         "calibration with an empty-skin model"),
                       InvalidArgument);
  CHECK_THROWS_WITH_AS(FrameEncoder::require_empty_skin(InputEncoding::skin_relative, false),
                       doctest::Contains("--calibration FILE"), InvalidArgument);
  CHECK_NOTHROW(FrameEncoder::require_empty_skin(InputEncoding::colour, false));
  const cv::Mat model(4, 4, CV_32FC3, cv::Scalar::all(1.0));
  FrameEncoder enc({p, ChannelOrder::bgr, model});
  CHECK_THROWS_AS(enc.set_empty_skin(cv::Mat()), InvalidArgument);
  CHECK_THROWS_WITH_AS(enc.set_empty_skin(cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(200))),
                       doctest::Contains("expected CV_32FC3"), InvalidArgument);
  CHECK_THROWS_WITH_AS(enc.set_empty_skin(cv::Mat(4, 4, CV_32FC3, cv::Scalar::all(200))),
                       doctest::Contains("outside [0, 8]"), InvalidArgument);
  cv::Mat nan_model = model.clone();
  nan_model.at<cv::Vec3f>(1, 1)[0] = std::nanf("");
  CHECK_THROWS_AS(enc.set_empty_skin(nan_model), InvalidArgument);
  cv::Mat f(4, 4, CV_32FC3, cv::Scalar::all(2.0)); // a float frame outside 0..1
  Tensor t;
  CHECK_THROWS_WITH_AS(enc.run(f, t), doctest::Contains("expected 0..1"), InvalidArgument);
  // Colour: a model given or not, the same bits (every existing model file is colour).
  const PreprocessParams c = identity_params(InputEncoding::colour);
  FrameEncoder plain({c, ChannelOrder::bgr}), with({c, ChannelOrder::bgr, model});
  cv::Mat frame(4, 4, CV_8UC3, cv::Scalar(10, 200, 90));
  CHECK(same(encode(plain, frame), encode(with, frame)));
  CHECK_THROWS_AS(plain.encode_input(frame, f), InvalidArgument);
}

namespace {
// A lit skin for darkness_warmth: the model times a light level (float frame), with a shadow
// (all channels x 0.3) and a contact (green and blue x 0.35, red kept). Light levels of the
// form (b + 0.5) / 512 are the reference's bin centres, so the reference is the level itself.
struct LitSkin {
  cv::Mat model{30, 40, CV_32FC3, cv::Scalar(0.9, 0.8, 0.7)}; // BGR
  cv::Rect shadow{5, 10, 8, 6}, contact{25, 18, 8, 7};
  LitSkin() { model.rowRange(0, 3).setTo(cv::Scalar::all(0.2)); } // not skin: sum 0.6 < 1.5
  cv::Mat frame(float level) const {
    cv::Mat f = model * level;
    f(shadow) *= 0.3;
    cv::Mat c = f(contact);
    c.forEach<cv::Vec3f>([](cv::Vec3f& v, const int*) { v[0] *= 0.35f, v[1] *= 0.35f; });
    return f;
  }
};
} // namespace

TEST_CASE("darkness_warmth: the pixel rule's darkness and warmth over the lit skin, any light") {
  const PreprocessParams p = identity_params(InputEncoding::darkness_warmth);
  const LitSkin skin;
  FrameEncoder enc({p, ChannelOrder::bgr, skin.model});
  const Tensor bright = encode(enc, skin.frame(409.5f / 512)),
               dim = encode(enc, skin.frame(204.5f / 512));
  REQUIRE(bright.h() == 30);
  // Planes: darkness, warmth, skin.
  auto at = [](const Tensor& t, int c, cv::Point q) { return t(0, c, q.y, q.x); };
  for (const Tensor* t : {&bright, &dim}) {
    const cv::Point lit(20, 5), shade(7, 12), touch(28, 20), off(20, 1);
    CHECK(at(*t, 0, lit) <= 1e-5f);
    CHECK(at(*t, 1, lit) == doctest::Approx(0.5).epsilon(1e-5));
    CHECK(at(*t, 2, lit) == 1.0f);
    CHECK(at(*t, 0, shade) == doctest::Approx(0.7).epsilon(1e-5));
    CHECK(at(*t, 1, shade) == doctest::Approx(0.5).epsilon(1e-5));
    CHECK(at(*t, 0, touch) == doctest::Approx(1.0 - (0.35 + 0.35 + 1.0) / 3).epsilon(1e-5));
    CHECK(at(*t, 1, touch) == doctest::Approx(0.5 + 0.5 * (1.0 - 0.35)).epsilon(1e-5));
    for (int c = 0; c < 3; ++c) CHECK(at(*t, c, off) == 0.0f); // off the skin
  }
  // The light is divided out: half the light, the same maps.
  double worst = 0;
  for (std::size_t i = 0; i < bright.size(); ++i)
    worst = std::max(worst, double(std::abs(bright.data()[i] - dim.data()[i])));
  CHECK(worst <= 1e-5);
  // Never dark: the caller's dark flag changes nothing (no brightness factor).
  const cv::Mat frame = skin.frame(0.3f);
  CHECK(same(encode(enc, frame, true), encode(enc, frame, false)));
  // RGB input: the same planes from the channel-swapped frame (the model stays BGR).
  cv::Mat rgb;
  cv::cvtColor(frame, rgb, cv::COLOR_BGR2RGB);
  FrameEncoder enc_rgb({p, ChannelOrder::rgb, skin.model});
  CHECK(same(encode(enc_rgb, rgb), encode(enc, frame)));
  // A model with no skin at all: every plane 0, no reference to take.
  FrameEncoder none({p, ChannelOrder::bgr, cv::Mat(30, 40, CV_32FC3, cv::Scalar::all(0.2))});
  const Tensor z = encode(none, frame);
  CHECK(std::all_of(z.values().begin(), z.values().end(), [](float v) { return v == 0.0f; }));
}

TEST_CASE("darkness_warmth is refused without a calibration and with lighting normalisation") {
  PreprocessParams p = identity_params(InputEncoding::darkness_warmth);
  CHECK_THROWS_WITH_AS(FrameEncoder({p, ChannelOrder::bgr}),
                       doctest::Contains("input encoding is darkness_warmth, which needs a "
                                         "calibration with an empty-skin model"),
                       InvalidArgument);
  const cv::Mat model(4, 4, CV_32FC3, cv::Scalar::all(1.0));
  CHECK_THROWS_WITH_AS(FrameEncoder(p, true, model),
                       doctest::Contains("--lighting-normalise) with a model whose input encoding "
                                         "is darkness_warmth"),
                       InvalidArgument);
  p.lighting_normalise = true;
  CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("takes no lighting normalisation"),
                       InvalidArgument);
  CHECK(parse_input_encoding("darkness_warmth") == InputEncoding::darkness_warmth);
  CHECK(std::string(to_string(InputEncoding::darkness_warmth)) == "darkness_warmth");
}

namespace {
// A lit skin for masks (8-bit BGR, 120 x 160): a textured empty skin (every pixel's own level,
// so the segmenter's smoothed profile and the model differ), the top 10 rows not skin, a
// shadow (all channels x 0.4: darkness 0.6) and a contact inside it (B, G x 0.3, R x 0.8).
struct MaskSkin {
  cv::Mat model = cv::Mat(120, 160, CV_32FC3); // BGR, relative brightness
  cv::Rect shadow{20, 30, 40, 30}, contact{100, 60, 20, 16};
  MaskSkin() {
    model.forEach<cv::Vec3f>([](cv::Vec3f& v, const int* at) {
      const float t = 0.9f + 0.1f * float((at[0] * 7 + at[1] * 3) % 5) / 4.0f;
      v = cv::Vec3f(0.85f * t, 0.9f * t, 1.0f * t);
    });
    model.rowRange(0, 10).setTo(cv::Scalar::all(0.1));
  }
  cv::Mat frame(float level) const {
    cv::Mat f = model * level;
    f(shadow) *= 0.4;
    f(contact).forEach<cv::Vec3f>(
        [](cv::Vec3f& v, const int*) { v[0] *= 0.3f, v[1] *= 0.3f, v[2] *= 0.8f; });
    cv::Mat out;
    f.convertTo(out, CV_8UC3, 255.0);
    return out;
  }
};
// The segmenter the masks encoding is defined by: default config and thresholds, the model.
Segmentation segment_with(const cv::Mat& model, const cv::Mat& bgr) {
  SegmenterConfig c;
  c.calibration.empty_skin = model;
  Segmenter seg(c);
  return seg.segment(bgr);
}
} // namespace

TEST_CASE("masks: the segmenter's shadow and contact masks beside the skin test, as 0 / 1") {
  const PreprocessParams p = identity_params(InputEncoding::masks);
  const MaskSkin skin;
  FrameEncoder enc({p, ChannelOrder::bgr, skin.model});
  const cv::Mat frame = skin.frame(0.8f);
  const Tensor t = encode(enc, frame);
  REQUIRE(t.h() == 120);
  REQUIRE(t.w() == 160);
  // Plane by plane (RGB planes: shadow, contact, skin), the segmenter's own masks.
  const Segmentation s = segment_with(skin.model, frame);
  REQUIRE(s.shadows.size() == 2); // the contact is dark too: a shadow blob of its own
  REQUIRE(s.contacts.size() == 1);
  long differ = 0, shadow_px = 0, contact_px = 0;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) {
      const float sh = s.shadow_mask.at<unsigned char>(y, x) ? 1.0f : 0.0f;
      const float co = s.contact_mask.at<unsigned char>(y, x) ? 1.0f : 0.0f;
      const float sk = y >= 10 ? 1.0f : 0.0f;
      differ += t(0, 0, y, x) != sh || t(0, 1, y, x) != co || t(0, 2, y, x) != sk;
      shadow_px += sh > 0, contact_px += co > 0;
    }
  CHECK(differ == 0);
  // The scene's ground truth: the shadow and the contact are where they were drawn.
  CHECK(t(0, 0, 45, 40) == 1.0f);
  CHECK(t(0, 1, 45, 40) == 0.0f);
  CHECK(t(0, 1, 68, 110) == 1.0f);
  CHECK(t(0, 0, 100, 140) == 0.0f);
  CHECK(t(0, 1, 100, 140) == 0.0f);
  CHECK(shadow_px >= 1000); // 40 x 30 drawn, less the blurred corners
  CHECK(contact_px >= 250); // 20 x 16 drawn
  // Independent of the light: a darker frame, the same masks; the dark flag changes nothing.
  CHECK(same(encode(enc, skin.frame(0.5f)), t));
  CHECK(same(encode(enc, frame, true), t));
  // A float RGB frame holding the same 8-bit values: the same image.
  cv::Mat rgb, rgb_float;
  cv::cvtColor(frame, rgb, cv::COLOR_BGR2RGB);
  rgb.convertTo(rgb_float, CV_32FC3, 1.0 / 255.0);
  FrameEncoder enc_rgb({p, ChannelOrder::rgb, skin.model});
  CHECK(same(encode(enc_rgb, rgb_float), t));
  // A model of another size is resized to the frame first (bilinear), as for the other
  // encodings; the segmenter then works at the frame's size.
  cv::Mat half;
  cv::resize(skin.model, half, cv::Size(80, 60), 0, 0, cv::INTER_AREA);
  FrameEncoder enc_half({p, ChannelOrder::bgr, half});
  cv::Mat up;
  cv::resize(half, up, frame.size(), 0, 0, cv::INTER_LINEAR);
  const Segmentation su = segment_with(up, frame);
  const Tensor th = encode(enc_half, frame);
  long differ_half = 0;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x)
      differ_half += th(0, 0, y, x) != (su.shadow_mask.at<unsigned char>(y, x) ? 1.0f : 0.0f) ||
                     th(0, 1, y, x) != (su.contact_mask.at<unsigned char>(y, x) ? 1.0f : 0.0f);
  CHECK(differ_half == 0);
  // encode_input gives the image itself (BGR slots).
  cv::Mat e;
  enc.encode_input(frame, e);
  CHECK(e.type() == CV_32FC3);
  CHECK(e.at<cv::Vec3f>(45, 40) == cv::Vec3f(1.0f, 0.0f, 1.0f));
  CHECK(e.at<cv::Vec3f>(68, 110) == cv::Vec3f(1.0f, 1.0f, 1.0f));
  CHECK(e.at<cv::Vec3f>(5, 5) == cv::Vec3f(0.0f, 0.0f, 0.0f));
}

TEST_CASE("darkness_contact: darkness_warmth's darkness and skin, the masks' contact plane") {
  const MaskSkin skin;
  const cv::Mat frame = skin.frame(0.8f);
  FrameEncoder dc(
      {identity_params(InputEncoding::darkness_contact), ChannelOrder::bgr, skin.model}),
      dw({identity_params(InputEncoding::darkness_warmth), ChannelOrder::bgr, skin.model}),
      mk({identity_params(InputEncoding::masks), ChannelOrder::bgr, skin.model});
  const Tensor c = encode(dc, frame), d = encode(dw, frame), m = encode(mk, frame);
  REQUIRE(c.size() == d.size());
  const std::size_t plane = static_cast<std::size_t>(c.h() * c.w());
  auto equal_plane = [&](const Tensor& a, int pa, const Tensor& b, int pb) {
    return std::equal(a.data() + pa * plane, a.data() + (pa + 1) * plane, b.data() + pb * plane);
  };
  CHECK(equal_plane(c, 0, d, 0)); // darkness
  CHECK(equal_plane(c, 1, m, 1)); // the contact mask
  CHECK(equal_plane(c, 2, d, 2)); // skin
  CHECK(c(0, 1, 68, 110) == 1.0f);
  CHECK(c(0, 1, 45, 40) == 0.0f); // shadow, no contact
  CHECK(c(0, 0, 45, 40) == doctest::Approx(0.6).epsilon(0.02));
  // Light-independent: the dark flag changes nothing; lighting normalisation is refused.
  CHECK(same(encode(dc, frame, true), c));
  CHECK_THROWS_WITH_AS(
      FrameEncoder(identity_params(InputEncoding::darkness_contact), true, skin.model),
      doctest::Contains("whose input encoding is darkness_contact"), InvalidArgument);
  CHECK_THROWS_WITH_AS(
      FrameEncoder({identity_params(InputEncoding::darkness_contact), ChannelOrder::bgr}),
      doctest::Contains("darkness_contact, which needs a calibration"), InvalidArgument);
  CHECK(parse_input_encoding("darkness_contact") == InputEncoding::darkness_contact);
  CHECK(light_independent(InputEncoding::darkness_contact));
}

TEST_CASE("masks is refused without a calibration and with lighting normalisation") {
  PreprocessParams p = identity_params(InputEncoding::masks);
  CHECK_THROWS_WITH_AS(FrameEncoder({p, ChannelOrder::bgr}),
                       doctest::Contains("input encoding is masks, which needs a calibration"),
                       InvalidArgument);
  const MaskSkin skin;
  CHECK_THROWS_WITH_AS(FrameEncoder(p, true, skin.model),
                       doctest::Contains("whose input encoding is masks"), InvalidArgument);
  FrameEncoder enc({p, ChannelOrder::bgr, skin.model});
  CHECK_THROWS_AS(enc.set_empty_skin(cv::Mat()), InvalidArgument);
  // A frame the segmenter refuses is named, not segmented.
  Tensor t;
  CHECK_THROWS_AS(enc.run(cv::Mat(120, 160, CV_32FC3, cv::Scalar::all(1.5)), t), InvalidArgument);
  p.lighting_normalise = true;
  CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("masks input encoding is already"),
                       InvalidArgument);
  CHECK(parse_input_encoding("masks") == InputEncoding::masks);
  CHECK(std::string(to_string(InputEncoding::masks)) == "masks");
  CHECK(light_independent(InputEncoding::masks));
  CHECK(!light_independent(InputEncoding::skin_relative));
}

namespace {
// Reads a golden file of tools/make_encoding_fixture.py (its docstring has the format) and
// encodes every case with `encoding`; returns the largest differences from train.py's stage 0
// and network input.
struct GoldenDiff {
  int cases = 0;
  double stage0 = 0, tensor = 0;
};
GoldenDiff golden_diff(const char* path, InputEncoding encoding) {
  // The calibration file was written by tools/calibration_file.py, so the C++ reader is checked
  // on the Python writer.
  const SegmenterCalibration cal =
      load_calibration(SHADOWSENSE_TEST_DATA_DIR "/encoding_calibration.calib");
  REQUIRE(cal.empty_skin.size() == cv::Size(40, 30));
  std::ifstream f(path, std::ios::binary);
  REQUIRE(f.good());
  const std::vector<char> b((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  std::size_t at = 0;
  auto take = [&](void* to, std::size_t n) {
    REQUIRE(at + n <= b.size());
    std::memcpy(to, b.data() + at, n);
    at += n;
  };
  auto u32 = [&] {
    std::uint32_t v = 0;
    take(&v, 4);
    return static_cast<int>(v);
  };
  auto f32 = [&] {
    float v = 0;
    take(&v, 4);
    return v;
  };
  GoldenDiff worst;
  worst.cases = u32();
  for (int k = 0; k < worst.cases; ++k) {
    const int h = u32(), w = u32();
    const bool dark = u32() != 0;
    PreprocessParams p;
    p.lighting_normalise = u32() != 0;
    p.resize_width = u32();
    p.resize_height = u32();
    p.crop_width = u32();
    p.crop_height = u32();
    p.contrast_factor = f32();
    p.dark_brightness_factor = f32();
    p.input_encoding = encoding;
    cv::Mat frame(h, w, CV_8UC3), expected_stage0(h, w, CV_32FC3);
    take(frame.data, frame.total() * 3);
    take(expected_stage0.data, expected_stage0.total() * 3 * 4);
    const int oh = u32(), ow = u32();
    Tensor expected;
    expected.resize(1, 3, oh, ow);
    take(expected.data(), expected.size() * 4);
    FrameEncoder enc({p, ChannelOrder::bgr, cal.empty_skin});
    cv::Mat stage0;
    enc.encode_input(frame, stage0);
    worst.stage0 = std::max(worst.stage0, cv::norm(stage0, expected_stage0, cv::NORM_INF));
    Tensor got;
    enc.run(frame, dark, got);
    REQUIRE(got.h() == oh);
    REQUIRE(got.w() == ow);
    double d = 0;
    for (std::size_t i = 0; i < got.size(); ++i)
      d = std::max(d, double(std::abs(got.data()[i] - expected.data()[i])));
    worst.tensor = std::max(worst.tensor, d);
  }
  CHECK(at == b.size());
  return worst;
}
} // namespace

TEST_CASE("skin_relative golden: the C++ encoder equals tools/train.py's encoding") {
  // Six frames encoded by train.py's functions, at the model's size and resized, plain, dark
  // and lighting-normalised.
  const GoldenDiff d =
      golden_diff(SHADOWSENSE_TEST_DATA_DIR "/encoding_golden.bin", InputEncoding::skin_relative);
  CHECK(d.cases == 6);
  MESSAGE("skin_relative vs train.py: stage 0 max abs diff "
          << d.stage0 << ", network input max abs diff " << d.tensor);
  // Stage 0 is the same float operations in the same order (cv2.resize is OpenCV's resize):
  // the same bits. The rest is the Preprocessor's golden bound (test_preprocess.cpp).
  CHECK(d.stage0 == 0.0);
  CHECK(d.tensor <= 1e-5);
}

TEST_CASE("darkness_warmth golden: the C++ encoder equals tools/train.py's encoding") {
  // Random frames (plain and with the dark flag, which must be ignored), lit skin with a
  // shadow and a contact at two light levels, and a black frame.
  const GoldenDiff d = golden_diff(SHADOWSENSE_TEST_DATA_DIR "/encoding_golden_darkness_warmth.bin",
                                   InputEncoding::darkness_warmth);
  CHECK(d.cases == 7);
  MESSAGE("darkness_warmth vs train.py: stage 0 max abs diff "
          << d.stage0 << ", network input max abs diff " << d.tensor);
  // The reference is an integer histogram and every float operation is train.py's, in its
  // order: the same bits at stage 0.
  CHECK(d.stage0 == 0.0);
  CHECK(d.tensor <= 1e-5);
}

namespace {
// The bounding box of the pixels above 128 in channel 0 (the test's white rectangle).
cv::Rect bright_box(const cv::Mat& img) {
  cv::Mat ch;
  cv::extractChannel(img, ch, 0);
  return cv::boundingRect(ch > 128);
}
// A black 635 x 350 frame (the network's frame size) with a white w x h rectangle at its centre.
cv::Mat rectangle_frame(int w, int h, cv::Size size = {635, 350}) {
  cv::Mat f(size, CV_8UC3, cv::Scalar::all(0));
  f(cv::Rect((size.width - w) / 2, (size.height - h) / 2, w, h)).setTo(cv::Scalar::all(255));
  return f;
}
} // namespace

TEST_CASE("the camera's scale: frames brought to the network's scale about the centre") {
  const double net = network_scale.px_per_cm;
  CHECK(net == 7.578125); // sim::Rig::robot(): 242.5 px per rad at 32 cm
  PreprocessParams p;
  auto encoder = [&](double camera, ScaleFill fill = ScaleFill::black) {
    FrameEncoder::Config c{p, ChannelOrder::bgr};
    c.camera_px_per_cm = camera;
    c.scale_fill = fill;
    return FrameEncoder(c);
  };
  const cv::Mat f = rectangle_frame(100, 60);
  cv::Mat out;
  SUBCASE("hands twice the network's size: the frame shrinks by 2, centred, black around") {
    FrameEncoder enc = encoder(2 * net);
    CHECK(enc.scale_factors(f.size()) == std::pair{2.0, 2.0});
    const cv::Mat& r = enc.rescale(f, out);
    REQUIRE(r.size() == f.size());
    const cv::Rect b = bright_box(r);
    CHECK(std::abs(b.width - 50) <= 1);
    CHECK(std::abs(b.height - 30) <= 1);
    CHECK(std::abs((b.x + b.width / 2.0) - 317.5) <= 1.0);
    CHECK(std::abs((b.y + b.height / 2.0) - 175.0) <= 1.0);
    // The shrunk frame is round(635 / 2) x 175 at offset (158, 87); outside it, black.
    cv::Mat g = f.clone();
    g.setTo(cv::Scalar::all(90));
    const cv::Mat& rg = enc.rescale(g, out);
    CHECK(rg.at<cv::Vec3b>(175, 157) == cv::Vec3b(0, 0, 0));
    CHECK(rg.at<cv::Vec3b>(175, 158) == cv::Vec3b(90, 90, 90));
    CHECK(rg.at<cv::Vec3b>(175, 158 + 318 - 1) == cv::Vec3b(90, 90, 90));
    CHECK(rg.at<cv::Vec3b>(175, 158 + 318) == cv::Vec3b(0, 0, 0));
    CHECK(rg.at<cv::Vec3b>(86, 317) == cv::Vec3b(0, 0, 0));
    CHECK(rg.at<cv::Vec3b>(87, 317) == cv::Vec3b(90, 90, 90));
  }
  SUBCASE("replicate fill repeats the shrunk frame's border") {
    cv::Mat g(350, 635, CV_8UC3, cv::Scalar::all(90));
    g.col(0).setTo(cv::Scalar(10, 20, 30));
    g.col(1).setTo(cv::Scalar(10, 20, 30));
    FrameEncoder enc = encoder(2 * net, ScaleFill::replicate);
    const cv::Mat& r = enc.rescale(g, out);
    CHECK(r.at<cv::Vec3b>(175, 0) == cv::Vec3b(10, 20, 30));
    CHECK(r.at<cv::Vec3b>(175, 157) == cv::Vec3b(10, 20, 30));
    CHECK(r.at<cv::Vec3b>(0, 317) == cv::Vec3b(90, 90, 90));
  }
  SUBCASE("hands half the network's size: the centre is enlarged by 2") {
    FrameEncoder enc = encoder(0.5 * net);
    const cv::Rect b = bright_box(enc.rescale(f, out));
    CHECK(std::abs(b.width - 200) <= 2);
    CHECK(std::abs(b.height - 120) <= 2);
    CHECK(std::abs((b.x + b.width / 2.0) - 317.5) <= 1.0);
    CHECK(std::abs((b.y + b.height / 2.0) - 175.0) <= 1.0);
  }
  SUBCASE("the scale is per frame width and height: a frame twice the rig's size at twice its "
          "px per cm is left alone; another aspect is scaled per axis") {
    FrameEncoder enc = encoder(2 * net);
    const cv::Mat big = rectangle_frame(200, 120, {1270, 700});
    CHECK(enc.scale_factors(big.size()) == std::pair{1.0, 1.0});
    CHECK(enc.rescale(big, out).data == big.data); // untouched, not copied
    FrameEncoder tall = encoder(net);
    const auto [sx, sy] = tall.scale_factors({635, 700});
    CHECK(sx == 1.0);
    CHECK(sy == doctest::Approx(0.5));
    const cv::Rect b = bright_box(tall.rescale(rectangle_frame(100, 60, {635, 700}), out));
    CHECK(b.width == 100);
    CHECK(std::abs(b.height - 120) <= 2);
  }
  SUBCASE("within 1% of the network's scale, or not known: nothing changes, bit for bit") {
    FrameEncoder close = encoder(1.009 * net), unknown = encoder(0), far = encoder(1.02 * net);
    CHECK(close.scale_factors(f.size()) == std::pair{1.0, 1.0});
    CHECK(unknown.scale_factors(f.size()) == std::pair{1.0, 1.0});
    CHECK(far.scale_factors(f.size()).first == doctest::Approx(1.02));
    cv::Mat noise(350, 635, CV_8UC3);
    cv::randu(noise, cv::Scalar::all(0), cv::Scalar::all(256));
    CHECK(same(encode(close, noise), encode(unknown, noise)));
    CHECK_FALSE(same(encode(far, noise), encode(unknown, noise)));
  }
  SUBCASE("a bad scale is refused naming it") {
    for (double v : {-1.0, 0.01, 20000.0, std::nan(""), double(INFINITY)}) {
      CAPTURE(v);
      CHECK_THROWS_WITH_AS(encoder(v), doctest::Contains("camera_px_per_cm"), InvalidArgument);
      FrameEncoder enc = encoder(0);
      CHECK_THROWS_AS(enc.set_camera_px_per_cm(v), InvalidArgument);
      CHECK(enc.config().camera_px_per_cm == 0);
    }
    FrameEncoder::Config c{p, ChannelOrder::bgr};
    c.scale_fill = static_cast<ScaleFill>(7);
    CHECK_THROWS_WITH_AS(FrameEncoder{c}, doctest::Contains("scale_fill"), InvalidArgument);
  }
}

TEST_CASE("the camera's scale: the light's gains and the dark rule come from the frame as it is") {
  // A uniform frame keeps its value at the centre whatever the framing, as long as the
  // lighting gains, the dark rule and the contrast's mean read the frame's own pixels. Read
  // from the rescaled frame (three quarters black at scale 2), the gains would quadruple, the
  // rule would call it dark and the contrast's mean would drop.
  cv::Mat grey(350, 635, CV_8UC3, cv::Scalar(70, 80, 90));
  cv::Mat grey_f;
  grey.convertTo(grey_f, CV_32FC3, 1.0 / 255.0);
  auto centre = [](const Tensor& t) {
    return std::array<float, 3>{t(0, 0, t.h() / 2, t.w() / 2), t(0, 1, t.h() / 2, t.w() / 2),
                                t(0, 2, t.h() / 2, t.w() / 2)};
  };
  for (const bool normalise : {true, false})
    for (const float contrast : {1.0f, 3.0f})
      for (const ScaleFill fill :
           {ScaleFill::black, ScaleFill::replicate, ScaleFill::black_frame_contrast}) {
        CAPTURE(normalise);
        CAPTURE(contrast);
        CAPTURE(to_string(fill));
        PreprocessParams p;
        p.lighting_normalise = normalise;
        p.contrast_factor = contrast;
        p.dark_luminance_threshold = 0.2f; // grey: luminance 0.31, not dark; padded: 0.08
        FrameEncoder plain({p, ChannelOrder::bgr});
        FrameEncoder::Config c{p, ChannelOrder::bgr};
        c.camera_px_per_cm = 2 * network_scale.px_per_cm;
        c.scale_fill = fill;
        FrameEncoder scaled(c);
        const auto a = centre(encode(plain, grey)), b = centre(encode(scaled, grey)),
                   bf = centre(encode(scaled, grey_f)); // float frames take the same stages
        // With contrast, a black fill moves the mean (what black_frame_contrast is for).
        const bool moved = contrast != 1.0f && fill == ScaleFill::black;
        for (int k = 0; k < 3; ++k) {
          CHECK((b[k] == doctest::Approx(a[k]).epsilon(1e-5)) != moved);
          CHECK((bf[k] == doctest::Approx(a[k]).epsilon(1e-5)) != moved);
        }
      }
}

TEST_CASE("Preprocessor contrast region: the mean reads only the pixels mapped from it") {
  PreprocessParams p; // resize 318 x 235, crop 220 x 150, contrast 3
  cv::Mat img(350, 635, CV_8UC3, cv::Scalar::all(0));
  const cv::Rect own(158, 87, 318, 175);
  img(own).setTo(cv::Scalar::all(100));
  Preprocessor whole({p, ChannelOrder::bgr}), part({p, ChannelOrder::bgr});
  part.set_contrast_region(own);
  CHECK(part.contrast_region() == own);
  const Tensor tw = whole(img, false), tp = part(img, false);
  // Inside the own part the value is 100/255 blended with the mean: the own part's mean is the
  // grey value of 100/255 itself (the weights sum to 0.9999); over the whole image it moves.
  const float v = 100.0f / 255.0f, gray = (0.2989f + 0.587f + 0.114f) * v;
  const float expect = (3.0f * v - 2.0f * gray - p.mean[0]) / p.std[0];
  CHECK(tp(0, 0, 75, 110) == doctest::Approx(expect).epsilon(1e-5));
  CHECK(tw(0, 0, 75, 110) != doctest::Approx(expect).epsilon(1e-3));
  // A region that maps to no pixel of the crop falls back to the whole image.
  part.set_contrast_region(cv::Rect(0, 0, 2, 2));
  const Tensor tf = part(img, false);
  CHECK(same(tf, tw));
  part.set_contrast_region({});
  CHECK(same(part(img, false), tw));
}
