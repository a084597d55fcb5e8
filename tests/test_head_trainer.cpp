// On-device transfer learning: the loss and its gradient (finite differences), Adam against
// torch.optim.Adam, the frozen feature extractor against the DenseNet's own classifier, the
// saved model reloading to the same predictions, training on generated gesture frames, and the
// few-shot options (anchor, balanced batches, standardised features, frame augmentation).
#include <shadowsense/classify/lighting_normalise.hpp>
#include <shadowsense/classify/preprocess.hpp>
#include <shadowsense/sim.hpp>
#include <shadowsense/train/frame_augment.hpp>
#include <shadowsense/train/gesture_samples.hpp>
#include <shadowsense/train/head_trainer.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

using namespace shadowsense;

namespace {
const std::filesystem::path tiny =
    std::filesystem::path(SHADOWSENSE_TEST_DATA_DIR) / "densenet_tiny.ssdn";

// The same fixed problem as the PyTorch reference in the Adam test.
void fixed_problem(Eigen::MatrixXd& x, std::vector<int>& y, LinearHead& h) {
  const int n = 8, d = 3, k = 4;
  x.resize(n, d);
  y.resize(n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < d; ++j) x(i, j) = ((i * 7 + j * 3) % 11) / 5.0 - 1.0;
    y[static_cast<std::size_t>(i)] = (i * 5) % k;
  }
  h.weight.resize(k, d);
  h.bias.resize(k);
  for (int r = 0; r < k; ++r) {
    for (int c = 0; c < d; ++c) h.weight(r, c) = ((r * 3 + c * 2) % 7) / 10.0 - 0.3;
    h.bias(r) = 0.05 * r - 0.1;
  }
}
} // namespace

TEST_CASE("head_loss: value from PyTorch and gradient by central finite differences") {
  Eigen::MatrixXd x;
  std::vector<int> y;
  LinearHead h;
  fixed_problem(x, y, h);
  LinearHead g;
  const double loss = head_loss(h, x, y, &g);
  CHECK(loss == doctest::Approx(1.3909910696566501).epsilon(1e-14));
  const double step = 1e-6;
  double worst = 0;
  for (int r = 0; r < h.classes(); ++r) {
    for (int c = 0; c <= h.features(); ++c) { // c == features: the bias
      LinearHead p = h, m = h;
      double& vp = c < h.features() ? p.weight(r, c) : p.bias(r);
      double& vm = c < h.features() ? m.weight(r, c) : m.bias(r);
      vp += step;
      vm -= step;
      const double numeric = (head_loss(p, x, y) - head_loss(m, x, y)) / (2 * step);
      const double analytic = c < h.features() ? g.weight(r, c) : g.bias(r);
      worst = std::max(worst, std::abs(numeric - analytic));
    }
  }
  CHECK(worst < 1e-8);
  // A wrong label changes the gradient: the check can fail.
  std::vector<int> y2 = y;
  y2[0] = (y2[0] + 1) % 4;
  LinearHead g2;
  head_loss(h, x, y2, &g2);
  CHECK((g2.weight - g.weight).cwiseAbs().maxCoeff() > 1e-3);
}

TEST_CASE("HeadTrainer: Adam equals torch.optim.Adam (5 full-batch steps)") {
  Eigen::MatrixXd x;
  std::vector<int> y;
  LinearHead h;
  fixed_problem(x, y, h);
  HeadTrainer trainer({.epochs = 5, .batch_size = 8});
  const auto r = trainer.train(h, x, y, Eigen::MatrixXd(), {});
  REQUIRE(r.best_epoch == 5);
  const double w[] = {-0.30499979628866952,   -0.095001765237718069, 0.095000697247255197,
                      -0.0049991600845872997, 0.20499975557326072,   -0.29500047700530441,
                      0.29501443270036848,    -0.2049992625611593,   0.0049993780761054662,
                      -0.095000727398698165,  0.095001054885917965,  0.29500048607291346};
  const double b[] = {-0.095006881815180189, -0.054995640718565802, -0.0049887561122678951,
                      0.045007176967342098};
  for (int i = 0; i < 12; ++i)
    CHECK(r.head.weight(i / 3, i % 3) == doctest::Approx(w[i]).epsilon(1e-12));
  for (int i = 0; i < 4; ++i) CHECK(r.head.bias(i) == doctest::Approx(b[i]).epsilon(1e-12));
}

TEST_CASE("HeadTrainer: rejects mismatched data with clear errors") {
  Eigen::MatrixXd x;
  std::vector<int> y;
  LinearHead h;
  fixed_problem(x, y, h);
  HeadTrainer trainer;
  std::vector<int> short_y(y.begin(), y.end() - 1);
  CHECK_THROWS_AS(trainer.train(h, x, short_y, Eigen::MatrixXd(), {}), InvalidArgument);
  std::vector<int> bad = y;
  bad[2] = 4;
  CHECK_THROWS_WITH_AS(trainer.train(h, x, bad, Eigen::MatrixXd(), {}),
                       doctest::Contains("label 4 outside [0, 4)"), InvalidArgument);
  Eigen::MatrixXd wide(8, 5);
  wide.setZero();
  CHECK_THROWS_AS(trainer.train(h, wide, y, Eigen::MatrixXd(), {}), InvalidArgument);
  x(1, 1) = std::nan("");
  CHECK_THROWS_AS(trainer.train(h, x, y, Eigen::MatrixXd(), {}), InvalidArgument);
  CHECK_THROWS_AS(HeadTrainer({.epochs = 0}), InvalidArgument);
  CHECK_THROWS_AS(HeadTrainer({.learning_rate = -1}), InvalidArgument);
}

namespace {
// n rows of d columns, deterministic, labels in [0, k): class c has its mean at +1 in column c.
void blobs(int n, int d, int k, Eigen::MatrixXd& x, std::vector<int>& y) {
  x.resize(n, d);
  y.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const int c = i % k;
    y[static_cast<std::size_t>(i)] = c;
    for (int j = 0; j < d; ++j) x(i, j) = (j == c ? 1.0 : 0.0) + 0.6 * std::sin(1.7 * i + 2.3 * j);
  }
}
Eigen::MatrixXd logits(const LinearHead& h, const Eigen::MatrixXd& x) {
  Eigen::MatrixXd z = x * h.weight.transpose();
  z.rowwise() += h.bias.transpose();
  return z;
}
LinearHead zero_head(int k, int d) {
  return {Eigen::MatrixXd::Zero(k, d), Eigen::VectorXd::Zero(k)};
}
} // namespace

TEST_CASE("HeadTrainer standardise: folded back exactly, invariant to per-column scale/offset") {
  Eigen::MatrixXd x;
  std::vector<int> y;
  blobs(40, 3, 3, x, y);
  // The same features in other units: column j scaled by d_j and shifted by c_j.
  const Eigen::RowVector3d d(1e3, 1e-3, 7.0), c(5.0, -2.0, 100.0);
  const Eigen::MatrixXd x2 = ((x.array().rowwise() * d.array()).rowwise() + c.array()).matrix();
  const HeadTrainer std_trainer({.epochs = 5, .batch_size = 8, .standardise = true});
  const auto a = std_trainer.train(zero_head(3, 3), x, y, Eigen::MatrixXd(), {});
  const auto b = std_trainer.train(zero_head(3, 3), x2, y, Eigen::MatrixXd(), {});
  // The returned heads apply to raw features: equal logits on the two encodings.
  const double diff = (logits(a.head, x) - logits(b.head, x2)).cwiseAbs().maxCoeff();
  CHECK(diff < 1e-9);
  REQUIRE(a.epochs.size() == 5u);
  CHECK(a.epochs.back().train_loss == doctest::Approx(b.epochs.back().train_loss).epsilon(1e-12));
  // Without standardisation the units matter (this comparison can fail).
  const HeadTrainer plain({.epochs = 5, .batch_size = 8});
  const auto pa = plain.train(zero_head(3, 3), x, y, Eigen::MatrixXd(), {});
  const auto pb = plain.train(zero_head(3, 3), x2, y, Eigen::MatrixXd(), {});
  CHECK((logits(pa.head, x) - logits(pb.head, x2)).cwiseAbs().maxCoeff() > 1e-3);
  // Ill-conditioned: the label is in a column of scale 1e-3 next to a noise column of scale
  // 1e3. Twenty epochs of Adam (steps ~1e-3 per weight) cannot use the tiny column; on
  // standardised features they separate the classes.
  Eigen::MatrixXd xi(60, 2);
  std::vector<int> yi(60);
  for (int i = 0; i < 60; ++i) {
    yi[static_cast<std::size_t>(i)] = i % 2;
    xi(i, 0) = 1e-3 * ((i % 2 ? 1.0 : -1.0) + 0.3 * std::sin(0.9 * i));
    xi(i, 1) = 1e3 * std::sin(2.1 * i);
  }
  int ok_plain = 0, ok_std = 0;
  head_loss(HeadTrainer({.epochs = 20}).train(zero_head(2, 2), xi, yi, {}, {}).head, xi, yi,
            nullptr, &ok_plain);
  head_loss(
      HeadTrainer({.epochs = 20, .standardise = true}).train(zero_head(2, 2), xi, yi, {}, {}).head,
      xi, yi, nullptr, &ok_std);
  MESSAGE("ill-conditioned: plain " << ok_plain << "/60, standardised " << ok_std << "/60");
  CHECK(ok_std == 60);
  CHECK(ok_plain <= 45);
  // A constant column (sd 0) keeps scale 1 and does not produce NaN.
  Eigen::MatrixXd xc = x;
  xc.col(2).setConstant(4.0);
  const auto rc = std_trainer.train(zero_head(3, 3), xc, y, Eigen::MatrixXd(), {});
  CHECK(rc.head.weight.allFinite());
  CHECK(rc.head.bias.allFinite());
}

TEST_CASE("HeadTrainer anchor: L2 toward the initial head") {
  Eigen::MatrixXd x;
  std::vector<int> y;
  LinearHead h;
  fixed_problem(x, y, h);
  // From a zero head the anchor is weight decay (checked against torch.optim.Adam above).
  const auto wd = HeadTrainer({.epochs = 30, .batch_size = 3, .weight_decay = 0.7})
                      .train(zero_head(4, 3), x, y, Eigen::MatrixXd(), {});
  const auto an = HeadTrainer({.epochs = 30, .batch_size = 3, .anchor = 0.7})
                      .train(zero_head(4, 3), x, y, Eigen::MatrixXd(), {});
  CHECK((wd.head.weight - an.head.weight).cwiseAbs().maxCoeff() == 0.0);
  CHECK((wd.head.bias - an.head.bias).cwiseAbs().maxCoeff() == 0.0);
  // From a non-zero head it pulls toward that head: the stronger, the closer.
  auto distance = [&](double anchor) {
    const auto r =
        HeadTrainer({.epochs = 200, .batch_size = 8, .learning_rate = 1e-2, .anchor = anchor})
            .train(h, x, y, Eigen::MatrixXd(), {});
    return std::sqrt((r.head.weight - h.weight).squaredNorm() +
                     (r.head.bias - h.bias).squaredNorm());
  };
  const double d0 = distance(0), d1 = distance(0.1), d2 = distance(10);
  MESSAGE("distance to the initial head: anchor 0 " << d0 << ", 0.1 " << d1 << ", 10 " << d2);
  CHECK(d1 < 0.8 * d0);
  CHECK(d2 < 0.2 * d1);
  CHECK_THROWS_WITH_AS(HeadTrainer({.anchor = -1}), doctest::Contains("anchor must be"),
                       InvalidArgument);
  CHECK_THROWS_AS(HeadTrainer({.anchor = std::nan("")}), InvalidArgument);
}

TEST_CASE("balanced_order and class-balanced batches") {
  const std::vector<int> labels = {0, 0, 2, 0, 1, 0, 2, 0}; // 5 x class 0, 1 x 1, 2 x 2, no 3
  std::mt19937_64 rng(4);
  const auto order = detail::balanced_order(labels, 4, rng);
  REQUIRE(order.size() == 15u); // 3 present classes x 5
  std::vector<int> seen(labels.size(), 0);
  for (std::size_t k = 0; k < order.size(); ++k) {
    CHECK(labels[static_cast<std::size_t>(order[k])] == static_cast<int>(k % 3));
    ++seen[static_cast<std::size_t>(order[k])];
  }
  CHECK(seen == std::vector<int>{1, 1, 2, 1, 5, 1, 3, 1}); // class 2: 5 visits over 2 rows
  CHECK_THROWS_AS(detail::balanced_order(std::vector<int>{0, 4}, 4, rng), InvalidArgument);
  // Imbalanced, overlapping 1-D classes: 50 frames of class 0 on [-1, 0.4], 5 of class 1 on
  // [-0.4, 1]. The plain head sets its threshold near class 1's side; balanced batches move it
  // to the middle, so more of class 1's frames are recognised.
  Eigen::MatrixXd x(55, 1);
  std::vector<int> y(55);
  for (int i = 0; i < 50; ++i) x(i, 0) = -1 + 1.4 * i / 49.0, y[static_cast<std::size_t>(i)] = 0;
  for (int i = 0; i < 5; ++i)
    x(50 + i, 0) = -0.4 + 1.4 * i / 4.0, y[50 + static_cast<std::size_t>(i)] = 1;
  auto threshold = [&](bool balanced) {
    const auto r = HeadTrainer({.epochs = 300, .learning_rate = 0.02, .balanced_batches = balanced})
                       .train(zero_head(2, 1), x, y, Eigen::MatrixXd(), {});
    // logit1 - logit0 = a x + c crosses 0 at -c / a
    const double a = r.head.weight(1, 0) - r.head.weight(0, 0);
    const double c = r.head.bias(1) - r.head.bias(0);
    REQUIRE(a > 0);
    return -c / a;
  };
  const double plain = threshold(false), balanced = threshold(true);
  MESSAGE("decision threshold: plain " << plain << ", balanced " << balanced);
  CHECK(plain > 0.5);
  CHECK(std::abs(balanced) < 0.15);
}

TEST_CASE("FrameAugmenter: identity at zero, exact mirror, deterministic, bad input rejected") {
  cv::Mat img(30, 40, CV_8UC3);
  for (int r = 0; r < img.rows; ++r)
    for (int c = 0; c < img.cols; ++c)
      img.at<cv::Vec3b>(r, c) = cv::Vec3b(static_cast<uchar>(r * 8), static_cast<uchar>(c * 6),
                                          static_cast<uchar>((r * c) % 256));
  const FrameAugmenter::Config none{0, 0, 0, 0, 0, 0, 0, 0};
  cv::Mat out;
  FrameAugmenter(none, 1).run(img, out);
  REQUIRE(out.type() == CV_8UC3);
  CHECK(cv::norm(out, img, cv::NORM_INF) == 0);
  FrameAugmenter::Config flip = none;
  flip.flip_probability = 1;
  cv::Mat mirrored;
  cv::flip(img, mirrored, 1);
  FrameAugmenter(flip, 1).run(img, out);
  CHECK(cv::norm(out, mirrored, cv::NORM_INF) == 0);
  // A shift moves a bright dot by at most shift x size, and moves it.
  FrameAugmenter::Config shift = none;
  shift.shift = 0.1;
  cv::Mat dot(30, 40, CV_8UC3, cv::Scalar::all(0));
  dot.at<cv::Vec3b>(15, 20) = cv::Vec3b(255, 255, 255);
  FrameAugmenter sa(shift, 7);
  bool moved = false;
  for (int i = 0; i < 5; ++i) {
    sa.run(dot, out);
    cv::Mat gray;
    cv::cvtColor(out, gray, cv::COLOR_BGR2GRAY);
    cv::Point at;
    cv::minMaxLoc(gray, nullptr, nullptr, nullptr, &at);
    CHECK(std::abs(at.x - 20) <= 5);
    CHECK(std::abs(at.y - 15) <= 4);
    moved = moved || at != cv::Point(20, 15);
  }
  CHECK(moved);
  // Default config: the same seed gives the same images, another seed others.
  cv::Mat a1, a2, b1;
  FrameAugmenter fa({}, 3), fb({}, 3), fc({}, 4);
  fa.run(img, a1);
  fb.run(img, a2);
  fc.run(img, b1);
  CHECK(cv::norm(a1, a2, cv::NORM_INF) == 0);
  CHECK(cv::norm(a1, b1, cv::NORM_INF) > 0);
  CHECK(a1.size() == img.size());
  CHECK_THROWS_AS(FrameAugmenter().run(cv::Mat(), out), InvalidArgument);
  CHECK_THROWS_AS(FrameAugmenter().run(cv::Mat(4, 4, CV_8UC1), out), InvalidArgument);
  FrameAugmenter::Config bad;
  bad.shift = 0.6;
  CHECK_THROWS_WITH_AS(FrameAugmenter(bad, 0), doctest::Contains("shift"), InvalidArgument);
  bad = {};
  bad.flip_probability = 1.5;
  CHECK_THROWS_AS(FrameAugmenter(bad, 0), InvalidArgument);
  bad = {};
  bad.noise = std::nan("");
  CHECK_THROWS_AS(FrameAugmenter(bad, 0), InvalidArgument);
}

TEST_CASE("FeatureExtractor + the model's own head reproduce the DenseNet's logits") {
  const auto model = ModelFile::load(tiny);
  FeatureExtractor fx(model);
  DenseNet net(model);
  const LinearHead head = LinearHead::from_model(model);
  REQUIRE(fx.dim() == model.architecture.final_features());
  Tensor input(2, 3, 40, 48);
  for (std::size_t i = 0; i < input.size(); ++i)
    input.data()[i] = static_cast<float>(std::sin(0.37 * double(i)));
  const auto f = fx.extract(input);
  REQUIRE(f.size() == 2u * static_cast<std::size_t>(fx.dim()));
  Eigen::MatrixXd feats(2, fx.dim());
  for (int i = 0; i < 2; ++i)
    for (int c = 0; c < fx.dim(); ++c) feats(i, c) = f[static_cast<std::size_t>(i * fx.dim() + c)];
  const auto logits = net.logits(input);
  for (int i = 0; i < 2; ++i)
    for (int k = 0; k < head.classes(); ++k) {
      const double mine = head.weight.row(k).dot(feats.row(i)) + head.bias(k);
      const double ref = logits[static_cast<std::size_t>(i * head.classes() + k)];
      CHECK(std::abs(mine - ref) <= 1e-5 * std::max(1.0, std::abs(ref)));
    }
}

TEST_CASE("model_with_head: the saved model reloads and reproduces the head's predictions") {
  const auto model = ModelFile::load(tiny);
  FeatureExtractor fx(model);
  Tensor input(3, 3, 40, 48);
  for (std::size_t i = 0; i < input.size(); ++i)
    input.data()[i] = static_cast<float>(std::cos(0.11 * double(i)));
  const auto f = fx.extract(input);
  Eigen::MatrixXd feats(3, fx.dim());
  for (int i = 0; i < 3; ++i)
    for (int c = 0; c < fx.dim(); ++c) feats(i, c) = f[static_cast<std::size_t>(i * fx.dim() + c)];
  const LinearHead head = LinearHead::random(5, fx.dim(), 42);
  std::filesystem::create_directories(SHADOWSENSE_TEST_TMP_DIR);
  const auto out = std::filesystem::path(SHADOWSENSE_TEST_TMP_DIR) / "head_trainer_saved.ssdn";
  save_model_file(model_with_head(model, head, {"a", "b", "c", "d", "e"}), out);
  const auto reloaded = ModelFile::load(out);
  CHECK(reloaded.class_names == std::vector<std::string>{"a", "b", "c", "d", "e"});
  CHECK(reloaded.architecture.num_classes == 5);
  DenseNet net(reloaded);
  const auto logits = net.logits(input);
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 5; ++k) {
      const double mine = head.weight.row(k).dot(feats.row(i)) + head.bias(k);
      const double ref = logits[static_cast<std::size_t>(i * 5 + k)];
      CHECK(std::abs(mine - ref) <= 1e-5 * std::max(1.0, std::abs(ref)));
    }
  CHECK_THROWS_AS(model_with_head(model, head, {"only", "four", "names", "here"}), InvalidArgument);
  CHECK_THROWS_AS(
      model_with_head(model, LinearHead::random(5, fx.dim() + 1, 1), {"a", "b", "c", "d", "e"}),
      InvalidArgument);
}

TEST_CASE("LightingNormaliser equals tools/train.py's normalise_lighting (golden from PyTorch)") {
  const unsigned char px[] = {0,  70,  140, 11, 81,  151, 22, 92,  162, 33,  103, 173,
                              37, 107, 177, 48, 118, 188, 59, 129, 199, 70,  140, 210,
                              74, 144, 214, 85, 155, 225, 96, 166, 236, 107, 177, 247};
  const float want[] = {
      0.f,          0.19838056f,  0.253229946f, 0.0719626099f, 0.229554638f, 0.273126602f,
      0.14392522f,  0.260728717f, 0.293023229f, 0.21588783f,   0.29190281f,  0.312919885f,
      0.242056057f, 0.303238839f, 0.320155025f, 0.314018667f,  0.334412932f, 0.340051651f,
      0.385981262f, 0.365587026f, 0.359948277f, 0.457943887f,  0.396761119f, 0.379844934f,
      0.484112114f, 0.408097148f, 0.387080073f, 0.556074739f,  0.439271212f, 0.4069767f,
      0.628037333f, 0.470445305f, 0.426873356f, 0.699999928f,  0.501619399f, 0.446769983f};
  cv::Mat img(3, 4, CV_8UC3);
  std::memcpy(img.data, px, sizeof px);
  cv::Mat out;
  LightingNormaliser().run(img, out);
  REQUIRE(out.type() == CV_32FC3);
  for (int i = 0; i < 36; ++i) CHECK(out.ptr<float>()[i] == doctest::Approx(want[i]).epsilon(1e-6));
  // Brightness and colour of the light are removed: a dimmer, tinted copy normalises the same.
  cv::Mat dim = img.clone(), out2;
  dim.forEach<cv::Vec3b>(
      [](cv::Vec3b& p, const int*) { p = cv::Vec3b(p[0] / 2, p[1] / 2, p[2] / 2); });
  LightingNormaliser().run(dim, out2);
  CHECK(cv::norm(out, out2, cv::NORM_INF) < 0.02);
  CHECK_THROWS_AS(LightingNormaliser().run(cv::Mat(), out), InvalidArgument);
  CHECK_THROWS_AS(LightingNormaliser().run(cv::Mat(2, 2, CV_8UC1), out), InvalidArgument);
  CHECK_THROWS_AS(LightingNormaliser({.target = 0}), InvalidArgument);
}

TEST_CASE("Head training on generated gesture frames of a new user (shipped backbone)") {
  // The shipped compact backbone (trained on users 100-111) is frozen; a new head is trained on
  // user 0's frames and scored on user 1's: unseen people, all three lighting presets.
  const auto model =
      ModelFile::load(std::filesystem::path(SHADOWSENSE_SOURCE_DIR) / "models" / "default.ssm");
  FeatureExtractor fx(model);
  FrameEncoder enc(model.preprocess, true);
  sim::Renderer renderer(sim::Rig::robot());
  sim::Frame frame;
  Tensor t;
  auto features = [&](int user_id, Eigen::MatrixXd& x, std::vector<int>& y) {
    sim::Rng rng(sim::derive_seed(77, static_cast<std::uint64_t>(user_id)));
    const sim::User user = sim::User::random(user_id, rng);
    std::vector<Eigen::VectorXd> rows;
    for (double level : {1.0, 0.5, 0.0}) {
      sim::GestureSession session(sim::derive_seed(78, static_cast<std::uint64_t>(user_id * 10) +
                                                           static_cast<std::uint64_t>(level * 2)),
                                  user, level, {.frames_per_gesture = 4});
      for (int f = 0; f < session.size(); ++f) {
        sim::GestureFrameInfo info;
        session.render(renderer, f, frame, &info);
        enc.run(frame.image, false, t);
        const auto v = fx.extract(t);
        Eigen::VectorXd r(fx.dim());
        for (int c = 0; c < fx.dim(); ++c) r(c) = v[static_cast<std::size_t>(c)];
        rows.push_back(r);
        const auto it = std::find(model.class_names.begin(), model.class_names.end(),
                                  std::string(sim::to_string(info.gesture)));
        REQUIRE(it != model.class_names.end());
        y.push_back(static_cast<int>(it - model.class_names.begin()));
      }
    }
    x.resize(static_cast<Eigen::Index>(rows.size()), fx.dim());
    for (std::size_t i = 0; i < rows.size(); ++i) x.row(static_cast<Eigen::Index>(i)) = rows[i];
  };
  Eigen::MatrixXd xa, xa2, xb;
  std::vector<int> ya, ya2, yb;
  features(0, xa, ya);
  features(2, xa2, ya2);
  features(1, xb, yb);
  xa.conservativeResize(xa.rows() + xa2.rows(), Eigen::NoChange);
  xa.bottomRows(xa2.rows()) = xa2;
  ya.insert(ya.end(), ya2.begin(), ya2.end());
  const auto r =
      HeadTrainer().train(LinearHead::random(6, fx.dim(), 3), xa, ya, Eigen::MatrixXd(), {});
  int correct = 0;
  const double loss = head_loss(r.head, xb, yb, nullptr, &correct);
  const double acc = double(correct) / double(yb.size());
  MESSAGE("new-user accuracy " << acc << ", loss " << loss);
  CHECK(acc >= 0.9);
  // Training improved on the initial head.
  CHECK(r.epochs.back().train_loss < r.epochs.front().train_loss);
}
