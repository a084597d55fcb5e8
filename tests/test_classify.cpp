// The backend concept with a user-defined backend, the log-sum-exp softmax on extreme logits,
// the one-instance-per-thread check, and the DenseNet reference classifier end to end on
// images (the whole frame encoding taken from the model file).
#include <shadowsense/classify/classifier.hpp>
// That classifier.hpp alone does not declare the DenseNet backend is checked by
// tests/firmware/classifier_alone.cpp (include_closure).
#include <shadowsense/backends/densenet/classifier.hpp>
#include <shadowsense/classify/lighting_normalise.hpp>

#include <doctest/doctest.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <numeric>
#include <thread>

using namespace shadowsense;

namespace {

// What a user writes around their own runtime: returns logits by value.
struct MeanBrightnessBackend {
  std::vector<std::string> names{"dark", "bright"};
  int calls = 0;
  const std::vector<std::string>& class_names() const { return names; }
  std::vector<float> logits(const Tensor& t) {
    ++calls;
    std::vector<float> out;
    for (int i = 0; i < t.n(); ++i) {
      const auto img = t.image(i);
      const double mean = std::accumulate(img.begin(), img.end(), 0.0) / double(img.size());
      out.push_back(static_cast<float>(-mean));
      out.push_back(static_cast<float>(mean));
    }
    return out;
  }
};

struct NoLogits {
  std::vector<std::string> class_names() const { return {}; }
};

// A backend returning a span into its own buffer (like DenseNet).
struct BrokenBackend {
  std::vector<std::string> names{"a", "b", "c"};
  std::vector<float> values;
  std::span<const std::string> class_names() const { return names; }
  std::span<const float> logits(const Tensor&) { return values; }
};

} // namespace

static_assert(ClassifierBackend<ClassifierBackendArchetype>);
static_assert(ClassifierBackend<MeanBrightnessBackend>);
static_assert(ClassifierBackend<BrokenBackend>);
static_assert(!ClassifierBackend<NoLogits>);
static_assert(!ClassifierBackend<int>);

TEST_CASE("softmax: logits of +-1e4, tied logits up to 3e38, exact small cases") {
  std::vector<float> p(3);
  softmax(std::vector<float>{1e4f, -1e4f, 0.0f}, p);
  CHECK(p[0] == 1.0f);
  CHECK(p[1] == 0.0f);
  CHECK(p[2] == 0.0f);
  softmax(std::vector<float>{1e4f, 1e4f, -1e4f}, p);
  CHECK(p[0] == 0.5f);
  CHECK(p[1] == 0.5f);
  CHECK(p[2] == 0.0f);
  // Near -1e4 floats are 0.001 apart: the expected values use the logits actually stored.
  const float l0 = -1e4f, l1 = -1e4f + std::log(3.0f);
  softmax(std::vector<float>{l0, l1, l0}, p);
  const double r = std::exp(double(l1) - double(l0));
  CHECK(p[0] == doctest::Approx(1.0 / (2.0 + r)).epsilon(1e-6));
  CHECK(p[1] == doctest::Approx(r / (2.0 + r)).epsilon(1e-6));
  CHECK(p[1] == doctest::Approx(0.6).epsilon(1e-3));
  // Tied logits far from zero: mx + log(sum) rounds the log away there (1e16: each got 1.0).
  for (const float big : {1e15f, 1e16f, 3e38f, -3e38f}) {
    std::vector<float> q(2);
    softmax(std::vector<float>{big, big}, q);
    CHECK(q[0] == 0.5f);
    CHECK(q[1] == 0.5f);
  }
  std::vector<float> six(6);
  softmax(std::vector<float>(6, 1e30f), six);
  for (const float v : six) CHECK(v == doctest::Approx(1.0 / 6.0).epsilon(1e-6));
  std::vector<float> one(1);
  softmax(std::vector<float>{-3.0e38f}, one);
  CHECK(one[0] == 1.0f);
  CHECK_THROWS_WITH_AS(softmax(std::vector<float>{0.0f, std::nanf("")}, std::span(p).first(2)),
                       doctest::Contains("NaN or Inf"), InvalidArgument);
  CHECK_THROWS_AS(softmax(std::vector<float>{}, std::span<float>()), InvalidArgument);
}

TEST_CASE("a user-defined backend plugs into Classifier") {
  Classifier<MeanBrightnessBackend> clf(MeanBrightnessBackend{});
  cv::Mat dark(300, 400, CV_8UC3, cv::Scalar(5, 5, 5)),
      bright(300, 400, CV_8UC3, cv::Scalar(250, 240, 230));
  // Contrast 3 on a flat image keeps it flat; normalised values are negative for dark pixels.
  const auto a = clf.classify(dark);
  CHECK(a.label == "dark");
  CHECK(a.index == 0);
  const auto b = clf.classify(bright);
  CHECK(b.label == "bright");
  CHECK(b.probabilities.size() == 2);
  CHECK(b.probabilities[0] + b.probabilities[1] == doctest::Approx(1.0));
  CHECK(clf.backend().calls == 2);
  Tensor batch(3, 3, 8, 8);
  for (int c = 0; c < 3; ++c) batch(1, c, 2, 2) = 50.0f;
  const auto r = clf.classify_batch(batch);
  REQUIRE(r.size() == 3);
  CHECK(r[1].label == "bright");
  CHECK(r[0].probabilities[0] == doctest::Approx(0.5));
  CHECK_THROWS_WITH_AS(clf.classify(batch), doctest::Contains("use classify_batch"),
                       InvalidArgument);
}

TEST_CASE("a backend returning the wrong count or NaN logits is reported") {
  Classifier<BrokenBackend> clf(BrokenBackend{});
  clf.backend().values = {1.0f, 2.0f};
  CHECK_THROWS_WITH_AS(clf.classify(Tensor(1, 3, 4, 4)),
                       doctest::Contains("expected batch x classes = 3"), Error);
  clf.backend().values = {1.0f, std::numeric_limits<float>::infinity(), 0.0f};
  CHECK_THROWS_WITH_AS(clf.classify(Tensor(1, 3, 4, 4)), doctest::Contains("NaN or Inf logits"),
                       Error);
  clf.backend().values = {1.0f, 3.0f, 0.0f};
  CHECK(clf.classify(Tensor(1, 3, 4, 4)).label == "b");
  BrokenBackend empty;
  empty.names.clear();
  CHECK_THROWS_WITH_AS(Classifier<BrokenBackend>(empty, {}), doctest::Contains("no classes"),
                       InvalidArgument);
}

TEST_CASE("the DenseNet classifier: preprocessing from the model file, softmax of its logits") {
  const auto model = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  auto clf = make_densenet_classifier(model, {.threads = 2});
  CHECK(clf.class_names().size() == 7);
  cv::Mat frame(60, 80, CV_8UC3);
  cv::randu(frame, cv::Scalar::all(0), cv::Scalar::all(256));
  for (bool dark : {false, true}) {
    const auto r = clf.classify(frame, dark);
    Preprocessor pre({.params = model.preprocess, .input_order = ChannelOrder::bgr});
    DenseNet net(model, {.run_self_test = false});
    const auto logits = net.logits(pre(frame, dark));
    std::vector<float> p(7);
    softmax(logits, p);
    for (int k = 0; k < 7; ++k)
      CHECK(r.probabilities[static_cast<std::size_t>(k)] ==
            doctest::Approx(p[static_cast<std::size_t>(k)]).epsilon(1e-5));
    CHECK(r.label == model.class_names[static_cast<std::size_t>(r.index)]);
  }
  // All-black, all-white and saturated frames give finite probabilities summing to 1.
  cv::Mat sat(60, 80, CV_8UC3, cv::Scalar(0, 0, 255));
  sat(cv::Rect(0, 0, 40, 60)).setTo(cv::Scalar(255, 0, 0));
  for (const cv::Mat& img : {cv::Mat(60, 80, CV_8UC3, cv::Scalar::all(0)),
                             cv::Mat(60, 80, CV_8UC3, cv::Scalar::all(255)), sat})
    for (bool dark : {false, true}) {
      const auto r = clf.classify(img, dark);
      double sum = 0;
      for (float v : r.probabilities) {
        CHECK(std::isfinite(v));
        sum += v;
      }
      CHECK(sum == doctest::Approx(1.0).epsilon(1e-6));
    }
}

namespace {
// Blocks inside logits() until released, so a second thread's call overlaps the first.
struct BlockingBackend {
  std::vector<std::string> names{"x", "y"};
  std::atomic<bool>* entered = nullptr;
  std::atomic<bool>* release = nullptr;
  std::vector<float> out{0.0f, 1.0f};
  std::span<const std::string> class_names() const { return names; }
  std::span<const float> logits(const Tensor&) {
    entered->store(true);
    while (!release->load()) std::this_thread::yield();
    return out;
  }
};
} // namespace

TEST_CASE("one Classifier used from two threads at once throws instead of mixing results") {
  std::atomic<bool> entered{false}, release{false};
  Classifier<BlockingBackend> clf(BlockingBackend{{"x", "y"}, &entered, &release});
  const Tensor input(1, 3, 4, 4);
  std::string first_label;
  std::thread first([&] { first_label = clf.classify(input).label; });
  while (!entered.load()) std::this_thread::yield();
  // The first call is inside the backend: a concurrent call is refused, naming the contract.
  CHECK_THROWS_WITH_AS(clf.classify(input), doctest::Contains("its own instance"),
                       ConcurrentUseError);
  CHECK_THROWS_WITH_AS(clf.classify_batch(input), doctest::Contains("two threads at once"), Error);
  CHECK_THROWS_AS(clf.classify(cv::Mat(8, 8, CV_8UC3, cv::Scalar::all(9))), Error);
  release.store(true);
  first.join();
  CHECK(first_label == "y");
  // Sequential use (from any thread) is fine once the first call has returned.
  CHECK(clf.classify(input).label == "y");
  std::string other;
  std::thread([&] { other = clf.classify(input).label; }).join();
  CHECK(other == "y");
  // A moved-to classifier starts unlocked.
  Classifier<BlockingBackend> moved = std::move(clf);
  CHECK(moved.classify(input).index == 1);
}

TEST_CASE("the Classifier applies the model's lighting normalisation and dark-frame rule") {
  auto model = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  REQUIRE(model.format_version == 1);
  CHECK_FALSE(model.preprocess.lighting_normalise);
  CHECK(model.preprocess.dark_luminance_threshold == 0.0f); // version 1: no frame is dark
  cv::Mat frame(60, 80, CV_8UC3);
  cv::randu(frame, cv::Scalar::all(0), cv::Scalar::all(60)); // luminance about 0.12
  DenseNet net(model, {.run_self_test = false});
  auto probabilities = [&](const Tensor& t) {
    const auto logits = net.logits(t);
    std::vector<float> p(logits.size());
    softmax(logits, p);
    return p;
  };
  Preprocessor pre({.params = model.preprocess, .input_order = ChannelOrder::bgr});
  {
    auto clf = make_densenet_classifier(model);
    CHECK(clf.classify(frame).probabilities == probabilities(pre(frame, false)));
  }
  model.preprocess.dark_luminance_threshold = 0.2f; // the frame is dark by this rule
  {
    auto clf = make_densenet_classifier(model);
    CHECK(clf.encoder().is_dark(frame));
    CHECK(clf.classify(frame).probabilities == probabilities(pre(frame, true)));
    CHECK(clf.classify(frame, false).probabilities == probabilities(pre(frame, false)));
    const cv::Mat bright = frame + cv::Scalar::all(120);
    CHECK_FALSE(clf.encoder().is_dark(bright));
    CHECK(clf.classify(bright).probabilities == probabilities(pre(bright, false)));
  }
  model.preprocess.lighting_normalise = true; // normalised, never brightened
  {
    auto clf = make_densenet_classifier(model);
    cv::Mat normalised;
    LightingNormaliser().run(frame, normalised);
    const auto expected = probabilities(pre(normalised, false));
    CHECK(clf.classify(frame).probabilities == expected);
    CHECK(clf.classify(frame, true).probabilities == expected);
  }
}

TEST_CASE("a float image in 0..255 instead of 0..1 is rejected, not clipped") {
  const auto model = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  auto clf = make_densenet_classifier(model);
  cv::Mat bytes(60, 80, CV_8UC3, cv::Scalar(10, 200, 90)), f;
  bytes.convertTo(f, CV_32FC3); // 0..255 floats: the common mistake
  CHECK_THROWS_WITH_AS(clf.classify(f), doctest::Contains("expected 0..1"), InvalidArgument);
  bytes.convertTo(f, CV_32FC3, 1.0 / 255.0);
  CHECK(clf.classify(f).probabilities == clf.classify(bytes).probabilities);
  f.at<cv::Vec3f>(3, 4)[1] = -0.01f;
  CHECK_THROWS_WITH_AS(clf.classify(f), doctest::Contains("expected 0..1"), InvalidArgument);
}
