// Threading contracts (issue 11): what must be safe (separate instances in separate threads
// give exactly the single-thread results; atomic writes racing on one target), and the owner
// check that turns a shared instance into a clear error. Also built and run under
// ThreadSanitizer in CI (.ci/steps/tsan.sh), so keep it small.
#include <shadowsense/core/atomic_file.hpp>
#include <shadowsense/core/thread_owner.hpp>
#include <shadowsense/eval.hpp>

#include <doctest/doctest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <utility>
#include <vector>

using namespace shadowsense;
namespace fs = std::filesystem;

namespace {

// A stateful type following the "one instance per thread" contract with the owner check.
class Counter {
public:
  // Enters, then calls hold() while still inside (to make an overlap deterministic).
  template <class F>
  int bump(F hold) {
    const auto guard = owner_.enter("Counter");
    hold();
    return ++value_;
  }
  int nested() {
    const auto guard = owner_.enter("Counter");
    return bump([] {});
  }
  bool busy() const { return owner_.owned(); }

private:
  ThreadOwner owner_;
  int value_ = 0;
};

std::vector<cv::Mat> tracking_frames(int n) {
  sim::Renderer renderer(sim::Rig::tracking_box());
  std::vector<cv::Mat> frames;
  for (int i = 0; i < n; ++i)
    frames.push_back(sim::render_random_tracking_frame(
                         renderer, sim::all_track_categories[static_cast<std::size_t>(i % 5)],
                         1000 + static_cast<std::uint64_t>(i))
                         .image.clone());
  return frames;
}

bool same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() &&
         (a.empty() || cv::countNonZero(a != b) == 0);
}

} // namespace

TEST_CASE("the owner check: a second thread inside the same instance gets ConcurrentUseError") {
  Counter c;
  std::atomic<int> stage{0};
  std::thread a([&] {
    c.bump([&] {
      stage = 1;
      while (stage.load() != 2) std::this_thread::yield();
    });
  });
  while (stage.load() != 1) std::this_thread::yield();
  CHECK(c.busy());
  CHECK_THROWS_WITH_AS(c.bump([] {}),
                       "Counter: one instance is used from two threads at once; this type is "
                       "not internally synchronised: give each thread its own instance (or "
                       "serialise the calls)",
                       ConcurrentUseError);
  stage = 2;
  a.join();
  CHECK_FALSE(c.busy());
  // Calls that do not overlap are fine from any thread; nested calls from the owner too.
  CHECK(c.bump([] {}) == 2);
  std::thread b([&] { CHECK(c.nested() == 3); });
  b.join();
  CHECK_FALSE(c.busy());
  // A copy is a new instance with its own owner.
  Counter d = c;
  CHECK_FALSE(d.busy());
}

TEST_CASE("Segmenter: two instances in two threads give the single-thread masks exactly") {
  const std::vector<cv::Mat> frames = tracking_frames(6);
  Segmenter::Config config;
  auto run = [&](std::vector<Segmentation>& out) {
    Segmenter s(config);
    for (const cv::Mat& f : frames) out.push_back(s.segment(f));
  };
  std::vector<Segmentation> one, a, b;
  run(one);
  std::thread ta([&] { run(a); });
  std::thread tb([&] { run(b); });
  ta.join();
  tb.join();
  REQUIRE(a.size() == one.size());
  REQUIRE(b.size() == one.size());
  int shadow_pixels = 0;
  for (std::size_t i = 0; i < one.size(); ++i) {
    CAPTURE(i);
    shadow_pixels += cv::countNonZero(one[i].shadow_mask);
    CHECK(same(a[i].shadow_mask, one[i].shadow_mask));
    CHECK(same(b[i].shadow_mask, one[i].shadow_mask));
    CHECK(same(a[i].contact_mask, one[i].contact_mask));
    CHECK(same(b[i].contact_mask, one[i].contact_mask));
    CHECK(a[i].shadow_box == one[i].shadow_box);
    CHECK(b[i].contact_box == one[i].contact_box);
  }
  CHECK(shadow_pixels > 0); // the frames really hold shadows
}

TEST_CASE("Classifier: two instances in two threads give the single-thread probabilities") {
  const auto model = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  std::vector<cv::Mat> frames;
  cv::RNG rng(7);
  for (int i = 0; i < 6; ++i) {
    cv::Mat f(60, 80, CV_8UC3);
    rng.fill(f, cv::RNG::UNIFORM, 0, 256);
    frames.push_back(f);
  }
  auto run = [&](std::vector<std::vector<float>>& out) {
    auto clf = make_densenet_classifier(model, {.threads = 1});
    for (const cv::Mat& f : frames) out.push_back(clf.classify(f, false).probabilities);
  };
  std::vector<std::vector<float>> one, a, b;
  run(one);
  std::thread ta([&] { run(a); });
  std::thread tb([&] { run(b); });
  ta.join();
  tb.join();
  CHECK(a == one); // bit-identical: same code, same inputs, no shared state
  CHECK(b == one);
}

TEST_CASE("DenseNet worker threads: 2 and 3 threads give the 1-thread logits exactly") {
  // Every output element is computed by one thread in the same order whatever the split, so
  // the logits are bit-identical; under ThreadSanitizer (CI) this also covers the GEMM, Winograd
  // (tile panel, row panel) and pool0/head splits for data races.
  const auto model = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  Tensor x(1, 3, 72, 104);
  for (std::size_t i = 0; i < x.size(); ++i) x.data()[i] = std::sin(0.011f * float(i));
  for (auto conv :
       {DenseNet::Conv3x3::direct, DenseNet::Conv3x3::winograd, DenseNet::Conv3x3::winograd4x4}) {
    const int method = static_cast<int>(conv);
    CAPTURE(method);
    DenseNet one(model, {.threads = 1, .conv3x3 = conv, .run_self_test = false});
    REQUIRE(one.accepts(x.h(), x.w()));
    const auto ref = one.logits(x);
    const std::vector<float> want(ref.begin(), ref.end());
    for (int threads : {2, 3}) {
      CAPTURE(threads);
      DenseNet net(model, {.threads = threads, .conv3x3 = conv, .run_self_test = false});
      for (int pass = 0; pass < 3; ++pass) { // reused buffers and a warm pool
        const auto got = net.logits(x);
        CHECK(std::vector<float>(got.begin(), got.end()) == want);
      }
    }
  }
}

TEST_CASE("atomic writes racing on one target: always one complete version, no temp files") {
  const fs::path dir = fs::path(SHADOWSENSE_TEST_TMP_DIR) / "threads" / "race";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path target = dir / "shared.txt";
  auto content = [](int t) { return std::string(20000 + t, static_cast<char>('a' + t)); };
  std::vector<std::thread> pool;
  for (int t = 0; t < 4; ++t)
    pool.emplace_back([&, t] {
      for (int k = 0; k < 5; ++k) write_file_atomically(target, content(t), Sync::deferred);
    });
  for (auto& th : pool) th.join();
  std::ifstream in(target, std::ios::binary);
  const std::string got{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  bool matches_one = false;
  for (int t = 0; t < 4; ++t) matches_one = matches_one || got == content(t);
  CHECK(matches_one);
  int files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++files;
  CHECK(files == 1);
}

TEST_CASE("ThreadPool: every task of every call runs exactly once, across spins and sleeps") {
  // The workers poll for new work for spin_us, then sleep: calls back to back (caught while
  // polling) and calls after a pause longer than spin_us (a sleeping worker woken) must both
  // run each task once and return only when all are done.
  for (const auto& [threads, spin_us] : {std::pair{2, 300}, std::pair{3, 300}, std::pair{2, 0}}) {
    detail::ThreadPool pool(threads, spin_us);
    std::vector<std::atomic<int>> hits(64);
    for (int call = 0; call < 300; ++call) {
      const int tasks = call % 7 == 0 ? 1 : (call * 13) % 64 + 1;
      for (auto& h : hits) h.store(0);
      auto fn = [&](int t) { hits[static_cast<std::size_t>(t)].fetch_add(1); };
      pool.run(tasks, fn);
      int wrong = 0;
      for (int t = 0; t < 64; ++t)
        wrong += hits[static_cast<std::size_t>(t)].load() != (t < tasks ? 1 : 0);
      REQUIRE_MESSAGE(wrong == 0,
                      "threads " << threads << ", spin_us " << spin_us << ", call " << call);
      if (call % 50 == 49)
        std::this_thread::sleep_for(std::chrono::microseconds(3 * pool.spin_us() + 100));
    }
    int none = 0;
    auto count = [&](int) { ++none; };
    pool.run(0, count);
    CHECK(none == 0);
    CHECK_THROWS_AS(pool.run(detail::ThreadPool::max_tasks + 1, count), InvalidArgument);
  }
  CHECK_THROWS_AS(detail::ThreadPool(2, -1), InvalidArgument);
  CHECK_THROWS_AS(detail::ThreadPool(2, 100001), InvalidArgument);
}

namespace {

// A pixel rule that holds the segmenter inside classify() until released, so that another
// thread's read of the pipeline overlaps an update deterministically.
struct HoldingRule {
  std::atomic<int>* stage = nullptr; // 1: inside classify; 2: released
  void classify(const PixelRuleInput& in, PixelRuleOutput& out) const {
    out.shadow_mask.setTo(0);
    out.contact_mask.setTo(0);
    out.darkness.release();
    out.warmth.release();
    (void)in;
    if (!stage) return;
    *stage = 1;
    while (stage->load() != 2) std::this_thread::yield();
  }
};
static_assert(PixelRule<HoldingRule>);

} // namespace

TEST_CASE("reading a TouchPipeline or Segmenter during another thread's update throws") {
  // Before: segmentation() had no check, so this read was a silent data race (TSan).
  std::atomic<int> stage{0};
  BasicSegmenter<HoldingRule> segmenter(SegmenterConfig{}, HoldingRule{&stage});
  BasicTouchPipeline<HoldingRule> pipeline(uncalibrated, segmenter);
  const cv::Mat frame(40, 40, CV_8UC3, cv::Scalar(120, 130, 140));
  std::thread a([&] { (void)pipeline.update(frame, 1.0); });
  while (stage.load() != 1) std::this_thread::yield();
  CHECK_THROWS_WITH_AS((void)pipeline.segmentation(),
                       doctest::Contains("TouchPipeline: one instance is used from two threads"),
                       ConcurrentUseError);
  CHECK_THROWS_AS((void)pipeline.tracker(), ConcurrentUseError);
  CHECK_THROWS_AS((void)pipeline.camera_health(), ConcurrentUseError);
  stage = 2;
  a.join();
  // After the update, from any thread: fine.
  std::thread b([&] { CHECK(pipeline.segmentation().shadows.empty()); });
  b.join();
}
