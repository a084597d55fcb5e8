// Every GEMM micro-kernel this machine runs, in one run: reference (the oracle), portable,
// the legacy portable kernel (the one the library shipped before the portable kernel was made
// vectorisable; kept here only, for the comparison), AVX2+FMA, AVX-512 and NEON where present.
// 1. GFLOP/s of each kernel on three GEMM shapes of DenseNet-121 at 3x150x220 (1 thread), and
//    the max abs / relative difference of its output from the reference kernel's.
// 2. DenseNet-121 forward time at batch 1, 3x150x220, 1 thread, per kernel (median), and the
//    max abs difference of the logits from the reference kernel's logits.
// 3. The portable and legacy portable forwards alternated in one loop (both under the same
//    load), medians and the speed-up: the figure issue 12 asks for.
// 4. ([int8]) The int8 GEMM kernels (reference, AVX2, NEON) on the shapes of 1., in GOP/s.
// SS_BENCH_KERNELS=portable,legacy-portable (comma list of names) restricts the kernels, e.g.
// to count instructions of one kernel with perf stat; differences are then taken from the first
// kernel listed in the output (the reference one unless it is left out).
#include <shadowsense/backends/densenet/densenet.hpp>
#include <shadowsense/backends/densenet/gemm_int8.hpp>

#include "common/bench_util.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

using namespace shadowsense;
using bench::thread_cpu_ms;

namespace {

// The portable kernel and loops as shipped before: a 4 x 16 block indexed acc[r][j], no
// __restrict. GCC keeps the block in memory and vectorises little of it.
template <int MR, int NR>
void legacy_micro_kernel(int K, const float* a, const float* b, float* out) {
  float acc[MR][NR] = {};
  for (int k = 0; k < K; ++k, a += MR, b += NR)
    for (int r = 0; r < MR; ++r)
      for (int j = 0; j < NR; ++j) acc[r][j] += a[r] * b[j];
  std::copy(&acc[0][0], &acc[0][0] + MR * NR, out);
}
void legacy_affine_relu(const float* s, float* d, int n, float sc, float sh) {
  for (int i = 0; i < n; ++i) {
    const float v = s[i] * sc + sh;
    d[i] = v > 0.0f ? v : 0.0f;
  }
}
void legacy_bias_relu(const float* s, float* d, int n, float b) {
  for (int i = 0; i < n; ++i) {
    const float v = s[i] + b;
    d[i] = v > 0.0f ? v : 0.0f;
  }
}
void legacy_pack3x3(const float* s, float* d, int cols, int nr, int pw) {
  for (int ky = 0; ky < 3; ++ky)
    for (int kx = 0; kx < 3; ++kx, d += nr) {
      const float* r = s + ky * pw + kx;
      for (int j = 0; j < cols; ++j) d[j] = r[j];
      for (int j = cols; j < nr; ++j) d[j] = 0.0f;
    }
}
void legacy_pool_affine_relu(const float* r0, const float* r1, float* d, int n, float sc,
                             float sh) {
  for (int j = 0; j < n; ++j) {
    float a = r0[2 * j] * sc + sh, b = r0[2 * j + 1] * sc + sh;
    float c = r1[2 * j] * sc + sh, e = r1[2 * j + 1] * sc + sh;
    a = a > 0.0f ? a : 0.0f;
    b = b > 0.0f ? b : 0.0f;
    c = c > 0.0f ? c : 0.0f;
    e = e > 0.0f ? e : 0.0f;
    d[j] = ((a + b) + (c + e)) * 0.25f;
  }
}

struct Candidate {
  std::string name;
  detail::MicroKernel kernel;
  detail::VectorOps ops;
};

bool wanted(const std::string& name) {
  const char* only = std::getenv("SS_BENCH_KERNELS");
  if (!only || !*only) return true;
  const std::string list = "," + std::string(only) + ",";
  return list.find("," + name + ",") != std::string::npos;
}

// Every kernel the machine runs plus the legacy one; the reference first (the oracle).
std::vector<Candidate> candidates() {
  std::vector<Candidate> out;
  auto kinds = detail::available_kernels();
  std::reverse(kinds.begin(), kinds.end()); // reference, portable, then the SIMD ones
  for (auto k : kinds) {
    const auto mk = detail::select_micro_kernel(k);
    out.push_back({mk.name, mk, detail::select_vector_ops(k)});
    if (k == GemmKernelKind::portable)
      out.push_back(
          {"legacy-portable",
           {GemmKernelKind::portable, 4, 16, &legacy_micro_kernel<4, 16>, "legacy-portable"},
           {&legacy_affine_relu, &legacy_bias_relu, &legacy_pool_affine_relu, &legacy_pack3x3}});
  }
  return out;
}

struct Timing {
  double wall_ms, cpu_ms; // medians; cpu_ms: this thread's CPU time (excludes time other
                          // processes held the core, so it is steadier on a loaded machine)
};

template <class F>
Timing median_ms(F&& f, int reps) {
  std::vector<double> wall, cpu;
  for (int i = 0; i < reps; ++i) {
    const double c0 = thread_cpu_ms();
    const auto t0 = std::chrono::steady_clock::now();
    f();
    wall.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    cpu.push_back(thread_cpu_ms() - c0);
  }
  std::sort(wall.begin(), wall.end());
  std::sort(cpu.begin(), cpu.end());
  return {wall[wall.size() / 2], cpu[cpu.size() / 2]};
}

void print_load() {
  double load[3] = {0, 0, 0};
  if (FILE* f = std::fopen("/proc/loadavg", "r")) {
    if (std::fscanf(f, "%lf %lf %lf", &load[0], &load[1], &load[2]) != 3) load[0] = -1;
    std::fclose(f);
  }
  std::printf("load average (1/5/15 min): %.2f %.2f %.2f\n", load[0], load[1], load[2]);
}

} // namespace

TEST_CASE("GEMM kernels: GFLOP/s and difference from the reference", "[gemm]") {
  print_load();
  struct Shape {
    const char* what;
    int m, k, n;
  };
  // DenseNet-121 at 3x150x220: block 1 is 38 x 55 (2090 pixels), block 2 19 x 27 (513).
  const Shape shapes[] = {{"block1 conv1 (1x1, 256 in)", 128, 256, 2090},
                          {"block1 conv2 (3x3, padded grid)", 32, 1152, 38 * 57},
                          {"block2 conv1 (1x1, 512 in)", 128, 512, 513}};
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> ud(-1.0f, 1.0f);
  detail::ThreadPool pool(1);
  for (const auto& s : shapes) {
    std::vector<float> w(static_cast<std::size_t>(s.m) * s.k),
        b(static_cast<std::size_t>(s.k) * s.n);
    for (auto& v : w) v = ud(rng);
    for (auto& v : b) v = ud(rng);
    std::vector<float> ref;
    std::printf("\n%s: M=%d K=%d N=%d\n", s.what, s.m, s.k, s.n);
    for (const auto& c : candidates()) {
      if (!wanted(c.name)) continue;
      detail::PackedMatrix pa;
      pa.pack(w.data(), s.m, s.k, c.kernel.mr);
      std::vector<detail::GemmScratch> scratch(1);
      scratch[0].panel.resize(static_cast<std::size_t>(s.k) * c.kernel.nr);
      scratch[0].tile.resize(static_cast<std::size_t>(c.kernel.mr) * c.kernel.nr);
      scratch[0].index.resize(static_cast<std::size_t>(c.kernel.nr));
      std::vector<float> out(static_cast<std::size_t>(s.m) * s.n);
      const int nr = c.kernel.nr;
      auto pack = [&](float* dst, int n0, int cols, int*) {
        for (int k = 0; k < s.k; ++k) {
          const float* src = b.data() + static_cast<std::size_t>(k) * s.n + n0;
          float* d = dst + static_cast<std::size_t>(k) * nr;
          for (int j = 0; j < cols; ++j) d[j] = src[j];
          for (int j = cols; j < nr; ++j) d[j] = 0.0f;
        }
      };
      auto store = [&](int m, int n0, int cols, const float* v) {
        std::copy_n(v, cols, out.data() + static_cast<std::size_t>(m) * s.n + n0);
      };
      auto run = [&] { detail::gemm(c.kernel, pa, s.n, pack, store, pool, scratch); };
      run();
      const int reps = c.name == "reference" ? 1 : 7;
      const Timing t = median_ms(run, reps);
      if (ref.empty()) ref = out;
      double max_abs = 0, scale = 0;
      for (std::size_t i = 0; i < out.size(); ++i) {
        max_abs = std::max(max_abs, std::abs(double(out[i]) - double(ref[i])));
        scale = std::max(scale, std::abs(double(ref[i])));
      }
      const double max_rel = max_abs / scale; // relative to the largest output
      const double flop = 2.0 * s.m * s.k * s.n;
      std::printf("  %-16s %2dx%-3d wall %8.3f ms %7.2f GFLOP/s | cpu %8.3f ms %7.2f GFLOP/s | "
                  "max abs diff %.3g, / max |C| %.3g\n",
                  c.name.c_str(), c.kernel.mr, c.kernel.nr, t.wall_ms, flop / t.wall_ms / 1e6,
                  t.cpu_ms, flop / t.cpu_ms / 1e6, max_abs, max_rel);
      CHECK(max_rel <= 1e-5);
    }
  }
}

// The int8 kernels (gemm_int8.hpp) on the same three shapes, in GOP/s (1 multiply-add = 2 ops,
// as above) beside the float figures; their outputs are exact, so any difference from the
// int8 reference fails.
TEST_CASE("int8 GEMM kernels: GOP/s on the same shapes", "[gemm][int8]") {
  print_load();
  struct Shape {
    const char* what;
    int m, k, n;
  };
  const Shape shapes[] = {{"block1 conv1 (1x1, 256 in)", 128, 256, 2090},
                          {"block1 conv2 (3x3, im2col)", 32, 1152, 38 * 55},
                          {"block2 conv1 (1x1, 512 in)", 128, 512, 513}};
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> wd(-127, 127), xd(0, 127);
  for (const auto& s : shapes) {
    const int kp = detail::int8_padded_k(s.k);
    std::vector<std::int8_t> w(static_cast<std::size_t>(s.m) * kp, 0);
    std::vector<std::uint8_t> x(static_cast<std::size_t>(s.n) * kp, 0);
    for (int i = 0; i < s.m; ++i)
      for (int k = 0; k < s.k; ++k) w[static_cast<std::size_t>(i) * kp + k] = std::int8_t(wd(rng));
    for (int j = 0; j < s.n; ++j)
      for (int k = 0; k < s.k; ++k) x[static_cast<std::size_t>(j) * kp + k] = std::uint8_t(xd(rng));
    std::printf("\n%s: M=%d K=%d N=%d (int8)\n", s.what, s.m, s.k, s.n);
    std::vector<std::int32_t> ref;
    for (auto kind : detail::available_int8_kernels()) {
      const auto g = detail::select_int8_gemm(kind);
      std::vector<std::int32_t> out(static_cast<std::size_t>(s.m) * s.n);
      auto run = [&] { g.fn(w.data(), s.m, x.data(), s.n, kp, out.data(), std::size_t(s.n)); };
      run();
      const Timing t = median_ms(run, kind == detail::Int8KernelKind::reference ? 1 : 7);
      if (ref.empty()) ref = out;
      const double ops = 2.0 * s.m * s.k * s.n;
      std::printf("  %-16s wall %8.3f ms %7.2f GOP/s | cpu %8.3f ms %7.2f GOP/s | %s\n", g.name,
                  t.wall_ms, ops / t.wall_ms / 1e6, t.cpu_ms, ops / t.cpu_ms / 1e6,
                  out == ref ? "equal to the reference" : "DIFFERS from the reference");
      CHECK(out == ref);
    }
  }
}

TEST_CASE("DenseNet-121 forward per kernel, batch 1, 3x150x220, 1 thread", "[gemm]") {
  print_load();
  const ModelFile model = bench::random_model(DenseNetArchitecture::densenet121(5));
  const Tensor x = bench::random_input(150, 220);
  std::vector<float> ref;
  std::printf("\n");
  for (const auto& c : candidates()) {
    if (!wanted(c.name)) continue;
    DenseNet::Config cfg{.threads = 1, .run_self_test = false};
    cfg.micro_kernel = c.kernel;
    cfg.vector_ops = c.ops;
    DenseNet net(model, cfg);
    net.logits(x); // warm-up
    const int reps = c.name == "reference"                          ? 1
                     : c.name.find("portable") != std::string::npos ? 5
                                                                    : 9;
    const Timing t = median_ms([&] { net.logits(x); }, reps);
    const auto got = net.logits(x);
    if (ref.empty()) ref.assign(got.begin(), got.end());
    double max_abs = 0, scale = 0;
    for (std::size_t i = 0; i < ref.size(); ++i) {
      max_abs = std::max(max_abs, std::abs(double(got[i]) - double(ref[i])));
      scale = std::max(scale, std::abs(double(ref[i])));
    }
    const double flop = 2.0 * net.macs(150, 220);
    std::printf("densenet121 %-16s wall %9.2f ms %6.2f GFLOP/s | cpu %9.2f ms %6.2f GFLOP/s | "
                "reps %d | logits vs reference: max abs diff %.3g, / max |logit| %.3g\n",
                c.name.c_str(), t.wall_ms, flop / t.wall_ms / 1e6, t.cpu_ms, flop / t.cpu_ms / 1e6,
                reps, max_abs, max_abs / scale);
    CHECK(max_abs <= 1e-4 * scale);
  }
}

// Issue 12's speed target in one number: the portable kernel against the legacy one on the
// DenseNet-121 forward, their forwards alternated (portable, legacy, legacy, portable, ...) so
// both see the same load from other processes; medians of 11 each, and the ratio.
TEST_CASE("DenseNet-121 forward: portable vs legacy portable, alternated", "[gemm]") {
  if (!wanted("portable") || !wanted("legacy-portable")) return;
  print_load();
  const ModelFile model = bench::random_model(DenseNetArchitecture::densenet121(5));
  const Tensor x = bench::random_input(150, 220);
  const auto all = candidates();
  auto find = [&](const std::string& name) {
    return *std::find_if(all.begin(), all.end(),
                         [&](const Candidate& c) { return c.name == name; });
  };
  auto make = [&](const Candidate& c) {
    DenseNet::Config cfg{.threads = 1, .run_self_test = false};
    cfg.micro_kernel = c.kernel;
    cfg.vector_ops = c.ops;
    return DenseNet(model, cfg);
  };
  DenseNet reference(model,
                     {.threads = 1, .kernel = GemmKernelKind::reference, .run_self_test = false});
  DenseNet portable = make(find("portable")), legacy = make(find("legacy-portable"));
  const auto ref_logits = reference.logits(x);
  const std::vector<float> ref(ref_logits.begin(), ref_logits.end());
  portable.logits(x); // warm-up
  legacy.logits(x);
  std::vector<double> p_wall, p_cpu, l_wall, l_cpu;
  auto time_one = [&](DenseNet& net, std::vector<double>& wall, std::vector<double>& cpu) {
    const double c0 = thread_cpu_ms();
    const auto t0 = std::chrono::steady_clock::now();
    net.logits(x);
    wall.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    cpu.push_back(thread_cpu_ms() - c0);
  };
  const int reps = 11;
  for (int i = 0; i < reps; ++i) {
    if (i % 2 == 0) {
      time_one(portable, p_wall, p_cpu);
      time_one(legacy, l_wall, l_cpu);
    } else {
      time_one(legacy, l_wall, l_cpu);
      time_one(portable, p_wall, p_cpu);
    }
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  auto max_diff = [&](DenseNet& net) {
    const auto got = net.logits(x);
    double max_abs = 0, scale = 0;
    for (std::size_t i = 0; i < ref.size(); ++i) {
      max_abs = std::max(max_abs, std::abs(double(got[i]) - double(ref[i])));
      scale = std::max(scale, std::abs(double(ref[i])));
    }
    return std::pair{max_abs, max_abs / scale};
  };
  const auto [p_abs, p_rel] = max_diff(portable);
  const auto [l_abs, l_rel] = max_diff(legacy);
  const double flop = 2.0 * portable.macs(150, 220);
  const double pw = median(p_wall), pc = median(p_cpu), lw = median(l_wall), lc = median(l_cpu);
  std::printf("\nalternated, %d forwards each (medians), logits vs reference kernel:\n", reps);
  std::printf("densenet121 portable         wall %8.2f ms %6.2f GFLOP/s | cpu %8.2f ms %6.2f "
              "GFLOP/s | max abs diff %.3g, / max |logit| %.3g\n",
              pw, flop / pw / 1e6, pc, flop / pc / 1e6, p_abs, p_rel);
  std::printf("densenet121 legacy-portable  wall %8.2f ms %6.2f GFLOP/s | cpu %8.2f ms %6.2f "
              "GFLOP/s | max abs diff %.3g, / max |logit| %.3g\n",
              lw, flop / lw / 1e6, lc, flop / lc / 1e6, l_abs, l_rel);
  std::printf("portable speed-up over legacy portable: wall %.2fx, cpu %.2fx\n", lw / pw, lc / pc);
  CHECK(p_rel <= 1e-4);
  CHECK(l_rel <= 1e-4);
}
