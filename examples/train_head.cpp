// On-device transfer learning without Python: the model's DenseNet features stay frozen, a new
// linear classifier is trained on a labelled image folder with the paper's recipe (Adam 1e-3,
// batch 16, 20 epochs, best epoch by validation accuracy), and a new model file is written.
//
//   ss_train_head --model BASE.ssm --data DIR --out NEW.ssm [--val-fraction 0.3]
//                 [--users 0,1] [--lightings night] [--epochs 20] [--lighting-normalise]
//                 [--fine-tune] [--seed S] [--threads N]
//
// DIR: a dataset folder with metadata.csv (docs/dataset_format.md), or a plain class-per-folder
// tree DIR/<class>/**/*.png (no metadata: user and lighting unknown, path order is the
// collection order, the model's dark-frame rule decides dark frames).
// Validation: the last 30% (by timestamp) of every session x class block. --fine-tune starts
// from the model's own classifier instead of a fresh one (same classes required). The new
// model keeps the base model's preprocessing; --lighting-normalise (for version-1 base models)
// is recorded in it.
#include <shadowsense/eval.hpp>
#include <shadowsense/train/gesture_samples.hpp>

#include <charconv>
#include <cstdio>
#include <iostream>
#include <set>
#include <sstream>

namespace ss = shadowsense;

namespace {
std::set<std::string> csv_set(const std::string& s) {
  std::set<std::string> out;
  std::stringstream in(s);
  for (std::string x; std::getline(in, x, ',');)
    if (!x.empty()) out.insert(x);
  return out;
}
double to_double(const std::string& flag, const std::string& v) {
  double x = 0;
  const auto r = std::from_chars(v.data(), v.data() + v.size(), x);
  if (r.ec != std::errc() || r.ptr != v.data() + v.size())
    throw ss::InvalidArgument(flag + ": '" + v + "' is not a number");
  return x;
}
} // namespace

int main(int argc, char** argv) try {
  std::string model_path, data, out, users, lightings;
  double val_fraction = 0.3;
  bool normalise = false, fine_tune = false;
  ss::HeadTrainer::Config tc;
  int threads = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw ss::InvalidArgument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--model")
      model_path = next();
    else if (a == "--data")
      data = next();
    else if (a == "--out")
      out = next();
    else if (a == "--users")
      users = next();
    else if (a == "--lightings")
      lightings = next();
    else if (a == "--val-fraction")
      val_fraction = to_double(a, next());
    else if (a == "--epochs")
      tc.epochs = static_cast<int>(to_double(a, next()));
    else if (a == "--seed")
      tc.seed = static_cast<std::uint64_t>(to_double(a, next()));
    else if (a == "--threads")
      threads = static_cast<int>(to_double(a, next()));
    else if (a == "--lighting-normalise")
      normalise = true;
    else if (a == "--fine-tune")
      fine_tune = true;
    else if (a == "--help" || a == "-h") {
      std::cout << "ss_train_head --model BASE.ssm --data DIR --out NEW.ssm [--val-fraction F] "
                   "[--users LIST] [--lightings LIST] [--epochs N] [--lighting-normalise] "
                   "[--fine-tune] [--seed S] [--threads N]\n";
      return 0;
    } else
      throw ss::InvalidArgument("unknown argument '" + a + "' (see --help)");
  }
  if (model_path.empty() || data.empty() || out.empty())
    throw ss::InvalidArgument("--model, --data and --out are required (see --help)");
  if (!(val_fraction > 0 && val_fraction < 1))
    throw ss::InvalidArgument("--val-fraction must be in (0, 1)");

  const auto model = ss::ModelFile::load(model_path);
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
  const auto u = csv_set(users), l = csv_set(lightings);
  const auto pool = ss::select_samples(set, [&](const ss::GestureSample& f) {
    return (u.empty() || u.count(std::to_string(f.user))) &&
           (l.empty() || l.count(std::string(ss::sim::to_string(f.lighting))));
  });
  const auto [train, val] = ss::time_split(set, pool, val_fraction);
  if (train.empty() || val.empty())
    throw ss::DatasetError(data + ": the selection leaves " + std::to_string(train.size()) +
                           " training and " + std::to_string(val.size()) +
                           " validation frames; expected both non-empty");
  std::cout << train.size() << " training, " << val.size() << " validation frames, "
            << set.class_names.size() << " classes\n";

  ss::FeatureExtractor fx(model, {.threads = threads});
  ss::FrameEncoder enc(model.preprocess, normalise);
  auto progress = [](std::size_t d, std::size_t n) {
    std::cout << "  features " << d << "/" << n << "\n" << std::flush;
  };
  const Eigen::MatrixXd xt = ss::extract_features(fx, enc, set, train, progress);
  const Eigen::MatrixXd xv = ss::extract_features(fx, enc, set, val, progress);
  const auto yt = ss::labels_of(set, train), yv = ss::labels_of(set, val);

  const int classes = static_cast<int>(set.class_names.size());
  ss::LinearHead init = fine_tune ? ss::LinearHead::from_model(model)
                                  : ss::LinearHead::random(classes, fx.dim(), tc.seed);
  const auto result = ss::HeadTrainer(tc).train(init, xt, yt, xv, yv, [](const ss::HeadEpoch& e) {
    std::printf("epoch %2d  train loss %.4f  train acc %.4f  val loss %.4f  val acc %.4f%s\n",
                e.epoch, e.train_loss, e.train_accuracy, e.val_loss, e.val_accuracy,
                e.best ? "  best" : "");
    std::fflush(stdout);
  });
  auto trained = ss::model_with_head(model, result.head, set.class_names);
  if (normalise) trained.preprocess.lighting_normalise = true; // recorded for the Classifier
  ss::save_model_file(trained, out);
  std::cout << "best epoch " << result.best_epoch << "; wrote " << out << "\n";
  return 0;
} catch (const std::exception& e) {
  std::cerr << "ss_train_head: " << e.what() << "\n";
  return 1;
}
