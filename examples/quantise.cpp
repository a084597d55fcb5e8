// Post-training int8 quantisation of a model file: per-output-channel symmetric int8 weights and
// per-convolution input scales calibrated on labelled frames (docs/int8.md), written as a
// version-3 model file (docs/model_format.md) that the DenseNet runs in int8 by default.
//
//   ss_quantise [--model IN.ssm] --input DIR --out OUT.ssm [--percentile 99.99]
//               [--max-frames N] [--lighting-normalise] [--calibration FILE]
//
// DIR: a dataset folder with metadata.csv (docs/dataset_format.md) or a class-per-folder tree,
// encoded exactly as the classifier encodes frames (the model's preprocessing). Every
// quantised convolution's input scale is the --percentile of its calibration inputs / 127
// (float forward, ReferenceForward); conv0 and the classifier stay float. --max-frames takes
// that many frames spread evenly over the folder (0: all). The output is written atomically.
// --calibration FILE: the empty-skin model of a model with a calibrated input encoding
// (docs/input_encodings.md), which refuses to run without it; the output keeps the encoding
// (model format version 4 with its int8 flag set).
#include <shadowsense/backends/densenet/quantise.hpp>
#include <shadowsense/eval.hpp>
#include <shadowsense/train/gesture_samples.hpp>

#include "common/cli.hpp"
#include "common/model_calibration.hpp"
#include "common/model_path.hpp"

#include <iostream>

namespace ss = shadowsense;

int main(int argc, char** argv) {
  return cli::run("ss_quantise", [&] {
    std::string model_path, data, out, calibration;
    double percentile = 99.99;
    int max_frames = 0;
    bool normalise = false;
    cli::Parser p("ss_quantise",
                  "Quantises a model's convolutions to int8 (per-channel weights, input scales "
                  "calibrated on a frame folder) and writes a version-3 model file.");
    p.option("--model", "IN.ssm", "model file to quantise", model_path)
        .default_text(cli::default_model_help(argv[0]));
    p.option("--input", "DIR", "calibration frames (dataset folder or class folders)", data)
        .required();
    p.alias("--data", "--input");
    p.option("--out", "OUT.ssm", "model file to write", out).required();
    p.option("--percentile", "P", "percentile of each convolution's inputs mapped to code 127",
             percentile)
        .range(0.001, 100.0);
    p.option("--max-frames", "N", "calibration frames, spread over the folder (0: all)", max_frames)
        .range(0, 100000000);
    p.flag("--lighting-normalise", "normalise lighting before the network (version-1 models)",
           normalise);
    p.option("--calibration", "FILE",
             "calibration file: its empty-skin model, for a model with a calibrated input "
             "encoding",
             calibration);
    p.parse(argc, argv);
    if (model_path.empty()) {
      std::string what;
      model_path = cli::find_default_model(argv[0], &what).string();
      std::cerr << "ss_quantise: model " << model_path << " (" << what << ")\n";
    }
    auto model = cli::load_model(model_path, normalise);
    model.int8.reset(); // calibrate the float model, not an earlier quantisation
    const cv::Mat empty_skin = cli::empty_skin_for(model, model_path, calibration);
    const auto set = ss::load_gesture_folder(data, model.class_names);
    if (set.frames.empty()) throw ss::DatasetError(data + ": no frames, expected at least one");
    const std::size_t total = set.frames.size();
    const std::size_t use =
        max_frames > 0 ? std::min(total, static_cast<std::size_t>(max_frames)) : total;
    ss::FrameEncoder enc(model.preprocess, /*force_lighting_normalise=*/false, empty_skin);
    ss::Int8Calibration cal(model, percentile);
    ss::Tensor t;
    for (std::size_t i = 0; i < use; ++i) {
      const auto& f = set.frames[i * total / use];
      try {
        const cv::Mat image = ss::read_colour_image(f.path);
        if (f.from_metadata)
          enc.run(image, ss::is_dark(f), t);
        else
          enc.run(image, t);
      } catch (const ss::IoError&) {
        throw;
      } catch (const ss::Error& e) {
        throw ss::DatasetError(f.path.string() + ": " + e.what());
      }
      cal.add(t.image(0).data(), t.h(), t.w());
    }
    model.int8 = cal.quantise();
    model.save(out); // validates (codes are the weights rounded) and writes atomically
    std::cout << "calibrated " << model.int8->size() << " convolutions on " << use
              << " frames (percentile " << percentile << "); wrote " << out << "\n";
    return 0;
  });
}
