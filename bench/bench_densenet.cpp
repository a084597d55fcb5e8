// DenseNet-121/-161 forward at batch 1 on the paper's 3x150x220 input, 1 and 2 threads, 3x3
// convolutions direct and automatic (Winograd where it pays), next to PyTorch
// (tools/bench_torch.py, same machine, same run) and to the practical GEMM limit (Eigen's
// large-GEMM GFLOP/s, and this library's own GEMM on the same shape). Prints a summary line per
// configuration: ms, GFLOP/s, working memory, max abs diff of the logits against torchvision.
// Random weights come from tools/densenet_to_model.py when /usr/bin/python3 has torch (with
// torchvision's logits embedded), else from C++ (no diff).
#include <shadowsense/backends/densenet/densenet.hpp>

#include "common/bench_util.hpp"

#include <Eigen/Core>
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <string>
#include <vector>

using namespace shadowsense;

namespace {

// The repository root (bench/CMakeLists.txt passes no source-dir define; CMake compiles with
// absolute paths, so __FILE__ locates it).
std::string source_dir() {
  return std::filesystem::path(__FILE__).parent_path().parent_path().string();
}

bool have_torch() {
  static const bool ok =
      std::system("/usr/bin/python3 -c 'import torch, torchvision' > /dev/null 2>&1") == 0;
  return ok;
}

ModelFile load_model(const std::string& arch) {
  if (have_torch()) {
    const auto path = std::filesystem::temp_directory_path() / ("ss_bench_" + arch + ".ssdn");
    const std::string cmd = "/usr/bin/python3 " + source_dir() +
                            "/tools/densenet_to_model.py --random-init --arch " + arch +
                            " --num-classes 5 --self-test 1 -o " + path.string() + " > /dev/null";
    if (std::system(cmd.c_str()) == 0) {
      auto m = ModelFile::load(path);
      std::filesystem::remove(path);
      return m;
    }
  }
  return bench::random_model(arch == "densenet161" ? DenseNetArchitecture::densenet161(5)
                                                   : DenseNetArchitecture::densenet121(5));
}

template <class F>
double median_ms(F&& f, int reps) {
  std::vector<double> t;
  for (int i = 0; i < reps; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    t.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

} // namespace

TEST_CASE("GEMM limit: 1024^3 single precision", "[densenet]") {
  const int n = 1024;
  Eigen::MatrixXf a = Eigen::MatrixXf::Random(n, n), b = Eigen::MatrixXf::Random(n, n), c(n, n);
  c.noalias() = a * b;
  const double eigen_ms = median_ms([&] { c.noalias() = a * b; }, 5);
  std::printf("eigen large GEMM (1024^3, 1 thread, this build's flags): %.1f ms, %.1f GFLOP/s\n",
              eigen_ms, 2.0 * n * n * n / eigen_ms / 1e6);
  for (int threads : {1, 2}) {
    auto kernel = detail::select_micro_kernel(GemmKernelKind::automatic);
    detail::PackedMatrix pa;
    std::vector<float> w(static_cast<std::size_t>(n) * n, 0.5f), bm(w), out(w.size());
    pa.pack(w.data(), n, n, kernel.mr);
    detail::ThreadPool pool(threads);
    std::vector<detail::GemmScratch> scratch(static_cast<std::size_t>(threads));
    for (auto& s : scratch) {
      s.panel.resize(static_cast<std::size_t>(n) * kernel.nr);
      s.tile.resize(static_cast<std::size_t>(kernel.mr) * kernel.nr);
      s.index.resize(static_cast<std::size_t>(kernel.nr));
    }
    const int nr = kernel.nr;
    auto pack = [&](float* dst, int n0, int cols, int*) {
      for (int k = 0; k < n; ++k) {
        const float* s = bm.data() + static_cast<std::size_t>(k) * n + n0;
        float* d = dst + static_cast<std::size_t>(k) * nr;
        for (int j = 0; j < cols; ++j) d[j] = s[j];
        for (int j = cols; j < nr; ++j) d[j] = 0.0f;
      }
    };
    auto store = [&](int m, int n0, int cols, const float* v) {
      std::copy_n(v, cols, out.data() + static_cast<std::size_t>(m) * n + n0);
    };
    const double ms =
        median_ms([&] { detail::gemm(kernel, pa, n, pack, store, pool, scratch); }, 5);
    std::printf("shadowsense GEMM (1024^3, %s, %d thread(s)): %.1f ms, %.1f GFLOP/s\n", kernel.name,
                threads, ms, 2.0 * n * n * n / ms / 1e6);
  }
  BENCHMARK("eigen 1024^3") {
    c.noalias() = a * b;
    return c(0, 0);
  };
}

TEST_CASE("DenseNet forward, batch 1, 3x150x220", "[densenet]") {
  for (const std::string arch : {"densenet121", "densenet161"}) {
    const ModelFile model = load_model(arch);
    Tensor x = bench::random_input(150, 220);
    std::vector<float> ref;
    if (model.self_test && model.self_test->input.h() == 150) {
      x = model.self_test->input;
      ref = model.self_test->logits;
    }
    for (int threads : {1, 2})
      for (auto conv : {DenseNet::Conv3x3::direct, DenseNet::Conv3x3::automatic}) {
        const std::string method = conv == DenseNet::Conv3x3::direct ? "direct" : "automatic";
        DenseNet net(model, {.threads = threads, .conv3x3 = conv, .run_self_test = false});
        net.logits(x); // warm-up: buffers allocated here, never again
        const int reps = arch == "densenet161" ? 5 : 9;
        const std::clock_t cpu0 = std::clock();
        const double ms = median_ms([&] { net.logits(x); }, reps);
        // Process CPU time per forward (all threads): on a shared machine, the work done
        // independent of how long other processes kept the cores.
        const double cpu_ms = 1000.0 * double(std::clock() - cpu0) / CLOCKS_PER_SEC / reps;
        double diff = -1;
        if (!ref.empty()) {
          const auto got = net.logits(x);
          diff = 0;
          for (std::size_t i = 0; i < ref.size(); ++i)
            diff = std::max(diff, std::abs(double(got[i]) - double(ref[i])));
        }
        std::printf("\nshadowsense %s threads=%d kernel=%s conv3x3=%s ms=%.2f cpu_ms=%.2f "
                    "GFLOP/s=%.1f weights_mb=%.1f "
                    "activations_mb=%.2f max_abs_diff_vs_torchvision=%s\n",
                    arch.c_str(), threads, net.kernel_name(), method.c_str(), ms, cpu_ms,
                    2.0 * net.macs(150, 220) / ms / 1e6, net.weight_bytes() / 1e6,
                    net.activation_bytes() / 1e6, diff < 0 ? "n/a" : std::to_string(diff).c_str());
        BENCHMARK(arch + " threads=" + std::to_string(threads) + " conv3x3=" + method) {
          return net.logits(x)[0];
        };
      }
    if (have_torch()) {
      const std::string cmd =
          "/usr/bin/python3 " + source_dir() + "/tools/bench_torch.py --reps 5 --archs " + arch;
      std::printf("\n");
      std::fflush(stdout);
      REQUIRE(std::system(cmd.c_str()) == 0);
    }
  }
}
