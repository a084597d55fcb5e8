// FrameEncoder: a camera frame -> the network's input tensor, the one path every classifier
// entry point shares (Classifier, ss_classify, ss_train_head, ss_eval_classify, ss_demo;
// tools/train.py does the same arithmetic in PyTorch):
//   0. the input encoding (params.input_encoding, classify/preprocess_params.hpp):
//      colour: the frame as it is. skin_relative: with m the calibration's empty-skin model
//      (SegmenterCalibration::empty_skin: per pixel and channel the lit empty skin's
//      brightness over its frame's reference, about 1 on the skin; bilinearly resized with
//      cv::resize INTER_LINEAR when its size is not the frame's) and f the frame in 0..1
//      (v / 255 for 8-bit frames), per pixel and channel, in float:
//        skin  = (m_B + m_G) + m_R >= 1.5      (the segmenter's skin test: mean >= 0.5)
//        value = skin ? min(f / max(m, 0.125), 1) : 0
//      so the lit empty skin becomes flat at its reference brightness (the light level stays:
//      the dark-frame rule and the lighting normalisation keep their meaning), a shadow keeps
//      its darkness relative to the skin under it, and whatever is not skin is black. The
//      dark-frame rule reads the frame itself, never the encoded image.
//      darkness_warmth: the relative pixel rule's features (sense/pixel_rule.hpp), defined here
//      so that tools/train.py computes the same bits. With m, f and skin as above, per skin pixel
//      and channel q = f / max(m, 0.125) (unclipped); the frame's reference per channel r is the
//      90th percentile of q over the skin pixels of every third row and column (rows and columns
//      1, 4, 7, ...): b = min(floor(512 q), 1023) binned, r = (b* + 0.5) / 512 with b* the
//      smallest bin whose count from below reaches ceil(9 n / 10) of the n samples, floored at
//      1/64 (r = 1 with no sample). Then p = q / r and, in float,
//        darkness = clamp(1 - ((p_B + p_G) + p_R) / 3, 0, 1)
//        warmth   = clamp(0.5 + 0.5 (p_R - p_B), 0, 1)
//      in the R, G and B slots of the image (the network's RGB channels 0, 1, 2 hold darkness,
//      warmth, skin), the B slot 1 on the skin; all three are 0 off the skin. The light level is
//      divided out (lighting normalisation is refused, PreprocessParams::validate) and the frame
//      is never dark (no brightness factor);
//      masks: what the calibrated segmenter decides (sense/segmenter.hpp): a Segmenter with the
//      default SegmenterConfig and the default relative-rule thresholds (SegmenterCalibration{}:
//      shadow darkness 0.2, contact darkness 0.45, contact warmth 0.08) over m, the empty-skin
//      model (bilinearly resized to the frame's size as above, then smoothed by the segmenter's
//      own profile_smoothing), segments the frame (a CV_32FC3 frame is first rounded to 8 bits,
//      v * 255 saturated as cv::Mat::convertTo does; an RGB one reordered to BGR). The image is
//      1 where the segmenter's shadow mask is set (R slot), 1 where its contact mask is set (G
//      slot; both after the mask blur and threshold), the skin test above in the B slot, and 0
//      elsewhere. The thresholds are the ones every masks model is trained with, not a robot's
//      fitted ones (which would change what the network sees); the calibration gives the empty
//      skin. Independent of the light level like darkness_warmth (no lighting normalisation,
//      never dark);
//      darkness_contact (a combination): darkness_warmth's image with the masks encoding's
//      contact plane in the warmth slot (G): darkness, the segmenter's contact decision, skin.
//      Light-independent likewise;
//   1. lighting normalisation (classify/lighting_normalise.hpp) when
//      params.lighting_normalise is set; the brightness factor is then never applied;
//   2. otherwise the dark-frame rule decides whether the brightness factor applies:
//      dark <=> mean luminance(frame) < params.dark_luminance_threshold (is_dark below);
//   2b. the camera's scale (config.camera_px_per_cm > 0, a calibration's px_per_cm): the frame
//      is brought to the scale the network was trained at, network_scale (the generator rig:
//      7.578125 px per cm of skin in a 635 x 350 frame), per axis about the frame's centre:
//        s_x = camera_px_per_cm / network_scale.px_per_cm * network_scale.width / W
//        s_y = camera_px_per_cm / network_scale.px_per_cm * network_scale.height / H
//      |s - 1| < 0.01: the axis is left as it is. s > 1 (hands look larger than in training):
//      the frame shrinks to n = round(N / s) (N = W or H) at offset floor((N - n) / 2) and the
//      rest is filled (config.scale_fill: black, or the shrunk frame's border repeated). s < 1:
//      the centre n = round(N s) at offset floor((N - n) / 2) is enlarged to N. cv::resize,
//      INTER_AREA when both axes shrink, else INTER_LINEAR. The dark-frame rule and the
//      lighting normalisation's gains are taken from the frame as it is (the light does not
//      change with the framing); the gains then apply to the rescaled frame. Without a scale
//      the frame is not touched (bit for bit the encoder before the stage existed);
//   3. the Preprocessor (resize, crop, contrast, brightness, Normalize).
//
// FrameEncoder(Config)
//   requires: config.params.validate() passes; input order rgb or bgr (else InvalidArgument);
//             config.empty_skin empty, or CV_32FC3 (B, G, R: the calibration's order whatever
//             the input order) with finite values in [0, 8] (else InvalidArgument).
//             config.camera_px_per_cm 0 or finite in [0.05, 10000] (else InvalidArgument).
//   throws:   InvalidArgument naming the input encoding when it needs a calibration
//             (needs_calibration) and config.empty_skin is empty: a model trained on
//             skin-relative frames never runs on raw colour.
// require_empty_skin(encoding, have): throws that error when have is false and the encoding
//   needs a calibration (callers check before costly work).
// set_empty_skin(model): replaces the empty-skin model (same requirements; an empty model is
//   refused when the encoding needs one, and ignored by the colour encoding).
// set_camera_px_per_cm(v): replaces the camera's scale (same requirement; 0 = not known).
// scale_factors(frame_size) -> (s_x, s_y) of stage 2b (1 on an axis left as it is).
// rescale(frame, out) -> out: stage 2b alone (frame itself when both factors are 1); any
//   type cv::resize takes; the tests and tools use it to see what the network sees. Also sets
//   the Preprocessor's contrast region for the next run (black_frame_contrast).
// FrameEncoder(params, force_lighting_normalise, empty_skin = {}, camera_px_per_cm = 0,
//              scale_fill = default_scale_fill)
//   the BGR encoder of params (with that empty-skin model and camera scale), with lighting
//   normalisation switched on
//   when force_lighting_normalise is true (programs' --lighting-normalise for version-1 model files
//   that do not record it); false keeps params.lighting_normalise as it is. Forcing it on a
//   darkness_warmth or masks model throws InvalidArgument naming the option (those take none).
// mean_luminance(frame) const -> double
//   requires: frame CV_8UC3 or CV_32FC3 (0..1) in config().input_order.
//   ensures: the mean over all pixels of 0.2989 R + 0.587 G + 0.114 B, in 0..1.
// is_dark(frame) const -> bool
//   ensures: mean_luminance(frame) < params.dark_luminance_threshold (false when it is 0).
// run(frame, out)        encodes with the dark-frame rule.
// run(frame, dark, out)  encodes with the caller's dark flag (evaluations that follow the
//                        paper's protocol, where dark comes from the collection metadata);
//                        ignored when lighting normalisation is on or the encoding is
//                        light-independent (darkness_warmth, masks).
//   requires: frame CV_8UC3 (0..255) or CV_32FC3 (0..1) in config().input_order.
//   ensures: out is the 1 x 3 x h x w input; throws InvalidArgument on a bad frame.
// encode_input(frame, out) (a calibrated encoding only): stage 0 alone, out CV_32FC3 in 0..1 in
//   the input order (the golden tests compare it with tools/train.py's).
// Threading: run() reuses internal buffers: one instance per thread.
#pragma once

#include <shadowsense/classify/lighting_normalise.hpp>
#include <shadowsense/classify/preprocess.hpp>
#include <shadowsense/classify/preprocess_params.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/tensor.hpp>
#include <shadowsense/core/version.hpp>
#include <shadowsense/sense/segmenter.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// The scale the network sees hands at (stage 2b): the generator rig every model of this project
// is trained on (sim::Rig::robot(): 242.5 px per rad at 32 cm on the optical axis, 635 x 350).
struct NetworkScale {
  double px_per_cm;
  int width, height;
};
inline constexpr NetworkScale network_scale{242.5 / 32.0, 635, 350};

// What fills the frame around a frame that stage 2b shrinks.
//   black                 0 in every channel (the robot's interior around the skin);
//   replicate             the shrunk frame's border pixels repeated;
//   black_frame_contrast  black, and the Preprocessor's contrast mean read from the frame's own
//                         pixels only (Preprocessor::set_contrast_region), so the fill does not
//                         move it.
enum class ScaleFill : std::uint32_t { black = 0, replicate = 1, black_frame_contrast = 2 };
inline constexpr const char* to_string(ScaleFill f) {
  return f == ScaleFill::black                  ? "black"
         : f == ScaleFill::replicate            ? "replicate"
         : f == ScaleFill::black_frame_contrast ? "black_frame_contrast"
                                                : "unknown";
}
inline std::optional<ScaleFill> parse_scale_fill(std::string_view name) {
  for (ScaleFill f : {ScaleFill::black, ScaleFill::replicate, ScaleFill::black_frame_contrast})
    if (name == to_string(f)) return f;
  return std::nullopt;
}
// The fill the pre-registered comparison selected (docs/validation_protocol.md, "Issue 21, scale
// from the calibration", rule 1).
inline constexpr ScaleFill default_scale_fill = ScaleFill::black_frame_contrast;

class FrameEncoder {
public:
  struct Config {
    PreprocessParams params{};                    // usually the model file's
    ChannelOrder input_order = ChannelOrder::bgr; // cv::imread / cv::VideoCapture give BGR
    // The calibration's empty-skin model (SegmenterCalibration::empty_skin, BGR); needed by
    // the skin_relative encoding, ignored by colour.
    cv::Mat empty_skin{};
    // The camera's scale (SegmenterCalibration::px_per_cm; 0 = not known: no rescaling) and
    // what fills the frame around it when it shrinks (stage 2b).
    double camera_px_per_cm = 0;
    ScaleFill scale_fill = default_scale_fill;
  };

  // The skin test and the division floor of the calibrated encodings, and the darkness_warmth
  // reference's bins and floor (header comment).
  static constexpr float skin_model_sum = 1.5f;
  static constexpr float model_floor = 0.125f;
  static constexpr int reference_bins = 1024;
  static constexpr float reference_bins_per_unit = 512.0f;
  static constexpr float reference_floor = 1.0f / 64.0f;

  FrameEncoder() : FrameEncoder(Config{}) {}
  explicit FrameEncoder(Config config)
      : config_(std::move(config)), pre_(Preprocessor::Config{config_.params, config_.input_order}),
        norm_(LightingNormaliser::Config{.target = config_.params.lighting_target}) {
    cv::Mat model = std::move(config_.empty_skin);
    config_.empty_skin.release();
    set_empty_skin(model);
    set_camera_px_per_cm(config_.camera_px_per_cm);
    detail::require(parse_scale_fill(to_string(config_.scale_fill)).has_value(),
                    "FrameEncoder: scale_fill must be black, replicate or black_frame_contrast");
  }
  FrameEncoder(const PreprocessParams& params, bool force_lighting_normalise,
               cv::Mat empty_skin = {}, double camera_px_per_cm = 0,
               ScaleFill scale_fill = default_scale_fill)
      : FrameEncoder(Config{forced(params, force_lighting_normalise), ChannelOrder::bgr,
                            std::move(empty_skin), camera_px_per_cm, scale_fill}) {}

  const Config& config() const { return config_; }
  bool lighting_normalise() const { return config_.params.lighting_normalise; }
  const Preprocessor& preprocessor() const { return pre_; }
  InputEncoding input_encoding() const { return config_.params.input_encoding; }

  // Throws the missing-calibration error when encoding e needs an empty-skin model and
  // have_empty_skin is false (make_densenet_classifier checks before the self-test).
  static void require_empty_skin(InputEncoding e, bool have_empty_skin) {
    if (needs_calibration(e) && !have_empty_skin)
      SHADOWSENSE_THROW(InvalidArgument(
          std::string("FrameEncoder: the model's input encoding is ") + to_string(e) +
          ", which needs a calibration with an empty-skin model (FrameEncoder::Config::"
          "empty_skin; programs: --calibration FILE from ss_calibrate), and none was given"));
  }

  void set_empty_skin(const cv::Mat& model) {
    const InputEncoding e = config_.params.input_encoding;
    if (model.empty()) {
      require_empty_skin(e, false);
      config_.empty_skin.release();
      model_.release();
      segmenter_.reset();
      return;
    }
    if (!(model.dims == 2 && model.type() == CV_32FC3))
      SHADOWSENSE_THROW(InvalidArgument("FrameEncoder: the empty-skin model is " +
                                        cv::typeToString(model.type()) +
                                        ", expected CV_32FC3 (a calibration's empty_skin)"));
    if (!cv::checkRange(model, true, nullptr, 0.0, 8.0))
      SHADOWSENSE_THROW(InvalidArgument(
          "FrameEncoder: the empty-skin model holds values outside [0, 8] or not finite, "
          "expected brightness relative to the reference (about 1 on the skin)"));
    config_.empty_skin = model.clone();
    model_.release(); // resized (and reordered) for the first frame's size
    segmenter_.reset();
  }

  void set_camera_px_per_cm(double v) {
    if (!(v == 0 || (std::isfinite(v) && v >= 0.05 && v <= 10000)))
      SHADOWSENSE_THROW(InvalidArgument("FrameEncoder: camera_px_per_cm is " + std::to_string(v) +
                                        ", expected 0 (not known) or a scale in [0.05, 10000] "
                                        "px per cm (the calibration's px_per_cm)"));
    config_.camera_px_per_cm = v;
  }

  std::pair<double, double> scale_factors(cv::Size frame) const {
    if (config_.camera_px_per_cm == 0 || frame.width < 1 || frame.height < 1) return {1.0, 1.0};
    const double r = config_.camera_px_per_cm / network_scale.px_per_cm;
    auto axis = [](double s) { return std::abs(s - 1.0) < 0.01 ? 1.0 : s; };
    return {axis(r * network_scale.width / frame.width),
            axis(r * network_scale.height / frame.height)};
  }

  const cv::Mat& rescale(const cv::Mat& frame, cv::Mat& out) {
    pre_.set_contrast_region({});
    const auto [sx, sy] = scale_factors(frame.size());
    if (sx == 1.0 && sy == 1.0) return frame;
    // Per axis: the source span [a, a + n) and where it lands in the output, [o, o + m).
    struct Span {
      int a, n, o, m;
    };
    auto span = [](int N, double s) {
      if (s > 1) {
        const int m = std::max(1, static_cast<int>(std::lround(N / s)));
        return Span{0, N, (N - m) / 2, m};
      }
      const int n = std::max(1, static_cast<int>(std::lround(N * s)));
      return Span{(N - n) / 2, n, 0, N};
    };
    const Span x = span(frame.cols, sx), y = span(frame.rows, sy);
    const int interpolation = sx > 1 && sy > 1 ? cv::INTER_AREA : cv::INTER_LINEAR;
    const cv::Mat source = frame(cv::Rect(x.a, y.a, x.n, y.n));
    if (x.m == frame.cols && y.m == frame.rows) {
      cv::resize(source, out, frame.size(), 0, 0, interpolation);
      return out;
    }
    cv::resize(source, shrunk_, cv::Size(x.m, y.m), 0, 0, interpolation);
    const bool black = config_.scale_fill != ScaleFill::replicate;
    if (config_.scale_fill == ScaleFill::black_frame_contrast)
      pre_.set_contrast_region(cv::Rect(x.o, y.o, x.m, y.m));
    cv::copyMakeBorder(shrunk_, out, y.o, frame.rows - y.m - y.o, x.o, frame.cols - x.m - x.o,
                       black ? cv::BORDER_CONSTANT : cv::BORDER_REPLICATE, cv::Scalar::all(0));
    return out;
  }

  // Stage 0 of a calibrated encoding: out CV_32FC3 in 0..1, in the input order.
  void encode_input(const cv::Mat& frame, cv::Mat& out) {
    check_frame(frame);
    detail::require(input_encoding() != InputEncoding::colour,
                    "FrameEncoder::encode_input: the input encoding is colour (nothing to do)");
    encode_calibrated(frame, out);
  }

  double mean_luminance(const cv::Mat& frame) const {
    check_frame(frame);
    return checked_mean_luminance(frame);
  }
  bool is_dark(const cv::Mat& frame) const {
    const float t = config_.params.dark_luminance_threshold;
    return t > 0.0f && mean_luminance(frame) < double(t);
  }

  void run(const cv::Mat& frame, Tensor& out) {
    check_frame(frame);
    const float t = config_.params.dark_luminance_threshold;
    const bool dark = !lighting_normalise() && !light_independent(input_encoding()) && t > 0.0f &&
                      checked_mean_luminance(frame) < double(t);
    checked_run(frame, dark, out);
  }
  void run(const cv::Mat& frame, bool dark, Tensor& out) {
    check_frame(frame);
    checked_run(frame, dark, out);
  }

private:
  // The checked_* functions take a frame check_frame has passed (each entry point checks once).
  double checked_mean_luminance(const cv::Mat& frame) const {
    const bool bgr = config_.input_order == ChannelOrder::bgr;
    const double wr = 0.2989, wg = 0.587, wb = 0.114;
    const cv::Scalar s = cv::mean(frame);
    const double scale = frame.type() == CV_8UC3 ? 1.0 / 255.0 : 1.0;
    const double r = bgr ? s[2] : s[0], b = bgr ? s[0] : s[2];
    return scale * (wr * r + wg * s[1] + wb * b);
  }
  void checked_run(const cv::Mat& frame, bool dark, Tensor& out) {
    // The encoded images are finite and in 0..1 by construction: no second range check.
    if (light_independent(input_encoding())) {
      encode_calibrated(frame, encoded_); // independent of the light: never dark
      pre_.run_in_range(rescale(encoded_, scaled_), false, out);
    } else if (input_encoding() == InputEncoding::skin_relative) {
      skin_relative(frame, encoded_);
      if (lighting_normalise()) {
        norm_.run(encoded_, float_);
        pre_.run_in_range(rescale(float_, scaled_), false, out);
      } else {
        pre_.run_in_range(rescale(encoded_, scaled_), dark, out);
      }
    } else if (lighting_normalise() && frame.type() == CV_8UC3) {
      // The normalisation's gains applied while resizing: the same values as norm_.run then
      // pre_.run, without a full-size float image. The gains come from the frame as it is, the
      // pixels from the rescaled frame (stage 2b).
      pre_.run_scaled(rescale(frame, scaled_), norm_.gains(frame), false, out);
    } else if (lighting_normalise()) {
      norm_.run(frame, float_);
      pre_.run(rescale(float_, scaled_), false, out);
    } else {
      pre_.run(rescale(frame, scaled_), dark, out);
    }
  }

  static PreprocessParams forced(PreprocessParams p, bool force) {
    if (force && light_independent(p.input_encoding))
      SHADOWSENSE_THROW(InvalidArgument(
          std::string("FrameEncoder: lighting normalisation was asked for (a program's "
                      "--lighting-normalise) with a model whose input encoding is ") +
          to_string(p.input_encoding) +
          ", which has the light divided out and takes none: "
          "drop the option"));
    if (force) p.lighting_normalise = true;
    return p;
  }
  static void check_frame(const cv::Mat& frame) {
    if (!(!frame.empty() && frame.dims == 2 &&
          (frame.type() == CV_8UC3 || frame.type() == CV_32FC3)))
      SHADOWSENSE_THROW(
          InvalidArgument("FrameEncoder: frame is " +
                          (frame.empty() ? std::string("empty") : cv::typeToString(frame.type())) +
                          ", expected CV_8UC3 (0..255) or CV_32FC3 (0..1)"));
  }

  // The model at the frame's size in the input order, its divisor max(m, model_floor) and the
  // skin test per pixel (made on the first frame of a size).
  void model_for(cv::Size size) {
    if (!model_.empty() && model_.size() == size) return;
    const cv::Mat& m = config_.empty_skin;
    if (m.size() == size)
      model_ = m.clone();
    else
      cv::resize(m, model_, size, 0, 0, cv::INTER_LINEAR);
    if (config_.input_order == ChannelOrder::rgb) cv::cvtColor(model_, model_, cv::COLOR_BGR2RGB);
    divisor_ = cv::max(model_, model_floor);
    // The skin test sums B, G, R in that order whatever the input order (as tools/train.py).
    const int b = config_.input_order == ChannelOrder::bgr ? 0 : 2, r = 2 - b;
    skin_.create(size, CV_8UC1);
    for (int y = 0; y < size.height; ++y) {
      const float* mm = model_.ptr<float>(y);
      unsigned char* k = skin_.ptr<unsigned char>(y);
      for (int x = 0; x < size.width; ++x, mm += 3)
        k[x] = (mm[b] + mm[1]) + mm[r] >= skin_model_sum ? 1 : 0;
    }
  }

  void encode_calibrated(const cv::Mat& frame, cv::Mat& out) {
    if (input_encoding() == InputEncoding::darkness_warmth)
      darkness_warmth(frame, out);
    else if (input_encoding() == InputEncoding::masks)
      masks(frame, out);
    else if (input_encoding() == InputEncoding::darkness_contact)
      darkness_contact(frame, out);
    else
      skin_relative(frame, out);
  }

  // q = f / max(m, floor) for every value of the frame (on the skin or not): flat loops over
  // each row, which the compiler vectorises (IEEE division: the same bits as one at a time).
  void skin_quotient(const cv::Mat& frame, cv::Mat& out) {
    check_float_frame(frame);
    model_for(frame.size());
    out.create(frame.rows, frame.cols, CV_32FC3);
    const int n = 3 * frame.cols;
    for (int y = 0; y < frame.rows; ++y) {
      const float* __restrict div = divisor_.ptr<float>(y);
      float* __restrict d = out.ptr<float>(y);
      if (frame.type() == CV_8UC3) {
        const unsigned char* __restrict v = frame.ptr<unsigned char>(y);
        for (int i = 0; i < n; ++i) d[i] = static_cast<float>(v[i]) / 255.0f / div[i];
      } else {
        const float* __restrict f = frame.ptr<float>(y);
        for (int i = 0; i < n; ++i) d[i] = f[i] / div[i];
      }
    }
  }

  void darkness_warmth(const cv::Mat& frame, cv::Mat& out) {
    skin_quotient(frame, out);
    // The reference: the 90th percentile of q per channel over the skin samples, binned.
    for (auto& h : hist_) h.fill(0);
    int n = 0;
    for (int y = 1; y < out.rows; y += 3) {
      const float* q = out.ptr<float>(y);
      const unsigned char* skin = skin_.ptr<unsigned char>(y);
      for (int x = 1; x < out.cols; x += 3) {
        if (!skin[x]) continue;
        ++n;
        for (int c = 0; c < 3; ++c) {
          const float v = q[3 * x + c] * reference_bins_per_unit;
          ++hist_[c][static_cast<std::size_t>(v >= reference_bins - 1 ? reference_bins - 1
                                                                      : static_cast<int>(v))];
        }
      }
    }
    float ref[3] = {1.0f, 1.0f, 1.0f};
    if (n > 0) {
      const int target = std::max(1, (9 * n + 9) / 10); // ceil(9 n / 10)
      for (int c = 0; c < 3; ++c) {
        int below = 0, bin = 0;
        for (; bin < reference_bins - 1; ++bin) {
          below += hist_[c][static_cast<std::size_t>(bin)];
          if (below >= target) break;
        }
        ref[c] =
            std::max(reference_floor, (static_cast<float>(bin) + 0.5f) / reference_bins_per_unit);
      }
    }
    // p = q / r as a flat loop over each row (r repeated per pixel), then the features in
    // place; slots by channel role whatever the input order.
    const int w = 3 * out.cols;
    reference_row_.resize(static_cast<std::size_t>(w));
    for (int i = 0; i < w; ++i) reference_row_[static_cast<std::size_t>(i)] = ref[i % 3];
    const float* __restrict rr = reference_row_.data();
    const int b = config_.input_order == ChannelOrder::bgr ? 0 : 2, r = 2 - b;
    for (int y = 0; y < out.rows; ++y) {
      float* __restrict d = out.ptr<float>(y);
      for (int i = 0; i < w; ++i) d[i] = d[i] / rr[i];
      const unsigned char* skin = skin_.ptr<unsigned char>(y);
      for (int x = 0; x < out.cols; ++x) {
        float* px = d + 3 * x;
        if (!skin[x]) {
          px[0] = px[1] = px[2] = 0.0f;
          continue;
        }
        const float pb = px[b], pg = px[1], pr = px[r];
        const float darkness = std::clamp(1.0f - ((pb + pg) + pr) / 3.0f, 0.0f, 1.0f);
        const float warmth = std::clamp(0.5f + 0.5f * (pr - pb), 0.0f, 1.0f);
        px[r] = darkness;
        px[1] = warmth;
        px[b] = 1.0f;
      }
    }
  }

  // A float frame's values are checked here (the Preprocessor sees only the encoded image).
  static void check_float_frame(const cv::Mat& frame) {
    if (frame.type() == CV_8UC3) return;
    detail::require(cv::checkRange(frame), "FrameEncoder: float frame holds NaN or Inf, "
                                           "expected finite values in 0..1");
    double lo = 0, hi = 0;
    cv::minMaxIdx(frame.reshape(1), &lo, &hi);
    if (!(lo >= 0.0 && hi <= 1.0))
      SHADOWSENSE_THROW(InvalidArgument("FrameEncoder: float frame values span " +
                                        std::to_string(lo) + ".." + std::to_string(hi) +
                                        ", expected 0..1"));
  }

  // The segmenter's shadow and contact masks beside the skin test (header comment).
  void masks(const cv::Mat& frame, cv::Mat& out) {
    check_float_frame(frame);
    model_for(frame.size());
    segment(frame);
    out.create(frame.rows, frame.cols, CV_32FC3);
    const int b = config_.input_order == ChannelOrder::rgb ? 2 : 0, r = 2 - b;
    for (int y = 0; y < frame.rows; ++y) {
      const unsigned char* shadow = segmentation_.shadow_mask.ptr<unsigned char>(y);
      const unsigned char* contact = segmentation_.contact_mask.ptr<unsigned char>(y);
      const unsigned char* skin = skin_.ptr<unsigned char>(y);
      float* d = out.ptr<float>(y);
      for (int x = 0; x < frame.cols; ++x, d += 3) {
        d[r] = shadow[x] ? 1.0f : 0.0f;
        d[1] = contact[x] ? 1.0f : 0.0f;
        d[b] = skin[x] ? 1.0f : 0.0f;
      }
    }
  }

  // darkness_warmth's image, the contact mask in the warmth slot (header comment).
  void darkness_contact(const cv::Mat& frame, cv::Mat& out) {
    darkness_warmth(frame, out);
    segment(frame);
    for (int y = 0; y < frame.rows; ++y) {
      const unsigned char* contact = segmentation_.contact_mask.ptr<unsigned char>(y);
      float* d = out.ptr<float>(y);
      for (int x = 0; x < frame.cols; ++x) d[3 * x + 1] = contact[x] ? 1.0f : 0.0f;
    }
  }

  // segmentation_ of the frame by the masks encoding's segmenter (header comment); the frame
  // has passed check_float_frame.
  void segment(const cv::Mat& frame) {
    const bool rgb = config_.input_order == ChannelOrder::rgb;
    const cv::Mat* bgr = &frame;
    if (frame.type() == CV_32FC3) {
      frame.convertTo(bgr8_, CV_8UC3, 255.0);
      if (rgb) cv::cvtColor(bgr8_, bgr8_, cv::COLOR_RGB2BGR);
      bgr = &bgr8_;
    } else if (rgb) {
      cv::cvtColor(frame, bgr8_, cv::COLOR_RGB2BGR);
      bgr = &bgr8_;
    }
    if (!segmenter_ || segmenter_size_ != frame.size()) {
      SegmenterConfig sc;
      const cv::Mat& m = config_.empty_skin; // BGR, the calibration's order
      if (m.size() == frame.size())
        sc.calibration.empty_skin = m;
      else
        cv::resize(m, sc.calibration.empty_skin, frame.size(), 0, 0, cv::INTER_LINEAR);
      segmenter_.emplace(sc);
      segmenter_size_ = frame.size();
    }
    segmenter_->segment(*bgr, segmentation_);
  }

  // min(q, 1) on the skin, 0 off it.
  void skin_relative(const cv::Mat& frame, cv::Mat& out) {
    skin_quotient(frame, out);
    for (int y = 0; y < out.rows; ++y) {
      float* d = out.ptr<float>(y);
      const unsigned char* skin = skin_.ptr<unsigned char>(y);
      for (int x = 0; x < out.cols; ++x)
        for (int c = 0; c < 3; ++c) d[3 * x + c] = skin[x] ? std::min(d[3 * x + c], 1.0f) : 0.0f;
    }
  }

  Config config_;
  Preprocessor pre_;
  LightingNormaliser norm_;
  cv::Mat float_, encoded_, model_, scaled_;
  cv::Mat divisor_, skin_;             // max(model_, model_floor); the skin test (0/1)
  std::vector<float> reference_row_;   // darkness_warmth: r per value of a row
  std::optional<Segmenter> segmenter_; // masks: made for the first frame of a size
  cv::Size segmenter_size_{};
  Segmentation segmentation_{};
  cv::Mat bgr8_;   // masks: a float or RGB frame as the segmenter's 8-bit BGR
  cv::Mat shrunk_; // rescale()'s shrunk frame before its border is filled
  std::array<std::array<int, reference_bins>, 3> hist_{}; // darkness_warmth's reference
};

SHADOWSENSE_NAMESPACE_END
