// The ClassifierBackend concept: what Classifier<Backend> needs from an inference engine.
//
//   template <class B> concept ClassifierBackend = requires(B& b, const B& cb, const Tensor& x) {
//     { cb.class_names() } -> std::convertible_to<std::span<const std::string>>;
//     { b.logits(x) }      -> std::convertible_to<std::span<const float>>;
//   };
//
// class_names() const
//   ensures: the class names in the order of the logits; at least one (Classifier checks).
// logits(input)
//   requires: input is an n x 3 x h x w tensor as FrameEncoder makes it (n >= 1).
//   ensures: n x classes finite values, row per image; the returned object (a span, a vector,
//            ...) stays valid until the next call on the backend. NaN/Inf or a wrong count are
//            reported by Classifier as Error.
// Models: DenseNet (backends/densenet/classifier.hpp), or a user's wrapper of OpenCV DNN, ONNX
// Runtime or TensorRT; nothing of the DenseNet backend (GEMM, thread pool) is needed for that.
//
// ClassifierBackendArchetype: the least a backend must provide, checked against the concept
// below. It documents the concept; it is not meant to be used (its logits are empty).
#pragma once

#include <shadowsense/core/tensor.hpp>
#include <shadowsense/core/version.hpp>

#include <concepts>
#include <span>
#include <string>

SHADOWSENSE_NAMESPACE_BEGIN

template <class B>
concept ClassifierBackend = requires(B& backend, const B& cbackend, const Tensor& input) {
  { cbackend.class_names() } -> std::convertible_to<std::span<const std::string>>;
  { backend.logits(input) } -> std::convertible_to<std::span<const float>>;
};

struct ClassifierBackendArchetype {
  std::span<const std::string> class_names() const { return {}; }
  std::span<const float> logits(const Tensor&) { return {}; }
};
static_assert(ClassifierBackend<ClassifierBackendArchetype>,
              "the archetype is the minimal model of ClassifierBackend");

SHADOWSENSE_NAMESPACE_END
