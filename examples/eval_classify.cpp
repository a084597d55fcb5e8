// The paper's classification experiments (section 5.1, Tables 1-4, Fig. 11) on a gesture folder
// in the library's dataset format, scored by the C++ DenseNet backend: every split trains a
// linear classifier on frozen backbone features with the paper's recipe (HeadTrainer: Adam
// 1e-3, batch 16, 20 epochs, best epoch on a 70/30 train/validation split by collection time)
// and scores the split's test frames. Backbones are separate model files trained on other data
// (tools/train.py, models/make_eval_backbones.sh), so no model scoring a split has seen its test
// users or lighting (docs/classification_eval.md).
//
//   ss_eval_classify --input DIR [--backbone ALL.ssm] [--backbone-dir DIR] [--lighting-normalise]
//                    [--tables 1,2,3,4] [--json OUT.json] [--confusion-dir DIR] [--threads N]
//   ss_eval_classify --speed MODEL.ssm[@WxH] ... [--input DIR --subsample K]   (speed vs error)
//
// --backbone: Tables 1 and 2 (must not have seen the evaluation users); default: the shipped
// model (common/model_path.hpp), trained on generated users 100-135.
// --backbone-dir: no_<lighting>.ssm (Table 3: never saw that lighting) and only_<lighting>.ssm
// (Table 4: saw only that lighting), for daylight, dusk and night.
// --calibration FILE: the empty-skin model that models with a calibrated input encoding
// (docs/input_encodings.md) divide every frame by; such a model refuses to run without it.
// --session-calibrations (with --score): instead, each frame's own session's calibration,
// INPUT/empty_skin/<session>.calib (ss_gesture_data --empty-skin, tools/realhand/score.sh), as
// tools/train.py reads them; a session without its file is an error naming the file.
// --camera-px-per-cm X: the camera's scale (px per cm of skin at the image centre): frames are
// brought to the network's scale (FrameEncoder stage 2b, docs/input_encodings.md; a
// calibration's px_per_cm is not used here); --scale-fill black|replicate|black_frame_contrast: the
// fill around a shrunk frame.
// --head-val-fraction F, --head-epochs N, --head-standardise, --head-balanced: the heads' recipe
// (HeadTrainer::Config; default the paper's: 0.3, 20, off, off).
// A class of the model with no frame anywhere in the data (a source without pointing hands) is
// absent: the Tables' heads keep its output, trained with no example of it, its confusion row
// stays empty, and the JSON lists it under "absent_classes". A class that is in the data but
// missing from one split's training or test part is still an error naming it.
#include <shadowsense/eval.hpp>
#include <shadowsense/train/gesture_samples.hpp>

#include "common/cli.hpp"
#include "common/frame_source.hpp"
#include "common/json.hpp"
#include "common/model_calibration.hpp"
#include "common/model_path.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <set>

namespace ss = shadowsense;
namespace fs = std::filesystem;
using Indices = std::vector<std::size_t>;
using Confusion = std::vector<std::vector<int>>; // [true][predicted]

namespace {

const std::array<ss::sim::Lighting, 3> lightings{ss::sim::Lighting::daylight,
                                                 ss::sim::Lighting::dusk, ss::sim::Lighting::night};

struct Options {
  std::string data, backbone, backbone_dir, json, confusion_dir;
  std::string calibration;           // --calibration: the empty-skin model of calibrated encodings
  bool session_calibrations = false; // --session-calibrations: INPUT/empty_skin/<session>.calib
  double camera_px_per_cm = 0;       // --camera-px-per-cm: 0 = frames as they are
  ss::ScaleFill scale_fill = ss::default_scale_fill; // --scale-fill
  std::set<int> tables{1, 2, 3, 4};
  bool normalise = false;
  int threads = 1;
  std::vector<std::string> speed_models;
  std::string score_model;
  int subsample = 1;
  bool quiet = false;
  // The heads' recipe: the paper's by default (docs/classification_eval.md, "Heads retrained").
  ss::HeadTrainer::Config head{};
  double head_val_fraction = 0.3;
};

// Features of every frame of the set under one backbone, computed once.
struct Features {
  std::string backbone;
  Eigen::MatrixXd x;
};

// A model's encoder: the --calibration's empty-skin model, the --camera-px-per-cm scale.
ss::FrameEncoder make_encoder(const ss::ModelFile& model, const std::string& path,
                              const Options& o) {
  return ss::FrameEncoder(model.preprocess, /*force_lighting_normalise=*/false,
                          cli::empty_skin_for(model, path, o.calibration), o.camera_px_per_cm,
                          o.scale_fill);
}

Features features_for(const std::string& path, const ss::GestureSamples& set, const Options& o,
                      const Indices& all) {
  const auto model = cli::load_model(path, o.normalise);
  if (model.class_names != set.class_names)
    throw ss::ModelFileError(path + ": classes differ from the Table-1 backbone's; every "
                                    "backbone must use the same class order");
  ss::FeatureExtractor fx(model, {.threads = o.threads});
  ss::FrameEncoder enc = make_encoder(model, path, o);
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

// Per class of the set: whether any frame of the data has it (see "absent" above).
std::vector<bool> classes_in_data(const ss::GestureSamples& set) {
  std::vector<bool> in(set.class_names.size(), false);
  for (const auto& f : set.frames) in[static_cast<std::size_t>(f.label)] = true;
  return in;
}

// Trains a head on `pool` (70/30 train/validation by time) and returns the predicted class of
// every test frame.
std::vector<int> train_and_predict(const Options& o, const ss::GestureSamples& set,
                                   const Features& f, const Indices& pool, const Indices& test) {
  const auto [train, val] = ss::time_split(set, pool, o.head_val_fraction);
  if (train.empty() || (o.head_val_fraction > 0 && val.empty()) || test.empty())
    throw ss::DatasetError("a split has no training, validation or test frames (" +
                           std::to_string(train.size()) + "/" + std::to_string(val.size()) + "/" +
                           std::to_string(test.size()) + ")");
  const int classes = static_cast<int>(set.class_names.size());
  const auto yt = ss::labels_of(set, train);
  const std::vector<bool> in_data = classes_in_data(set);
  for (int c = 0; c < classes; ++c)
    if (in_data[static_cast<std::size_t>(c)] && std::find(yt.begin(), yt.end(), c) == yt.end())
      throw ss::DatasetError("class '" + set.class_names[static_cast<std::size_t>(c)] +
                             "' of the model has no training frames in a split of this data "
                             "(a class folder is missing or empty)");
  const auto r = ss::HeadTrainer(o.head).train(
      ss::LinearHead::random(classes, static_cast<int>(f.x.cols()), 0), rows(f.x, train), yt,
      rows(f.x, val), ss::labels_of(set, val));
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
  const std::vector<bool> in_data = classes_in_data(set);
  for (std::size_t c = 0; c < k; ++c) {
    int n = 0;
    for (int v : s.confusion[c]) n += v;
    if (n == 0 && in_data[c])
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

// A confusion matrix as rows of counts, [true][predicted].
void json_confusion(cli::JsonWriter& j, const Confusion& c) {
  j.begin_array(cli::JsonWriter::compact);
  for (const auto& row : c) {
    j.begin_array();
    for (int v : row) j.value(v);
    j.end_array();
  }
  j.end_array();
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
  frames::write_png_atomically(path, img); // temp + rename: never a truncated PNG
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
  cli::JsonWriter json;
  json.begin_object().key("speed").begin_array();
  for (const auto& spec : o.speed_models) {
    std::string path = spec;
    std::optional<std::pair<int, int>> size;
    if (const auto at = spec.rfind('@'); at != std::string::npos) {
      path = spec.substr(0, at);
      const std::string wxh = spec.substr(at + 1);
      const auto x = wxh.find('x');
      cli::detail::Constraint<int> side;
      side.has_range = true;
      side.lo = 8;
      side.hi = 4096;
      if (x == std::string::npos)
        throw cli::UsageError("--speed: expected MODEL@WxH, got '" + spec + "'");
      const int w = side.parse("--speed " + spec + ": width", std::string_view(wxh).substr(0, x));
      const int h = side.parse("--speed " + spec + ": height", std::string_view(wxh).substr(x + 1));
      size = std::pair{w, h};
    }
    auto model = cli::load_model(path, o.normalise);
    if (size) {
      model.preprocess.resize_width = size->first;
      model.preprocess.resize_height = size->second;
      model.preprocess.crop_width = model.preprocess.crop_height = 0;
    }
    const int in_w =
        model.preprocess.crop_width ? model.preprocess.crop_width : model.preprocess.resize_width;
    const int in_h =
        model.preprocess.crop_width ? model.preprocess.crop_height : model.preprocess.resize_height;
    // The timed classify(frame) includes the model's whole input encoding (a calibrated one too).
    auto clf = ss::Classifier<ss::DenseNet>(
        ss::DenseNet(model, {.threads = o.threads, .run_self_test = !size}),
        {model.preprocess, ss::ChannelOrder::bgr, cli::empty_skin_for(model, path, o.calibration),
         o.camera_px_per_cm, o.scale_fill});
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
      ss::FrameEncoder enc = make_encoder(model, path, o);
      Features f{path,
                 Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(set->frames.size()), fx.dim())};
      const Eigen::MatrixXd part = ss::extract_features(fx, enc, *set, all);
      for (std::size_t k = 0; k < all.size(); ++k)
        f.x.row(static_cast<Eigen::Index>(all[k])) = part.row(static_cast<Eigen::Index>(k));
      const auto [pool, test] = ss::time_split(*set, all, 0.3);
      const auto pred = train_and_predict(o, *set, f, pool, test);
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
    json.begin_object(cli::JsonWriter::compact).field("model", fs::path(path).filename().string());
    json.field("input_width", in_w).field("input_height", in_h).field("ms_per_frame", ms);
    json.key("table1_average_accuracy");
    if (acc < 0)
      json.value(nullptr);
    else
      json.value(acc);
    json.end_object();
  }
  json.end_array().end_object();
  if (!o.json.empty()) json.save(o.json);
  return 0;
}

// Scores a model file as it is (its own classifier, no training) on every frame of --input with
// the C++ Classifier: accuracy per lighting and overall, confusion matrices.
int run_score(const Options& o) {
  if (o.data.empty()) throw cli::UsageError("--score: needs --input DIR");
  const auto model = cli::load_model(o.score_model, o.normalise);
  const auto set = ss::load_gesture_samples(o.data, model.class_names);
  // Per session (--session-calibrations on a calibrated model): one encoder, given each
  // session's empty-skin model when the frames move to another session (memory stays one
  // encoder's however many sessions there are); otherwise one empty-skin model for every frame.
  const bool per_session =
      o.session_calibrations && ss::needs_calibration(model.preprocess.input_encoding);
  auto session_skin = [&](const ss::GestureSample& f) {
    if (f.session.find_first_of("/\\") != std::string::npos || f.session == "." ||
        f.session == "..")
      throw ss::DatasetError(f.path.string() + ": session '" + f.session +
                             "' is not a file name, so it names no empty_skin/<session>.calib");
    const fs::path cal = fs::path(o.data) / "empty_skin" / (f.session + ".calib");
    if (!fs::is_regular_file(cal))
      throw ss::DatasetError(cal.string() +
                             ": missing; --session-calibrations needs the "
                             "calibration of session '" +
                             f.session + "' (ss_gesture_data --empty-skin writes it)");
    return cli::empty_skin_for(model, o.score_model, cal.string());
  };
  const ss::GestureSample& first = set.frames.front();
  // (Per session, only the empty-skin models are read; the scale is --camera-px-per-cm's.)
  ss::FrameEncoder encoder(model.preprocess, /*force_lighting_normalise=*/false,
                           per_session ? session_skin(first)
                                       : cli::empty_skin_for(model, o.score_model, o.calibration),
                           o.camera_px_per_cm, o.scale_fill);
  std::string session = first.session; // whose empty-skin model the encoder holds
  // The classifier runs on the encoder's tensors; its own encoder (which needs an empty-skin
  // model to exist) gets the first frame's.
  auto clf = ss::make_densenet_classifier(model, {.threads = o.threads}, ss::ChannelOrder::bgr,
                                          encoder.config().empty_skin);
  const std::size_t k = set.class_names.size();
  std::map<std::string, Confusion> conf;
  ss::Tensor t;
  for (const auto& f : set.frames) {
    ss::Classification c;
    try {
      if (per_session && f.session != session) {
        encoder.set_empty_skin(session_skin(f));
        session = f.session;
      }
      encoder.run(ss::read_colour_image(f.path), ss::is_dark(f), t);
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
  cli::JsonWriter json;
  json.begin_object().field("model", o.score_model).field("data", o.data);
  json.key("accuracy").begin_object(cli::JsonWriter::compact);
  for (const auto& [key, m] : conf) {
    int ok = 0, n = 0;
    for (std::size_t i = 0; i < k; ++i)
      for (std::size_t j = 0; j < k; ++j) {
        n += m[i][j];
        ok += i == j ? m[i][j] : 0;
      }
    std::cout << "  " << std::left << std::setw(10) << key << "  " << pct(double(ok) / n) << "   "
              << n << "\n";
    json.field(key, double(ok) / n);
    if (!o.confusion_dir.empty())
      write_confusion_png(fs::path(o.confusion_dir) / ("score_" + key + ".png"), m, set.class_names,
                          "Shipped model - " + key + ": " + pct(double(ok) / n));
  }
  json.end_object().key("confusion").begin_object();
  for (const auto& [key, m] : conf) {
    json.key(key);
    json_confusion(json, m);
  }
  json.end_object().end_object();
  if (!o.json.empty()) json.save(o.json);
  return 0;
}

Options parse_options(int argc, char** argv) {
  Options o;
  std::vector<int> tables{1, 2, 3, 4};
  cli::Parser p("ss_eval_classify",
                "The paper's classification experiments (section 5.1, Tables 1-4) on a gesture "
                "folder: every split trains a linear classifier on frozen backbone features and "
                "scores the split's test frames (docs/classification_eval.md). --score scores a "
                "model as it is; --speed times models (speed vs error).");
  p.usage("ss_eval_classify --input DIR [--backbone ALL.ssm] [--backbone-dir DIR] [--tables LIST] "
          "[options]");
  p.usage("ss_eval_classify --score MODEL --input DIR [options]");
  p.usage("ss_eval_classify --speed MODEL[@WxH] ... [--input DIR --subsample K] [options]");
  p.option("--input", "DIR", "gesture folder (dataset format)", o.data);
  p.alias("--data", "--input");
  p.option("--backbone", "ALL.ssm", "backbone of Tables 1 and 2 (never saw the evaluated users)",
           o.backbone)
      .default_text(cli::default_model_help(argv[0]) + ", trained on generated users 100-135");
  p.option("--backbone-dir", "DIR",
           "no_<lighting>.ssm (Table 3) and only_<lighting>.ssm (Table 4) backbones",
           o.backbone_dir);
  p.list("--tables", "LIST", "tables to compute", tables).range(1, 4);
  p.flag("--lighting-normalise", "normalise lighting before the network", o.normalise);
  p.option("--calibration", "FILE",
           "the robot's calibration (ss_calibrate): its empty-skin model, needed by models "
           "with a calibrated input encoding (docs/input_encodings.md)",
           o.calibration);
  p.flag("--session-calibrations",
         "with --score: each frame's session's own calibration, INPUT/empty_skin/<session>.calib "
         "(ss_gesture_data --empty-skin), instead of one --calibration",
         o.session_calibrations);
  p.option("--camera-px-per-cm", "X",
           "the camera's scale, px per cm of skin (0: none): frames are brought to the "
           "network's scale",
           o.camera_px_per_cm)
      .range(0.0, 10000.0);
  std::string fill = ss::to_string(o.scale_fill);
  p.option("--scale-fill", "black|replicate|black_frame_contrast",
           "what fills the frame around a frame shrunk to the network's scale", fill)
      .choices({"black", "replicate", "black_frame_contrast"});
  p.option("--json", "OUT.json", "write the results as JSON", o.json);
  p.option("--confusion-dir", "DIR", "write confusion matrices as PNG images", o.confusion_dir);
  p.option("--threads", "N", "worker threads", o.threads).range(1, 256);
  p.option("--score", "MODEL", "score this model's own classifier on --input", o.score_model);
  p.repeated("--speed", "MODEL[@WxH]",
             "time this model, optionally resized to WxH; with --input also its Table-1 accuracy",
             o.speed_models);
  p.option("--subsample", "K", "with --speed: every K-th frame of each session x class block",
           o.subsample)
      .range(1, 1000000);
  p.flag("--quiet", "no progress messages", o.quiet);
  p.option("--head-val-fraction", "F",
           "heads: validation share of the training part (0: none, the last epoch is kept)",
           o.head_val_fraction)
      .range(0.0, 0.99);
  p.option("--head-epochs", "N", "heads: training epochs", o.head.epochs).range(1, 100000);
  p.flag("--head-standardise", "heads: train on standardised features", o.head.standardise);
  p.flag("--head-balanced", "heads: class-balanced batches", o.head.balanced_batches);
  p.parse(argc, argv);
  o.tables = std::set<int>(tables.begin(), tables.end());
  o.scale_fill = *ss::parse_scale_fill(fill);
  if (o.camera_px_per_cm > 0 && o.camera_px_per_cm < 0.05)
    throw cli::UsageError("--camera-px-per-cm: expected 0 or a scale in [0.05, 10000]");
  if (o.session_calibrations && o.score_model.empty())
    throw cli::UsageError("--session-calibrations: only with --score MODEL");
  if (o.session_calibrations && !o.calibration.empty())
    throw cli::UsageError("--session-calibrations and --calibration: give one of them");
  if (o.speed_models.empty() && o.score_model.empty()) {
    if (o.data.empty())
      throw cli::UsageError("--input is required (or --score / --speed; see --help)");
    if ((o.tables.count(3) || o.tables.count(4)) && o.backbone_dir.empty())
      throw cli::UsageError(
          "--backbone-dir: Tables 3 and 4 need it (no_<lighting>.ssm, only_<lighting>.ssm)");
    if (o.backbone.empty()) { // say which file the default is, as --help does
      std::string what;
      o.backbone = cli::find_default_model(argv[0], &what).string();
      std::cerr << "ss_eval_classify: backbone " << o.backbone << " (" << what << ")\n";
    }
  }
  return o;
}

// ------------------------------------------------------------------------------ Tables 1 to 4
// What every table needs: the data, the features of its backbone(s) (computed once each), where
// to put confusion images and the JSON document under construction.
struct TableRun {
  const Options& o;
  const ss::GestureSamples& set;
  const Indices& all;
  cli::JsonWriter& json;
  std::string mode; // printed after each table's title
  std::map<std::string, Features> features;

  const Features& backbone_features(const std::string& path) {
    if (!features.count(path)) features.emplace(path, features_for(path, set, o, all));
    return features.at(path);
  }
  // The backbone that never saw lighting l ("no") or saw only l ("only").
  const Features& lighting_backbone(const std::string& kind, ss::sim::Lighting l) {
    return backbone_features(
        (fs::path(o.backbone_dir) / (kind + "_" + lname(l) + ".ssm")).string());
  }
  void confusion_png(const std::string& file, const Confusion& c, const std::string& title) const {
    if (!o.confusion_dir.empty())
      write_confusion_png(fs::path(o.confusion_dir) / file, c, set.class_names, title);
  }
};

// Table 1: combined data, every gesture x lighting block split 70/30 by collection time.
void table1_combined(TableRun& r) {
  const auto [pool, test] = ss::time_split(r.set, r.all, 0.3);
  const auto pred = train_and_predict(r.o, r.set, r.backbone_features(r.o.backbone), pool, test);
  std::cout << "\nTable 1: combined data, every gesture x lighting split 70/30 by collection time"
            << r.mode << "\n";
  std::cout << "  lighting    accuracy   test frames\n";
  std::vector<Score> scores;
  double sum = 0;
  for (const auto l : lightings) {
    scores.push_back(
        score(r.set, test, pred, [&](const ss::GestureSample& f) { return f.lighting == l; }));
    const Score& s = scores.back();
    sum += s.accuracy;
    std::cout << "  " << std::left << std::setw(10) << lname(l) << "  " << pct(s.accuracy) << "   "
              << s.frames << "\n";
    r.confusion_png("table1_" + lname(l) + ".png", s.confusion,
                    "Table 1 - " + lname(l) + ": " + pct(s.accuracy));
  }
  std::cout << "  average     " << pct(sum / 3) << "\n";
  r.json.key("table1").begin_object();
  r.json.key("accuracy").begin_object(cli::JsonWriter::compact);
  for (std::size_t li = 0; li < lightings.size(); ++li)
    r.json.field(lname(lightings[li]), scores[li].accuracy);
  r.json.end_object().field("average", sum / 3);
  r.json.key("confusion").begin_object();
  for (std::size_t li = 0; li < lightings.size(); ++li) {
    r.json.key(lname(lightings[li]));
    json_confusion(r.json, scores[li].confusion);
  }
  r.json.end_object().end_object();
}

// Table 2: leave one user out.
void table2_leave_one_user_out(TableRun& r) {
  std::set<int> users;
  for (const auto& f : r.set.frames) users.insert(f.user);
  std::cout << "\nTable 2: leave one user out" << r.mode << "\n  user   accuracy\n";
  r.json.key("table2").begin_object().key("accuracy").begin_object(cli::JsonWriter::compact);
  double sum = 0;
  for (int u : users) {
    const Indices pool =
        ss::select_samples(r.set, [&](const ss::GestureSample& f) { return f.user != u; });
    const Indices test =
        ss::select_samples(r.set, [&](const ss::GestureSample& f) { return f.user == u; });
    const Score s = score(
        r.set, test, train_and_predict(r.o, r.set, r.backbone_features(r.o.backbone), pool, test));
    sum += s.accuracy;
    std::cout << "  " << std::setw(5) << u << "  " << pct(s.accuracy) << "\n";
    r.json.field(std::to_string(u), s.accuracy);
  }
  std::cout << "  mean   " << pct(sum / double(users.size())) << "\n";
  r.json.end_object().field("mean", sum / double(users.size())).end_object();
}

// Table 3: leave one lighting condition out (backbone no_<lighting>.ssm).
void table3_leave_one_lighting_out(TableRun& r) {
  std::cout << "\nTable 3: leave one lighting condition out (backbone no_<lighting>.ssm)" << r.mode
            << "\n  test lighting   accuracy\n";
  r.json.key("table3").begin_object().key("accuracy").begin_object(cli::JsonWriter::compact);
  double sum = 0;
  for (const auto l : lightings) {
    const Indices pool =
        ss::select_samples(r.set, [&](const ss::GestureSample& f) { return f.lighting != l; });
    const Indices test =
        ss::select_samples(r.set, [&](const ss::GestureSample& f) { return f.lighting == l; });
    const Score s =
        score(r.set, test, train_and_predict(r.o, r.set, r.lighting_backbone("no", l), pool, test));
    sum += s.accuracy;
    std::cout << "  " << std::left << std::setw(14) << lname(l) << "  " << pct(s.accuracy) << "\n";
    r.json.field(lname(l), s.accuracy);
    r.confusion_png("table3_" + lname(l) + ".png", s.confusion,
                    "Table 3 - unseen " + lname(l) + ": " + pct(s.accuracy));
  }
  std::cout << "  mean            " << pct(sum / 3) << "\n";
  r.json.end_object().field("mean", sum / 3).end_object();
}

// Table 4: train on one lighting condition, test on each other (backbone only_<lighting>.ssm).
void table4_one_lighting_to_others(TableRun& r) {
  std::cout << "\nTable 4: train on one lighting condition, test on each other (backbone "
               "only_<lighting>.ssm)"
            << r.mode << "\n  train \\ test   daylight    dusk      night\n";
  r.json.key("table4").begin_object().key("accuracy").begin_object();
  double worst = 1;
  for (const auto l : lightings) {
    const Indices pool =
        ss::select_samples(r.set, [&](const ss::GestureSample& f) { return f.lighting == l; });
    const Indices test =
        ss::select_samples(r.set, [&](const ss::GestureSample& f) { return f.lighting != l; });
    const auto pred = train_and_predict(r.o, r.set, r.lighting_backbone("only", l), pool, test);
    std::cout << "  " << std::left << std::setw(12) << lname(l);
    r.json.key(lname(l)).begin_object(cli::JsonWriter::compact);
    for (const auto m : lightings) {
      if (m == l) {
        std::cout << "     -    ";
        continue;
      }
      const Score s =
          score(r.set, test, pred, [&](const ss::GestureSample& f) { return f.lighting == m; });
      worst = std::min(worst, s.accuracy);
      std::cout << "  " << pct(s.accuracy);
      r.json.field(lname(m), s.accuracy);
    }
    std::cout << "\n";
    r.json.end_object();
  }
  std::cout << "  lowest cell   " << pct(worst) << "\n";
  r.json.end_object().field("min", worst).end_object();
}

int run_tables(const Options& o) {
  const auto base = cli::load_model(o.backbone, o.normalise);
  const auto set = ss::load_gesture_samples(o.data, base.class_names);
  const Indices all = ss::select_samples(set, [](const ss::GestureSample&) { return true; });
  cli::JsonWriter json;
  json.begin_object().field("data", o.data).field("frames", set.frames.size());
  json.field("lighting_normalise", o.normalise);
  json.key("class_names").begin_array(cli::JsonWriter::compact);
  for (const auto& n : set.class_names) json.value(n);
  json.end_array().field("backbone", o.backbone);
  const std::vector<bool> in_data = classes_in_data(set);
  json.key("absent_classes").begin_array(cli::JsonWriter::compact);
  for (std::size_t c = 0; c < in_data.size(); ++c)
    if (!in_data[c]) {
      json.value(set.class_names[c]);
      if (!o.quiet)
        std::cerr << "note: class '" << set.class_names[c] << "' has no frame in " << o.data
                  << ": the heads are trained without it and it has no row in the scores\n";
    }
  json.end_array();
  TableRun r{
      o, set, all, json, o.normalise ? " (lighting normalisation on)" : " (paper preprocessing)",
      {}};
  if (o.tables.count(1)) table1_combined(r);
  if (o.tables.count(2)) table2_leave_one_user_out(r);
  if (o.tables.count(3)) table3_leave_one_lighting_out(r);
  if (o.tables.count(4)) table4_one_lighting_to_others(r);
  json.end_object();
  if (!o.json.empty()) json.save(o.json);
  return 0;
}

} // namespace

int main(int argc, char** argv) {
  return cli::run("ss_eval_classify", [&] {
    const Options o = parse_options(argc, argv);
    if (!o.speed_models.empty()) return run_speed(o);
    if (!o.score_model.empty()) return run_score(o);
    return run_tables(o);
  });
}
