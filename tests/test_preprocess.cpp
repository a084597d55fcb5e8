// Preprocessing against torchvision's tensor path (golden vectors from
// tools/make_preprocess_fixture.py), its effect on DenseNet logits, and input validation.
#include <shadowsense/backends/densenet/densenet.hpp>
#include <shadowsense/classify/preprocess.hpp>
#include <shadowsense/classify/scaled_resize.hpp>
#include <shadowsense/core/codegen.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <utility>
#include <vector>

using namespace shadowsense;

namespace {

struct GoldenCase {
  int h = 0, w = 0;
  bool dark = false;
  PreprocessParams params;
  cv::Mat bgr;
  Tensor expected;
};

std::vector<GoldenCase> read_golden(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  REQUIRE(f.good());
  std::vector<char> b((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  std::size_t at = 0;
  auto u32 = [&] {
    std::uint32_t v;
    REQUIRE(at + 4 <= b.size());
    std::memcpy(&v, b.data() + at, 4);
    at += 4;
    return static_cast<int>(v);
  };
  auto f32 = [&] {
    float v;
    REQUIRE(at + 4 <= b.size());
    std::memcpy(&v, b.data() + at, 4);
    at += 4;
    return v;
  };
  std::vector<GoldenCase> cases(static_cast<std::size_t>(u32()));
  for (auto& c : cases) {
    c.h = u32();
    c.w = u32();
    c.dark = u32() != 0;
    c.params.resize_width = u32();
    c.params.resize_height = u32();
    c.params.crop_width = u32();
    c.params.crop_height = u32();
    c.params.contrast_factor = f32();
    c.params.dark_brightness_factor = f32();
    const std::size_t n = static_cast<std::size_t>(c.h) * c.w * 3;
    REQUIRE(at + n <= b.size());
    c.bgr = cv::Mat(c.h, c.w, CV_8UC3);
    std::memcpy(c.bgr.data, b.data() + at, n);
    at += n;
    const int oh = u32(), ow = u32();
    c.expected.resize(1, 3, oh, ow);
    REQUIRE(at + c.expected.size() * 4 <= b.size());
    std::memcpy(c.expected.data(), b.data() + at, c.expected.size() * 4);
    at += c.expected.size() * 4;
  }
  CHECK(at == b.size());
  return cases;
}

double max_abs_diff(const Tensor& a, const Tensor& b) {
  REQUIRE(a.shape_string() == b.shape_string());
  double d = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    d = std::max(d, std::abs(double(a.data()[i]) - double(b.data()[i])));
  return d;
}

// Normalised units: 1/255 of input is ~0.017 after /std, x3 contrast, x2 brightness, so 1e-5
// is float rounding (bilinear weights, mean summation order), far below one grey level.
constexpr double tensor_bound = 1e-5;

} // namespace

TEST_CASE("preprocessing equals torchvision's tensor path on the golden images") {
  const auto cases = read_golden(SHADOWSENSE_TEST_DATA_DIR "/preprocess_golden.bin");
  REQUIRE(cases.size() == 7);
  auto model = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  DenseNet net(model, {.run_self_test = false});
  double worst = 0, worst_logit = 0;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const auto& c = cases[i];
    CAPTURE(i);
    Preprocessor pre({.params = c.params, .input_order = ChannelOrder::bgr});
    const Tensor got = pre(c.bgr, c.dark);
    const double d = max_abs_diff(got, c.expected);
    CHECK(d <= tensor_bound);
    worst = std::max(worst, d);
    // Effect on the logits of the compact DenseNet.
    const std::vector<float> a(net.logits(got).begin(), net.logits(got).end());
    const auto b = net.logits(c.expected);
    for (std::size_t k = 0; k < a.size(); ++k)
      worst_logit = std::max(worst_logit, std::abs(double(a[k]) - double(b[k])));
  }
  CHECK(worst_logit <= 1e-4);
  MESSAGE("preprocessing vs torchvision: max abs tensor diff ", worst,
          ", max abs logit diff it causes ", worst_logit);
}

TEST_CASE("channel order is explicit: an RGB image with input_order rgb gives the same tensor") {
  const auto cases = read_golden(SHADOWSENSE_TEST_DATA_DIR "/preprocess_golden.bin");
  const auto& c = cases[0];
  cv::Mat rgb;
  cv::cvtColor(c.bgr, rgb, cv::COLOR_BGR2RGB);
  const Tensor a = Preprocessor({.params = c.params, .input_order = ChannelOrder::bgr})(c.bgr);
  const Tensor b = Preprocessor({.params = c.params, .input_order = ChannelOrder::rgb})(rgb);
  CHECK(max_abs_diff(a, b) == 0.0);
  // Treating BGR as RGB swaps the planes: a smooth image then differs clearly.
  const Tensor wrong = Preprocessor({.params = c.params, .input_order = ChannelOrder::rgb})(c.bgr);
  CHECK(max_abs_diff(a, wrong) > 0.5);
  // A float image in 0..1 gives the same result as the 8-bit one.
  cv::Mat f;
  c.bgr.convertTo(f, CV_32FC3, 1.0 / 255.0);
  // (convertTo multiplies by 1/255 where ToTensor divides: 1 ulp, x13 after contrast and std)
  CHECK(max_abs_diff(a, Preprocessor({.params = c.params})(f)) <= 5e-6);
}

TEST_CASE("the model's parameters are the default and fields can be overridden") {
  const auto model = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  auto pre = Preprocessor::for_model(model, ChannelOrder::bgr);
  CHECK(pre.config().params.crop_width == 61);
  CHECK(pre.config().params.crop_height == 45);
  auto params = model.preprocess;
  params.contrast_factor = 1.0f; // override
  params.crop_width = params.crop_height = 0;
  Preprocessor plain({.params = params});
  cv::Mat img(60, 80, CV_8UC3, cv::Scalar(10, 128, 250));
  const Tensor t = plain(img);
  CHECK(t.h() == 60);
  CHECK(t.w() == 80);
  // Contrast 1 leaves values unchanged: R = 250/255 normalised with mean/std of R.
  CHECK(t(0, 0, 5, 5) == doctest::Approx((250.0 / 255.0 - 0.485) / 0.229).epsilon(1e-6));
  CHECK(t(0, 2, 5, 5) == doctest::Approx((10.0 / 255.0 - 0.406) / 0.225).epsilon(1e-6));
}

TEST_CASE("bad images and configs are rejected with clear messages") {
  Preprocessor pre;
  CHECK_THROWS_WITH_AS(pre(cv::Mat()), doctest::Contains("image is empty"), InvalidArgument);
  CHECK_THROWS_WITH_AS(pre(cv::Mat(300, 400, CV_8UC1)), doctest::Contains("expected CV_8UC3"),
                       InvalidArgument);
  cv::Mat f(300, 400, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5));
  f.at<cv::Vec3f>(7, 9)[1] = std::numeric_limits<float>::quiet_NaN();
  CHECK_THROWS_WITH_AS(pre(f), doctest::Contains("NaN or Inf"), InvalidArgument);
  f.at<cv::Vec3f>(7, 9)[1] = std::numeric_limits<float>::infinity();
  CHECK_THROWS_WITH_AS(pre(f), doctest::Contains("NaN or Inf"), InvalidArgument);
  PreprocessParams p;
  p.resize_width = p.resize_height = 0;
  CHECK_THROWS_WITH_AS(Preprocessor({.params = p})(cv::Mat(100, 100, CV_8UC3)),
                       doctest::Contains("larger than the (resized) image"), InvalidArgument);
  p.std[1] = 0.0f;
  CHECK_THROWS_WITH_AS(Preprocessor({.params = p}),
                       doctest::Contains("expected a finite value > 0"), InvalidArgument);
  // Paper geometry from the default config: 1 x 3 x 150 x 220 for a 400x300 frame.
  const Tensor t = pre(cv::Mat(300, 400, CV_8UC3, cv::Scalar(0, 0, 0)), true);
  CHECK(t.shape_string() == "1x3x150x220");
  CHECK(t.all_finite());
}

TEST_CASE("Tensor::all_finite finds one Inf or NaN anywhere, and accepts the extreme finites") {
  Tensor t(1, 3, 41, 29); // 3567 values: three whole blocks of 1024 and a partial one
  for (std::size_t i = 0; i < t.size(); ++i)
    t.data()[i] = (i % 3 == 0)   ? std::numeric_limits<float>::max()
                  : (i % 3 == 1) ? -std::numeric_limits<float>::denorm_min()
                                 : -std::numeric_limits<float>::max();
  CHECK(t.all_finite());
  for (std::size_t at :
       {std::size_t{0}, std::size_t{1023}, std::size_t{1024}, std::size_t{2500}, t.size() - 1})
    for (float bad :
         {std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
          std::numeric_limits<float>::quiet_NaN(), -std::numeric_limits<float>::quiet_NaN()}) {
      CAPTURE(at);
      const float keep = t.data()[at];
      t.data()[at] = bad;
      CHECK_FALSE(t.all_finite());
      t.data()[at] = keep;
    }
  CHECK(t.all_finite());
}

TEST_CASE("paper geometry (400x300 -> 318x235 -> 220x150) against torchvision at test time") {
  if (std::system("/usr/bin/python3 -c 'import torch, torchvision' > /dev/null 2>&1") != 0) {
    MESSAGE("SKIPPED: /usr/bin/python3 cannot import torch/torchvision");
    return;
  }
  std::filesystem::create_directories(SHADOWSENSE_TEST_TMP_DIR);
  const std::string path = SHADOWSENSE_TEST_TMP_DIR "/preprocess_paper.bin";
  const std::string cmd = "/usr/bin/python3 " SHADOWSENSE_SOURCE_DIR
                          "/tools/make_preprocess_fixture.py --paper -o " +
                          path + " > /dev/null";
  REQUIRE(std::system(cmd.c_str()) == 0);
  double worst = 0;
  for (const auto& c : read_golden(path)) {
    Preprocessor pre({.params = c.params});
    const double d = max_abs_diff(pre(c.bgr, c.dark), c.expected);
    CHECK(d <= tensor_bound);
    worst = std::max(worst, d);
  }
  MESSAGE("paper geometry: max abs tensor diff vs torchvision ", worst);
}

TEST_CASE("run_in_range: run() on a float image in 0..1 without the range check") {
  Preprocessor pre;
  cv::Mat f(300, 400, CV_32FC3);
  cv::theRNG().state = 11;
  cv::randu(f, cv::Scalar::all(0.0), cv::Scalar::all(1.0));
  for (const bool dark : {false, true}) {
    Tensor checked, trusted;
    pre.run(f, dark, checked);
    pre.run_in_range(f, dark, trusted);
    CHECK(checked.shape_string() == trusted.shape_string());
    CHECK(std::equal(checked.values().begin(), checked.values().end(), trusted.values().begin()));
  }
  Tensor t;
  CHECK_THROWS_WITH_AS(pre.run_in_range(cv::Mat(300, 400, CV_8UC3), false, t),
                       doctest::Contains("run_in_range: image is CV_8UC3, expected CV_32FC3"),
                       InvalidArgument);
  CHECK_THROWS_WITH_AS(pre.run_in_range(cv::Mat(), false, t), doctest::Contains("image is empty"),
                       InvalidArgument);
}

namespace {
// crop_normalise written out value by value as torchvision's steps (std::clamp, the blend
// computed per value, the mean summed in double in pixel order), every operation rounded on
// its own: what the Preprocessor's row loops (SSE body, plain tail) must give bit for bit.
SHADOWSENSE_STRICT_FP Tensor normalise_by_value(const cv::Mat& bgr, const PreprocessParams& p,
                                                bool dark) {
  SHADOWSENSE_STRICT_FP_BODY
  double sum = 0;
  for (int y = 0; y < bgr.rows; ++y)
    for (int x = 0; x < bgr.cols; ++x) {
      const cv::Vec3f v = bgr.at<cv::Vec3f>(y, x);
      sum += 0.2989f * v[2] + 0.587f * v[1] + 0.114f * v[0];
    }
  const float mean_gray = static_cast<float>(sum / (double(bgr.rows) * bgr.cols));
  Tensor out(1, 3, bgr.rows, bgr.cols);
  for (int c = 0; c < 3; ++c) // RGB; the network order is RGB (the default)
    for (int y = 0; y < bgr.rows; ++y)
      for (int x = 0; x < bgr.cols; ++x) {
        const float s = bgr.at<cv::Vec3f>(y, x)[2 - c];
        float v =
            std::clamp(p.contrast_factor * s + (1.0f - p.contrast_factor) * mean_gray, 0.0f, 1.0f);
        if (dark) v = std::clamp(p.dark_brightness_factor * v, 0.0f, 1.0f);
        out(0, c, y, x) =
            (v - p.mean[static_cast<std::size_t>(c)]) / p.std[static_cast<std::size_t>(c)];
      }
  return out;
}
} // namespace

TEST_CASE("contrast, brightness and Normalize: the row loops equal a value-by-value loop bit for "
          "bit") {
  // Widths around the 4-value steps (tails of 0-3 values), pixels at and beyond both clamp
  // bounds (0, 1, values a contrast factor of 3 pushes out of 0..1), three contrast factors,
  // plain and dark.
  cv::theRNG().state = 5;
  std::size_t values = 0, differ = 0;
  for (const int w : {1, 2, 3, 4, 5, 7, 8, 9, 13, 31, 160})
    for (const float contrast : {1.0f, 3.0f, 0.5f})
      for (const bool dark : {false, true}) {
        cv::Mat f(5, w, CV_32FC3);
        cv::randu(f, cv::Scalar::all(0.0), cv::Scalar::all(1.0));
        f.at<cv::Vec3f>(0, 0) = cv::Vec3f(0.0f, 1.0f, 0.0f);
        f.at<cv::Vec3f>(4, w - 1) = cv::Vec3f(1.0f, 0.0f, 1.0f);
        PreprocessParams p;
        p.resize_width = w;
        p.resize_height = 5;
        p.crop_width = p.crop_height = 0;
        p.contrast_factor = contrast;
        Preprocessor pre({.params = p});
        Tensor got;
        pre.run_in_range(f, dark, got);
        const Tensor want = normalise_by_value(f, p, dark);
        REQUIRE(got.shape_string() == want.shape_string());
        for (std::size_t i = 0; i < got.size(); ++i) {
          ++values;
          differ += std::memcmp(&got.data()[i], &want.data()[i], sizeof(float)) != 0;
        }
      }
  CHECK(values == 3 * 5 * std::size_t{1 + 2 + 3 + 4 + 5 + 7 + 8 + 9 + 13 + 31 + 160} * 3 * 2);
  CHECK(differ == 0);
}

namespace {
// One pixel's gray, each operation rounded on its own.
SHADOWSENSE_STRICT_FP float gray_of(float r, float g, float b) {
  SHADOWSENSE_STRICT_FP_BODY
  return 0.2989f * r + 0.587f * g + 0.114f * b;
}
// detail::gray_sum's definition: the grays summed in double in pixel order.
double gray_sum_in_order(const std::vector<float>& img, int w, int h) {
  const auto n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) sum += gray_of(img[i], img[n + i], img[2 * n + i]);
  return sum;
}
double gray_sum_of(const std::vector<float>& img, int w, int h) {
  const auto n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  return detail::gray_sum(img.data(), img.data() + n, img.data() + 2 * n,
                          static_cast<std::size_t>(w), w, h);
}
} // namespace

TEST_CASE("gray_sum: the sum in pixel order, bit for bit, on every kind of image") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  int images = 0, differ = 0;
  // Sizes with every width mod 8, the network's 160 x 88; values on 1/255 steps times a gain,
  // uniform floats (every mantissa), and zeros mixed in.
  const std::pair<int, int> sizes[] = {{1, 1}, {7, 3}, {9, 2}, {17, 5}, {40, 4}, {160, 88}};
  for (const auto& [w, h] : sizes)
    for (int kind = 0; kind < 3; ++kind) {
      std::vector<float> img(3 * static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
      for (float& v : img)
        v = kind == 0   ? std::min(1.0f, static_cast<float>(rng() % 256) / 255.0f * 1.37f)
            : kind == 1 ? unit(rng)
                        : (rng() % 3 == 0 ? 0.0f : unit(rng));
      const double want = gray_sum_in_order(img, w, h), got = gray_sum_of(img, w, h);
      differ += std::memcmp(&want, &got, sizeof want) != 0;
      ++images;
    }
  CHECK(images == 18);
  CHECK(differ == 0);
  // Where the order matters: a gray of about 1 first, then grays of 2^-40 that the sum in pixel
  // order loses one by one; eight partial sums would keep them (checked: the image is one where
  // the orders differ), so the sum must be taken again in pixel order.
  const int w = 64, h = 4;
  const auto n = static_cast<std::size_t>(w * h);
  std::vector<float> img(3 * n, std::ldexp(1.0f, -40));
  img[0] = img[n] = img[2 * n] = 1.0f;
  double lanes[8] = {};
  for (std::size_t i = 0; i < n; ++i) lanes[i % 8] += gray_of(img[i], img[n + i], img[2 * n + i]);
  double any_order = 0;
  for (const double v : lanes) any_order += v;
  const double want = gray_sum_in_order(img, w, h), got = gray_sum_of(img, w, h);
  REQUIRE(any_order != want);
  CHECK(std::memcmp(&want, &got, sizeof want) == 0);
}

TEST_CASE("scaled resize: the VBMI kernel's values equal scaled_byte for every byte and gain") {
  if (!detail::scaled_resize_cpu_has_vbmi()) {
    MESSAGE("this CPU has no AVX-512 VBMI: the portable loop runs (tested below)");
    return;
  }
  // 256 pixels, pixel x holding x, 255 - x and 7 x mod 256; identity taps with weights 1 and 0,
  // so each output is the scaled value itself (v * 1 + w * 0, then * 1 + * 0: exact).
  std::vector<std::uint8_t> row(3 * 256 + 64);
  for (int x = 0; x < 256; ++x) {
    row[static_cast<std::size_t>(3 * x)] = static_cast<std::uint8_t>(x);
    row[static_cast<std::size_t>(3 * x + 1)] = static_cast<std::uint8_t>(255 - x);
    row[static_cast<std::size_t>(3 * x + 2)] = static_cast<std::uint8_t>((7 * x) % 256);
  }
  detail::ResizeTaps t;
  for (int x = 0; x < 256; ++x) {
    t.a.push_back(x);
    t.b.push_back(x);
    t.w0.push_back(1.0f);
    t.w1.push_back(0.0f);
  }
  const auto plan = detail::ScaledResizePlan::make(256, 3 * 256, t);
  REQUIRE(std::all_of(plan.start.begin(), plan.start.end(), [](int s) { return s >= 0; }));
  for (const std::array<float, 3> gains :
       {std::array<float, 3>{1.0f, 1.0f, 1.0f}, std::array<float, 3>{0.35f / 0.1234f, 2.7f, 0.001f},
        std::array<float, 3>{1e6f, 0.6180339f, 1.0001f}}) {
    detail::ScaledTable table;
    detail::fill_scaled_table(gains, table);
    std::vector<float> d(3 * 256, -1.0f);
    detail::scaled_resize_row_vbmi(plan, t, row.data(), row.data(), 1.0f, 0.0f, table, gains,
                                   {d.data(), d.data() + 256, d.data() + 512});
    int differ = 0;
    for (int x = 0; x < 256; ++x)
      for (int c = 0; c < 3; ++c) {
        const float want =
            detail::scaled_byte(row[static_cast<std::size_t>(3 * x + c)], gains[std::size_t(c)]);
        differ += std::memcmp(&want, &d[static_cast<std::size_t>(256 * c + x)], 4) != 0;
      }
    CHECK(differ == 0);
  }
}

TEST_CASE("scaled resize: the VBMI kernel equals the portable loop bit for bit on every geometry") {
  if (!detail::scaled_resize_cpu_has_vbmi()) {
    MESSAGE("this CPU has no AVX-512 VBMI: nothing to compare");
    return;
  }
  std::mt19937 rng(11);
  // (in_w, out_w): the robot rig's 635 -> 160, the paper's 400 -> 318, upscaling, a shrink by
  // more than 5 (groups that do not fit a window), widths that are not multiples of 8, rows of
  // fewer than 128 bytes (no window fits), one output pixel.
  const std::pair<int, int> widths[] = {{635, 160}, {400, 318}, {50, 203}, {1000, 100},
                                        {97, 31},   {40, 17},   {43, 43},  {9, 1}};
  int vector_groups = 0, portable_groups = 0;
  for (const auto& [in_w, out_w] : widths) {
    CAPTURE(in_w);
    CAPTURE(out_w);
    detail::ResizeTaps t;
    detail::resize_taps(in_w, out_w, t);
    const int row_bytes = 3 * in_w;
    const auto plan = detail::ScaledResizePlan::make(out_w, row_bytes, t);
    for (const int s : plan.start) (s >= 0 ? vector_groups : portable_groups) += 1;
    // Two rows exactly row_bytes long each (their own allocations: the kernel must not read
    // past them; ASan's builds check it).
    std::vector<std::uint8_t> r0(static_cast<std::size_t>(row_bytes)),
        r1(static_cast<std::size_t>(row_bytes));
    for (auto& v : r0) v = static_cast<std::uint8_t>(rng());
    for (auto& v : r1) v = static_cast<std::uint8_t>(rng());
    for (const std::array<float, 3> gains :
         {std::array<float, 3>{1.0f, 1.0f, 1.0f}, std::array<float, 3>{1.9f, 0.45f, 3.3f}}) {
      detail::ScaledTable table;
      detail::fill_scaled_table(gains, table);
      // One row per channel, planar.
      const auto n = static_cast<std::size_t>(out_w);
      std::vector<float> want(3 * n, -1.0f), got = want;
      detail::scaled_resize_row_portable(plan, t, r0.data(), r1.data(), 0.3f, 0.7f, table, gains,
                                         {want.data(), want.data() + n, want.data() + 2 * n});
      detail::scaled_resize_row_vbmi(plan, t, r0.data(), r1.data(), 0.3f, 0.7f, table, gains,
                                     {got.data(), got.data() + n, got.data() + 2 * n});
      CHECK(std::memcmp(want.data(), got.data(), 4 * want.size()) == 0);
    }
  }
  CHECK(vector_groups > 0);   // the permutes ran
  CHECK(portable_groups > 0); // and the groups that do not fit a window
}

TEST_CASE("Preprocessor::run_scaled equals run_mapped with the scaled table; bad gains refused") {
  PreprocessParams p;
  p.resize_width = 160;
  p.resize_height = 88;
  p.crop_width = 0;
  p.crop_height = 0;
  Preprocessor pre(Preprocessor::Config{p, ChannelOrder::bgr});
  cv::Mat image(350, 635, CV_8UC3);
  cv::randu(image, 0, 256);
  const std::array<float, 3> gains{1.7f, 0.8f, 1.0f};
  detail::ScaledTable table;
  detail::fill_scaled_table(gains, table);
  Tensor scaled, mapped;
  pre.run_scaled(image, gains, false, scaled);
  pre.run_mapped(image, table, false, mapped);
  REQUIRE(scaled.size() == mapped.size());
  CHECK(std::memcmp(scaled.data(), mapped.data(), 4 * scaled.size()) == 0);
  // Without a resize every pixel is mapped: the same path for both.
  p.resize_width = 0;
  p.resize_height = 0;
  Preprocessor same(Preprocessor::Config{p, ChannelOrder::bgr});
  same.run_scaled(image, gains, false, scaled);
  same.run_mapped(image, table, false, mapped);
  CHECK(std::memcmp(scaled.data(), mapped.data(), 4 * scaled.size()) == 0);
  CHECK_THROWS_WITH_AS(pre.run_scaled(image, {1.0f, 0.0f, 1.0f}, false, scaled),
                       "Preprocessor::run_scaled: a gain is 0.000000, expected finite and > 0",
                       InvalidArgument);
  CHECK_THROWS_WITH_AS(
      pre.run_scaled(image, {1.0f, 1.0f, std::numeric_limits<float>::quiet_NaN()}, false, scaled),
      "Preprocessor::run_scaled: a gain is nan, expected finite and > 0", InvalidArgument);
  cv::Mat floats(350, 635, CV_32FC3, cv::Scalar::all(0.5));
  CHECK_THROWS_WITH_AS(pre.run_scaled(floats, gains, false, scaled),
                       "Preprocessor::run_scaled: image is CV_32FC3, expected CV_8UC3",
                       InvalidArgument);
}
