// The backend concept with a user-defined backend, the log-sum-exp softmax on extreme logits,
// and the DenseNet reference classifier end to end on images.
#include <shadowsense/classify/classifier.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <numeric>

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

static_assert(ClassifierBackend<MeanBrightnessBackend>);
static_assert(ClassifierBackend<BrokenBackend>);
static_assert(!ClassifierBackend<NoLogits>);
static_assert(!ClassifierBackend<int>);

TEST_CASE("softmax through log-sum-exp: logits of +-1e4 and exact small cases") {
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
