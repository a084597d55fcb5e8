// forward_time: times the DenseNet forward pass of one model file on one raw input, for the
// side-by-side comparison with ONNX Runtime (tools/onnxruntime_bench/run.py drives it and the
// ONNX Runtime timer alternately). Prints one JSON object on stdout: per-iteration wall times
// (ms), the process CPU time per pass (ms, all threads), the multiply-adds of one forward pass, the
// kernel, the int8 kernel ("" unless the model file has an int8 section: then the quantised
// convolutions run in int8, docs/int8.md) and the logits.
//   forward_time MODEL.ssm INPUT.f32 H W THREADS ITERATIONS [SPIN_US [CONV3X3 [KERNEL]]]
// INPUT.f32: 3 x H x W little-endian float32 values (CHW, already preprocessed).
#include <shadowsense/backends/densenet/densenet.hpp>
#include <shadowsense/backends/densenet/model_file.hpp>

#include "common/bench_util.hpp"

#include <chrono>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <initializer_list>
#include <iostream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace ss = shadowsense;
using bench::positive_int;

namespace {

constexpr std::string_view usage =
    "usage: forward_time MODEL.ssm INPUT.f32 H W THREADS ITERATIONS [SPIN_US [CONV3X3 [KERNEL\n"
    "                    [CONV0 [CONV1X1]]]]]\n"
    "Times the DenseNet forward pass on a 1 x 3 x H x W float32 input (raw little-endian CHW)\n"
    "and prints {\"ms\": [...], \"macs\": ..., \"kernel\": ..., \"logits\": [...]} on stdout.\n"
    "SPIN_US: how long idle worker threads poll before they sleep (DenseNet::Config::spin_us,\n"
    "default 300; 0 = sleep at once).\n"
    "CONV3X3: automatic (default), direct, winograd (F(2x2, 3x3)) or winograd4x4 (F(4x4, 3x3))\n"
    "  (DenseNet::Config::conv3x3).\n"
    "KERNEL: automatic (default), avx512, avx2, neon, portable or reference (Config::kernel);\n"
    "  for a model with an int8 section, int8-vnni, int8-avx2, int8-neon or int8-reference\n"
    "  picks the int8 kernel instead (Config::int8_kernel).\n"
    "CONV0: automatic (default), direct or winograd (F(3x3, 4x4) over the input's stride-2\n"
    "  phases) (DenseNet::Config::conv0).\n"
    "CONV1X1: automatic (default), channel_rows or pixel_rows (DenseNet::Config::conv1x1; the\n"
    "  AVX-512 kernel only).\n";

// The value named `value` in `names`, else InvalidArgument naming the argument and the choices.
template <class T>
T named(std::string_view value, const char* argument,
        std::initializer_list<std::pair<std::string_view, T>> names) {
  std::string choices;
  std::size_t i = 0;
  for (const auto& [name, v] : names) {
    if (value == name) return v;
    choices += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + std::string(name);
    ++i;
  }
  throw ss::InvalidArgument(std::string(argument) + " is '" + std::string(value) + "', expected " +
                            choices);
}

// The float and int8 kernels KERNEL picks (one of them stays automatic).
struct Kernels {
  ss::GemmKernelKind gemm = ss::GemmKernelKind::automatic;
  ss::detail::Int8KernelKind int8 = ss::detail::Int8KernelKind::automatic;
};

ss::Tensor read_input(const std::string& path, int h, int w) {
  ss::Tensor t(1, 3, h, w);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ss::IoError(path + ": cannot open the input file");
  in.read(reinterpret_cast<char*>(t.data()), static_cast<std::streamsize>(t.size() * 4));
  if (in.gcount() != static_cast<std::streamsize>(t.size() * 4) || in.peek() != EOF)
    throw ss::IoError(path + ": expected exactly 3 x " + std::to_string(h) + " x " +
                      std::to_string(w) + " float32 values");
  return t;
}

} // namespace

int main(int argc, char** argv) {
  if (argc == 2 && std::string_view(argv[1]) == "--help") {
    std::cout << usage;
    return 0;
  }
  if (argc == 2 && std::string_view(argv[1]) == "--version") {
    std::cout << "forward_time shadowsense " << ss::version_string << '\n';
    return 0;
  }
  try {
    if (argc < 7 || argc > 12)
      throw ss::InvalidArgument("expected 6 to 11 arguments, got " + std::to_string(argc - 1));
    const int h = positive_int(argv[3], "H"), w = positive_int(argv[4], "W");
    const int threads = positive_int(argv[5], "THREADS");
    const int iterations = positive_int(argv[6], "ITERATIONS");
    const int spin_us = argc == 7                          ? ss::detail::ThreadPool::default_spin_us
                        : std::string_view(argv[7]) == "0" ? 0
                                                           : positive_int(argv[7], "SPIN_US");
    using Conv3x3 = ss::DenseNet::Conv3x3;
    const Conv3x3 conv3x3 = argc < 9 ? Conv3x3::automatic
                                     : named<Conv3x3>(argv[8], "CONV3X3",
                                                      {{"automatic", Conv3x3::automatic},
                                                       {"direct", Conv3x3::direct},
                                                       {"winograd", Conv3x3::winograd},
                                                       {"winograd4x4", Conv3x3::winograd4x4}});
    using Gemm = ss::GemmKernelKind;
    using Int8 = ss::detail::Int8KernelKind;
    const Kernels kernels =
        argc < 10 ? Kernels{}
                  : named<Kernels>(argv[9], "KERNEL",
                                   {{"automatic", Kernels{}},
                                    {"avx512", Kernels{Gemm::avx512}},
                                    {"avx2", Kernels{Gemm::avx2}},
                                    {"neon", Kernels{Gemm::neon}},
                                    {"portable", Kernels{Gemm::portable}},
                                    {"reference", Kernels{Gemm::reference}},
                                    {"int8-vnni", Kernels{.int8 = Int8::vnni}},
                                    {"int8-avx2", Kernels{.int8 = Int8::avx2}},
                                    {"int8-neon", Kernels{.int8 = Int8::neon}},
                                    {"int8-reference", Kernels{.int8 = Int8::reference}}});
    using Conv0 = ss::DenseNet::Conv0;
    const Conv0 conv0 = argc < 11 ? Conv0::automatic
                                  : named<Conv0>(argv[10], "CONV0",
                                                 {{"automatic", Conv0::automatic},
                                                  {"direct", Conv0::direct},
                                                  {"winograd", Conv0::winograd}});
    using Conv1x1 = ss::DenseNet::Conv1x1;
    const Conv1x1 conv1x1 = argc < 12 ? Conv1x1::automatic
                                      : named<Conv1x1>(argv[11], "CONV1X1",
                                                       {{"automatic", Conv1x1::automatic},
                                                        {"channel_rows", Conv1x1::channel_rows},
                                                        {"pixel_rows", Conv1x1::pixel_rows}});
    const ss::ModelFile model = ss::ModelFile::load(argv[1]);
    ss::DenseNet net(model, {.threads = threads,
                             .spin_us = spin_us,
                             .kernel = kernels.gemm,
                             .conv3x3 = conv3x3,
                             .conv0 = conv0,
                             .conv1x1 = conv1x1,
                             .run_self_test = false,
                             .int8_kernel = kernels.int8});
    const ss::Tensor input = read_input(argv[2], h, w);
    for (int i = 0; i < 3; ++i) net.logits(input); // warm-up: buffers, caches, threads
    std::vector<double> ms;
    timespec c0{}, c1{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &c0);
    for (int i = 0; i < iterations; ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      net.logits(input);
      ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &c1);
    const double cpu_ms =
        (double(c1.tv_sec - c0.tv_sec) * 1e3 + double(c1.tv_nsec - c0.tv_nsec) * 1e-6) /
        iterations; // all threads of the process, per pass
    const auto logits = net.logits(input);
    std::cout << "{\"ms\": [";
    for (std::size_t i = 0; i < ms.size(); ++i) std::printf("%s%.4f", i ? ", " : "", ms[i]);
    std::fflush(stdout);
    std::printf("], \"cpu_ms\": %.4f", cpu_ms);
    std::fflush(stdout);
    std::cout << ", \"macs\": " << net.macs(h, w) << ", \"kernel\": \"" << net.kernel_name()
              << "\", \"int8_kernel\": \"" << net.int8_kernel_name() << "\", \"logits\": [";
    for (std::size_t i = 0; i < logits.size(); ++i) std::printf("%s%.9g", i ? ", " : "", logits[i]);
    std::fflush(stdout);
    std::cout << "]}\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "forward_time: error: " << e.what() << '\n' << usage;
    return 2;
  }
}
