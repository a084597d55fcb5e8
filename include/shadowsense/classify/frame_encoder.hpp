// FrameEncoder: a camera frame -> the network's input tensor, the one path every classifier
// entry point shares (Classifier, ss_classify, ss_train_head, ss_eval_classify, ss_demo;
// tools/train.py does the same arithmetic in PyTorch):
//   1. lighting normalisation (classify/lighting_normalise.hpp) when
//      params.lighting_normalise is set; the brightness factor is then never applied;
//   2. otherwise the dark-frame rule decides whether the brightness factor applies:
//      dark <=> mean luminance(frame) < params.dark_luminance_threshold (is_dark below);
//   3. the Preprocessor (resize, crop, contrast, brightness, Normalize).
//
// FrameEncoder(Config)
//   requires: config.params.validate() passes; input order rgb or bgr (else InvalidArgument).
// FrameEncoder(params, force_lighting_normalise)
//   the BGR encoder of params, with lighting normalisation switched on when
//   force_lighting_normalise is true (programs' --lighting-normalise for version-1 model
//   files that do not record it); false keeps params.lighting_normalise as it is.
// mean_luminance(frame) const -> double
//   requires: frame CV_8UC3 or CV_32FC3 (0..1) in config().input_order.
//   ensures: the mean over all pixels of 0.2989 R + 0.587 G + 0.114 B, in 0..1.
// is_dark(frame) const -> bool
//   ensures: mean_luminance(frame) < params.dark_luminance_threshold (false when it is 0).
// run(frame, out)        encodes with the dark-frame rule.
// run(frame, dark, out)  encodes with the caller's dark flag (evaluations that follow the
//                        paper's protocol, where dark comes from the collection metadata);
//                        ignored when lighting normalisation is on.
//   requires: frame CV_8UC3 (0..255) or CV_32FC3 (0..1) in config().input_order.
//   ensures: out is the 1 x 3 x h x w input; throws InvalidArgument on a bad frame.
// Threading: run() reuses internal buffers: one instance per thread.
#pragma once

#include <shadowsense/classify/lighting_normalise.hpp>
#include <shadowsense/classify/preprocess.hpp>
#include <shadowsense/classify/preprocess_params.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/tensor.hpp>
#include <shadowsense/core/version.hpp>

#include <opencv2/core.hpp>

#include <string>

SHADOWSENSE_NAMESPACE_BEGIN

class FrameEncoder {
public:
  struct Config {
    PreprocessParams params{};                    // usually the model file's
    ChannelOrder input_order = ChannelOrder::bgr; // cv::imread / cv::VideoCapture give BGR
  };

  FrameEncoder() : FrameEncoder(Config{}) {}
  explicit FrameEncoder(Config config)
      : config_(config), pre_(Preprocessor::Config{config.params, config.input_order}),
        norm_(LightingNormaliser::Config{.target = config.params.lighting_target}) {}
  FrameEncoder(const PreprocessParams& params, bool force_lighting_normalise)
      : FrameEncoder(Config{forced(params, force_lighting_normalise), ChannelOrder::bgr}) {}

  const Config& config() const { return config_; }
  bool lighting_normalise() const { return config_.params.lighting_normalise; }
  const Preprocessor& preprocessor() const { return pre_; }

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
    const bool dark =
        !lighting_normalise() && t > 0.0f && checked_mean_luminance(frame) < double(t);
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
    if (lighting_normalise() && frame.type() == CV_8UC3) {
      // The normalisation as a value table applied while resizing: the same values as
      // norm_.run then pre_.run, without a full-size float image.
      norm_.table(frame, table_);
      pre_.run_mapped(frame, table_, false, out);
    } else if (lighting_normalise()) {
      norm_.run(frame, float_);
      pre_.run(float_, false, out);
    } else {
      pre_.run(frame, dark, out);
    }
  }

  static PreprocessParams forced(PreprocessParams p, bool force) {
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

  Config config_;
  Preprocessor pre_;
  LightingNormaliser norm_;
  cv::Mat float_;
  LightingNormaliser::Table table_{};
};

SHADOWSENSE_NAMESPACE_END
