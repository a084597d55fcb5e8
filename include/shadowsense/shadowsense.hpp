// Runtime umbrella header: what a robot links (OpenCV core + imgproc only; no Eigen, no
// image files, no scene generator).
//   core/      version, errors, tensors, directions, image checks
//   sense/     segmenter, tracker, touch state machine (shadow -> contact -> touch events),
//              temporal touch gestures (tap, pat, stroke, rub, hold, hit per track)
//   classify/  preprocessing, the backend concept, Classifier<Backend>
//   backends/densenet/  the reference backend: model file + hand-written forward pass
//   output/    event sinks: EventSink concept, CSV, JSON lines, TUIO 1.1 over UDP (OSC encoder)
//   runtime/   Runtime: the touch pipeline and the gated classifier composed, one result per frame
// Other targets, each with its own umbrella: <shadowsense/io.hpp> (dataset files, imgcodecs),
// <shadowsense/train.hpp> (on-device head training, Eigen), <shadowsense/sim.hpp> (scene
// generator), <shadowsense/eval.hpp> (evaluation helpers).
#pragma once

#include <shadowsense/backends/densenet/classifier.hpp>
#include <shadowsense/backends/densenet/densenet.hpp>
#include <shadowsense/backends/densenet/model_file.hpp>
#include <shadowsense/classify/backend.hpp>
#include <shadowsense/classify/classifier.hpp>
#include <shadowsense/classify/frame_encoder.hpp>
#include <shadowsense/classify/lighting_normalise.hpp>
#include <shadowsense/classify/preprocess.hpp>
#include <shadowsense/classify/preprocess_params.hpp>
#include <shadowsense/core/crc32.hpp>
#include <shadowsense/core/direction.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/image_check.hpp>
#include <shadowsense/core/tensor.hpp>
#include <shadowsense/core/version.hpp>
#include <shadowsense/output/output.hpp>
#include <shadowsense/runtime/densenet_runtime.hpp>
#include <shadowsense/runtime/runtime.hpp>
#include <shadowsense/sense/camera_health.hpp>
#include <shadowsense/sense/gesture_event.hpp>
#include <shadowsense/sense/segmenter.hpp>
#include <shadowsense/sense/temporal_gestures.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>
#include <shadowsense/sense/touch_state_machine.hpp>
#include <shadowsense/sense/tracker.hpp>
