// Gesture classification over any inference backend (classify/backend.hpp: the
// ClassifierBackend concept and its archetype). Classifier<Backend> owns the whole encoding of
// a frame (FrameEncoder: lighting normalisation, the dark-frame rule, preprocessing), runs the
// backend, and turns logits into probabilities with a numerically safe softmax and a label.
// This header includes no backend: the DenseNet one is backends/densenet/classifier.hpp
// (make_densenet_classifier).
//
// softmax(logits, probabilities)
//   requires: logits non-empty and finite; probabilities.size() == logits.size().
//   ensures: probabilities = softmax(logits), summing to 1 up to rounding; else InvalidArgument.
// Classifier(backend, config)
//   requires: the backend has at least one class; config.preprocess valid; config.empty_skin
//             set when config.preprocess.input_encoding needs a calibration (InvalidArgument);
//             config.camera_px_per_cm 0 (not known) or the calibration's px_per_cm: frames are
//             then brought to the network's scale (FrameEncoder stage 2b).
// classify(frame)        encodes frame (the dark-frame rule decides the brightness factor),
//                        infers, returns label, index and one probability per class.
// classify(frame, dark)  the same with the caller's dark flag (evaluation protocols).
// classify(tensor), classify_batch(tensor)
//                        an already encoded 1 x 3 x h x w / n x 3 x h x w tensor.
// classify(frame, out), classify(tensor, out)
//                        the same results written into out, reusing its storage: after the
//                        first call no heap allocation per frame (labels up to the string's
//                        small-buffer size, 15 characters in libstdc++, are never allocated).
//   throws: InvalidArgument for a bad frame or tensor; Error when the backend returns the
//           wrong number of logits or NaN/Inf.
// Threading: ONE INSTANCE PER THREAD. classify() reuses the encoder's buffers and the
//   backend's; an owner check (core/thread_owner.hpp) throws ConcurrentUseError when two
//   threads call into the same instance at once, instead of returning another thread's
//   probabilities. Movable (not while in use), not copyable.
#pragma once

#include <shadowsense/classify/backend.hpp>
#include <shadowsense/classify/frame_encoder.hpp>
#include <shadowsense/classify/preprocess.hpp>
#include <shadowsense/classify/preprocess_params.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/tensor.hpp>
#include <shadowsense/core/thread_owner.hpp>
#include <shadowsense/core/version.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <concepts>
#include <span>
#include <string>
#include <utility>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// Softmax through log-sum-exp in double: exp never overflows (logits of +-1e4 or more are
// fine) and the probabilities sum to 1 up to rounding. Throws on NaN/Inf logits.
inline void softmax(std::span<const float> logits, std::span<float> probabilities) {
  detail::require(!logits.empty(), "softmax: no logits, expected at least one");
  if (!(probabilities.size() == logits.size()))
    SHADOWSENSE_THROW(InvalidArgument("softmax: output has " +
                                      std::to_string(probabilities.size()) + " values, expected " +
                                      std::to_string(logits.size())));
  double mx = -INFINITY;
  for (float v : logits) {
    detail::require(std::isfinite(v), "softmax: logits hold NaN or Inf, expected finite values");
    mx = std::max(mx, double(v));
  }
  // Divide by the sum rather than subtract mx + log(sum): near 1e16 that addition rounds the
  // log away (two tied logits then gave 1 and 1, not 0.5 and 0.5).
  double sum = 0;
  for (float v : logits) sum += std::exp(double(v) - mx);
  for (std::size_t i = 0; i < logits.size(); ++i)
    probabilities[i] = static_cast<float>(std::exp(double(logits[i]) - mx) / sum);
}

struct Classification {
  std::string label;
  int index = -1;
  std::vector<float> probabilities; // one per class, in the backend's class order
};

template <ClassifierBackend Backend>
class Classifier {
public:
  struct Config {
    PreprocessParams preprocess{};                // usually the model file's
    ChannelOrder input_order = ChannelOrder::bgr; // order of the cv::Mat images passed in
    // The calibration's empty-skin model, for an input encoding that needs one
    // (FrameEncoder::Config::empty_skin; the encoder throws InvalidArgument without it).
    cv::Mat empty_skin{};
    // The camera's scale (SegmenterCalibration::px_per_cm; 0 = not known) and the fill around a
    // shrunk frame (FrameEncoder::Config).
    double camera_px_per_cm = 0;
    ScaleFill scale_fill = default_scale_fill;
  };

  explicit Classifier(Backend backend, Config config = {})
      : backend_(std::move(backend)),
        encoder_(FrameEncoder::Config{config.preprocess, config.input_order,
                                      std::move(config.empty_skin), config.camera_px_per_cm,
                                      config.scale_fill}) {
    detail::require(!class_names().empty(),
                    "Classifier: the backend has no classes, expected at least one");
  }

  Backend& backend() { return backend_; }
  const Backend& backend() const { return backend_; }
  std::span<const std::string> class_names() const { return backend_.class_names(); }
  const FrameEncoder& encoder() const { return encoder_; }
  const Preprocessor& preprocessor() const { return encoder_.preprocessor(); }

  // One frame, encoded by the model's own rules (lighting normalisation, dark-frame rule).
  Classification classify(const cv::Mat& frame) {
    const auto in_use = busy_.enter("Classifier::classify");
    encoder_.run(frame, input_);
    return classify_unchecked(input_);
  }
  // One frame with the caller's dark flag (ignored when the model normalises lighting).
  Classification classify(const cv::Mat& frame, bool dark) {
    const auto in_use = busy_.enter("Classifier::classify");
    encoder_.run(frame, dark, input_);
    return classify_unchecked(input_);
  }

  // A preprocessed 1 x 3 x h x w tensor.
  Classification classify(const Tensor& input) {
    const auto in_use = busy_.enter("Classifier::classify");
    return classify_unchecked(input);
  }

  // As classify(frame) / classify(tensor), into out (its storage reused).
  void classify(const cv::Mat& frame, Classification& out) {
    const auto in_use = busy_.enter("Classifier::classify");
    encoder_.run(frame, input_);
    classify_into(input_, out);
  }
  void classify(const Tensor& input, Classification& out) {
    const auto in_use = busy_.enter("Classifier::classify");
    classify_into(input, out);
  }

  std::vector<Classification> classify_batch(const Tensor& input) {
    const auto in_use = busy_.enter("Classifier::classify_batch");
    return classify_batch_unchecked(input);
  }

private:
  Classification classify_unchecked(const Tensor& input) {
    Classification out;
    classify_into(input, out);
    return out;
  }

  void classify_into(const Tensor& input, Classification& out) {
    if (input.n() != 1)
      SHADOWSENSE_THROW(InvalidArgument("Classifier::classify: batch of " +
                                        std::to_string(input.n()) +
                                        ", expected 1 (use classify_batch)"));
    with_logits(input, [&](std::span<const float> logits) { fill(logits, 0, out); });
  }

  // fn(logits) with the backend's logits for input, checked for count (n x classes), while the
  // backend's returned object is alive.
  template <class F>
  void with_logits(const Tensor& input, F&& fn) {
    if (input.empty())
      SHADOWSENSE_THROW(
          InvalidArgument("Classifier: input tensor is empty, expected n x 3 x h x w"));
    const std::size_t classes = class_names().size();
    decltype(auto) raw = backend_.logits(input); // keeps a returned container alive
    const std::span<const float> logits(raw);
    if (logits.size() != classes * static_cast<std::size_t>(input.n()))
      SHADOWSENSE_THROW(Error("Classifier: the backend returned " + std::to_string(logits.size()) +
                              " logits, expected batch x classes = " +
                              std::to_string(classes * static_cast<std::size_t>(input.n()))));
    fn(logits);
  }

  // Probabilities, index and label of image i.
  void fill(std::span<const float> logits, std::size_t i, Classification& c) const {
    const auto names = class_names();
    const std::size_t classes = names.size();
    c.probabilities.resize(classes);
    const auto row = logits.subspan(i * classes, classes);
    for (const float v : row)
      if (!std::isfinite(v))
        SHADOWSENSE_THROW(Error("Classifier: the backend returned NaN or Inf logits for image " +
                                std::to_string(i) + ", expected finite values"));
    softmax(row, c.probabilities);
    // argmax on logits: no ties
    c.index = static_cast<int>(std::max_element(row.begin(), row.end()) - row.begin());
    c.label = names[static_cast<std::size_t>(c.index)];
  }

  std::vector<Classification> classify_batch_unchecked(const Tensor& input) {
    std::vector<Classification> out;
    with_logits(input, [&](std::span<const float> logits) {
      out.resize(static_cast<std::size_t>(input.n()));
      for (std::size_t i = 0; i < out.size(); ++i) fill(logits, i, out[i]);
    });
    return out;
  }

  Backend backend_;
  FrameEncoder encoder_;
  Tensor input_;
  ThreadOwner busy_;
};

SHADOWSENSE_NAMESPACE_END
