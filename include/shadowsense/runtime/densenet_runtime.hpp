// The runtime users have: the calibrated segmenter's touch pipeline and the reference DenseNet
// classifier (runtime/runtime.hpp for the contract).
//
//   namespace ss = shadowsense;
//   ss::Runtime sense{ss::TouchPipeline{ss::Segmenter({.calibration = ss::load_calibration(
//                                           "skin.calib")})},
//                     ss::make_densenet_classifier(ss::ModelFile::load("default.ssm"))};
//   for (const auto& [frame, t_ms] : camera) {
//     const ss::RuntimeFrame& r = sense.update(frame, t_ms); // r.touch.events, r.gesture
//     ss::publish(sense.output(), csv, tuio);                // any event sinks
//   }
//
// Pass std::nullopt as the classifier for touch events only.
// Threading: as BasicRuntime: one instance per thread.
#pragma once

#include <shadowsense/backends/densenet/classifier.hpp>
#include <shadowsense/runtime/runtime.hpp>
#include <shadowsense/sense/pixel_rule.hpp>

SHADOWSENSE_NAMESPACE_BEGIN

using Runtime = BasicRuntime<CalibratedRule, DenseNet>;

SHADOWSENSE_NAMESPACE_END
