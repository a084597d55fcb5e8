// Lighting normalisation: an optional stage before the Preprocessor that makes a classifier
// robust to the light level and colour (the paper's models fail on a lighting condition they
// were not trained on: Table 3, 53.79%; Table 4, down to 14.66%). Every channel is scaled so its
// mean over the image becomes `target` (gray world + exposure), then clamped to [0, 1]. A
// shadow's shape survives; the light's brightness and colour temperature do not.
// tools/train.py --lighting-normalise applies the same arithmetic in PyTorch; a model trained
// with it must be used with it (and without the dark-image brightness factor, which the
// normalisation replaces).
//
// run(image, out): image CV_8UC3 (0..255) or CV_32FC3 (0..1) -> out CV_32FC3 in [0, 1], same
//   channel order; throws InvalidArgument on a bad image.
// For a CV_8UC3 image the channel means are exact: the integer sums of the values over 255 n.
// table(image, out): for a CV_8UC3 image (not checked), out[c][v] is the value run() writes
//   for value v of channel c, bit for bit: detail::scaled_byte(v, gains(image)[c]).
// gains(image): those per-channel gains (FrameEncoder hands them to Preprocessor::run_scaled,
//   which applies them while resizing).
// channel_sums(image): the exact per-channel sums of a CV_8UC3 image (not checked).
// No state beyond the config: const, callable from any thread.
#pragma once

#include <shadowsense/classify/channel_sums.hpp>
#include <shadowsense/classify/scaled_resize.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/version.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>

SHADOWSENSE_NAMESPACE_BEGIN

struct LightingNormaliser {
  struct Config {
    float target = 0.35f;   // channel mean after normalisation (tools/train.py: NORMALISE_TARGET)
    float min_mean = 1e-3f; // a black channel is scaled as if its mean were this
  };

  LightingNormaliser() : LightingNormaliser(Config{}) {}
  explicit LightingNormaliser(Config config) : config_(config) {
    detail::require(config.target > 0.0f && config.target <= 1.0f,
                    "LightingNormaliser: target must be in (0, 1]");
    detail::require(config.min_mean > 0.0f && config.min_mean < 1.0f,
                    "LightingNormaliser: min_mean must be in (0, 1)");
  }
  const Config& config() const { return config_; }

  // Per-channel table of an 8-bit image: table[c][v] is what run() writes for value v of
  // channel c. The channel means are the exact integer sums of the 8-bit values divided once by
  // 255 n in double: the exact mean of the ToTensor values v / 255, rounded once. (PyTorch's float
  // mean differs from it by float rounding, as did this function's earlier exact sum of the
  // float values v / 255: by at most one float step of the mean.)
  // requires: image CV_8UC3 (checked by the callers: run() and FrameEncoder).
  using Table = detail::ScaledTable;
  void table(const cv::Mat& image, Table& out) const {
    detail::fill_scaled_table(gains(image), out);
  }
  // The per-channel gains of table: table[c][v] = detail::scaled_byte(v, gains[c]) =
  // clamp((v / 255) * gains[c], 0, 1), gains[c] = target / max(mean of channel c, min_mean).
  // requires: image CV_8UC3 (not checked).
  std::array<float, 3> gains(const cv::Mat& image) const {
    const std::array<std::uint64_t, 3> total = channel_sums(image);
    const double n = double(image.rows) * image.cols;
    std::array<float, 3> g{};
    for (std::size_t c = 0; c < 3; ++c) {
      const double mean = double(total[c]) / (255.0 * n);
      g[c] = config_.target / std::max(static_cast<float>(mean), config_.min_mean);
    }
    return g;
  }

  // The sum of each channel's 8-bit values over a CV_8UC3 image (not checked), exact: row by
  // row with the kernel this CPU runs (classify/channel_sums.hpp: AVX2, NEON or portable; the
  // same integers from each), in pieces of at most 2^24 pixels (the kernels' contract). A
  // continuous image is one row: the kernels' scalar tails then run once, not once a row.
  static std::array<std::uint64_t, 3> channel_sums(const cv::Mat& image) {
    constexpr long long piece = 1 << 24;
    ChannelSums total{0, 0, 0};
    const bool one_row = image.isContinuous();
    const int rows = one_row ? 1 : image.rows;
    const long long cols = one_row ? static_cast<long long>(image.rows) * image.cols : image.cols;
    for (int y = 0; y < rows; ++y) {
      const unsigned char* s = image.ptr<unsigned char>(y);
      for (long long x = 0; x < cols; x += piece)
        add_channel_sums(s + 3 * static_cast<std::size_t>(x),
                         static_cast<int>(std::min(piece, cols - x)), total);
    }
    return total;
  }

  // bgr: CV_8UC3 (0..255). out: CV_32FC3 in [0, 1], same channel order, ready for
  // Preprocessor::run (call it with dark = false).
  void run(const cv::Mat& image, cv::Mat& out) const {
    if (!(!image.empty() && image.dims == 2 &&
          (image.type() == CV_8UC3 || image.type() == CV_32FC3)))
      SHADOWSENSE_THROW(
          InvalidArgument("LightingNormaliser: image is " +
                          (image.empty() ? std::string("empty") : cv::typeToString(image.type())) +
                          ", expected CV_8UC3 (0..255) or CV_32FC3 (0..1)"));
    if (image.type() == CV_32FC3) {
      double lo = 0, hi = 0;
      detail::require(cv::checkRange(image), "LightingNormaliser: float image holds NaN or Inf, "
                                             "expected finite values in 0..1");
      cv::minMaxIdx(image.reshape(1), &lo, &hi);
      if (!(lo >= 0.0 && hi <= 1.0))
        SHADOWSENSE_THROW(InvalidArgument("LightingNormaliser: float image values span " +
                                          std::to_string(lo) + ".." + std::to_string(hi) +
                                          ", expected 0..1"));
    }
    if (image.type() == CV_8UC3) { // one table lookup per value (table(): same bits)
      Table t;
      table(image, t);
      cv::Mat src = image; // out may alias image
      if (image.data == out.data) src = image.clone();
      out.create(image.rows, image.cols, CV_32FC3);
      for (int y = 0; y < src.rows; ++y) {
        const auto* s = src.ptr<unsigned char>(y);
        auto* d = out.ptr<float>(y);
        for (int x = 0; x < src.cols; ++x)
          for (int c = 0; c < 3; ++c) d[3 * x + c] = t[static_cast<std::size_t>(c)][s[3 * x + c]];
      }
      return;
    }
    cv::Mat src = image; // out may alias image
    if (image.data == out.data) src = image.clone();
    out.create(image.rows, image.cols, CV_32FC3);
    double sum[3] = {0, 0, 0};
    const bool bytes = src.type() == CV_8UC3;
    for (int y = 0; y < src.rows; ++y) {
      auto* d = out.ptr<float>(y);
      for (int x = 0; x < src.cols; ++x)
        for (int c = 0; c < 3; ++c) {
          const float v = bytes ? static_cast<float>(src.ptr<unsigned char>(y)[3 * x + c]) / 255.0f
                                : src.ptr<float>(y)[3 * x + c]; // ToTensor
          d[3 * x + c] = v;
          sum[c] += v;
        }
    }
    const double n = double(image.rows) * image.cols;
    float gain[3];
    for (int c = 0; c < 3; ++c)
      gain[c] = config_.target / std::max(static_cast<float>(sum[c] / n), config_.min_mean);
    for (int y = 0; y < image.rows; ++y) {
      auto* d = out.ptr<float>(y);
      for (int x = 0; x < image.cols; ++x)
        for (int c = 0; c < 3; ++c) d[3 * x + c] = std::clamp(d[3 * x + c] * gain[c], 0.0f, 1.0f);
    }
  }

private:
  Config config_;
};

SHADOWSENSE_NAMESPACE_END
