// The DenseNet forward pass against torchvision: a committed compact fixture (always), its
// extreme-BatchNorm twin, and DenseNet-121/-161 with random weights generated at test time by
// tools/densenet_to_model.py when Debian's python3-torch is installed.
#include <shadowsense/backends/densenet/densenet.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <string>

using namespace shadowsense;

namespace {

std::size_t argmax(std::span<const float> v) {
  return static_cast<std::size_t>(std::max_element(v.begin(), v.end()) - v.begin());
}

// Compares logits against the model's embedded torchvision logits: |diff| <= 1e-4 *
// max(1, |logit|) for every value and the same argmax per image. Returns the max abs diff.
double check_against_torchvision(DenseNet& net, const ModelSelfTest& st) {
  const auto got = net.logits(st.input);
  REQUIRE(got.size() == st.logits.size());
  double max_diff = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    const double ref = st.logits[i], diff = std::abs(double(got[i]) - ref);
    max_diff = std::max(max_diff, diff);
    CAPTURE(i);
    CHECK(diff <= 1e-4 * std::max(1.0, std::abs(ref)));
  }
  const auto classes = static_cast<std::size_t>(net.num_classes());
  for (int i = 0; i < st.input.n(); ++i) {
    const auto off = static_cast<std::size_t>(i) * classes;
    CHECK(argmax(got.subspan(off, classes)) ==
          argmax(std::span<const float>(st.logits).subspan(off, classes)));
  }
  return max_diff;
}

// Every kernel this CPU runs, the reference (the oracle) included.
std::vector<GemmKernelKind> available_kernels() {
  return detail::available_kernels();
}

bool torch_available() {
  static const bool ok =
      std::system("/usr/bin/python3 -c 'import torch, torchvision' > /dev/null 2>&1") == 0;
  return ok;
}

// Generates a random-weight torchvision DenseNet with an embedded self-test at the paper's
// 3x150x220 input; returns the path (empty when torch is missing).
std::filesystem::path generate(const std::string& arch) {
  if (!torch_available()) return {};
  std::filesystem::create_directories(SHADOWSENSE_TEST_TMP_DIR);
  const auto path = std::filesystem::path(SHADOWSENSE_TEST_TMP_DIR) / (arch + "_random.ssdn");
  const std::string cmd = "/usr/bin/python3 " SHADOWSENSE_SOURCE_DIR
                          "/tools/densenet_to_model.py --random-init --arch " +
                          arch + " --num-classes 5 --self-test 1 --seed 3 -o " + path.string() +
                          " > /dev/null";
  REQUIRE(std::system(cmd.c_str()) == 0);
  return path;
}

} // namespace

TEST_CASE("compact DenseNet fixture: logits equal torchvision's for every kernel and 1-2 threads") {
  const auto m = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  REQUIRE(m.self_test.has_value());
  for (auto kernel : available_kernels())
    for (int threads : {1, 2, 3}) {
      // one 3x3 method per thread count: F(2x2), direct, F(4x4)
      const auto conv = threads == 1   ? DenseNet::Conv3x3::winograd
                        : threads == 2 ? DenseNet::Conv3x3::direct
                                       : DenseNet::Conv3x3::winograd4x4;
      DenseNet net(m, {.threads = threads, .kernel = kernel, .conv3x3 = conv});
      const std::string kernel_name = net.kernel_name();
      CAPTURE(kernel_name);
      CAPTURE(threads);
      const double diff = check_against_torchvision(net, *m.self_test);
      MESSAGE("tiny fixture, ", kernel_name, ", ", threads, " thread(s): max abs diff ", diff);
    }
}

TEST_CASE("BatchNorm running_var of 0, 1e-9 and x1e6 fold without losing accuracy") {
  const auto m = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny_extreme_bn.ssdn");
  REQUIRE(m.self_test.has_value());
  CHECK(m.tensor("features.norm5.running_var").values[0] == 0.0f);
  DenseNet net(m);
  check_against_torchvision(net, *m.self_test);
}

TEST_CASE("buffers are reused across input sizes without changing results") {
  const auto m = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  DenseNet net(m, {.run_self_test = false});
  Tensor small(1, 3, 33, 40);
  for (std::size_t i = 0; i < small.size(); ++i) small.data()[i] = std::sin(0.37f * i);
  const std::vector<float> first(net.logits(small).begin(), net.logits(small).end());
  check_against_torchvision(net, *m.self_test); // a different size in between
  const auto again = net.logits(small);
  DenseNet fresh(m, {.run_self_test = false});
  const auto ref = fresh.logits(small);
  for (std::size_t i = 0; i < first.size(); ++i) {
    CHECK(again[i] == first[i]);
    CHECK(ref[i] == first[i]);
  }
}

TEST_CASE("bad inputs: NaN/Inf pixels, wrong channels, too small, denormals") {
  const auto m = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  DenseNet net(m);
  Tensor t(1, 3, 45, 61);
  t(0, 1, 10, 10) = std::numeric_limits<float>::quiet_NaN();
  CHECK_THROWS_WITH_AS(net.logits(t), doctest::Contains("NaN or Inf"), InvalidArgument);
  t(0, 1, 10, 10) = std::numeric_limits<float>::infinity();
  CHECK_THROWS_WITH_AS(net.logits(t), doctest::Contains("NaN or Inf"), InvalidArgument);
  CHECK_THROWS_WITH_AS(net.logits(Tensor(1, 1, 45, 61)), doctest::Contains("expected n x 3"),
                       InvalidArgument);
  CHECK_THROWS_WITH_AS(net.logits(Tensor()), doctest::Contains("empty"), InvalidArgument);
  CHECK_THROWS_WITH_AS(net.logits(Tensor(1, 3, 8, 61)), doctest::Contains("too small"),
                       InvalidArgument);
  // The smallest accepted size runs (2 transitions: block 1 needs >= 4 pixels per side).
  CHECK(net.accepts(13, 13));
  CHECK_FALSE(net.accepts(12, 13));
  CHECK(net.logits(Tensor(1, 3, 13, 13)).size() == 7);

  // Denormal inputs behave like zeros (to float rounding) and stay finite.
  Tensor zeros(1, 3, 45, 61), denormal(1, 3, 45, 61);
  for (float& v : denormal.values()) v = std::numeric_limits<float>::denorm_min() * 7;
  const std::vector<float> z(net.logits(zeros).begin(), net.logits(zeros).end());
  const auto d = net.logits(denormal);
  for (std::size_t i = 0; i < z.size(); ++i) {
    CHECK(std::isfinite(d[i]));
    CHECK(std::abs(d[i] - z[i]) <= 1e-6f);
  }
}

TEST_CASE("NaN or Inf produced by extreme weights is reported with the image index") {
  auto m = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  // Finite weights and a valid file, but activations of ~1e20 * 1e20 overflow float.
  for (auto& t : m.tensors)
    if (t.name == "features.conv0.weight" ||
        t.name == "features.denseblock1.denselayer1.conv1.weight")
      for (float& v : t.values) v *= 1e20f;
  Tensor x(2, 3, 45, 61); // image 0 all zeros: conv0 sees only its bias and stays finite
  for (int y = 0; y < 45; ++y)
    for (int c = 0; c < 3; ++c)
      for (int i = 0; i < 61; ++i) x(1, c, y, i) = std::sin(0.1f * float(y * 61 + i + c));
  for (auto kernel : available_kernels()) {
    DenseNet net(m, {.kernel = kernel, .run_self_test = false});
    CAPTURE(net.kernel_name());
    CHECK_THROWS_WITH_AS(net.logits(x), doctest::Contains("of image 1 is"), Error);
    CHECK_THROWS_WITH_AS(net.features(x), doctest::Contains("expected a finite number"), Error);
    Tensor first(1, 3, 45, 61); // image 0 alone is fine
    const auto ok = net.logits(first);
    for (float v : ok) CHECK(std::isfinite(v));
  }
}

TEST_CASE("a broken conversion is caught by the embedded self-test at load time") {
  auto m = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  m.self_test->logits[3] += 0.01f;
  CHECK_THROWS_WITH_AS(DenseNet(m, {}), doctest::Contains("model self-test failed: logit 3"),
                       ModelFileError);
  CHECK_NOTHROW(DenseNet(m, {.run_self_test = false}));
  CHECK_THROWS_WITH_AS(DenseNet(m, {.threads = 0}), doctest::Contains("expected 1..256"),
                       InvalidArgument);
}

TEST_CASE("DenseNet-121 and DenseNet-161, random weights, 3x150x220: equal to torchvision") {
  if (!torch_available()) {
    MESSAGE("SKIPPED: /usr/bin/python3 cannot import torch and torchvision (install "
            "python3-torch python3-torchvision to run the DenseNet-121/-161 comparison)");
    return;
  }
  for (const std::string arch : {"densenet121", "densenet161"}) {
    CAPTURE(arch);
    const auto path = generate(arch);
    const auto m = ModelFile::load(path);
    REQUIRE(m.self_test.has_value());
    for (auto conv : {DenseNet::Conv3x3::automatic, DenseNet::Conv3x3::direct,
                      DenseNet::Conv3x3::winograd, DenseNet::Conv3x3::winograd4x4}) {
      const int method = static_cast<int>(conv);
      CAPTURE(method);
      DenseNet net(m, {.threads = 2, .conv3x3 = conv, .run_self_test = false});
      const double diff = check_against_torchvision(net, *m.self_test);
      const std::string name = conv == DenseNet::Conv3x3::automatic  ? "automatic"
                               : conv == DenseNet::Conv3x3::direct   ? "direct"
                               : conv == DenseNet::Conv3x3::winograd ? "winograd"
                                                                     : "winograd4x4";
      MESSAGE(arch, " conv3x3 ", name, ": max abs diff of logits vs torchvision ", diff);
      if (conv == DenseNet::Conv3x3::automatic) {
        // A smaller input moves block 1 from F(4x4) to F(2x2) (its transformed weights built
        // then, next to the F(4x4) ones) and block 2 to direct: the logits equal a fresh
        // instance's; back at 3x150x220 they are those of the first pass, bit for bit.
        const std::vector<float> first(net.logits(m.self_test->input).begin(),
                                       net.logits(m.self_test->input).end());
        Tensor small(1, 3, 36, 52);
        for (std::size_t i = 0; i < small.size(); ++i) small.data()[i] = std::sin(0.37f * i);
        const std::vector<float> small_logits(net.logits(small).begin(), net.logits(small).end());
        DenseNet fresh(m, {.threads = 2, .run_self_test = false}); // small input first
        const auto small_fresh = fresh.logits(small);
        CHECK(std::vector<float>(small_fresh.begin(), small_fresh.end()) == small_logits);
        const auto again = net.logits(m.self_test->input);
        CHECK(std::vector<float>(again.begin(), again.end()) == first);
      }
    }
    std::filesystem::remove(path);
  }
}

TEST_CASE("features() are what the classifier sees: logits = W * features + b") {
  const auto m = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  DenseNet net(m);
  CHECK(net.feature_size() == m.architecture.final_features());
  CHECK(net.feature_size() == 36); // ((16 + 2*8) / 2 + 3*8) / 2 + 2*8
  const auto& x = m.self_test->input;
  const std::vector<float> f(net.features(x).begin(), net.features(x).end());
  const std::size_t fs = 36;
  REQUIRE(f.size() == 2 * fs);
  for (float v : f) CHECK(v >= 0.0f); // after ReLU and averaging
  const auto w = net.classifier_weight();
  const auto b = net.classifier_bias();
  for (std::size_t i = 0; i < 2; ++i)
    for (std::size_t o = 0; o < 7; ++o) {
      double acc = b[o];
      for (std::size_t c = 0; c < fs; ++c) acc += double(w[o * fs + c]) * f[i * fs + c];
      CHECK(acc == doctest::Approx(m.self_test->logits[i * 7 + o]).epsilon(1e-5));
    }
}

TEST_CASE("the stages run one at a time give logits() bit for bit, and run again the same") {
  const auto m = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  Tensor x(1, 3, 41, 57);
  for (std::size_t i = 0; i < x.size(); ++i) x.data()[i] = std::sin(0.21f * i) + 0.1f;
  for (auto kernel : available_kernels())
    for (int threads : {1, 2})
      for (auto conv : {DenseNet::Conv3x3::automatic, DenseNet::Conv3x3::direct,
                        DenseNet::Conv3x3::winograd, DenseNet::Conv3x3::winograd4x4}) {
        DenseNet net(m, {.threads = threads, .kernel = kernel, .conv3x3 = conv});
        CAPTURE(net.kernel_name());
        CAPTURE(threads);
        CAPTURE(static_cast<int>(conv));
        const std::vector<float> whole(net.logits(x).begin(), net.logits(x).end());
        const int stages = net.stage_count();
        REQUIRE(stages == 2 * static_cast<int>(m.architecture.block_config.size()) + 1);
        CHECK(net.stage_name(0) == "conv0+pool0");
        CHECK(net.stage_name(1) == "block1");
        CHECK(net.stage_name(2) == "transition1");
        CHECK(net.stage_name(stages - 2) ==
              "block" + std::to_string(m.architecture.block_config.size()));
        CHECK(net.stage_name(stages - 1) == "head");
        // A fresh instance: the staged run sizes its own buffers.
        DenseNet staged(m, {.threads = threads, .kernel = kernel, .conv3x3 = conv});
        staged.begin_stages(x);
        for (int s = 0; s < stages; ++s) staged.run_stage(s);
        auto got = staged.stage_logits();
        REQUIRE(got.size() == whole.size());
        for (std::size_t i = 0; i < whole.size(); ++i) CHECK(got[i] == whole[i]);
        // Every stage repeated (as the roofline bench times them) leaves the same logits.
        for (int s = 0; s < stages; ++s)
          for (int rep = 0; rep < 2; ++rep) staged.run_stage(s);
        got = staged.stage_logits();
        for (std::size_t i = 0; i < whole.size(); ++i) CHECK(got[i] == whole[i]);
        // On the instance logits() ran on: the same again.
        net.begin_stages(x);
        for (int s = 0; s < stages; ++s) net.run_stage(s);
        for (std::size_t i = 0; i < whole.size(); ++i) CHECK(net.stage_logits()[i] == whole[i]);
      }
}

TEST_CASE("staged runs refuse misuse with errors naming it") {
  const auto m = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  DenseNet net(m, {.run_self_test = false});
  Tensor x(1, 3, 41, 57);
  for (float& v : x.values()) v = 0.5f;
  CHECK_THROWS_WITH_AS(net.run_stage(0), doctest::Contains("begin_stages() first"), Error);
  CHECK_THROWS_WITH_AS(net.stage_name(net.stage_count()), doctest::Contains("expected 0.."),
                       InvalidArgument);
  CHECK_THROWS_WITH_AS(net.begin_stages(Tensor(2, 3, 41, 57)),
                       doctest::Contains("expected one image"), InvalidArgument);
  net.begin_stages(x);
  CHECK_THROWS_WITH_AS(net.run_stage(2), doctest::Contains("before stage 0 ran"), Error);
  CHECK_THROWS_WITH_AS(net.run_stage(-1), doctest::Contains("expected 0.."), InvalidArgument);
  net.run_stage(0);
  net.run_stage(1);
  (void)net.logits(x); // ends the staged run
  CHECK_THROWS_WITH_AS(net.run_stage(2), doctest::Contains("begin_stages() first"), Error);
}

TEST_CASE("Conv1x1: pixel rows and channel rows give the same logits bit for bit, at 1-3 threads") {
  // On the AVX-512 kernel the two layouts run different kernels; elsewhere the setting is
  // ignored and this compares a layout with itself.
  const auto model = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  for (const auto& [h, w] : {std::pair{72, 104}, {36, 52}, {150, 220}}) {
    CAPTURE(h);
    CAPTURE(w);
    Tensor x(1, 3, h, w);
    for (std::size_t i = 0; i < x.size(); ++i) x.data()[i] = std::sin(0.013f * float(i));
    DenseNet ref(model, {.conv1x1 = DenseNet::Conv1x1::channel_rows, .run_self_test = false});
    REQUIRE(ref.accepts(h, w));
    const std::vector<float> want(ref.logits(x).begin(), ref.logits(x).end());
    for (auto mode : {DenseNet::Conv1x1::pixel_rows, DenseNet::Conv1x1::automatic})
      for (int threads : {1, 2, 3}) {
        const int m = static_cast<int>(mode);
        CAPTURE(m);
        CAPTURE(threads);
        DenseNet net(model, {.threads = threads, .conv1x1 = mode, .run_self_test = false});
        const auto got = net.logits(x);
        CHECK(std::vector<float>(got.begin(), got.end()) == want);
      }
  }
}
