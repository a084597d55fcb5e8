// Paper 5.1.2 preprocessing: resize (paper 318x235, width x height), centre crop (220x150),
// contrast factor 3, brightness factor 2 for images taken in the dark, then normalisation with
// the ImageNet mean/std. The result is the network's input tensor.
//
// Defined as torchvision's TENSOR path, on purpose: ToTensor (x / 255), Resize (bilinear,
// align_corners=False, antialias=False), CenterCrop (offsets round((size - crop) / 2), half to
// even like Python), functional adjust_contrast (blend with the mean of the float grayscale
// 0.2989 R + 0.587 G + 0.114 B, clamp to [0, 1]), adjust_brightness (scale, clamp to [0, 1]),
// Normalize. Clamping follows each step, so contrast-then-brightness is the order. The PIL path
// (integer grayscale, uint8 rounding after every step) differs by up to a few 1/255 steps; the
// golden tests (tools/make_preprocess_fixture.py) come from the tensor path.
// OpenCV images are BGR: the input channel order is a required, explicit choice.
//
// Preprocessor(Config)
//   throws InvalidArgument naming the field when config.params.validate() fails (sizes above
//   preprocess_max_side included) or the input order is not rgb/bgr.
// run(image, dark, out)
//   requires: image CV_8UC3 (0..255) or CV_32FC3 with every value in 0..1 (a float image in
//             0..255 is rejected, not clipped); crop inside the (resized) image.
//   ensures: out is the 1 x 3 x h x w network input; throws InvalidArgument otherwise.
// run_mapped(image, table, dark, out)
//   requires: image CV_8UC3; table[c][v] finite and in 0..1 (the float value of v in channel
//             c; not checked). ensures: run() on the image mapped through table, computed
//             without a full-size float image (8-bit images in run() go this way with
//             table = v / 255). Throws InvalidArgument on a bad image or crop.
// run_scaled(image, gains, dark, out)
//   requires: image CV_8UC3; gains finite and > 0 (else InvalidArgument naming the gain).
//   ensures: run_mapped() with table[c][v] = clamp((v / 255) * gains[c], 0, 1) in float
//             (detail::scaled_byte), bit for bit; computed from the tapped bytes where the CPU
//             has AVX-512 VBMI (classify/scaled_resize.hpp). run() of an 8-bit image is
//             run_scaled with gains 1; FrameEncoder hands it LightingNormaliser::gains.
// run_in_range(image, dark, out)
//   requires: image CV_32FC3 whose values are finite and in 0..1 (not checked: the caller's
//             contract, e.g. FrameEncoder's own encoded images). ensures: run() on the image
//             without its full-size range check. Throws InvalidArgument on a bad type or crop.
// set_contrast_region(r): adjust_contrast's mean reads only the pixels of the (resized, cropped)
//   image whose centres map into r, a rectangle of the input image (input pixels; a resized
//   pixel j maps to (j + 0.5) * in / out - 0.5); an empty r (the default) or one that leaves no
//   pixel = the whole image, as torchvision. FrameEncoder sets it to the frame's own part of a
//   padded frame (ScaleFill::black_frame_contrast), so the fill does not move the mean.
// Threading: run() reuses internal buffers: one instance per thread.
#pragma once

#include <shadowsense/classify/preprocess_params.hpp>
#include <shadowsense/classify/scaled_resize.hpp>
#include <shadowsense/core/codegen.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/tensor.hpp>
#include <shadowsense/core/version.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

namespace detail {

// The sum in double, in pixel order (row by row), of the float grayscale
// 0.2989 r + 0.587 g + 0.114 b (each operation rounded in float) of a w x h image given as three
// planes whose rows are `stride` floats apart: adjust_contrast's mean times the pixel count.
// Taken in eight partial sums, which give that same double whenever no partial sum rounds: with
// lo the smallest non-zero |gray| and E = ilogb(lo), every gray value (a float) is an integer
// times 2^(E - 23), and so is every partial sum, whose size is at most n max|gray| (n pixels);
// below 2^(E + 30) such a number is a double, so no addition rounds, in any order. Where
// n max|gray| > 2^(E + 29) (a margin of 2 for the product's rounding) the sum is taken again in
// pixel order. Images in 0..1 get there only with grays below about 2^-29 next to grays near 1
// (grays of 1/255 steps need more than 2^20 pixels). NaN: NaN either way. Which lane a gray
// goes to does not matter (no addition rounds), so the SSE2 loop takes four at a time.
SHADOWSENSE_STRICT_FP inline double gray_sum(const float* r, const float* g, const float* b,
                                             std::size_t stride, int w, int h) {
  SHADOWSENSE_STRICT_FP_BODY
  constexpr float inf = std::numeric_limits<float>::infinity();
  // The partial sums, the smallest non-zero and the largest |gray|, per lane.
  std::array<double, 8> part{};
  std::array<float, 8> lo, hi{};
  lo.fill(inf);
  const auto add = [&](std::size_t lane, std::size_t i) SHADOWSENSE_STRICT_FP {
    SHADOWSENSE_STRICT_FP_BODY
    const float v = 0.2989f * r[i] + 0.587f * g[i] + 0.114f * b[i];
    const float a = std::fabs(v);
    part[lane] += static_cast<double>(v);
    hi[lane] = std::max(hi[lane], a);
    lo[lane] = std::min(lo[lane], a > 0.0f ? a : inf);
  };
  for (int y = 0; y < h; ++y) {
    const std::size_t o = static_cast<std::size_t>(y) * stride;
    int x = 0;
#if defined(__SSE2__)
    // Four grays a step (every x86-64 CPU has SSE2; GCC left the loop below scalar), each
    // computed as the scalar line, their doubles into four lanes of part.
    const __m128 kr = _mm_set1_ps(0.2989f), kg = _mm_set1_ps(0.587f), kb = _mm_set1_ps(0.114f);
    const __m128 sign = _mm_set1_ps(-0.0f), zero = _mm_setzero_ps(), vinf = _mm_set1_ps(inf);
    __m128d s01 = _mm_loadu_pd(&part[0]), s23 = _mm_loadu_pd(&part[2]);
    __m128 vlo = _mm_loadu_ps(&lo[0]), vhi = _mm_loadu_ps(&hi[0]);
    for (; x + 4 <= w; x += 4) {
      const std::size_t i = o + static_cast<std::size_t>(x);
      const __m128 v = _mm_add_ps(
          _mm_add_ps(_mm_mul_ps(kr, _mm_loadu_ps(r + i)), _mm_mul_ps(kg, _mm_loadu_ps(g + i))),
          _mm_mul_ps(kb, _mm_loadu_ps(b + i)));
      const __m128 a = _mm_andnot_ps(sign, v);
      s01 = _mm_add_pd(s01, _mm_cvtps_pd(v));
      s23 = _mm_add_pd(s23, _mm_cvtps_pd(_mm_movehl_ps(v, v)));
      vhi = _mm_max_ps(a, vhi); // a NaN gray leaves hi as it is (the sums are NaN then)
      const __m128 positive = _mm_cmpgt_ps(a, zero);
      vlo = _mm_min_ps(vlo, _mm_or_ps(_mm_and_ps(positive, a), _mm_andnot_ps(positive, vinf)));
    }
    _mm_storeu_pd(&part[0], s01);
    _mm_storeu_pd(&part[2], s23);
    _mm_storeu_ps(&lo[0], vlo);
    _mm_storeu_ps(&hi[0], vhi);
#endif
    for (; x + 8 <= w; x += 8)
      for (std::size_t j = 0; j < 8; ++j) add(j, o + static_cast<std::size_t>(x) + j);
    for (std::size_t j = 0; x < w; ++x, ++j) add(j, o + static_cast<std::size_t>(x));
  }
  const float lo_all = *std::min_element(lo.begin(), lo.end());
  const float hi_all = *std::max_element(hi.begin(), hi.end());
  double sum = 0;
  const double n = double(w) * double(h);
  if (lo_all == inf || n * double(hi_all) <= std::ldexp(1.0, std::ilogb(lo_all) + 29)) {
    for (const double v : part) sum += v;
    return sum;
  }
  for (int y = 0; y < h; ++y) {
    const std::size_t o = static_cast<std::size_t>(y) * stride;
    for (int x = 0; x < w; ++x) {
      const std::size_t i = o + static_cast<std::size_t>(x);
      sum += 0.2989f * r[i] + 0.587f * g[i] + 0.114f * b[i];
    }
  }
  return sum;
}

} // namespace detail

class Preprocessor {
public:
  struct Config {
    PreprocessParams params{};                    // paper values; usually taken from the model
    ChannelOrder input_order = ChannelOrder::bgr; // cv::imread / cv::VideoCapture give BGR
  };

  Preprocessor() : Preprocessor(Config{}) {}
  explicit Preprocessor(Config config) : config_(config) {
    detail::add_context<InvalidArgument>("Preprocessor config: ",
                                         [&] { config_.params.validate(); });
    detail::require(config_.input_order == ChannelOrder::rgb ||
                        config_.input_order == ChannelOrder::bgr,
                    "Preprocessor config: input_order must be rgb or bgr");
  }
  // The model's parameters, optionally overridden field by field afterwards by the caller.
  // Model: any type with a PreprocessParams member named preprocess (e.g. ModelFile).
  template <class Model>
  static Preprocessor for_model(const Model& model, ChannelOrder input_order) {
    return Preprocessor(Config{.params = model.preprocess, .input_order = input_order});
  }

  const Config& config() const { return config_; }

  // Output size (height, width) for an input of rows x cols.
  std::pair<int, int> output_size(int rows, int cols) const {
    const auto& p = config_.params;
    if (p.crop_width > 0) return {p.crop_height, p.crop_width};
    if (p.resize_width > 0) return {p.resize_height, p.resize_width};
    return {rows, cols};
  }

  // image: CV_8UC3 (0..255) or CV_32FC3 (0..1, finite) in config().input_order. dark applies
  // the brightness factor (paper: images collected in a dark environment). Writes a
  // 1 x 3 x h x w tensor in the network's channel order.
  Tensor operator()(const cv::Mat& image, bool dark = false) {
    Tensor t;
    run(image, dark, t);
    return t;
  }

  void set_contrast_region(cv::Rect r) { region_ = r; }
  cv::Rect contrast_region() const { return region_; }

  void run(const cv::Mat& image, bool dark, Tensor& out) {
    detail::require(!image.empty(), "Preprocessor: image is empty, expected CV_8UC3 or CV_32FC3");
    if (!(image.dims == 2 && (image.type() == CV_8UC3 || image.type() == CV_32FC3)))
      SHADOWSENSE_THROW(InvalidArgument("Preprocessor: image type is " +
                                        cv::typeToString(image.type()) +
                                        ", expected CV_8UC3 (0..255) or CV_32FC3 (0..1)"));
    // ToTensor: x / 255 in float (division, as torchvision does): scaled with gain 1.
    if (image.type() == CV_8UC3) {
      run_scaled_unchecked(image, {1.0f, 1.0f, 1.0f}, dark, out);
      return;
    }
    detail::require(cv::checkRange(image),
                    "Preprocessor: float image holds NaN or Inf, expected finite values in 0..1");
    double lo = 0, hi = 0;
    cv::minMaxIdx(image.reshape(1), &lo, &hi);
    if (!(lo >= 0.0 && hi <= 1.0))
      SHADOWSENSE_THROW(
          InvalidArgument("Preprocessor: float image values span " + std::to_string(lo) + ".." +
                          std::to_string(hi) +
                          ", expected 0..1 (divide a 0..255 float image by 255, or pass CV_8UC3)"));
    finish(image, dark, out);
  }

  void run_in_range(const cv::Mat& image, bool dark, Tensor& out) {
    if (!(!image.empty() && image.dims == 2 && image.type() == CV_32FC3))
      SHADOWSENSE_THROW(
          InvalidArgument("Preprocessor::run_in_range: image is " +
                          (image.empty() ? std::string("empty") : cv::typeToString(image.type())) +
                          ", expected CV_32FC3"));
    finish(image, dark, out);
  }

  // Per-channel value table of an 8-bit image: table[c][v] is the float value (0..1) of value v
  // in channel c of the image (in the image's channel order).
  using Table = detail::ScaledTable;

  // run() on an 8-bit image whose values are first mapped through table (ToTensor is the
  // table v / 255; LightingNormaliser::table gives the lighting-normalised one). Only the
  // pixels the resize reads are mapped, so no full-size float image is made.
  // requires: image CV_8UC3; every table value finite and in 0..1 (not checked: the caller's
  //           contract). Throws InvalidArgument on a bad image or crop.
  void run_mapped(const cv::Mat& image, const Table& table, bool dark, Tensor& out) {
    if (!(!image.empty() && image.dims == 2 && image.type() == CV_8UC3))
      SHADOWSENSE_THROW(
          InvalidArgument("Preprocessor::run_mapped: image is " +
                          (image.empty() ? std::string("empty") : cv::typeToString(image.type())) +
                          ", expected CV_8UC3"));
    run_mapped_unchecked(image, table, dark, out);
  }

  // run_mapped with table[c][v] = clamp((v / 255) * gains[c], 0, 1) in float
  // (detail::scaled_byte: ToTensor for gains 1, LightingNormaliser::gains for the lighting
  // normalisation), the same floats, faster where the CPU has AVX-512 VBMI (the values are
  // computed from the tapped bytes, classify/scaled_resize.hpp).
  // requires: image CV_8UC3; gains finite and > 0. Throws InvalidArgument naming what is wrong
  //           (the image, a gain, the crop).
  void run_scaled(const cv::Mat& image, const std::array<float, 3>& gains, bool dark, Tensor& out) {
    if (!(!image.empty() && image.dims == 2 && image.type() == CV_8UC3))
      SHADOWSENSE_THROW(
          InvalidArgument("Preprocessor::run_scaled: image is " +
                          (image.empty() ? std::string("empty") : cv::typeToString(image.type())) +
                          ", expected CV_8UC3"));
    for (const float g : gains)
      if (!(std::isfinite(g) && g > 0.0f))
        SHADOWSENSE_THROW(InvalidArgument("Preprocessor::run_scaled: a gain is " +
                                          std::to_string(g) + ", expected finite and > 0"));
    run_scaled_unchecked(image, gains, dark, out);
  }

private:
  void run_scaled_unchecked(const cv::Mat& image, const std::array<float, 3>& gains, bool dark,
                            Tensor& out) {
    if (gains != scaled_gains_) { // the lighting's gains change a little every frame
      detail::fill_scaled_table(gains, scaled_table_);
      scaled_gains_ = gains;
    }
    const auto& p = config_.params;
    if (!(p.resize_width > 0 && (p.resize_width != image.cols || p.resize_height != image.rows))) {
      run_mapped_unchecked(image, scaled_table_, dark, out); // no resize: every pixel mapped
      return;
    }
    input_size_ = image.size();
    const int out_w = p.resize_width, out_h = p.resize_height;
    set_taps(image.cols, image.rows, out_w, out_h);
    if (plan_.row_bytes != 3 * image.cols || plan_.out_w != out_w)
      plan_ = detail::ScaledResizePlan::make(out_w, 3 * image.cols, xt_);
    const auto row = detail::scaled_resize_cpu_has_vbmi() ? &detail::scaled_resize_row_vbmi
                                                          : &detail::scaled_resize_row_portable;
    planar_create(out_h, out_w);
    for (int y = 0; y < out_h; ++y) {
      const auto ky = static_cast<std::size_t>(y);
      row(plan_, xt_, image.ptr<unsigned char>(yt_.a[ky]), image.ptr<unsigned char>(yt_.b[ky]),
          yt_.w0[ky], yt_.w1[ky], scaled_table_, gains, planar_out(y));
    }
    crop_normalise_planar(dark, out);
  }

  void run_mapped_unchecked(const cv::Mat& image, const Table& table, bool dark, Tensor& out) {
    const auto& p = config_.params;
    input_size_ = image.size();
    if (p.resize_width > 0 && (p.resize_width != image.cols || p.resize_height != image.rows)) {
      resize_bilinear_mapped(image, table, p.resize_width, p.resize_height);
      crop_normalise_planar(dark, out);
      return;
    }
    planar_create(image.rows, image.cols);
    for (int y = 0; y < image.rows; ++y) {
      const auto* s = image.ptr<unsigned char>(y);
      const detail::PlanarRow d = planar_out(y);
      for (int x = 0; x < image.cols; ++x)
        for (std::size_t c = 0; c < 3; ++c) d[c][x] = table[c][s[3 * x + c]];
    }
    crop_normalise_planar(dark, out);
  }

  // A float image in 0..1: resize, then crop_normalise.
  void finish(const cv::Mat& image, bool dark, Tensor& out) {
    const auto& p = config_.params;
    // Resize: bilinear, half-pixel centres, no antialias, with torch's own arithmetic for
    // source positions and weights (cv::resize differs by up to 5e-4 after normalisation on
    // noisy images because it rounds positions differently).
    const cv::Mat* cur = &image;
    input_size_ = image.size();
    if (p.resize_width > 0 && (p.resize_width != cur->cols || p.resize_height != cur->rows)) {
      resize_bilinear(*cur, p.resize_width, p.resize_height);
      cur = &resized_;
    }
    crop_normalise(*cur, dark, out);
  }

  // The pixels of a view (a crop of the resized image, of size `image`) that adjust_contrast's
  // mean reads, relative to the view. view.tl(): the crop's top-left corner in the image.
  cv::Rect mean_rect(cv::Size image, cv::Rect view) const {
    const cv::Rect all(0, 0, view.width, view.height);
    const cv::Point offset = view.tl();
    if (region_.empty() || input_size_.empty()) return all;
    auto span = [](int lo, int len, int in, int out, int shift) {
      const double k = double(out) / in; // output pixels per input pixel
      const int a = static_cast<int>(std::ceil((lo + 0.5) * k - 0.5));
      const int b = static_cast<int>(std::floor((lo + len - 0.5) * k - 0.5));
      return std::pair{a - shift, b - shift};
    };
    const auto [x0, x1] = span(region_.x, region_.width, input_size_.width, image.width, offset.x);
    const auto [y0, y1] =
        span(region_.y, region_.height, input_size_.height, image.height, offset.y);
    const cv::Rect r = cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1) & all;
    return r.empty() ? all : r;
  }

  // Centre crop, contrast, brightness, Normalize of an interleaved float image in 0..1: its
  // channels split into the planar image, then crop_normalise_planar.
  void crop_normalise(const cv::Mat& image, bool dark, Tensor& out) {
    planar_create(image.rows, image.cols);
    for (int y = 0; y < image.rows; ++y) {
      const float* s = image.ptr<float>(y);
      const detail::PlanarRow d = planar_out(y);
      for (int x = 0; x < image.cols; ++x) {
        d[0][x] = s[3 * x];
        d[1][x] = s[3 * x + 1];
        d[2][x] = s[3 * x + 2];
      }
    }
    crop_normalise_planar(dark, out);
  }

  // Centre crop, contrast, brightness, Normalize of the planar image (planar_: one plane per
  // channel in the input's order, values in 0..1).
  void crop_normalise_planar(bool dark, Tensor& out) {
    const auto& p = config_.params;
    const cv::Size image(planar_w_, planar_h_);
    cv::Rect view(0, 0, image.width, image.height);
    if (p.crop_width > 0) {
      if (!(p.crop_width <= image.width && p.crop_height <= image.height))
        SHADOWSENSE_THROW(
            InvalidArgument("Preprocessor: crop " + std::to_string(p.crop_width) + "x" +
                            std::to_string(p.crop_height) + " is larger than the (resized) image " +
                            std::to_string(image.width) + "x" + std::to_string(image.height) +
                            ", expected a crop inside the image"));
      const int top = round_half_even((image.height - p.crop_height) / 2.0);
      const int left = round_half_even((image.width - p.crop_width) / 2.0);
      view = cv::Rect(left, top, p.crop_width, p.crop_height);
    }
    const int h = view.height, w = view.width;
    out.resize(1, 3, h, w);
    // The planes in RGB order (input channel of R, G, B).
    const int ri = config_.input_order == ChannelOrder::bgr ? 2 : 0, bi = 2 - ri;
    const std::array<int, 3> plane_of{ri, 1, bi};
    // adjust_contrast: mean of the float grayscale over the whole (cropped) image, or over the
    // part of it that comes from the contrast region.
    const cv::Rect m = mean_rect(image, view);
    const float mean_gray =
        gray_mean(cv::Rect(m.x + view.x, m.y + view.y, m.width, m.height), plane_of);
    const float cf = p.contrast_factor;
    const float blend = (1.0f - cf) * mean_gray;
    const bool rgb_out = p.network_channel_order == ChannelOrder::rgb;
    // Row by row and channel by channel, contrast, brightness and Normalize on the contiguous
    // plane rows (normalise_row). Per value the same float operations in the same order as
    // torchvision's steps, each rounded on its own.
    for (int y = 0; y < h; ++y)
      for (int c = 0; c < 3; ++c) { // c: RGB channel index
        const int dst = rgb_out ? c : 2 - c;
        normalise_row(planar_row(plane_of[static_cast<std::size_t>(c)], view.y + y) + view.x, w, cf,
                      blend, dark, p.dark_brightness_factor, p.mean[static_cast<std::size_t>(dst)],
                      p.std[static_cast<std::size_t>(dst)], &out(0, dst, y, 0));
      }
  }

  // adjust_contrast's mean: the float grayscale of each pixel of rectangle m of the planar
  // image (plane_of: the planes of R, G, B), summed in double in pixel order (detail::gray_sum).
  float gray_mean(cv::Rect m, const std::array<int, 3>& plane_of) const {
    const auto at = [&](std::size_t c) { return planar_row(plane_of[c], m.y) + m.x; };
    const double sum = detail::gray_sum(at(0), at(1), at(2), static_cast<std::size_t>(planar_w_),
                                        m.width, m.height);
    return static_cast<float>(sum / (double(m.height) * m.width));
  }

  // clamp(v, 0, 1) exactly as std::clamp gives it (NaN and -0 kept), as max then min: compilers
  // turn this form into maxss / minss (fcsel on aarch64) where std::clamp stayed two branches.
  static float unit_clamp(float v) { return std::min(std::max(v, 0.0f), 1.0f); }

  // One channel's row: clamp(cf v + blend) (adjust_contrast), then clamp(bf v) when dark
  // (adjust_brightness), then (v - mean) / sd (Normalize); each operation rounded on its own.
  // Four values a step with SSE (every x86-64 CPU has it, so no run-time check; the same
  // operations in the same order, max and min with the operand order that matches
  // unit_clamp), the rest in plain C++. GCC left the plain loop scalar and branchy at -O2
  // (pixels either side of a clamp's bound mispredict) and, for dark rows, even at -O3.
  SHADOWSENSE_STRICT_FP static void normalise_row(const float* s, int w, float cf, float blend,
                                                  bool dark, float bf, float mean, float sd,
                                                  float* d) {
    SHADOWSENSE_STRICT_FP_BODY
    int x = 0;
#if defined(__SSE2__)
    const __m128 vcf = _mm_set1_ps(cf), vblend = _mm_set1_ps(blend), vbf = _mm_set1_ps(bf);
    const __m128 vmean = _mm_set1_ps(mean), vsd = _mm_set1_ps(sd);
    const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f);
    // _mm_max_ps(zero, v) is (0 > v ? 0 : v) = std::max(v, 0); _mm_min_ps(one, v) is
    // (1 < v ? 1 : v) = std::min(v, 1).
    for (; x + 4 <= w; x += 4) {
      __m128 v = _mm_add_ps(_mm_mul_ps(vcf, _mm_loadu_ps(s + x)), vblend);
      v = _mm_min_ps(one, _mm_max_ps(zero, v));
      if (dark) v = _mm_min_ps(one, _mm_max_ps(zero, _mm_mul_ps(vbf, v)));
      _mm_storeu_ps(d + x, _mm_div_ps(_mm_sub_ps(v, vmean), vsd));
    }
#endif
    for (; x < w; ++x) {
      float v = unit_clamp(cf * s[x] + blend);
      if (dark) v = unit_clamp(bf * v);
      d[x] = (v - mean) / sd;
    }
  }

  // The taps of an in_w x in_h -> out_w x out_h resize, made when the sizes change.
  void set_taps(int in_w, int in_h, int out_w, int out_h) {
    const std::array<int, 4> sizes{in_w, in_h, out_w, out_h};
    if (sizes == taps_for_) return;
    detail::resize_taps(in_w, out_w, xt_);
    detail::resize_taps(in_h, out_h, yt_);
    taps_for_ = sizes;
  }
  void resize_bilinear(const cv::Mat& src, int out_w, int out_h) {
    set_taps(src.cols, src.rows, out_w, out_h);
    resized_.create(out_h, out_w, CV_32FC3);
    for (int y = 0; y < out_h; ++y) {
      const auto ky = static_cast<std::size_t>(y);
      const float* r0 = src.ptr<float>(yt_.a[ky]);
      const float* r1 = src.ptr<float>(yt_.b[ky]);
      const float h0 = yt_.w0[ky], h1 = yt_.w1[ky];
      float* d = resized_.ptr<float>(y);
      for (int x = 0; x < out_w; ++x) {
        const auto kx = static_cast<std::size_t>(x);
        const int a = 3 * xt_.a[kx], b = 3 * xt_.b[kx];
        const float w0 = xt_.w0[kx], w1 = xt_.w1[kx];
        for (int c = 0; c < 3; ++c) {
          const float t0 = r0[a + c] * w0 + r0[b + c] * w1;
          const float t1 = r1[a + c] * w0 + r1[b + c] * w1;
          d[3 * x + c] = t0 * h0 + t1 * h1;
        }
      }
    }
  }

  // resize_bilinear of the image mapped through table, reading only the tapped pixels, into the
  // planar image.
  void resize_bilinear_mapped(const cv::Mat& src, const Table& table, int out_w, int out_h) {
    set_taps(src.cols, src.rows, out_w, out_h);
    planar_create(out_h, out_w);
    for (int y = 0; y < out_h; ++y) {
      const auto ky = static_cast<std::size_t>(y);
      detail::scaled_resize_pixels(xt_, 0, out_w, src.ptr<unsigned char>(yt_.a[ky]),
                                   src.ptr<unsigned char>(yt_.b[ky]), yt_.w0[ky], yt_.w1[ky], table,
                                   planar_out(y));
    }
  }

  // Python's round() on k / 2 values: halves go to the even neighbour.
  static int round_half_even(double v) {
    const double f = std::floor(v);
    if (v - f != 0.5) return static_cast<int>(std::floor(v + 0.5));
    const auto i = static_cast<long long>(f);
    return static_cast<int>(i % 2 == 0 ? i : i + 1);
  }

  // The planar image (planar_w_ x planar_h_, three planes in the input's channel order) that
  // crop_normalise_planar reads; grown, never shrunk (no allocation once at the frame size).
  void planar_create(int h, int w) {
    planar_h_ = h;
    planar_w_ = w;
    const std::size_t n = 3 * static_cast<std::size_t>(h) * static_cast<std::size_t>(w);
    if (planar_.size() < n) planar_.resize(n);
  }
  std::size_t planar_offset(int c, int y) const {
    return (static_cast<std::size_t>(c) * static_cast<std::size_t>(planar_h_) +
            static_cast<std::size_t>(y)) *
           static_cast<std::size_t>(planar_w_);
  }
  float* planar_row(int c, int y) {
    return planar_.data() + planar_offset(c, y);
  }
  const float* planar_row(int c, int y) const {
    return planar_.data() + planar_offset(c, y);
  }
  detail::PlanarRow planar_out(int y) {
    return {planar_row(0, y), planar_row(1, y), planar_row(2, y)};
  }

  Config config_;
  cv::Mat resized_;
  std::vector<float> planar_;
  int planar_w_ = 0, planar_h_ = 0;
  cv::Rect region_{};     // set_contrast_region; empty = the whole image
  cv::Size input_size_{}; // the image passed to the current run, before the resize
  detail::ResizeTaps xt_, yt_;
  std::array<int, 4> taps_for_{};       // the sizes xt_ and yt_ were made for
  detail::ScaledResizePlan plan_;       // run_scaled's vector plan over xt_
  detail::ScaledTable scaled_table_{};  // run_scaled's values (its portable loop, its tails)
  std::array<float, 3> scaled_gains_{}; // the gains scaled_table_ holds (0: none yet)
};

SHADOWSENSE_NAMESPACE_END
