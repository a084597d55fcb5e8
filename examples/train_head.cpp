// On-device transfer learning without Python: the model's DenseNet features stay frozen, a new
// linear classifier is trained on a labelled image folder with the paper's recipe (Adam 1e-3,
// batch 16, 20 epochs, best epoch by validation accuracy), and a new model file is written.
//
//   ss_train_head [--model BASE.ssm] --input DIR --out NEW.ssm [--val-fraction 0.3]
//                 [--users 0,1] [--lightings night] [--epochs 20] [--lighting-normalise]
//                 [--fine-tune] [--seed S] [--threads N]
//                 [--anchor L] [--balanced] [--standardise] [--augment K]
//                 [--learning-rate R] [--batch-size B] [--calibration FILE]
//
// DIR: a dataset folder with metadata.csv (docs/dataset_format.md), or a plain class-per-folder
// tree DIR/<class>/**/*.png (no metadata: user and lighting unknown, path order is the
// collection order, the model's dark-frame rule decides dark frames).
// Validation: the last 30% (by timestamp) of every session x class block; --val-fraction 0
// trains on every selected frame and keeps the last epoch. --fine-tune starts from the model's
// own classifier instead of a fresh one (same classes required). The new model keeps the base
// model's preprocessing; --lighting-normalise (for version-1 base models) is recorded in it.
// Few-shot options (docs/classification_eval.md, "Few-shot adaptation"): --anchor L pulls the
// head toward its initial weights (L2), --balanced uses class-balanced batches, --standardise
// trains on standardised features (folded back into the written classifier), --augment K adds
// K randomly shifted/scaled/rotated/mirrored/re-exposed copies of every training frame
// (FrameAugmenter, through the real preprocessing and backbone).
// --calibration FILE: the empty-skin model a base model with a calibrated input encoding
// (docs/input_encodings.md) divides every frame by; such a model refuses to run without it, and
// the new model keeps the encoding. --scale-to-network: train on frames brought to the network's
// scale with the calibration's camera scale (ss_calibrate --px-per-cm); classify with the same
// option (docs/input_encodings.md).
// --model defaults to the shipped model, found by common/model_path.hpp (installed,
// $SHADOWSENSE_MODEL, or the source tree's when run from the build folder).
#include <shadowsense/eval.hpp>
#include <shadowsense/train/gesture_samples.hpp>

#include "common/cli.hpp"
#include "common/model_calibration.hpp"
#include "common/model_path.hpp"

#include <cstdio>
#include <iostream>
#include <set>

namespace ss = shadowsense;

int main(int argc, char** argv) {
  return cli::run("ss_train_head", [&] {
    std::string model_path, data, out;
    std::vector<int> users;
    std::vector<std::string> lightings;
    double val_fraction = 0.3;
    bool normalise = false, fine_tune = false;
    int augment = 0;
    ss::HeadTrainer::Config tc;
    int threads = 1;
    std::string calibration;
    bool scale_to_network = false;
    cli::Parser p("ss_train_head",
                  "Trains a new linear classifier on the frozen DenseNet features of a model "
                  "(Adam 1e-3, batch 16, best epoch by validation accuracy) and writes a new model "
                  "file.");
    p.option("--model", "BASE.ssm", "model file whose features are used", model_path)
        .default_text(cli::default_model_help(argv[0]));
    p.option("--input", "DIR", "labelled gesture folder (dataset format)", data).required();
    p.alias("--data", "--input");
    p.option("--out", "NEW.ssm", "model file to write", out).required();
    p.option("--val-fraction", "F",
             "validation share of every session x class block (by time); 0: none, the last epoch "
             "is kept",
             val_fraction)
        .range(0.0, 1.0);
    p.list("--users", "LIST", "train on these user ids only (default: all)", users)
        .range(0, 1000000000);
    p.list("--lightings", "LIST", "train on these lightings only (default: all)", lightings)
        .choices({"daylight", "dusk", "night", "custom"});
    p.option("--epochs", "N", "training epochs", tc.epochs).range(1, 100000);
    p.option("--calibration", "FILE",
             "calibration file: its empty-skin model, for a model with a calibrated input "
             "encoding",
             calibration);
    p.flag("--scale-to-network",
           "frames brought to the network's scale with the calibration's px_per_cm",
           scale_to_network);
    p.flag("--lighting-normalise", "normalise lighting before the network", normalise);
    p.flag("--fine-tune", "start from the model's own classifier (same classes required)",
           fine_tune);
    p.option("--seed", "S", "random seed of the initial classifier", tc.seed);
    p.option("--threads", "N", "worker threads", threads).range(1, 256);
    p.option("--anchor", "L", "L2 pull toward the initial head (0: off)", tc.anchor)
        .range(0.0, 1e6);
    p.flag("--balanced", "class-balanced batches (smaller classes repeated)", tc.balanced_batches);
    p.flag("--standardise", "train on standardised features (folded back into the head)",
           tc.standardise);
    p.option("--augment", "K", "augmented copies of every training frame (0: off)", augment)
        .range(0, 1000);
    p.option("--learning-rate", "R", "Adam learning rate", tc.learning_rate).range(1e-8, 10.0);
    p.option("--batch-size", "B", "mini-batch size", tc.batch_size).range(1, 1000000);
    p.parse(argc, argv);
    if (!(val_fraction >= 0 && val_fraction < 1))
      throw cli::UsageError("--val-fraction: expected a number in [0, 1) (0: no validation, the "
                            "last epoch is kept), got " +
                            std::to_string(val_fraction));

    if (model_path.empty()) { // say which file the default is, as --help does
      std::string what;
      model_path = cli::find_default_model(argv[0], &what).string();
      std::cerr << "ss_train_head: model " << model_path << " (" << what << ")\n";
    }
    const auto model = cli::load_model(model_path, normalise);
    const cli::EncoderCalibration cal =
        cli::encoder_calibration_for(model, model_path, calibration, scale_to_network);
    // Classes: the model's, unless the folder has others (a new task): then sorted folder names.
    auto set = [&] {
      try {
        return ss::load_gesture_folder(data, model.class_names);
      } catch (const ss::DatasetError&) {
        if (fine_tune) throw;
        if (!std::filesystem::exists(std::filesystem::path(data) / "metadata.csv"))
          return ss::load_class_folders(data, {});
        const auto md = ss::read_metadata(std::filesystem::path(data) / "metadata.csv");
        std::set<std::string> names;
        for (const auto& r : md.rows) names.insert(r.label);
        return ss::load_gesture_samples(data, {names.begin(), names.end()});
      }
    }();
    const std::set<int> u(users.begin(), users.end());
    const std::set<std::string> l(lightings.begin(), lightings.end());
    const auto pool = ss::select_samples(set, [&](const ss::GestureSample& f) {
      return (u.empty() || u.count(f.user)) &&
             (l.empty() || l.count(std::string(ss::sim::to_string(f.lighting))));
    });
    const auto [train, val] = ss::time_split(set, pool, val_fraction);
    if (train.empty() || (val_fraction > 0 && val.empty()))
      throw ss::DatasetError(data + ": the selection leaves " + std::to_string(train.size()) +
                             " training and " + std::to_string(val.size()) +
                             " validation frames; expected both non-empty (or --val-fraction 0)");
    std::cout << train.size() << " training, " << val.size() << " validation frames, "
              << set.class_names.size() << " classes";
    if (augment > 0) std::cout << ", " << augment << " augmented copies of each training frame";
    std::cout << "\n";

    ss::FeatureExtractor fx(model, {.threads = threads});
    ss::FrameEncoder enc(model.preprocess, /*force_lighting_normalise=*/false, cal.empty_skin,
                         cal.camera_px_per_cm);
    auto progress = [](std::size_t d, std::size_t n) {
      std::cout << "  features " << d << "/" << n << "\n" << std::flush;
    };
    Eigen::MatrixXd xt = ss::extract_features(fx, enc, set, train, progress);
    const Eigen::MatrixXd xv = ss::extract_features(fx, enc, set, val, progress);
    auto yt = ss::labels_of(set, train);
    const auto yv = ss::labels_of(set, val);
    if (augment > 0) { // the copies follow the originals
      ss::FrameAugmenter aug(ss::FrameAugmenter::Config{}, tc.seed);
      const Eigen::Index n0 = xt.rows();
      xt.conservativeResize(n0 * (1 + augment), Eigen::NoChange);
      cv::Mat copy;
      ss::Tensor t;
      Eigen::Index row = n0;
      for (std::size_t k = 0; k < train.size(); ++k) {
        const auto& f = set.frames[train[k]];
        const cv::Mat image = ss::read_colour_image(f.path);
        for (int a = 0; a < augment; ++a, ++row) {
          aug.run(image, copy);
          if (f.from_metadata)
            enc.run(copy, ss::is_dark(f), t);
          else
            enc.run(copy, t);
          const auto v = fx.extract(t);
          for (int c = 0; c < fx.dim(); ++c) xt(row, c) = v[static_cast<std::size_t>(c)];
          yt.push_back(f.label);
        }
      }
      std::cout << "  augmented features " << (row - n0) << "\n";
    }

    const int classes = static_cast<int>(set.class_names.size());
    ss::LinearHead init = fine_tune ? ss::LinearHead::from_model(model)
                                    : ss::LinearHead::random(classes, fx.dim(), tc.seed);
    const auto result =
        ss::HeadTrainer(tc).train(init, xt, yt, xv, yv, [&](const ss::HeadEpoch& e) {
          if (val.empty())
            std::printf("epoch %2d  train loss %.4f  train acc %.4f\n", e.epoch, e.train_loss,
                        e.train_accuracy);
          else
            std::printf(
                "epoch %2d  train loss %.4f  train acc %.4f  val loss %.4f  val acc %.4f%s\n",
                e.epoch, e.train_loss, e.train_accuracy, e.val_loss, e.val_accuracy,
                e.best ? "  best" : "");
          std::fflush(stdout);
        });
    auto trained = ss::model_with_head(model, result.head, set.class_names);
    ss::save_model_file(trained, out);
    std::cout << "best epoch " << result.best_epoch << "; wrote " << out << "\n";
    return 0;
  });
}
