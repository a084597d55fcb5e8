// Mask smoothing: the segmenter's majority filter for an 8-bit class mask, a k x k Gaussian blur
// (sigma from k, replicated borders) followed by a threshold at half height, computed in the
// library's own separable fixed-point filter with buffers kept from call to call (no heap
// allocation once they have grown to the frame size).
//
// The result is bit-identical to
//   cv::GaussianBlur(mask, tmp, {k, k}, 0, 0, cv::BORDER_REPLICATE);
//   cv::threshold(tmp, mask, 127, 255, cv::THRESH_BINARY);
// for every CV_8UC1 input: OpenCV's 8-bit Gaussian is fixed point and bit-exact. Its kernel is
// the Gaussian of sigma = 0.3 ((k - 1) / 2 - 1) + 0.8 (the exact dyadic tables for k = 3, 5, 7),
// quantised to 8 fractional bits with error diffusion from the outside in, the centre taking
// the rest so the taps sum to 256. The horizontal pass sums pixel x tap exactly (8.8 fixed
// point), the vertical pass sums those times the taps exactly (16.16), and the value is rounded
// half up: out = (acc + 2^15) >> 16. A side of length 1 is not blurred along (OpenCV sets that
// kernel to 1). So out > 127 exactly when acc >= 128 * 2^16 - 2^15.
//
// gaussian_taps_q8(k)
//   requires: k odd, 1 <= k <= 31.
//   ensures:  the k integer taps (sum 256) OpenCV's 8-bit Gaussian uses for sigma 0.
//   throws:   InvalidArgument for another k.
// MaskSmoother::apply(mask, k)
//   requires: mask CV_8UC1 (any values), k 0, 1 or odd <= 31.
//   ensures:  k <= 1: mask unchanged. Else mask = 255 where the blurred value is > 127, else 0,
//             in place.
//   throws:   InvalidArgument for a bad mask or k.
// Row by row (the segmenter's one pass: each row is smoothed while it is still in cache):
// MaskSmoother::streams(k, size): true when k is 0, 1, 3 or 5 and both sides are >= 2 (the
//   sizes the row kernels of segment_kernels.hpp do; apply() handles every other case).
// begin(mask, k, marks, marks_stride)
//   requires: streams(k, mask.size()); mask CV_8UC1, allocated; marks null or rows of at least
//             mask.cols bytes, marks_stride apart; row_flags null or mask.rows bytes.
//   then, for y = 0 .. rows - 1 in order: write raw row y (w bytes, any values) into row(),
//   then push(); then end().
//   ensures:  after end(), mask is what apply(raw mask, k) gives (k <= 1: the raw mask), and
//             marks row y holds 1 where mask row y is non-zero, else 0, and row_flags[y]
//             (when given) is 1 when mask row y has a non-zero pixel, else 0. Rows of mask are
//             written as soon as they are final (row y - k / 2 at the push of row y), so mask may
//             be the raw mask's own storage only through apply().
// Threading: a MaskSmoother holds scratch rows; one instance per thread (a Segmenter owns one).
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sense/segment_kernels.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

namespace detail {

// Whether any of the n bytes at p is non-zero (8 bytes at a time).
inline bool any_nonzero(const std::uint8_t* p, int n) {
  std::uint64_t acc = 0;
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t v;
    std::memcpy(&v, p + i, 8);
    acc |= v;
  }
  for (; i < n; ++i) acc |= p[i];
  return acc != 0;
}

// OpenCV's fixed-point (8 fractional bits) Gaussian taps for kernel size k and sigma 0.
inline std::array<int, 31> gaussian_taps_q8(int k) {
  detail::require(k >= 1 && k <= 31 && k % 2 == 1, "gaussian_taps_q8: kernel size " +
                                                       std::to_string(k) +
                                                       "; expected an odd size in [1, 31]");
  std::array<int, 31> taps{};
  if (k == 1) {
    taps[0] = 256;
    return taps;
  }
  // The exact dyadic kernels OpenCV uses for small sizes (all multiples of 1/256).
  static constexpr int k3[] = {64, 128, 64};
  static constexpr int k5[] = {16, 64, 96, 64, 16};
  static constexpr int k7[] = {8, 28, 56, 72, 56, 28, 8};
  if (k <= 7) {
    const int* t = k == 3 ? k3 : k == 5 ? k5 : k7;
    std::copy(t, t + k, taps.begin());
    return taps;
  }
  // Sampled Gaussian, normalised, then quantised with error diffusion (outside in).
  const int half = (k - 1) / 2;
  const double sigma = std::fma(double(k), 0.15, 0.35); // 0.3 ((k - 1) / 2 - 1) + 0.8
  const double scale = -0.125 / (sigma * sigma);
  std::array<double, 16> values{};
  double sum = 0;
  for (int i = 0, x = 1 - k; i < half; ++i, x += 2) {
    values[static_cast<std::size_t>(i)] = std::exp(double(x * x) * scale);
    sum += values[static_cast<std::size_t>(i)];
  }
  sum = sum * 2 + 1;
  const double inv = 1 / sum;
  double err = 0;
  int total = 0;
  for (int i = 0; i < half; ++i) {
    const double adj = values[static_cast<std::size_t>(i)] * inv * 256 + err;
    const int v = static_cast<int>(std::nearbyint(adj)); // half to even, as cvRound
    err = adj - v;
    taps[static_cast<std::size_t>(i)] = taps[static_cast<std::size_t>(k - 1 - i)] = v;
    total += v;
  }
  taps[static_cast<std::size_t>(half)] = 256 - 2 * total;
  return taps;
}

} // namespace detail

class MaskSmoother {
public:
  void apply(cv::Mat& mask, int k) {
    if (!(k >= 0 && k <= 31 && (k <= 1 || k % 2 == 1))) // the message only on failure
      SHADOWSENSE_THROW(InvalidArgument("MaskSmoother::apply: kernel size " + std::to_string(k) +
                                        "; expected 0, 1 or an odd size up to 31"));
    if (k <= 1) return;
    detail::require(mask.type() == CV_8UC1 && !mask.empty(),
                    "MaskSmoother::apply: expected a non-empty CV_8UC1 mask");
    if (k != k_) {
      taps_ = detail::gaussian_taps_q8(k);
      k_ = k;
    }
    const int w = mask.cols, h = mask.rows;
    if (streams(k, mask.size())) { // the default sizes: row by row, all in 16 bits
      begin(mask, k);
      for (int y = 0; y < h; ++y) {
        std::copy(mask.ptr<uchar>(y), mask.ptr<uchar>(y) + w, row()); // row y is still raw
        push();
      }
      end();
      return;
    }
    // OpenCV leaves a side of length 1 unblurred (replicated borders).
    const int kx = w == 1 ? 1 : k, ky = h == 1 ? 1 : k;
    const auto uw = static_cast<std::size_t>(w);
    horizontal_.resize(uw * static_cast<std::size_t>(h));
    padded_.resize(uw + static_cast<std::size_t>(kx - 1));
    // The common sizes unrolled (one pass per row, vectorised).
    with_unrolled(kx, [&](auto n) { horizontal<decltype(n)::value>(mask); });
    with_unrolled(ky, [&](auto n) { vertical<decltype(n)::value>(mask); });
  }

  static bool streams(int k, cv::Size size) {
    return k <= 1 || ((k == 3 || k == 5) && size.width >= 2 && size.height >= 2);
  }

  void begin(cv::Mat& mask, int k, std::uint8_t* marks = nullptr, std::size_t marks_stride = 0,
             std::uint8_t* row_flags = nullptr) {
    detail::require(mask.type() == CV_8UC1 && !mask.empty() && streams(k, mask.size()),
                    "MaskSmoother::begin: expected a CV_8UC1 mask of at least 2 x 2 and a kernel "
                    "size of 0, 1, 3 or 5");
    mask_ = &mask;
    marks_ = marks;
    marks_stride_ = marks_stride;
    row_flags_ = row_flags;
    stream_k_ = k <= 1 ? 1 : k;
    next_ = 0;
    const auto uw = static_cast<std::size_t>(mask.cols);
    if (stream_k_ > 1) {
      padded_.resize(uw + static_cast<std::size_t>(stream_k_ - 1));
      ring_.resize(uw * static_cast<std::size_t>(stream_k_));
      ring_zero_.fill(false); // what the ring holds is not known yet
      const detail::SegmentKernels& kern = segment_kernels();
      hsum_ = stream_k_ == 3 ? kern.hsum3 : kern.hsum5;
      vsum_ = stream_k_ == 3 ? kern.vsum3 : kern.vsum5;
    }
  }
  // Where the raw row goes: k <= 1 straight into the mask, else a row with room for the
  // replicated ends.
  std::uint8_t* row() {
    return stream_k_ == 1 ? mask_->ptr<uchar>(next_) : padded_.data() + stream_k_ / 2;
  }
  void push() {
    const int w = mask_->cols, r = stream_k_ / 2, y = next_++;
    if (stream_k_ == 1) {
      if (marks_) {
        const uchar* src = mask_->ptr<uchar>(y);
        std::uint8_t* m = marks_ + static_cast<std::size_t>(y) * marks_stride_;
        std::uint8_t any = 0;
        for (int x = 0; x < w; ++x) any |= m[x] = std::min<uchar>(src[x], 1);
        if (row_flags_) row_flags_[y] = any;
      }
      return;
    }
    std::uint8_t* pad = padded_.data();
    // Most rows of a frame have no shadow: an all-0 row has all-0 sums, written once into its
    // ring slot (the slot stays 0 while 0 rows follow), and emit() skips the vertical sums of
    // a row whose k source rows are all 0.
    const std::size_t slot = static_cast<std::size_t>(y % stream_k_);
    if (!detail::any_nonzero(pad + r, w)) {
      if (!ring_zero_[slot]) std::fill_n(ring_row(y), w, std::uint16_t{0});
      ring_zero_[slot] = true;
    } else {
      std::fill(pad, pad + r, pad[r]);
      std::fill(pad + r + w, pad + 2 * r + w, pad[r + w - 1]);
      hsum_(pad, w, ring_row(y));
      ring_zero_[slot] = false;
    }
    if (y >= r) emit(y - r);
  }
  void end() {
    if (stream_k_ > 1)
      for (int y = std::max(0, mask_->rows - stream_k_ / 2); y < mask_->rows; ++y) emit(y);
    mask_ = nullptr;
  }

private:
  // k = 3 and 5 (the row kernels): the taps are g w with g = 64, w = (1 2 1) and g = 16,
  // w = (1 4 6 4 1). With g taken out, h' = sum w p < 2^12 and V = sum w h' < 2^16, and
  // acc = g^2 V; so out > 127 exactly when V >= (2^23 - 2^15) / g^2 (2040 and 32640, both
  // exact).
  // f(std::integral_constant<int, size>) for the unrolled sizes 1, 3, 5 and 7, else
  // f(std::integral_constant<int, 0>) (the generic loop).
  template <class F>
  static void with_unrolled(int size, F&& f) {
    switch (size) {
    case 1:
      return f(std::integral_constant<int, 1>{});
    case 3:
      return f(std::integral_constant<int, 3>{});
    case 5:
      return f(std::integral_constant<int, 5>{});
    case 7:
      return f(std::integral_constant<int, 7>{});
    default:
      return f(std::integral_constant<int, 0>{});
    }
  }
  std::uint16_t* ring_row(int y) {
    return ring_.data() +
           static_cast<std::size_t>(y % stream_k_) * static_cast<std::size_t>(mask_->cols);
  }
  // Final row y of the mask from the horizontal sums of rows y - r .. y + r (clamped: the
  // replicated top and bottom rows), all in the ring.
  void emit(int y) {
    const int h = mask_->rows, r = stream_k_ / 2;
    std::array<const std::uint16_t*, 5> rows{};
    bool all_zero = true;
    for (int t = 0; t < stream_k_; ++t) {
      const int src = std::clamp(y + t - r, 0, h - 1);
      rows[static_cast<std::size_t>(t)] = ring_row(src);
      all_zero = all_zero && ring_zero_[static_cast<std::size_t>(src % stream_k_)];
    }
    const auto w = static_cast<std::size_t>(mask_->cols);
    std::uint8_t* marks = marks_ ? marks_ + static_cast<std::size_t>(y) * marks_stride_ : nullptr;
    bool any = false;
    if (all_zero) { // the sums are 0, below the threshold: what vsum_ would write
      std::fill_n(mask_->ptr<uchar>(y), w, uchar{0});
      if (marks) std::fill_n(marks, w, std::uint8_t{0});
    } else {
      any = vsum_(rows.data(), mask_->cols, mask_->ptr<uchar>(y), marks);
    }
    if (row_flags_) row_flags_[y] = any ? 1 : 0;
  }

  // A pass's taps in 16-bit lanes: K = 1 is one tap of 256 (a side of length 1 is not
  // blurred), K = 0 the k_ taps of the generic loop.
  template <int K>
  std::array<std::uint16_t, 31> lane_taps() const {
    const int n = K == 0 ? k_ : K;
    std::array<std::uint16_t, 31> c{};
    for (int t = 0; t < n; ++t)
      c[static_cast<std::size_t>(t)] =
          K == 1 ? std::uint16_t{256}
                 : static_cast<std::uint16_t>(taps_[static_cast<std::size_t>(t)]);
    return c;
  }

  // Horizontal pass into horizontal_: 8.8 fixed point, exact (at most 255 * 256). K = 0: k_ taps.
  template <int K>
  void horizontal(const cv::Mat& mask) {
    const int n = K == 0 ? k_ : K, r = n / 2, w = mask.cols;
    const std::array<std::uint16_t, 31> c = lane_taps<K>();
    for (int y = 0; y < mask.rows; ++y) {
      const uchar* src = mask.ptr<uchar>(y);
      std::uint8_t* __restrict pad = padded_.data();
      std::fill(pad, pad + r, src[0]);
      std::copy(src, src + w, pad + r);
      std::fill(pad + r + w, pad + 2 * r + w, src[w - 1]);
      std::uint16_t* out =
          horizontal_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(w);
      for (int x = 0; x < w; ++x) {
        std::uint16_t sum = 0;
        for (int t = 0; t < n; ++t)
          sum = static_cast<std::uint16_t>(sum + c[static_cast<std::size_t>(t)] * pad[x + t]);
        out[x] = sum;
      }
    }
  }

  // Vertical pass: 16.16 fixed point, exact; rounded half up and thresholded at 127. With each
  // horizontal value split as h = 256 a + b (a, b < 256) the sum is 256 A + B, A = sum c a and
  // B = sum c b, both < 2^16; (256 A + B + 2^15) >> 16 > 127 exactly when A + (B >> 8) >= 32640.
  // So everything stays in 16-bit lanes.
  template <int K>
  void vertical(cv::Mat& mask) {
    const int n = K == 0 ? k_ : K, r = n / 2, w = mask.cols, h = mask.rows;
    const std::array<std::uint16_t, 31> c = lane_taps<K>();
    constexpr std::uint16_t on = 32640;
    std::array<const std::uint16_t*, 31> rows{};
    for (int y = 0; y < h; ++y) {
      for (int t = 0; t < n; ++t)
        rows[static_cast<std::size_t>(t)] =
            horizontal_.data() +
            static_cast<std::size_t>(std::clamp(y + t - r, 0, h - 1)) * static_cast<std::size_t>(w);
      uchar* __restrict dst = mask.ptr<uchar>(y);
      if constexpr (K > 0) { // rows and taps in registers: one vectorised pass
        std::array<const std::uint16_t* __restrict, K> in{};
        for (int t = 0; t < K; ++t)
          in[static_cast<std::size_t>(t)] = rows[static_cast<std::size_t>(t)];
        for (int x = 0; x < w; ++x) {
          std::uint16_t hi = 0, lo = 0;
          for (std::size_t t = 0; t < K; ++t) {
            hi = static_cast<std::uint16_t>(hi + c[t] * (in[t][x] >> 8));
            lo = static_cast<std::uint16_t>(lo + c[t] * (in[t][x] & 255));
          }
          dst[x] = static_cast<std::uint16_t>(hi + (lo >> 8)) >= on ? 255 : 0;
        }
      } else {
        for (int x = 0; x < w; ++x) {
          std::uint32_t acc = 0;
          for (int t = 0; t < n; ++t)
            acc += std::uint32_t{c[static_cast<std::size_t>(t)]} *
                   rows[static_cast<std::size_t>(t)][x];
          dst[x] = acc >= (std::uint32_t{on} << 8) ? 255 : 0;
        }
      }
    }
  }

  // The streaming state (begin .. end).
  cv::Mat* mask_ = nullptr;
  std::uint8_t* marks_ = nullptr;
  std::size_t marks_stride_ = 0;
  std::uint8_t* row_flags_ = nullptr; // per row: 0 when the final row is all 0 (or null)
  int stream_k_ = 1, next_ = 0;
  detail::HsumRowFn hsum_ = nullptr;
  detail::VsumRowFn vsum_ = nullptr;
  std::vector<std::uint16_t> ring_; // horizontal sums of the last k rows (row y at y % k)
  std::array<bool, 5> ring_zero_{}; // per ring slot: it holds all 0 sums

  int k_ = 0;
  std::array<int, 31> taps_{};
  std::vector<std::uint16_t> horizontal_; // the whole mask after the horizontal pass
  std::vector<std::uint8_t> padded_;      // one source row with replicated ends
};

SHADOWSENSE_NAMESPACE_END
