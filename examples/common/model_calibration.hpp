// The calibration a classifier program hands its model's frame encoder (--calibration FILE):
// a model whose input encoding needs one (classify/preprocess_params.hpp, needs_calibration)
// refuses to run without it, with a message naming the model and what to pass.
//
// empty_skin_for(model, model_path, calibration_path)
//   ensures: the calibration's empty-skin model when the model's input encoding needs one;
//            an empty Mat for a colour model.
//   throws:  cli::UsageError (exit 2) naming the model when it needs a calibration and
//            calibration_path is empty; the calibration file's own errors (IoError,
//            CalibrationFileError naming the file); shadowsense::Error naming both files when
//            the calibration holds no empty-skin model.
// encoder_calibration_for(model, model_path, calibration_path, scale_to_network)
//   -> EncoderCalibration
//   ensures: empty_skin as empty_skin_for; camera_px_per_cm the calibration's px_per_cm (the
//            camera's scale, any input encoding) when scale_to_network (a program's
//            --scale-to-network: off by default, docs/input_encodings.md), else 0: what the
//            frame encoder needs of the calibration.
//   throws:  as empty_skin_for; UsageError when scale_to_network and no calibration is given
//            or it records no px_per_cm (ss_calibrate --px-per-cm).
// camera_scale_for(calibration, calibration_path, scale_to_network) -> double
//   ensures: the calibration's px_per_cm when scale_to_network, else 0.
//   throws:  UsageError naming --scale-to-network and the file when scale_to_network and the
//            calibration records no px_per_cm. A program calls it where it reads its options,
//            so the option is checked whether or not a classifier runs.
// encoder_calibration_from(model, model_path, calibration, calibration_path, scale_to_network)
//   -> EncoderCalibration
//   The same for a program that has loaded the calibration already (ss_track, ss_demo);
//   calibration_path only names the file in messages.
//   throws:  shadowsense::Error naming both files when the model's input encoding needs an
//            empty-skin model and the calibration holds none; UsageError when scale_to_network
//            and the calibration records no px_per_cm.
// force_lighting_normalise(model, model_path)
//   A program's --lighting-normalise: switches the model's lighting normalisation on.
//   throws:  UsageError (exit 2) naming the model and the option when the model's input encoding
//            is light-independent (darkness_warmth, masks: the light divided out), taking none.
// load_model(model_path, lighting_normalise) -> ModelFile
//   ModelFile::load, then force_lighting_normalise when lighting_normalise (the option) is set:
//   the one place every program (ss_classify, ss_eval_classify, ss_train_head, ss_quantise)
//   applies --lighting-normalise, so their encoders take the model's preprocessing as it is.
// Plain functions; no state.
#pragma once

#include <shadowsense/backends/densenet/model_file.hpp>
#include <shadowsense/sense/calibration_file.hpp>

#include "cli.hpp"

#include <opencv2/core.hpp>

#include <string>

namespace cli {

struct EncoderCalibration {
  cv::Mat empty_skin;
  double camera_px_per_cm = 0;
};

inline void force_lighting_normalise(shadowsense::ModelFile& model, const std::string& model_path) {
  const shadowsense::InputEncoding e = model.preprocess.input_encoding;
  if (shadowsense::light_independent(e))
    throw UsageError("--lighting-normalise with model " + model_path +
                     ", whose input encoding is " + shadowsense::to_string(e) +
                     ": it has the light divided out and takes no "
                     "lighting normalisation; drop the option");
  model.preprocess.lighting_normalise = true;
}

inline shadowsense::ModelFile load_model(const std::string& model_path, bool lighting_normalise) {
  auto model = shadowsense::ModelFile::load(model_path);
  if (lighting_normalise) force_lighting_normalise(model, model_path);
  return model;
}

inline double camera_scale_for(const shadowsense::SegmenterCalibration& cal,
                               const std::string& calibration_path, bool scale_to_network) {
  if (!scale_to_network) return 0;
  if (!(cal.px_per_cm > 0))
    throw UsageError("--scale-to-network: calibration " + calibration_path +
                     " records no camera scale; make it with ss_calibrate --px-per-cm X");
  return cal.px_per_cm;
}

inline EncoderCalibration encoder_calibration_from(const shadowsense::ModelFile& model,
                                                   const std::string& model_path,
                                                   const shadowsense::SegmenterCalibration& cal,
                                                   const std::string& calibration_path,
                                                   bool scale_to_network) {
  namespace ss = shadowsense;
  const ss::InputEncoding e = model.preprocess.input_encoding;
  EncoderCalibration c;
  if (ss::needs_calibration(e)) {
    if (cal.empty_skin.empty())
      throw ss::Error("calibration " + calibration_path +
                      " holds no empty-skin model, which model " + model_path +
                      " (input encoding " + ss::to_string(e) +
                      ") needs; calibrate with ss_calibrate --empty to store one");
    c.empty_skin = cal.empty_skin;
  }
  c.camera_px_per_cm = camera_scale_for(cal, calibration_path, scale_to_network);
  return c;
}

inline EncoderCalibration encoder_calibration_for(const shadowsense::ModelFile& model,
                                                  const std::string& model_path,
                                                  const std::string& calibration_path,
                                                  bool scale_to_network) {
  namespace ss = shadowsense;
  const ss::InputEncoding e = model.preprocess.input_encoding;
  if (!ss::needs_calibration(e) && !scale_to_network) return {};
  if (calibration_path.empty()) {
    if (ss::needs_calibration(e))
      throw UsageError("model " + model_path + " was trained with input encoding " +
                       ss::to_string(e) +
                       " and needs --calibration FILE (the robot's calibration with its "
                       "empty-skin model, from ss_calibrate --empty)");
    throw UsageError("--scale-to-network needs --calibration FILE recording the camera's scale "
                     "(ss_calibrate --px-per-cm)");
  }
  return encoder_calibration_from(model, model_path, ss::load_calibration(calibration_path),
                                  calibration_path, scale_to_network);
}

inline cv::Mat empty_skin_for(const shadowsense::ModelFile& model, const std::string& model_path,
                              const std::string& calibration_path) {
  return encoder_calibration_for(model, model_path, calibration_path, false).empty_skin;
}

} // namespace cli
