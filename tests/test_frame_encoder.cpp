// FrameEncoder: the one frame -> tensor path (lighting normalisation, the dark-frame rule,
// preprocessing), checked against the stages it is made of.
#include <shadowsense/classify/frame_encoder.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

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

TEST_CASE("LightingNormaliser's integer sum: every v / 255 is a whole number of its units") {
  // table() sums the channel values as integers of 2^-unit_exponent; exact only if each float
  // v / 255 is such a multiple (below 1, so 2^unit_exponent units at most).
  for (int v = 0; v < 256; ++v) {
    CAPTURE(v);
    const double units =
        std::ldexp(double(static_cast<float>(v) / 255.0f), LightingNormaliser::unit_exponent);
    CHECK(units == std::floor(units));
    CHECK(units <= std::ldexp(1.0, LightingNormaliser::unit_exponent));
  }
}

TEST_CASE("8-bit frames: the table path (normalise while resizing) equals the float path bit for "
          "bit") {
  // The float path, written out: ToTensor, per-channel means summed row by row in double,
  // gain, clamp; then the Preprocessor's float-image path (resize, crop, contrast, Normalize).
  auto reference_normalise = [](const cv::Mat& bgr, float target) {
    cv::Mat out(bgr.rows, bgr.cols, CV_32FC3);
    double sum[3] = {0, 0, 0};
    for (int y = 0; y < bgr.rows; ++y)
      for (int x = 0; x < bgr.cols; ++x)
        for (int c = 0; c < 3; ++c) {
          const float v = static_cast<float>(bgr.ptr<unsigned char>(y)[3 * x + c]) / 255.0f;
          out.ptr<float>(y)[3 * x + c] = v;
          sum[c] += v;
        }
    const double n = double(bgr.rows) * bgr.cols;
    for (int c = 0; c < 3; ++c) {
      const float gain = target / std::max(static_cast<float>(sum[c] / n), 1e-3f);
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
