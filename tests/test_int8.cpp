// The int8 path: every int8 GEMM kernel this CPU runs (AVX2, NEON) equals the portable
// reference exactly (int32 sums are exact, so equality is the contract), including the
// extreme codes where vpmaddubsw would saturate with 8-bit activations; the int8 forward against
// the plain reference forward with the same quantisation simulated in floating point; the
// model file's int8 section (version 3) and its errors. Needs only the DenseNet
// headers and doctest, so it also runs cross-compiled for aarch64 under qemu-user
// (.ci/steps/50_aarch64.sh).
#include <shadowsense/backends/densenet/densenet.hpp>
#include <shadowsense/backends/densenet/gemm_int8.hpp>
#include <shadowsense/backends/densenet/quantise.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

using namespace shadowsense;

namespace {

struct Operands {
  std::vector<std::int8_t> w;
  std::vector<std::uint8_t> x;
};

// m x kp weights and n x kp activations, the first k of each row set by fill, the rest 0.
template <class FillW, class FillX>
Operands operands(int m, int n, int k, int kp, FillW fw, FillX fx) {
  Operands o;
  o.w.assign(static_cast<std::size_t>(m) * kp, 0);
  o.x.assign(static_cast<std::size_t>(n) * kp, 0);
  for (int i = 0; i < m; ++i)
    for (int q = 0; q < k; ++q) o.w[static_cast<std::size_t>(i) * kp + q] = fw(i, q);
  for (int j = 0; j < n; ++j)
    for (int q = 0; q < k; ++q) o.x[static_cast<std::size_t>(j) * kp + q] = fx(j, q);
  return o;
}

std::vector<std::int32_t> run(detail::Int8GemmFn fn, const Operands& o, int m, int n, int kp,
                              std::size_t ldc) {
  std::vector<std::int32_t> c(static_cast<std::size_t>(m) * ldc, -7); // -7: untouched marker
  fn(o.w.data(), m, o.x.data(), n, kp, c.data(), ldc);
  return c;
}

} // namespace

TEST_CASE("int8 reference GEMM: hand-computed sums") {
  // w = [1 -2 3], [-127 127 0]; x pixels [4 5 6], [127 127 127]
  const int kp = 32;
  std::vector<std::int8_t> w(2 * kp, 0);
  std::vector<std::uint8_t> x(2 * kp, 0);
  w[0] = 1, w[1] = -2, w[2] = 3, w[kp] = -127, w[kp + 1] = 127;
  x[0] = 4, x[1] = 5, x[2] = 6, x[kp] = 127, x[kp + 1] = 127, x[kp + 2] = 127;
  std::vector<std::int32_t> c(4);
  detail::gemm_s8u7_reference(w.data(), 2, x.data(), 2, kp, c.data(), 2);
  CHECK(c[0] == 4 - 10 + 18);
  CHECK(c[1] == 127 * (1 - 2 + 3));
  CHECK(c[2] == -127 * 4 + 127 * 5);
  CHECK(c[3] == 0);
}

TEST_CASE("int8 GEMM kernels equal the reference exactly") {
  const auto kinds = detail::available_int8_kernels();
  REQUIRE(kinds.front() == detail::Int8KernelKind::reference);
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> wd(-127, 127), xd(0, 127);
  // Shapes with every remainder of the 4 x 2 and 4 x 4 blockings, K below, at and above one
  // register.
  const int shapes[][3] = {{1, 1, 1},     {3, 1, 5},    {4, 2, 32},    {5, 3, 33},
                           {7, 5, 64},    {8, 9, 100},  {48, 31, 432}, {12, 17, 9},
                           {2, 64, 1152}, {13, 2, 300}, {4, 1, 31},    {9, 4, 200}};
  for (auto kind : kinds) {
    const auto g = detail::select_int8_gemm(kind);
    CAPTURE(std::string(g.name));
    for (const auto& s : shapes) {
      const int m = s[0], n = s[1], k = s[2], kp = detail::int8_padded_k(k);
      CAPTURE(m);
      CAPTURE(n);
      CAPTURE(k);
      const std::size_t ldc = static_cast<std::size_t>(n) + 3; // a stride wider than n
      const auto random = operands(
          m, n, k, kp, [&](int, int) { return static_cast<std::int8_t>(wd(rng)); },
          [&](int, int) { return static_cast<std::uint8_t>(xd(rng)); });
      CHECK(run(g.fn, random, m, n, kp, ldc) ==
            run(detail::gemm_s8u7_reference, random, m, n, kp, ldc));
      // The extremes: every pair sum at +-2 x 127 x 127, the worst case for int16 pair sums.
      const auto extreme = operands(
          m, n, k, kp, [](int i, int) { return static_cast<std::int8_t>(i % 2 ? -127 : 127); },
          [](int, int) { return static_cast<std::uint8_t>(127); });
      const auto got = run(g.fn, extreme, m, n, kp, ldc);
      for (int i = 0; i < m; ++i)
        for (int j = 0; j < n; ++j)
          REQUIRE(got[static_cast<std::size_t>(i) * ldc + j] == (i % 2 ? -1 : 1) * 127 * 127 * k);
      // Columns n..ldc-1 are not written.
      for (int i = 0; i < m; ++i)
        for (std::size_t j = static_cast<std::size_t>(n); j < ldc; ++j)
          REQUIRE(got[static_cast<std::size_t>(i) * ldc + j] == -7);
    }
  }
}

TEST_CASE("int8 GEMM: the kernel this CPU picks") {
  const auto g = detail::select_int8_gemm(detail::Int8KernelKind::automatic);
#if SHADOWSENSE_X86_KERNELS
  if (detail::cpu_has_int8(detail::Int8KernelKind::vnni))
    CHECK(std::string(g.name) == "int8-vnni");
  else if (__builtin_cpu_supports("avx2"))
    CHECK(std::string(g.name) == "int8-avx2");
  else
    CHECK(std::string(g.name) == "int8-reference");
  if (!detail::cpu_has_int8(detail::Int8KernelKind::vnni))
    CHECK_THROWS_AS(detail::select_int8_gemm(detail::Int8KernelKind::vnni), InvalidArgument);
#endif
#if SHADOWSENSE_NEON_KERNELS
  CHECK(std::string(g.name) == "int8-neon");
#endif
  const bool has_fn = g.fn != nullptr;
  CHECK(has_fn);
  if (!detail::cpu_has_int8(detail::Int8KernelKind::neon))
    CHECK_THROWS_AS(detail::select_int8_gemm(detail::Int8KernelKind::neon), InvalidArgument);
}

namespace {

// Appended in place: GCC 12's -Warray-bounds misreads the inlined operator+ chain on a string
// literal as an overflow for some lengths of the data folder's path (a false positive).
std::string fixture(const char* name) {
  std::string path(SHADOWSENSE_TEST_DATA_DIR);
  path.append("/").append(name);
  return path;
}

// Calibration inputs: normalised-image-like values, deterministic.
Tensor random_images(int n, int h, int w, unsigned seed) {
  Tensor t;
  t.resize(n, 3, h, w);
  std::mt19937 rng(seed);
  std::normal_distribution<float> d(0.0f, 1.0f);
  for (float& v : t.values()) v = d(rng);
  return t;
}

ModelFile quantised_tiny(double percentile = 99.99) {
  ModelFile m = ModelFile::load(fixture("densenet_tiny.ssdn"));
  Int8Calibration cal(m, percentile);
  const Tensor t = random_images(3, 40, 36, 5);
  for (int i = 0; i < t.n(); ++i) cal.add(t.image(i).data(), t.h(), t.w());
  m.int8 = cal.quantise();
  return m;
}

double max_abs_diff(std::span<const float> a, std::span<const float> b) {
  double d = 0;
  for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(double(a[i]) - double(b[i])));
  return d;
}

} // namespace

TEST_CASE("quantise_weights: per-channel symmetric codes, hand-checked") {
  ModelFile m = ModelFile::load(fixture("densenet_tiny.ssdn"));
  const auto convs = m.architecture.expected_int8_convs();
  REQUIRE(convs.size() == 2 * (2 + 3 + 2) + 2); // conv1 + conv2 per layer, 2 transitions
  CHECK(convs.front().name == "features.denseblock1.denselayer1.conv1.weight");
  auto& w = m.tensor(convs.front().name).values;
  const int len = convs.front().shape[1];
  // Row 0: max |w| = 2.54 -> scale 0.02; 1.0 -> 50, -2.54 -> -127, 0.011 -> 1 (0.55 rounds up).
  std::fill(w.begin(), w.begin() + len, 0.0f);
  w[0] = 1.0f, w[1] = -2.54f, w[2] = 0.011f;
  const std::vector<float> scales(convs.size(), 0.5f);
  const auto q = quantise_weights(m, scales);
  CHECK(q[0].weight_scales[0] == doctest::Approx(0.02).epsilon(1e-6));
  CHECK(int(q[0].weights[0]) == 50);
  CHECK(int(q[0].weights[1]) == -127);
  CHECK(int(q[0].weights[2]) == 1);
  CHECK(int(q[0].weights[3]) == 0);
  CHECK(q[0].input_scale == 0.5f);
  CHECK_THROWS_AS(quantise_weights(m, std::vector<float>(3, 1.0f)), InvalidArgument);
}

TEST_CASE("int8 activation codes: rounding and the 127 clamp") {
  CHECK(detail::int8_code(0.0f, 10.0f) == 0);
  CHECK(detail::int8_code(0.049f, 10.0f) == 0);
  CHECK(detail::int8_code(0.051f, 10.0f) == 1);
  CHECK(detail::int8_code(12.7f, 10.0f) == 127);
  CHECK(detail::int8_code(1e30f, 10.0f) == 127);
  CHECK(detail::int8_code(std::numeric_limits<float>::infinity(), 10.0f) == 127);
}

TEST_CASE("int8 forward: every kernel gives the same logits, close to the fake-quantised "
          "reference") {
  const ModelFile m = quantised_tiny();
  const Tensor in = random_images(2, 45, 37, 9); // odd sizes: every remainder of the blocking
  const ReferenceForward ref(m);
  DenseNet ref_net(m, {.precision = DenseNet::Precision::int8,
                       .int8_kernel = detail::Int8KernelKind::reference});
  REQUIRE(ref_net.int8());
  CHECK(std::string(ref_net.int8_kernel_name()) == "int8-reference");
  const auto got = std::vector<float>(ref_net.logits(in).begin(), ref_net.logits(in).end());
  // Exact int32 sums and the same float code after them: the logits are bit-identical for
  // every kernel and thread count.
  for (auto kind : detail::available_int8_kernels())
    for (int threads : {1, 2}) {
      DenseNet net(
          m, {.threads = threads, .precision = DenseNet::Precision::int8, .int8_kernel = kind});
      const auto l = net.logits(in);
      CAPTURE(std::string(net.int8_kernel_name()));
      CAPTURE(threads);
      CHECK(std::equal(l.begin(), l.end(), got.begin(), got.end()));
    }
  // Against the reference forward with the same codes simulated in floating point: the only
  // differences are float rounding before a code (which moves an activation by one step when it
  // lies within rounding of a half step; aarch64 compilers may also fuse multiply-adds) and
  // double vs float sums. Bound: 1e-3 x max(1, |logit|) (measured on x86: 3.5e-8) - while the
  // quantisation error itself (fake-quantised vs float, 0.16 here) is at least 100 x the
  // int8-vs-fake difference, so the bound cannot hide a path that does not quantise.
  const int classes = m.architecture.num_classes;
  double worst_fq = 0, worst_float = 0;
  for (int i = 0; i < in.n(); ++i) {
    const auto fq = ref.logits(in.image(i).data(), in.h(), in.w(), {}, &*m.int8);
    const auto fl = ref.logits(in.image(i).data(), in.h(), in.w());
    const std::span<const float> g(got.data() + i * classes, static_cast<std::size_t>(classes));
    for (int o = 0; o < classes; ++o) {
      const double bound = 1e-3 * std::max(1.0, std::abs(double(fq[static_cast<std::size_t>(o)])));
      CHECK(std::abs(double(g[static_cast<std::size_t>(o)]) - fq[static_cast<std::size_t>(o)]) <=
            bound);
    }
    worst_fq = std::max(worst_fq, max_abs_diff(g, fq));
    worst_float = std::max(worst_float, max_abs_diff(fq, fl));
  }
  MESSAGE("int8 vs fake-quant: " << worst_fq << ", fake-quant vs float: " << worst_float);
  CHECK(worst_float >= 100 * worst_fq);
}

TEST_CASE("int8 forward: the stages run one at a time give logits() bit for bit") {
  const ModelFile m = quantised_tiny();
  const Tensor in = random_images(1, 45, 37, 11);
  for (int threads : {1, 2}) {
    DenseNet net(m, {.threads = threads, .precision = DenseNet::Precision::int8});
    REQUIRE(net.int8());
    const std::vector<float> whole(net.logits(in).begin(), net.logits(in).end());
    DenseNet staged(m, {.threads = threads, .precision = DenseNet::Precision::int8});
    staged.begin_stages(in);
    for (int s = 0; s < staged.stage_count(); ++s) staged.run_stage(s);
    const auto got = staged.stage_logits();
    CAPTURE(threads);
    CHECK(std::equal(got.begin(), got.end(), whole.begin(), whole.end()));
    // Not the float path's logits (the stages must take the int8 path too).
    DenseNet fp(m, {.threads = threads, .precision = DenseNet::Precision::float32});
    const auto f = fp.logits(in);
    CHECK_FALSE(std::equal(f.begin(), f.end(), whole.begin(), whole.end()));
  }
}

TEST_CASE("int8 forward: the float path, the self-test and the precision switch") {
  const ModelFile m = quantised_tiny();
  // automatic = int8 with the section; the self-test (torchvision's float logits) still passes
  // on the float path at construction.
  DenseNet automatic(m);
  CHECK(automatic.int8());
  DenseNet f(m, {.precision = DenseNet::Precision::float32});
  CHECK_FALSE(f.int8());
  CHECK(std::string(f.int8_kernel_name()).empty());
  const ModelFile plain = ModelFile::load(fixture("densenet_tiny.ssdn"));
  CHECK_FALSE(DenseNet(plain).int8());
  CHECK_THROWS_WITH_AS(DenseNet(plain, {.precision = DenseNet::Precision::int8}),
                       doctest::Contains("no int8 section"), InvalidArgument);
  // Float logits with the int8 section present equal those of the float-only file.
  const Tensor in = random_images(1, 40, 40, 3);
  DenseNet fp(plain, {.precision = DenseNet::Precision::float32});
  const auto a = f.logits(in);
  const std::vector<float> av(a.begin(), a.end());
  const auto b = fp.logits(in);
  CHECK(std::equal(av.begin(), av.end(), b.begin(), b.end()));
}

TEST_CASE("model file version 3: the int8 section round-trips; float files stay version 2") {
  const ModelFile plain = ModelFile::load(fixture("densenet_tiny.ssdn"));
  const auto plain_bytes = plain.to_bytes();
  CHECK(plain_bytes[8] == 2); // no int8 section: version 2, as before
  const ModelFile q = quantised_tiny();
  const auto bytes = q.to_bytes();
  CHECK(bytes[8] == 3);
  const ModelFile back = ModelFile::from_bytes(std::span<const std::uint8_t>(bytes));
  CHECK(back.format_version == 3);
  REQUIRE(back.int8);
  REQUIRE(back.int8->size() == q.int8->size());
  for (std::size_t i = 0; i < q.int8->size(); ++i) {
    const auto& x = (*q.int8)[i];
    const auto& y = (*back.int8)[i];
    CHECK(x.name == y.name);
    CHECK(x.input_scale == y.input_scale);
    CHECK(x.weight_scales == y.weight_scales);
    CHECK(x.weights == y.weights);
  }
  CHECK(back.to_bytes() == bytes);
  // The int8 section is the version-2 bytes with the section inserted before the checksum.
  CHECK(std::equal(plain_bytes.begin() + 12, plain_bytes.end() - 4, bytes.begin() + 12));
  ModelFile dropped = back;
  dropped.int8.reset();
  CHECK(dropped.to_bytes() == plain_bytes);
}

TEST_CASE("model file version 4: a calibrated encoding with int8 weights keeps both") {
  ModelFile q = quantised_tiny();
  const auto v3 = q.to_bytes();
  q.preprocess.input_encoding = InputEncoding::skin_relative;
  const auto bytes = q.to_bytes();
  CHECK(bytes[8] == 4);
  CHECK(bytes.size() == v3.size() + 8); // the encoding field and the int8 flag
  const ModelFile back = ModelFile::from_bytes(std::span<const std::uint8_t>(bytes));
  CHECK(back.format_version == 4);
  CHECK(back.preprocess.input_encoding == InputEncoding::skin_relative);
  REQUIRE(back.int8);
  REQUIRE(back.int8->size() == q.int8->size());
  for (std::size_t i = 0; i < q.int8->size(); ++i)
    CHECK((*back.int8)[i].weights == (*q.int8)[i].weights);
  CHECK(back.to_bytes() == bytes);
  ModelFile colour = back;
  colour.preprocess.input_encoding = InputEncoding::colour;
  CHECK(colour.to_bytes() == v3); // back to version 3, byte for byte
}

TEST_CASE("model file version 3: bad int8 sections are refused with a clear error") {
  const ModelFile good = quantised_tiny();
  auto error_of = [](const ModelFile& m) {
    try {
      m.validate();
    } catch (const ModelFileError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK(error_of(good) == "no error");
  {
    ModelFile m = good;
    (*m.int8)[2].weights[5] = -128;
    CHECK(error_of(m).find("weight code -128") != std::string::npos);
  }
  {
    ModelFile m = good; // codes that are not the float weights rounded (another model's)
    auto& w = (*m.int8)[3].weights;
    w[0] = static_cast<std::int8_t>(w[0] > 0 ? w[0] - 3 : w[0] + 3);
    CHECK(error_of(m).find("does not belong to these float weights") != std::string::npos);
  }
  {
    ModelFile m = good;
    (*m.int8)[0].input_scale = 0.0f;
    CHECK(error_of(m).find("input scale") != std::string::npos);
    (*m.int8)[0].input_scale = std::nanf("");
    CHECK(error_of(m).find("input scale") != std::string::npos);
  }
  {
    ModelFile m = good;
    (*m.int8)[1].weight_scales[0] = -1.0f;
    CHECK(error_of(m).find("weight scale of row 0") != std::string::npos);
  }
  {
    ModelFile m = good;
    m.int8->pop_back();
    CHECK(error_of(m).find("quantised convolutions, expected") != std::string::npos);
  }
  {
    ModelFile m = good;
    std::swap((*m.int8)[0], (*m.int8)[1]);
    CHECK(error_of(m).find("expected 'features.denseblock1.denselayer1.conv1.weight'") !=
          std::string::npos);
  }
  {
    ModelFile m = good;
    (*m.int8)[4].weights.pop_back();
    CHECK(error_of(m).find("weights, expected") != std::string::npos);
  }
  // Truncated in the int8 section (the checksum is recomputed so only the size is wrong).
  auto bytes = good.to_bytes();
  REQUIRE(bytes.size() > 4 + 10);
  // erase, not resize: a shrinking resize also instantiates the growing path, whose memset
  // GCC 12 flags (stringop-overflow) in the sanitizer build.
  bytes.erase(bytes.end() - (4 + 10), bytes.end());
  const std::uint32_t crc = detail::crc32(bytes);
  for (int i = 0; i < 4; ++i) bytes.push_back(static_cast<std::uint8_t>(crc >> (8 * i)));
  try {
    (void)ModelFile::from_bytes(std::span<const std::uint8_t>(bytes));
    FAIL("a truncated int8 section loaded");
  } catch (const ModelFileError& e) {
    CHECK(std::string(e.what()).find("int8 section") != std::string::npos);
  }
}
