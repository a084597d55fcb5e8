// The paper's classification experiments (section 5.1, Tables 1-4, Fig. 11) on a gesture folder
// in the library's dataset format, scored by the C++ DenseNet backend: every split trains a
// linear classifier on frozen backbone features with the paper's recipe (HeadTrainer: Adam
// 1e-3, batch 16, 20 epochs, best epoch on a 70/30 train/validation split by collection time)
// and scores the split's test frames. Backbones are separate model files trained on other data
// (tools/train.py, models/make_eval_backbones.sh), so no model scoring a split has seen its test
// users or lighting (docs/classification_eval.md).
//
//   ss_eval_classify --data DIR --backbone ALL.ssm [--backbone-dir DIR] [--lighting-normalise]
//                    [--tables 1,2,3,4] [--json OUT.json] [--confusion-dir DIR] [--threads N]
//   ss_eval_classify --speed MODEL.ssm[@WxH] ... [--data DIR --subsample K]   (speed vs error)
//
// --backbone: Tables 1 and 2 (must not have seen the evaluation users).
// --backbone-dir: no_<lighting>.ssm (Table 3: never saw that lighting) and only_<lighting>.ssm
// (Table 4: saw only that lighting), for daylight, dusk and night.
#include <shadowsense/eval.hpp>
#include <shadowsense/train/gesture_samples.hpp>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

namespace ss = shadowsense;
namespace fs = std::filesystem;
using Indices = std::vector<std::size_t>;
using Confusion = std::vector<std::vector<int>>; // [true][predicted]

namespace {

const std::array<ss::sim::Lighting, 3> lightings{ss::sim::Lighting::daylight,
                                                 ss::sim::Lighting::dusk, ss::sim::Lighting::night};

struct Options {
  std::string data, backbone, backbone_dir, json, confusion_dir;
  std::set<int> tables{1, 2, 3, 4};
  bool normalise = false;
  int threads = 1;
  std::vector<std::string> speed_models;
  std::string score_model;
  int subsample = 1;
  bool quiet = false;
};

// Features of every frame of the set under one backbone, computed once.
struct Features {
  std::string backbone;
  Eigen::MatrixXd x;
};

Features features_for(const std::string& path, const ss::GestureSamples& set, const Options& o,
                      const Indices& all) {
  const auto model = ss::ModelFile::load(path);
  if (model.class_names != set.class_names)
    throw ss::ModelFileError(path + ": classes differ from the Table-1 backbone's; every "
                                    "backbone must use the same class order");
  ss::FeatureExtractor fx(model, {.threads = o.threads});
  ss::FrameEncoder enc(model.preprocess, o.normalise);
  if (!o.quiet) std::cerr << "features: " << path << "\n";
  Features f{path, Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(set.frames.size()), fx.dim())};
  const Eigen::MatrixXd part = ss::extract_features(fx, enc, set, all);
  for (std::size_t k = 0; k < all.size(); ++k)
    f.x.row(static_cast<Eigen::Index>(all[k])) = part.row(static_cast<Eigen::Index>(k));
  return f;
}

Eigen::MatrixXd rows(const Eigen::MatrixXd& x, const Indices& idx) {
  Eigen::MatrixXd out(static_cast<Eigen::Index>(idx.size()), x.cols());
  for (std::size_t k = 0; k < idx.size(); ++k)
    out.row(static_cast<Eigen::Index>(k)) = x.row(static_cast<Eigen::Index>(idx[k]));
  return out;
}

// Trains a head on `pool` (70/30 train/validation by time) and returns the predicted class of
// every test frame.
std::vector<int> train_and_predict(const ss::GestureSamples& set, const Features& f,
                                   const Indices& pool, const Indices& test) {
  const auto [train, val] = ss::time_split(set, pool, 0.3);
  if (train.empty() || val.empty() || test.empty())
    throw ss::DatasetError("a split has no training, validation or test frames (" +
                           std::to_string(train.size()) + "/" + std::to_string(val.size()) + "/" +
                           std::to_string(test.size()) + ")");
  const int classes = static_cast<int>(set.class_names.size());
  const auto yt = ss::labels_of(set, train);
  for (int c = 0; c < classes; ++c)
    if (std::find(yt.begin(), yt.end(), c) == yt.end())
      throw ss::DatasetError("class '" + set.class_names[static_cast<std::size_t>(c)] +
                             "' of the model has no training frames in a split of this data "
                             "(a class folder is missing or empty)");
  const auto r =
      ss::HeadTrainer().train(ss::LinearHead::random(classes, static_cast<int>(f.x.cols()), 0),
                              rows(f.x, train), yt, rows(f.x, val), ss::labels_of(set, val));
  const Eigen::MatrixXd xs = rows(f.x, test);
  Eigen::MatrixXd z = xs * r.head.weight.transpose();
  z.rowwise() += r.head.bias.transpose();
  std::vector<int> pred;
  for (Eigen::Index i = 0; i < z.rows(); ++i) {
    Eigen::Index a = 0;
    z.row(i).maxCoeff(&a);
    pred.push_back(static_cast<int>(a));
  }
  return pred;
}

struct Score {
  double accuracy = 0;
  Confusion confusion;
  int frames = 0;
};
Score score(const ss::GestureSamples& set, const Indices& test, const std::vector<int>& pred,
            const std::function<bool(const ss::GestureSample&)>& keep = {}) {
  const std::size_t k = set.class_names.size();
  Score s;
  s.confusion.assign(k, std::vector<int>(k, 0));
  int ok = 0;
  for (std::size_t i = 0; i < test.size(); ++i) {
    const auto& fr = set.frames[test[i]];
    if (keep && !keep(fr)) continue;
    ++s.confusion[static_cast<std::size_t>(fr.label)][static_cast<std::size_t>(pred[i])];
    ok += fr.label == pred[i];
    ++s.frames;
  }
  if (s.frames == 0) throw ss::DatasetError("a test split has no frames");
  for (std::size_t c = 0; c < k; ++c) {
    int n = 0;
    for (int v : s.confusion[c]) n += v;
    if (n == 0)
      throw ss::DatasetError("class '" + set.class_names[c] +
                             "' has no test frames in a split (its class folder is missing or "
                             "empty for these users/lightings)");
  }
  s.accuracy = double(ok) / s.frames;
  return s;
}

std::string pct(double a) {
  char b[32];
  std::snprintf(b, sizeof b, "%6.2f%%", 100 * a);
  return b;
}

std::string json_confusion(const Confusion& c) {
  std::string s = "[";
  for (std::size_t i = 0; i < c.size(); ++i) {
    s += i ? ", [" : "[";
    for (std::size_t j = 0; j < c[i].size(); ++j) s += (j ? ", " : "") + std::to_string(c[i][j]);
    s += "]";
  }
  return s + "]";
}

// A confusion matrix as an image (Fig. 11 style): rows true, columns predicted, cells shaded by
// the row-normalised rate with the count and percentage written in.
void write_confusion_png(const fs::path& path, const Confusion& c,
                         const std::vector<std::string>& names, const std::string& title) {
  const int n = static_cast<int>(names.size()), cell = 70, left = 100, top = 60;
  cv::Mat img(top + n * cell + 20, left + n * cell + 20, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::putText(img, title, {10, 22}, cv::FONT_HERSHEY_SIMPLEX, 0.55, {0, 0, 0}, 1, cv::LINE_AA);
  for (int i = 0; i < n; ++i) {
    int total = 0;
    for (int v : c[static_cast<std::size_t>(i)]) total += v;
    cv::putText(img, names[static_cast<std::size_t>(i)], {5, top + i * cell + cell / 2 + 5},
                cv::FONT_HERSHEY_SIMPLEX, 0.42, {0, 0, 0}, 1, cv::LINE_AA);
    cv::putText(img, names[static_cast<std::size_t>(i)].substr(0, 8),
                {left + i * cell + 3, top - 8}, cv::FONT_HERSHEY_SIMPLEX, 0.38, {0, 0, 0}, 1,
                cv::LINE_AA);
    for (int j = 0; j < n; ++j) {
      const int v = c[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
      const double r = total ? double(v) / total : 0;
      const cv::Rect box(left + j * cell, top + i * cell, cell - 2, cell - 2);
      cv::rectangle(img, box, cv::Scalar(255 - 40 * r, 255 - 120 * r, 255 - 200 * r), cv::FILLED);
      const cv::Scalar ink = r > 0.6 ? cv::Scalar(255, 255, 255) : cv::Scalar(0, 0, 0);
      cv::putText(img, std::to_string(v), {box.x + 8, box.y + 28}, cv::FONT_HERSHEY_SIMPLEX, 0.5,
                  ink, 1, cv::LINE_AA);
      char p[16];
      std::snprintf(p, sizeof p, "%.1f%%", 100 * r);
      cv::putText(img, p, {box.x + 8, box.y + 52}, cv::FONT_HERSHEY_SIMPLEX, 0.42, ink, 1,
                  cv::LINE_AA);
    }
  }
  fs::create_directories(path.parent_path());
  if (!cv::imwrite(path.string(), img)) throw ss::IoError("cannot write " + path.string());
}

std::string lname(ss::sim::Lighting l) {
  return std::string(ss::sim::to_string(l));
}

// ----------------------------------------------------------------------------- speed vs error
// MODEL[@WxH]: the model's preprocessing, optionally resized to WxH (no crop) for timing and
// features. Accuracy: Table 1 protocol with this model as a frozen backbone (its own classifier
// is replaced by a trained head), on every `subsample`-th frame of each block.
int run_speed(const Options& o) {
  std::optional<ss::GestureSamples> set;
  Indices all;
  std::cout
      << "Speed vs error (1 thread; ms/frame = preprocessing + forward of one 635x350 frame)\n";
  std::cout << "model                                  input     ms/frame   Table-1 avg acc\n";
  std::string json = "{\n  \"speed\": [";
  bool first = true;
  for (const auto& spec : o.speed_models) {
    std::string path = spec;
    std::optional<std::pair<int, int>> size;
    if (const auto at = spec.rfind('@'); at != std::string::npos) {
      path = spec.substr(0, at);
      int w = 0, h = 0;
      if (std::sscanf(spec.c_str() + at + 1, "%dx%d", &w, &h) != 2 || w < 8 || h < 8)
        throw ss::InvalidArgument("--speed " + spec + ": expected MODEL@WxH");
      size = std::pair{w, h};
    }
    auto model = ss::ModelFile::load(path);
    if (size) {
      model.preprocess.resize_width = size->first;
      model.preprocess.resize_height = size->second;
      model.preprocess.crop_width = model.preprocess.crop_height = 0;
    }
    const int in_w =
        model.preprocess.crop_width ? model.preprocess.crop_width : model.preprocess.resize_width;
    const int in_h =
        model.preprocess.crop_width ? model.preprocess.crop_height : model.preprocess.resize_height;
    auto clf = ss::make_densenet_classifier(model, {.threads = o.threads, .run_self_test = !size});
    cv::Mat frame(350, 635, CV_8UC3);
    cv::randu(frame, 0, 255);
    for (int i = 0; i < 2; ++i) clf.classify(frame); // warm-up
    int reps = 0;
    const auto t0 = std::chrono::steady_clock::now();
    double elapsed = 0;
    while (reps < 3 || (elapsed < 2.0 && reps < 50)) {
      clf.classify(frame);
      ++reps;
      elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    const double ms = 1000 * elapsed / reps;
    double acc = -1;
    if (!o.data.empty()) {
      if (!set) {
        set = ss::load_gesture_samples(o.data, model.class_names);
        all = ss::select_samples(*set, [&](const ss::GestureSample& f) {
          (void)f;
          return true;
        });
        if (o.subsample > 1) { // every k-th frame of each session x class block
          std::map<std::pair<std::string, int>, int> seen;
          Indices kept;
          for (std::size_t i : all)
            if (seen[{set->frames[i].session, set->frames[i].label}]++ % o.subsample == 0)
              kept.push_back(i);
          all = kept;
        }
      }
      if (model.class_names != set->class_names)
        throw ss::ModelFileError(path + ": class order differs from the first --speed model's");
      // Save the resized model so FeatureExtractor sees the same geometry.
      ss::FeatureExtractor fx(model, {.threads = o.threads, .run_self_test = false});
      ss::FrameEncoder enc(model.preprocess, o.normalise);
      Features f{path,
                 Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(set->frames.size()), fx.dim())};
      const Eigen::MatrixXd part = ss::extract_features(fx, enc, *set, all);
      for (std::size_t k = 0; k < all.size(); ++k)
        f.x.row(static_cast<Eigen::Index>(all[k])) = part.row(static_cast<Eigen::Index>(k));
      const auto [pool, test] = ss::time_split(*set, all, 0.3);
      const auto pred = train_and_predict(*set, f, pool, test);
      double sum = 0;
      for (auto l : lightings)
        sum += score(*set, test, pred, [&](const ss::GestureSample& s) {
                 return s.lighting == l;
               }).accuracy;
      acc = sum / 3;
    }
    char line[256];
    std::snprintf(line, sizeof line, "%-38s %3dx%-4d %9.2f   %s\n",
                  fs::path(path).filename().string().c_str(), in_w, in_h, ms,
                  acc < 0 ? "-" : pct(acc).c_str());
    std::cout << line << std::flush;
    char js[512];
    std::snprintf(js, sizeof js,
                  "%s\n    {\"model\": \"%s\", \"input_width\": %d, \"input_height\": %d, "
                  "\"ms_per_frame\": %.3f, \"table1_average_accuracy\": %s}",
                  first ? "" : ",", fs::path(path).filename().string().c_str(), in_w, in_h, ms,
                  acc < 0 ? "null" : std::to_string(acc).c_str());
    json += js;
    first = false;
  }
  json += "\n  ]\n}\n";
  if (!o.json.empty()) {
    std::ofstream(o.json + ".tmp") << json;
    fs::rename(o.json + ".tmp", o.json);
  }
  return 0;
}

// Scores a model file as it is (its own classifier, no training) on every frame of --data with
// the C++ Classifier: accuracy per lighting and overall, confusion matrices.
int run_score(const Options& o) {
  if (o.data.empty()) throw ss::InvalidArgument("--score needs --data DIR");
  const auto model = ss::ModelFile::load(o.score_model);
  const auto set = ss::load_gesture_samples(o.data, model.class_names);
  auto clf = ss::make_densenet_classifier(model, {.threads = o.threads});
  ss::FrameEncoder enc(model.preprocess, o.normalise);
  const std::size_t k = set.class_names.size();
  std::map<std::string, Confusion> conf;
  ss::Tensor t;
  for (const auto& f : set.frames) {
    ss::Classification c;
    try {
      enc.run(ss::read_colour_image(f.path), ss::is_dark(f), t);
      c = clf.classify(t);
    } catch (const ss::IoError&) {
      throw;
    } catch (const ss::Error& e) {
      throw ss::DatasetError(f.path.string() + ": " + e.what());
    }
    for (const std::string& key : {lname(f.lighting), std::string("all")}) {
      auto& m = conf[key];
      if (m.empty()) m.assign(k, std::vector<int>(k, 0));
      ++m[static_cast<std::size_t>(f.label)][static_cast<std::size_t>(c.index)];
    }
  }
  std::cout << "Model " << o.score_model << " on " << o.data << " (" << set.frames.size()
            << " frames" << (o.normalise ? ", lighting normalisation on" : "")
            << ")\n  lighting    accuracy   frames\n";
  std::ostringstream js;
  js << "{\n  \"model\": \"" << o.score_model << "\",\n  \"data\": \"" << o.data
     << "\",\n  \"accuracy\": {";
  bool first = true;
  for (const auto& [key, m] : conf) {
    int ok = 0, n = 0;
    for (std::size_t i = 0; i < k; ++i)
      for (std::size_t j = 0; j < k; ++j) {
        n += m[i][j];
        ok += i == j ? m[i][j] : 0;
      }
    std::cout << "  " << std::left << std::setw(10) << key << "  " << pct(double(ok) / n) << "   "
              << n << "\n";
    js << (first ? "" : ", ") << '"' << key << "\": " << double(ok) / n;
    first = false;
    if (!o.confusion_dir.empty())
      write_confusion_png(fs::path(o.confusion_dir) / ("score_" + key + ".png"), m, set.class_names,
                          "Shipped model - " + key + ": " + pct(double(ok) / n));
  }
  js << "},\n  \"confusion\": {";
  first = true;
  for (const auto& [key, m] : conf) {
    js << (first ? "" : ", ") << '"' << key << "\": " << json_confusion(m);
    first = false;
  }
  js << "}\n}\n";
  if (!o.json.empty()) {
    std::ofstream(o.json + ".tmp") << js.str();
    fs::rename(o.json + ".tmp", o.json);
  }
  return 0;
}

} // namespace

int main(int argc, char** argv) try {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw ss::InvalidArgument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--data")
      o.data = next();
    else if (a == "--backbone")
      o.backbone = next();
    else if (a == "--backbone-dir")
      o.backbone_dir = next();
    else if (a == "--json")
      o.json = next();
    else if (a == "--confusion-dir")
      o.confusion_dir = next();
    else if (a == "--lighting-normalise")
      o.normalise = true;
    else if (a == "--threads")
      o.threads = std::stoi(next());
    else if (a == "--subsample")
      o.subsample = std::max(1, std::stoi(next()));
    else if (a == "--speed")
      o.speed_models.push_back(next());
    else if (a == "--score")
      o.score_model = next();
    else if (a == "--quiet")
      o.quiet = true;
    else if (a == "--tables") {
      o.tables.clear();
      std::stringstream in(next());
      for (std::string t; std::getline(in, t, ',');) {
        if (t != "1" && t != "2" && t != "3" && t != "4")
          throw ss::InvalidArgument("--tables: '" + t + "' is not 1, 2, 3 or 4");
        o.tables.insert(std::stoi(t));
      }
    } else if (a == "--help" || a == "-h") {
      std::cout << "ss_eval_classify --data DIR --backbone ALL.ssm [--backbone-dir DIR] "
                   "[--lighting-normalise] [--tables 1,2,3,4] [--json OUT] [--confusion-dir DIR] "
                   "[--threads N]\nss_eval_classify --score MODEL --data DIR "
                   "[--lighting-normalise] [--json OUT] "
                   "[--confusion-dir DIR]\nss_eval_classify --speed MODEL[@WxH] ... [--data DIR] "
                   "[--subsample K] [--json OUT]\n";
      return 0;
    } else
      throw ss::InvalidArgument("unknown argument '" + a + "' (see --help)");
  }
  if (!o.speed_models.empty()) return run_speed(o);
  if (!o.score_model.empty()) return run_score(o);
  if (o.data.empty() || o.backbone.empty())
    throw ss::InvalidArgument("--data and --backbone are required (see --help)");
  if ((o.tables.count(3) || o.tables.count(4)) && o.backbone_dir.empty())
    throw ss::InvalidArgument(
        "Tables 3 and 4 need --backbone-dir (no_<lighting>.ssm, only_<lighting>.ssm)");

  const auto base = ss::ModelFile::load(o.backbone);
  const auto set = ss::load_gesture_samples(o.data, base.class_names);
  const Indices all = ss::select_samples(set, [](const ss::GestureSample&) { return true; });
  std::set<int> users;
  for (const auto& f : set.frames) users.insert(f.user);
  const auto& names = set.class_names;
  std::ostringstream js;
  js << "{\n  \"data\": \"" << o.data << "\",\n  \"frames\": " << set.frames.size()
     << ",\n  \"lighting_normalise\": " << (o.normalise ? "true" : "false")
     << ",\n  \"class_names\": [";
  for (std::size_t i = 0; i < names.size(); ++i) js << (i ? ", " : "") << '"' << names[i] << '"';
  js << "],\n  \"backbone\": \"" << o.backbone << "\"";
  auto confusion_png = [&](const std::string& file, const Confusion& c, const std::string& title) {
    if (!o.confusion_dir.empty())
      write_confusion_png(fs::path(o.confusion_dir) / file, c, names, title);
  };
  const std::string mode = o.normalise ? " (lighting normalisation on)" : " (paper preprocessing)";

  std::optional<Features> fall;
  if (o.tables.count(1) || o.tables.count(2)) fall = features_for(o.backbone, set, o, all);
  if (o.tables.count(1)) {
    const auto [pool, test] = ss::time_split(set, all, 0.3);
    const auto pred = train_and_predict(set, *fall, pool, test);
    std::cout << "\nTable 1: combined data, every gesture x lighting split 70/30 by collection time"
              << mode << "\n";
    std::cout << "  lighting    accuracy   test frames\n";
    js << ",\n  \"table1\": {\"accuracy\": {";
    double sum = 0;
    std::string conf;
    for (std::size_t li = 0; li < lightings.size(); ++li) {
      const auto l = lightings[li];
      const Score s =
          score(set, test, pred, [&](const ss::GestureSample& f) { return f.lighting == l; });
      sum += s.accuracy;
      std::cout << "  " << std::left << std::setw(10) << lname(l) << "  " << pct(s.accuracy)
                << "   " << s.frames << "\n";
      js << (li ? ", " : "") << '"' << lname(l) << "\": " << s.accuracy;
      conf += (li ? ", " : "") + ("\"" + lname(l) + "\": ") + json_confusion(s.confusion);
      confusion_png("table1_" + lname(l) + ".png", s.confusion,
                    "Table 1 - " + lname(l) + ": " + pct(s.accuracy));
    }
    std::cout << "  average     " << pct(sum / 3) << "\n";
    js << "}, \"average\": " << sum / 3 << ", \"confusion\": {" << conf << "}}";
  }
  if (o.tables.count(2)) {
    std::cout << "\nTable 2: leave one user out" << mode << "\n  user   accuracy\n";
    js << ",\n  \"table2\": {\"accuracy\": {";
    double sum = 0;
    bool first = true;
    for (int u : users) {
      const Indices pool =
          ss::select_samples(set, [&](const ss::GestureSample& f) { return f.user != u; });
      const Indices test =
          ss::select_samples(set, [&](const ss::GestureSample& f) { return f.user == u; });
      const Score s = score(set, test, train_and_predict(set, *fall, pool, test));
      sum += s.accuracy;
      std::cout << "  " << std::setw(5) << u << "  " << pct(s.accuracy) << "\n";
      js << (first ? "" : ", ") << "\"" << u << "\": " << s.accuracy;
      first = false;
    }
    std::cout << "  mean   " << pct(sum / double(users.size())) << "\n";
    js << "}, \"mean\": " << sum / double(users.size()) << "}";
  }
  std::map<std::string, Features> fl;
  auto lit = [&](const std::string& kind, ss::sim::Lighting l) -> const Features& {
    const std::string key = kind + "_" + lname(l);
    if (!fl.count(key))
      fl.emplace(key,
                 features_for((fs::path(o.backbone_dir) / (key + ".ssm")).string(), set, o, all));
    return fl.at(key);
  };
  if (o.tables.count(3)) {
    std::cout << "\nTable 3: leave one lighting condition out (backbone no_<lighting>.ssm)" << mode
              << "\n  test lighting   accuracy\n";
    js << ",\n  \"table3\": {\"accuracy\": {";
    double sum = 0;
    for (std::size_t li = 0; li < lightings.size(); ++li) {
      const auto l = lightings[li];
      const Indices pool =
          ss::select_samples(set, [&](const ss::GestureSample& f) { return f.lighting != l; });
      const Indices test =
          ss::select_samples(set, [&](const ss::GestureSample& f) { return f.lighting == l; });
      const Score s = score(set, test, train_and_predict(set, lit("no", l), pool, test));
      sum += s.accuracy;
      std::cout << "  " << std::left << std::setw(14) << lname(l) << "  " << pct(s.accuracy)
                << "\n";
      js << (li ? ", " : "") << '"' << lname(l) << "\": " << s.accuracy;
      confusion_png("table3_" + lname(l) + ".png", s.confusion,
                    "Table 3 - unseen " + lname(l) + ": " + pct(s.accuracy));
    }
    std::cout << "  mean            " << pct(sum / 3) << "\n";
    js << "}, \"mean\": " << sum / 3 << "}";
  }
  if (o.tables.count(4)) {
    std::cout << "\nTable 4: train on one lighting condition, test on each other (backbone "
                 "only_<lighting>.ssm)"
              << mode << "\n  train \\ test   daylight    dusk      night\n";
    js << ",\n  \"table4\": {\"accuracy\": {";
    double worst = 1;
    for (std::size_t li = 0; li < lightings.size(); ++li) {
      const auto l = lightings[li];
      const Indices pool =
          ss::select_samples(set, [&](const ss::GestureSample& f) { return f.lighting == l; });
      const Indices test =
          ss::select_samples(set, [&](const ss::GestureSample& f) { return f.lighting != l; });
      const auto pred = train_and_predict(set, lit("only", l), pool, test);
      std::cout << "  " << std::left << std::setw(12) << lname(l);
      js << (li ? ", " : "") << '"' << lname(l) << "\": {";
      bool first = true;
      for (auto m : lightings) {
        if (m == l) {
          std::cout << "     -    ";
          continue;
        }
        const Score s =
            score(set, test, pred, [&](const ss::GestureSample& f) { return f.lighting == m; });
        worst = std::min(worst, s.accuracy);
        std::cout << "  " << pct(s.accuracy);
        js << (first ? "" : ", ") << '"' << lname(m) << "\": " << s.accuracy;
        first = false;
      }
      std::cout << "\n";
      js << "}";
    }
    std::cout << "  lowest cell   " << pct(worst) << "\n";
    js << "}, \"min\": " << worst << "}";
  }
  js << "\n}\n";
  if (!o.json.empty()) {
    const std::string tmp = o.json + ".tmp";
    std::ofstream f(tmp);
    f << js.str();
    f.close();
    if (!f) throw ss::IoError("cannot write " + tmp);
    fs::rename(tmp, o.json);
  }
  return 0;
} catch (const std::exception& e) {
  std::cerr << "ss_eval_classify: " << e.what() << "\n";
  return 1;
}
