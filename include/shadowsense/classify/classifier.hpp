// Gesture classification over any inference backend. A backend is any type with
//   class_names() const  -> something convertible to std::span<const std::string>
//   logits(const Tensor&) -> something convertible to std::span<const float>
//                            (n x classes values for an n x 3 x h x w tensor)
// e.g. the DenseNet reference below, or a user's wrapper of OpenCV DNN, ONNX Runtime or
// TensorRT. Classifier<Backend> adds preprocessing, a numerically safe softmax and the label.
#pragma once

#include <shadowsense/backends/densenet/densenet.hpp>
#include <shadowsense/backends/densenet/model_file.hpp>
#include <shadowsense/classify/preprocess.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/tensor.hpp>
#include <shadowsense/core/version.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <concepts>
#include <span>
#include <string>
#include <utility>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

template <class B>
concept ClassifierBackend = requires(B& backend, const B& cbackend, const Tensor& input) {
  { cbackend.class_names() } -> std::convertible_to<std::span<const std::string>>;
  { backend.logits(input) } -> std::convertible_to<std::span<const float>>;
};

static_assert(ClassifierBackend<DenseNet>, "the reference backend satisfies the concept");

// Softmax through log-sum-exp in double: exp never overflows (logits of +-1e4 or more are
// fine) and the probabilities sum to 1 up to rounding. Throws on NaN/Inf logits.
inline void softmax(std::span<const float> logits, std::span<float> probabilities) {
  detail::require(!logits.empty(), "softmax: no logits, expected at least one");
  detail::require(probabilities.size() == logits.size(),
                  "softmax: output has " + std::to_string(probabilities.size()) +
                      " values, expected " + std::to_string(logits.size()));
  double mx = -INFINITY;
  for (float v : logits) {
    detail::require(std::isfinite(v), "softmax: logits hold NaN or Inf, expected finite values");
    mx = std::max(mx, double(v));
  }
  double sum = 0;
  for (float v : logits) sum += std::exp(double(v) - mx);
  const double lse = mx + std::log(sum);
  for (std::size_t i = 0; i < logits.size(); ++i)
    probabilities[i] = static_cast<float>(std::exp(double(logits[i]) - lse));
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
  };

  explicit Classifier(Backend backend, Config config = {})
      : backend_(std::move(backend)),
        preprocessor_(Preprocessor::Config{config.preprocess, config.input_order}) {
    detail::require(!class_names().empty(),
                    "Classifier: the backend has no classes, expected at least one");
  }

  Backend& backend() { return backend_; }
  const Backend& backend() const { return backend_; }
  std::span<const std::string> class_names() const { return backend_.class_names(); }
  const Preprocessor& preprocessor() const { return preprocessor_; }

  // One frame: preprocess (dark applies the brightness factor), infer, softmax.
  Classification classify(const cv::Mat& image, bool dark = false) {
    preprocessor_.run(image, dark, input_);
    return classify(input_);
  }

  // A preprocessed 1 x 3 x h x w tensor.
  Classification classify(const Tensor& input) {
    detail::require(input.n() == 1, "Classifier::classify: batch of " + std::to_string(input.n()) +
                                        ", expected 1 (use classify_batch)");
    return std::move(classify_batch(input).front());
  }

  std::vector<Classification> classify_batch(const Tensor& input) {
    detail::require(!input.empty(), "Classifier: input tensor is empty, expected n x 3 x h x w");
    const auto names = class_names();
    const std::size_t classes = names.size();
    decltype(auto) raw = backend_.logits(input); // keeps a returned container alive
    const std::span<const float> logits(raw);
    detail::require<Error>(logits.size() == classes * static_cast<std::size_t>(input.n()),
                           "Classifier: the backend returned " + std::to_string(logits.size()) +
                               " logits, expected batch x classes = " +
                               std::to_string(classes * static_cast<std::size_t>(input.n())));
    std::vector<Classification> out(static_cast<std::size_t>(input.n()));
    for (std::size_t i = 0; i < out.size(); ++i) {
      auto& c = out[i];
      c.probabilities.resize(classes);
      try {
        softmax(logits.subspan(i * classes, classes), c.probabilities);
      } catch (const InvalidArgument&) {
        throw Error("Classifier: the backend returned NaN or Inf logits for image " +
                    std::to_string(i) + ", expected finite values");
      }
      const auto row = logits.subspan(i * classes, classes); // argmax on logits: no ties
      c.index = static_cast<int>(std::max_element(row.begin(), row.end()) - row.begin());
      c.label = names[static_cast<std::size_t>(c.index)];
    }
    return out;
  }

private:
  Backend backend_;
  Preprocessor preprocessor_;
  Tensor input_;
};

// The reference classifier: DenseNet over a model file, preprocessing from the same file.
inline Classifier<DenseNet> make_densenet_classifier(const ModelFile& model,
                                                     DenseNet::Config config = {},
                                                     ChannelOrder input_order = ChannelOrder::bgr) {
  return Classifier<DenseNet>(DenseNet(model, config), {model.preprocess, input_order});
}

SHADOWSENSE_NAMESPACE_END
