// The int8 path: every int8 GEMM kernel this CPU runs (AVX2, NEON) equals the portable
// reference exactly (int32 sums are exact, so equality is the contract), including the
// extreme codes where vpmaddubsw would saturate with 8-bit activations. Needs only the DenseNet
// headers and doctest, so it also runs cross-compiled for aarch64 under qemu-user
// (.ci/steps/50_aarch64.sh).
#include <shadowsense/backends/densenet/gemm_int8.hpp>

#include <doctest/doctest.h>

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
  // Shapes with every remainder of the 4 x 2 blocking, K below, at and above one register.
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
  if (__builtin_cpu_supports("avx2")) CHECK(std::string(g.name) == "int8-avx2");
#endif
#if SHADOWSENSE_NEON_KERNELS
  CHECK(std::string(g.name) == "int8-neon");
#endif
  const bool has_fn = g.fn != nullptr;
  CHECK(has_fn);
  if (!detail::cpu_has_int8(detail::Int8KernelKind::neon))
    CHECK_THROWS_AS(detail::select_int8_gemm(detail::Int8KernelKind::neon), InvalidArgument);
}
