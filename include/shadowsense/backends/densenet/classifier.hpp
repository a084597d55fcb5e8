// The reference classifier: Classifier<DenseNet> over a model file, its whole frame encoding
// (preprocessing, lighting normalisation, dark-frame rule) taken from the same file.
//
// make_densenet_classifier(model, config = {}, input_order = bgr, empty_skin = {},
//                          camera_px_per_cm = 0)
//   requires: model valid (ModelFileError otherwise; the DenseNet constructor re-runs the
//             embedded self-test unless config.run_self_test is false); empty_skin the
//             calibration's empty-skin model when model.preprocess.input_encoding needs one
//             (InvalidArgument naming the encoding otherwise); camera_px_per_cm the
//             calibration's px_per_cm (0 = not known; FrameEncoder stage 2b).
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
                                                     ChannelOrder input_order = ChannelOrder::bgr,
                                                     const cv::Mat& empty_skin = {},
                                                     double camera_px_per_cm = 0) {
  // The encoder's check before the DenseNet's self-test, so a missing calibration costs nothing.
  FrameEncoder::require_empty_skin(model.preprocess.input_encoding, !empty_skin.empty());
  return Classifier<DenseNet>(DenseNet(model, config),
                              {model.preprocess, input_order, empty_skin, camera_px_per_cm});
}

SHADOWSENSE_NAMESPACE_END
