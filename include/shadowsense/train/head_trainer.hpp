// On-device transfer learning (paper 5.1.3 without Python): the DenseNet's feature extractor
// stays frozen, its pooled features are computed once per image, and only the final linear
// classifier is trained, with the paper's recipe: Adam (lr 1e-3, betas 0.9/0.999, eps 1e-8,
// weight decay 0) on the negative log-likelihood of log-softmax, mini-batches of 16, the epoch
// with the best validation accuracy kept. A robot re-calibrates to its own skin and lighting
// from a few dozen labelled frames; the result is a new model file.
//
//   FeatureExtractor fx(model);                          // frozen backbone
//   Eigen::MatrixXd X = ...;                             // one row of fx.extract(...) per image
//   auto init = LinearHead::random(classes, fx.dim(), seed); // or the model's own head
//   auto r = HeadTrainer(HeadTrainer::Config{}).train(init, X, y, Xv, yv);
//   save_model_file(model_with_head(model, r.head, names), "robot.ssm");
//
// Few-shot options of HeadTrainer::Config (off by default; measured in
// docs/classification_eval.md, "Few-shot adaptation"): anchor (L2 toward the initial head),
// balanced_batches (detail::balanced_order), standardise (per-column standardised features,
// folded back into the returned head so it applies to raw features). Without validation data
// the last epoch is kept (ss_train_head --val-fraction 0).
//
// HeadTrainer(config)
//   requires: epochs in [1, 100000], batch_size >= 1, learning_rate > 0, betas in [0, 1),
//   epsilon > 0, weight_decay >= 0, anchor finite and >= 0 (else InvalidArgument).
// train(init, x, y, xv, yv, on_epoch)
//   requires: one label per row, labels in [0, init.classes()), x.cols() == init.features(),
//   finite features, x.rows() >= 1; xv may be empty (then yv too) (else InvalidArgument).
//   ensures: the head of the best validation epoch (ties: lower validation loss), or of the
//   last epoch without validation; deterministic for a given config.seed.
// Threading: HeadTrainer is immutable after construction; train() may run concurrently on
// different data. FeatureExtractor wraps a DenseNet: one instance per thread.
#pragma once

#include <shadowsense/backends/densenet/densenet.hpp>
#include <shadowsense/backends/densenet/model_file.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/tensor.hpp>
#include <shadowsense/core/version.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <numeric>
#include <random>
#include <span>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// The frozen feature extractor: the DenseNet up to norm5 -> ReLU -> global average pool
// (DenseNet::features). The model's own classifier and self-test are kept but not used here.
class FeatureExtractor {
public:
  explicit FeatureExtractor(const ModelFile& model, DenseNet::Config config = {})
      : net_(model, config), dim_(net_.feature_size()) {}

  int dim() const { return dim_; }
  DenseNet& network() { return net_; }

  // n x dim features for an n x 3 x h x w preprocessed tensor (row per image); the span stays
  // valid until the next call.
  std::span<const float> extract(const Tensor& input) { return net_.features(input); }

private:
  DenseNet net_;
  int dim_;
};

// A linear classifier on features: logits = weight * x + bias.
struct LinearHead {
  Eigen::MatrixXd weight; // classes x features
  Eigen::VectorXd bias;   // classes

  int classes() const { return static_cast<int>(weight.rows()); }
  int features() const { return static_cast<int>(weight.cols()); }

  // The classifier of a model file.
  static LinearHead from_model(const ModelFile& model) {
    const auto& w = model.tensor("classifier.weight");
    const auto& b = model.tensor("classifier.bias");
    detail::require(w.shape.size() == 2 && b.shape.size() == 1 && w.shape[0] == b.shape[0],
                    "LinearHead::from_model: classifier tensors are not [classes, features] and "
                    "[classes]");
    LinearHead h;
    h.weight.resize(w.shape[0], w.shape[1]);
    for (int r = 0; r < w.shape[0]; ++r)
      for (int c = 0; c < w.shape[1]; ++c)
        h.weight(r, c) = w.values[static_cast<std::size_t>(r) * w.shape[1] + c];
    h.bias.resize(b.shape[0]);
    for (int r = 0; r < b.shape[0]; ++r) h.bias(r) = b.values[static_cast<std::size_t>(r)];
    return h;
  }

  // PyTorch's nn.Linear initialisation: weight and bias uniform in +-1/sqrt(features).
  static LinearHead random(int classes, int features, std::uint64_t seed) {
    detail::require(classes >= 1 && features >= 1,
                    "LinearHead::random: classes and features must be >= 1");
    std::mt19937_64 rng(seed);
    const double bound = 1.0 / std::sqrt(double(features));
    auto u = [&] { return (double(rng() >> 11) * 0x1.0p-53 * 2.0 - 1.0) * bound; };
    LinearHead h;
    h.weight.resize(classes, features);
    for (int r = 0; r < classes; ++r)
      for (int c = 0; c < features; ++c) h.weight(r, c) = u();
    h.bias.resize(classes);
    for (int r = 0; r < classes; ++r) h.bias(r) = u();
    return h;
  }
};

namespace detail {
inline void check_head_data(const LinearHead& head, const Eigen::MatrixXd& x,
                            std::span<const int> labels, const char* what) {
  require(x.rows() == static_cast<Eigen::Index>(labels.size()),
          std::string(what) + ": " + std::to_string(x.rows()) + " feature rows but " +
              std::to_string(labels.size()) + " labels, expected one label per row");
  require(x.cols() == head.features(),
          std::string(what) + ": features have " + std::to_string(x.cols()) +
              " columns, expected " + std::to_string(head.features()) + " (the backbone's width)");
  for (int l : labels)
    require(l >= 0 && l < head.classes(), std::string(what) + ": label " + std::to_string(l) +
                                              " outside [0, " + std::to_string(head.classes()) +
                                              ")");
  require(x.allFinite(), std::string(what) + ": features hold NaN or Inf, expected finite");
}

// One epoch's visiting order with class-balanced batches: for every class present in labels a
// Fisher-Yates shuffled list of its rows, repeated (each repetition reshuffled) until it is as
// long as the largest class's; then round after round, one row of every present class in
// increasing class order. The result has (present classes) x (largest class count) entries;
// classes absent from labels are skipped. requires: labels in [0, classes).
template <class Rng>
std::vector<int> balanced_order(std::span<const int> labels, int classes, Rng& rng) {
  std::vector<std::vector<int>> by_class(static_cast<std::size_t>(classes));
  for (std::size_t i = 0; i < labels.size(); ++i) {
    require(labels[i] >= 0 && labels[i] < classes, "balanced_order: label outside [0, classes)");
    by_class[static_cast<std::size_t>(labels[i])].push_back(static_cast<int>(i));
  }
  std::size_t most = 0;
  for (const auto& c : by_class) most = std::max(most, c.size());
  auto shuffle = [&](std::vector<int>& v) {
    for (std::size_t i = v.size(); i > 1; --i)
      std::swap(v[i - 1], v[static_cast<std::size_t>(rng() % i)]);
  };
  std::vector<std::vector<int>> lists;
  for (auto& c : by_class) {
    if (c.empty()) continue;
    std::vector<int> list;
    while (list.size() < most) {
      shuffle(c);
      list.insert(list.end(), c.begin(),
                  c.begin() + static_cast<std::ptrdiff_t>(std::min(c.size(), most - list.size())));
    }
    lists.push_back(std::move(list));
  }
  std::vector<int> order;
  order.reserve(lists.size() * most);
  for (std::size_t k = 0; k < most; ++k)
    for (const auto& l : lists) order.push_back(l[k]);
  return order;
}
} // namespace detail

// Mean negative log-likelihood of log-softmax(weight * x + bias) over the rows of x; when
// gradient is given, also d loss / d (weight, bias) (same shapes as head). correct, if given,
// receives the number of rows whose argmax equals the label.
inline double head_loss(const LinearHead& head, const Eigen::MatrixXd& x,
                        std::span<const int> labels, LinearHead* gradient = nullptr,
                        int* correct = nullptr) {
  detail::check_head_data(head, x, labels, "head_loss");
  detail::require(x.rows() >= 1, "head_loss: no rows, expected at least one");
  const Eigen::Index n = x.rows();
  Eigen::MatrixXd z = x * head.weight.transpose(); // n x classes
  z.rowwise() += head.bias.transpose();
  double loss = 0;
  int ok = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    Eigen::Index arg = 0;
    const double mx = z.row(i).maxCoeff(&arg);
    const double sum = (z.row(i).array() - mx).exp().sum();
    const int y = labels[static_cast<std::size_t>(i)];
    loss -= (z(i, y) - mx) - std::log(sum); // shifted by mx first: exact for huge logits
    ok += arg == y;
    if (gradient) { // d/dz = softmax - onehot, averaged over the batch
      z.row(i) = (z.row(i).array() - mx).exp() / sum;
      z(i, y) -= 1.0;
    }
  }
  if (gradient) {
    z /= double(n);
    gradient->weight = z.transpose() * x;
    gradient->bias = z.colwise().sum().transpose();
  }
  if (correct) *correct = ok;
  return loss / double(n);
}

struct HeadEpoch {
  int epoch = 0; // 1-based
  double train_loss = 0, train_accuracy = 0;
  double val_loss = 0, val_accuracy = 0; // NaN without validation data
  bool best = false;                     // best so far (the kept head)
};

struct HeadTrainingResult {
  LinearHead head; // of the best epoch
  int best_epoch = 0;
  std::vector<HeadEpoch> epochs;
};

class HeadTrainer {
public:
  struct Config {
    int epochs = 20;
    int batch_size = 16;
    double learning_rate = 1e-3;
    double beta1 = 0.9, beta2 = 0.999, epsilon = 1e-8;
    double weight_decay = 0.0; // L2 added to the gradient, as torch.optim.Adam does
    std::uint64_t seed = 0;    // initialisation and shuffling
    // Few-shot options (all off by default: the paper's recipe).
    // anchor: L2 pull toward the initial head, anchor * (p - init) added to the gradient like
    // weight_decay (which pulls toward 0): a fine-tuned head stays near the shipped classifier.
    double anchor = 0.0;
    // balanced_batches: every epoch visits each class equally often: per class a shuffled
    // list, smaller classes repeated (reshuffled) up to the largest class's count, then
    // interleaved class by class (balanced_order), so every batch of >= classes rows holds
    // each class once before any class twice.
    bool balanced_batches = false;
    // standardise: train on features standardised by the training rows' per-column mean and
    // standard deviation (columns with sd < 1e-12 keep scale 1), then fold the transform back
    // into the returned head, so the head applies to raw features (same model file format).
    // The initial head and anchor are mapped into the standardised space.
    bool standardise = false;
  };

  HeadTrainer() : HeadTrainer(Config{}) {}
  explicit HeadTrainer(Config config) : config_(config) {
    detail::require(config.epochs >= 1 && config.epochs <= 100000,
                    "HeadTrainer: epochs must be in [1, 100000]");
    detail::require(config.batch_size >= 1, "HeadTrainer: batch_size must be >= 1");
    detail::require(std::isfinite(config.learning_rate) && config.learning_rate > 0,
                    "HeadTrainer: learning_rate must be > 0");
    detail::require(config.beta1 >= 0 && config.beta1 < 1 && config.beta2 >= 0 && config.beta2 < 1,
                    "HeadTrainer: betas must be in [0, 1)");
    detail::require(config.epsilon > 0 && config.weight_decay >= 0,
                    "HeadTrainer: epsilon must be > 0 and weight_decay >= 0");
    detail::require(std::isfinite(config.anchor) && config.anchor >= 0,
                    "HeadTrainer: anchor must be a finite number >= 0, got " +
                        std::to_string(config.anchor));
  }
  const Config& config() const { return config_; }

  // Trains from `init` (LinearHead::random for a new head, or the model's own classifier to
  // fine-tune it). Validation may be empty: then the last epoch is kept. on_epoch is called
  // after every epoch (progress output). Reported losses and accuracies are of the features
  // the head is trained on (standardised ones with Config::standardise).
  HeadTrainingResult train(LinearHead init, const Eigen::MatrixXd& x, std::span<const int> y,
                           const Eigen::MatrixXd& xv, std::span<const int> yv,
                           const std::function<void(const HeadEpoch&)>& on_epoch = {}) const {
    detail::check_head_data(init, x, y, "HeadTrainer::train (training set)");
    detail::require(x.rows() >= 1, "HeadTrainer::train: no training rows");
    if (xv.rows() > 0)
      detail::check_head_data(init, xv, yv, "HeadTrainer::train (validation set)");
    else
      detail::require(yv.empty(), "HeadTrainer::train: validation labels without features");
    if (!config_.standardise) return run(std::move(init), x, y, xv, yv, on_epoch);

    // x = sd * s + mean per column: W x + b = (W diag(sd)) s + (W mean + b).
    const Eigen::RowVectorXd mean = x.colwise().mean();
    Eigen::RowVectorXd sd =
        ((x.rowwise() - mean).array().square().colwise().sum() / double(x.rows())).sqrt();
    for (Eigen::Index c = 0; c < sd.size(); ++c)
      if (!(sd(c) >= 1e-12)) sd(c) = 1.0;
    auto standardised = [&](const Eigen::MatrixXd& m) -> Eigen::MatrixXd {
      if (m.rows() == 0) return m;
      return ((m.rowwise() - mean).array().rowwise() / sd.array()).matrix();
    };
    init.bias += init.weight * mean.transpose();
    init.weight = init.weight * sd.asDiagonal();
    HeadTrainingResult r = run(std::move(init), standardised(x), y, standardised(xv), yv, on_epoch);
    r.head.weight = r.head.weight * sd.cwiseInverse().asDiagonal();
    r.head.bias -= r.head.weight * mean.transpose();
    return r;
  }

private:
  HeadTrainingResult run(LinearHead init, const Eigen::MatrixXd& x, std::span<const int> y,
                         const Eigen::MatrixXd& xv, std::span<const int> yv,
                         const std::function<void(const HeadEpoch&)>& on_epoch) const {
    const bool has_val = xv.rows() > 0;
    const LinearHead anchor = init;
    LinearHead p = std::move(init), g, m, v;
    m.weight = Eigen::MatrixXd::Zero(p.weight.rows(), p.weight.cols());
    m.bias = Eigen::VectorXd::Zero(p.bias.size());
    v = m;
    std::mt19937_64 rng(config_.seed ^ 0x9E3779B97F4A7C15ull);
    std::vector<int> order(static_cast<std::size_t>(x.rows()));
    Eigen::MatrixXd xb;
    std::vector<int> yb;
    long long step = 0;
    HeadTrainingResult result;
    double best_acc = -1, best_loss = std::numeric_limits<double>::infinity();
    for (int epoch = 1; epoch <= config_.epochs; ++epoch) {
      if (config_.balanced_batches) {
        order = detail::balanced_order(y, p.classes(), rng);
      } else {
        order.resize(static_cast<std::size_t>(x.rows()));
        std::iota(order.begin(), order.end(), 0);
        for (std::size_t i = order.size(); i > 1; --i) // Fisher-Yates, portable
          std::swap(order[i - 1], order[static_cast<std::size_t>(rng() % i)]);
      }
      double loss_sum = 0;
      long long correct_sum = 0;
      for (std::size_t s = 0; s < order.size(); s += static_cast<std::size_t>(config_.batch_size)) {
        const std::size_t e =
            std::min(order.size(), s + static_cast<std::size_t>(config_.batch_size));
        xb.resize(static_cast<Eigen::Index>(e - s), x.cols());
        yb.resize(e - s);
        for (std::size_t k = s; k < e; ++k) {
          xb.row(static_cast<Eigen::Index>(k - s)) = x.row(order[k]);
          yb[k - s] = y[static_cast<std::size_t>(order[k])];
        }
        int correct = 0;
        loss_sum += head_loss(p, xb, yb, &g, &correct) * double(e - s);
        correct_sum += correct;
        if (config_.anchor > 0) {
          g.weight += config_.anchor * (p.weight - anchor.weight);
          g.bias += config_.anchor * (p.bias - anchor.bias);
        }
        adam_step(p, g, m, v, ++step);
      }
      HeadEpoch ep;
      ep.epoch = epoch;
      ep.train_loss = loss_sum / double(order.size());
      ep.train_accuracy = double(correct_sum) / double(order.size());
      if (has_val) {
        int correct = 0;
        ep.val_loss = head_loss(p, xv, yv, nullptr, &correct);
        ep.val_accuracy = double(correct) / double(xv.rows());
        ep.best =
            ep.val_accuracy > best_acc || (ep.val_accuracy == best_acc && ep.val_loss < best_loss);
      } else {
        ep.val_loss = ep.val_accuracy = std::numeric_limits<double>::quiet_NaN();
        ep.best = true;
      }
      if (ep.best) {
        best_acc = ep.val_accuracy;
        best_loss = ep.val_loss;
        result.head = p;
        result.best_epoch = epoch;
      }
      result.epochs.push_back(ep);
      if (on_epoch) on_epoch(ep);
    }
    return result;
  }

  // torch.optim.Adam (amsgrad off): bias-corrected first and second moments.
  void adam_step(LinearHead& p, LinearHead& g, LinearHead& m, LinearHead& v, long long t) const {
    const double b1 = config_.beta1, b2 = config_.beta2;
    if (config_.weight_decay > 0) {
      g.weight += config_.weight_decay * p.weight;
      g.bias += config_.weight_decay * p.bias;
    }
    const double c1 = 1.0 - std::pow(b1, double(t)), c2 = std::sqrt(1.0 - std::pow(b2, double(t)));
    const double step = config_.learning_rate / c1;
    auto update = [&](auto& pp, const auto& gg, auto& mm, auto& vv) {
      mm = b1 * mm + (1 - b1) * gg;
      vv.array() = b2 * vv.array() + (1 - b2) * gg.array().square();
      pp.array() -= step * mm.array() / (vv.array().sqrt() / c2 + config_.epsilon);
    };
    update(p.weight, g.weight, m.weight, v.weight);
    update(p.bias, g.bias, m.bias, v.bias);
  }

  Config config_;
};

// A copy of `base` whose classifier is `head` (rounded to float) with these class names.
// The self-test is dropped: its logits belong to the old classifier.
inline ModelFile model_with_head(const ModelFile& base, const LinearHead& head,
                                 std::vector<std::string> class_names) {
  base.validate();
  detail::require(head.features() == base.architecture.final_features(),
                  "model_with_head: head has " + std::to_string(head.features()) +
                      " inputs, expected the backbone's " +
                      std::to_string(base.architecture.final_features()));
  detail::require(static_cast<int>(class_names.size()) == head.classes(),
                  "model_with_head: " + std::to_string(class_names.size()) + " class names for " +
                      std::to_string(head.classes()) + " classes");
  detail::require(head.weight.allFinite() && head.bias.allFinite(),
                  "model_with_head: head weights hold NaN or Inf");
  ModelFile m = base;
  m.architecture.num_classes = head.classes();
  m.class_names = std::move(class_names);
  auto& w = m.tensor("classifier.weight");
  w.shape = {head.classes(), head.features()};
  w.values.resize(static_cast<std::size_t>(head.classes()) * head.features());
  for (int r = 0; r < head.classes(); ++r)
    for (int c = 0; c < head.features(); ++c)
      w.values[static_cast<std::size_t>(r) * head.features() + c] =
          static_cast<float>(head.weight(r, c));
  auto& b = m.tensor("classifier.bias");
  b.shape = {head.classes()};
  b.values.resize(static_cast<std::size_t>(head.classes()));
  for (int r = 0; r < head.classes(); ++r)
    b.values[static_cast<std::size_t>(r)] = static_cast<float>(head.bias(r));
  m.self_test.reset();
  m.validate();
  return m;
}

// Writes the model atomically (ModelFile::save): an existing file is either replaced
// completely or left untouched.
inline void save_model_file(const ModelFile& model, const std::filesystem::path& path) {
  model.save(path);
}

SHADOWSENSE_NAMESPACE_END
