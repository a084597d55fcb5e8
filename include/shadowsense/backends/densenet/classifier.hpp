// The reference classifier: Classifier<DenseNet> over a model file, its whole frame encoding
// (preprocessing, lighting normalisation, dark-frame rule) taken from the same file.
//
// make_densenet_classifier(model, config = {}, input_order = bgr)
//   requires: model valid (ModelFileError otherwise; the DenseNet constructor re-runs the
//             embedded self-test unless config.run_self_test is false).
//   ensures: a Classifier whose classify(frame) encodes frames as the model was trained.
// Threading: as Classifier: one instance per thread.
#pragma once

#include <shadowsense/backends/densenet/densenet.hpp>
#include <shadowsense/backends/densenet/model_file.hpp>
#include <shadowsense/classify/backend.hpp>
#include <shadowsense/classify/classifier.hpp>
#include <shadowsense/core/version.hpp>

SHADOWSENSE_NAMESPACE_BEGIN

static_assert(ClassifierBackend<DenseNet>, "the reference backend satisfies the concept");

inline Classifier<DenseNet> make_densenet_classifier(const ModelFile& model,
                                                     DenseNet::Config config = {},
                                                     ChannelOrder input_order = ChannelOrder::bgr) {
  return Classifier<DenseNet>(DenseNet(model, config), {model.preprocess, input_order});
}

SHADOWSENSE_NAMESPACE_END
