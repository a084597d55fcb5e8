// roofline: for every stage of the shipped model's frame (segmenter, the rest of the touch
// pipeline, frame encoder, DenseNet conv0+pool0, each dense block and transition, the head,
// the whole forward pass, the whole frame) the floor this machine allows next to the measured
// time, as one Markdown table (docs/roofline.md). Everything is measured on the machine it runs
// on, so the table can be regenerated anywhere (an aarch64 robot included):
//   bandwidth  a stream-style loop (copy c = a, triad a = b + s c) on one core, over arrays
//              that fit the L2 cache, the last-level cache (LLC), and much larger than the LLC
//              (DRAM); STREAM's byte count (copy 2 x 4 B, triad 3 x 4 B per element; the
//              write-allocate read is not counted); per level the larger of copy and triad.
//              Also the DRAM figure on 2 threads (wall time; not used by the floors: the frame
//              runs on one core). Best of several samples, as STREAM reports it.
//   peak       the library's own GEMM micro-kernel (whichever gemm.hpp's dispatch picks) on
//              in-cache operands: one A panel (K x mr) and one B panel (K x nr), K = 256,
//              called back to back; 2 mr nr K FLOP per call; the best of 25 samples of
//              about 1 ms (short samples: on a shared machine some fall between other work).
//              Also at K = the bottleneck width (the K of the Winograd GEMMs), where the
//              tile's loads and stores weigh more.
// Per stage, from the data shapes (the model below), bytes moved and FLOPs, then
//   floor = max(bytes / bandwidth, FLOPs / peak)
// where the bandwidth is that of the smallest cache level holding the stage's working set
// (the arrays it touches; the frame-to-frame steady state keeps them there: at the shipped
// model's 160 x 88 input the DenseNet's activations fit in about 512 KiB, a 635 x 350 frame's
// segmenter arrays need 6.7 MB), and the measured median CPU time on one core (as
// bench/frame_time.cpp times it).
// The whole forward pass's floor is the sum of its stages' floors, the whole frame's the sum
// of segmenter, rest of pipeline, encoder and forward.
//
// Bytes model (4-byte floats; B/px per frame pixel): each stage reads its input arrays once and
// writes its output arrays once, and the arrays its design must materialise between steps are
// written and read once; the implementation's own copies (conv0's input phases, packed GEMM
// panels, Winograd transforms, padded grids) and re-reads of cached data are not counted: they
// are what the measured time loses against the floor.
//   segment    frame in (3 B/px), the empty-skin model's 3 inverse planes (binary16, 6 B/px)
//              and skin mask (1 B/px), the rule's outputs: 2 masks (2 B/px) and the darkness
//              and warmth planes (2 floats, 8 B/px), the masks' smoothing (each read and
//              written: 4 B/px), blob extraction (each mask read: 2 B/px): 26 B/px. Working
//              set: the distinct arrays, 20 B/px. (Until 2026-11-29 the inverse planes were
//              floats, and the model also counted the skin weight plane the rule never reads:
//              36 and 30 B/px.)
//   pipeline   the rest of TouchPipeline::update (camera health, tracker, state machines):
//              the camera health's sample grid (every 4th pixel of every 4th row: every cache
//              line of every 4th row, 3/4 B/px); the rest is per track. Measured as pipeline
//              minus segment.
//   encode     frame in (3 B/px: the dark-frame rule's mean luminance reads all of it), the
//              network input out (3 floats per input pixel); the resize and crop can be fused.
//   conv0+pool0  image in, conv0 weights, conv0's output written and read by pool0, pool0's
//              output written.
//   block b    per dense layer: its cin input channels read, the bottleneck (bn_size x growth
//              channels) written and read, growth new channels written, its two weight
//              matrices read (DenseNet's layers each read every earlier channel: that
//              re-reading is the algorithm's, not a loss).
//   transition b  the block's c channels read, c/2 channels at half size written, weights.
//   head       the last block's channels read, the classifier weights read, logits written.
// FLOPs: 2 per multiply-add of the convolutions and the classifier from the model's shapes; the
// dense layers' 3x3 convolutions counted as direct convolutions (the library computes most of
// them by Winograd with 2.25-4x fewer multiply-adds, so a block can run under its compute
// floor); the transitions with the pool first, as the library computes them (torchvision's
// order is 4x the multiply-adds); BatchNorm, ReLU and pooling not counted (a few operations per
// element against >= 100 multiply-adds per output). A second count, "executed", is the GEMM
// work as the library runs it (densenet_stages), and its rate against the peak. The
// segmenter's and encoder's work is byte
// and element-wise arithmetic that the GEMM kernel's peak does not bound: no FLOPs counted,
// their floor is the bytes term.
//
//   roofline [--model PATH] [--frames N] [--rounds R] [--dram-mb M] [--out PATH] [--json]
// --out PATH replaces the part of PATH between the lines "<!-- roofline:begin -->" and
// "<!-- roofline:end -->" (the rest of the document is kept; a new file gets only that part),
// written atomically (core/atomic_file.hpp); a file without the markers is an error. Without
// --out the table goes to stdout. --json prints the same figures as JSON to stdout.
#include <shadowsense/backends/densenet/classifier.hpp>
#include <shadowsense/core/atomic_file.hpp>
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>
#include <shadowsense/sim.hpp>

#include "common/bench_util.hpp"
#include "common/frame_options.hpp"
#include "common/robot_frames.hpp"

#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>
#include <string>
#include <string_view>
#include <thread>
#include <unistd.h>
#include <vector>

namespace ss = shadowsense;
using bench::thread_cpu_ms;

namespace {

constexpr std::string_view usage =
    "usage: roofline [--model PATH] [--frames N] [--rounds R] [--dram-mb M] [--out PATH] "
    "[--json]\n"
    "       [--help] [--version]\n"
    "Measures this machine's memory bandwidth (stream-style copy/triad in L2, in the last-level\n"
    "cache and from DRAM) and the GEMM micro-kernel's peak, then times every stage of a model's\n"
    "frame (default models/default.ssm) on one core and prints each stage's floor\n"
    "max(bytes / bandwidth, FLOPs / peak) next to its median CPU time, as a Markdown table.\n"
    "  --frames N   generator frames per round (default 20)   --rounds R  rounds (default 7)\n"
    "  --dram-mb M  MB per array of the DRAM stream loop (default: twice the LLC, >= 32)\n"
    "  --out PATH   replace the table between <!-- roofline:begin --> and <!-- roofline:end -->\n"
    "               in PATH (atomically; a new file gets only the table)\n"
    "  --json       the figures as JSON on stdout\n";

constexpr const char* begin_marker = "<!-- roofline:begin -->";
constexpr const char* end_marker = "<!-- roofline:end -->";

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// ---- machine ----

std::string cpu_model() {
  std::ifstream f("/proc/cpuinfo");
  std::string line;
  // x86: "model name"; aarch64 kernels print "CPU implementer"/"CPU part" and sometimes a
  // "Hardware" or "Model" line instead.
  std::string found;
  while (std::getline(f, line)) {
    for (const char* key : {"model name", "Model", "Hardware"}) {
      const std::string k = key;
      if (line.rfind(k, 0) == 0 && line.find(':') != std::string::npos &&
          line.substr(0, line.find(':')).find_last_not_of(" \t") + 1 == k.size()) {
        std::string v = line.substr(line.find(':') + 1);
        v.erase(0, v.find_first_not_of(" \t"));
        if (!v.empty() && found.empty()) found = v;
      }
    }
  }
  return found.empty() ? "unknown" : found;
}

// Cache size in bytes of the given level (2 or 3) from sysfs, else sysconf, else 0.
std::size_t cache_bytes(int level) {
  for (int i = 0; i < 8; ++i) {
    const std::string dir = "/sys/devices/system/cpu/cpu0/cache/index" + std::to_string(i) + "/";
    std::ifstream lv(dir + "level"), ty(dir + "type"), sz(dir + "size");
    int l = 0;
    std::string type, size;
    if (!(lv >> l) || !(ty >> type) || !(sz >> size)) continue;
    if (l != level || type == "Instruction") continue;
    std::size_t v = std::strtoull(size.c_str(), nullptr, 10);
    if (size.back() == 'K') v <<= 10;
    if (size.back() == 'M') v <<= 20;
    if (v) return v;
  }
#ifdef _SC_LEVEL2_CACHE_SIZE
  const long v = sysconf(level == 2 ? _SC_LEVEL2_CACHE_SIZE : _SC_LEVEL3_CACHE_SIZE);
  if (v > 0) return static_cast<std::size_t>(v);
#endif
  return 0;
}

std::string compiler() {
#if defined(__clang__)
  return std::string("clang ") + __clang_version__;
#elif defined(__GNUC__)
  return std::string("g++ ") + __VERSION__;
#else
  return "unknown";
#endif
}

std::string load_average() {
  std::ifstream f("/proc/loadavg");
  double a = -1, b = -1, c = -1;
  if (!(f >> a >> b >> c)) return "unknown";
  char s[64];
  std::snprintf(s, sizeof s, "%.2f %.2f %.2f", a, b, c);
  return s;
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  char s[32];
  std::strftime(s, sizeof s, "%Y-%m-%d %H:%M UTC", std::gmtime(&t));
  return s;
}

// ---- bandwidth ----

__attribute__((noinline)) void stream_copy(const float* __restrict a, float* __restrict c,
                                           std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) c[i] = a[i];
}
__attribute__((noinline)) void stream_triad(float* __restrict a, const float* __restrict b,
                                            const float* __restrict c, float s, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) a[i] = b[i] + s * c[i];
}

struct Bandwidth {
  std::size_t array_bytes = 0; // per array
  double copy_gbs = 0, triad_gbs = 0;
  double best() const { return std::max(copy_gbs, triad_gbs); }
};

// Copy and triad over arrays of n floats each: GB/s (1e9 B/s) from the best CPU time of
// `samples` samples, each `reps` passes (about 256 MB of traffic, at least one pass). The best,
// as STREAM reports it: the machine's capability, which other load only ever lowers.
Bandwidth measure_bandwidth(std::size_t n, int samples) {
  std::vector<float> a(n, 1.0f), b(n, 2.0f), c(n, 0.5f);
  const int reps = static_cast<int>(std::max<std::size_t>(1, (256u << 20) / (12 * n)));
  auto run = [&](auto&& pass, double bytes_per_pass) {
    pass(); // warm-up: pages, caches
    std::vector<double> ms;
    for (int s = 0; s < samples; ++s) {
      const double c0 = thread_cpu_ms();
      for (int r = 0; r < reps; ++r) pass();
      ms.push_back(thread_cpu_ms() - c0);
    }
    return bytes_per_pass * reps / (*std::min_element(ms.begin(), ms.end()) * 1e-3) / 1e9;
  };
  Bandwidth bw;
  bw.array_bytes = n * sizeof(float);
  bw.copy_gbs = run([&] { stream_copy(a.data(), c.data(), n); }, 8.0 * double(n));
  bw.triad_gbs =
      run([&] { stream_triad(a.data(), b.data(), c.data(), 3.0f, n); }, 12.0 * double(n));
  if (!(a[n / 2] > 0)) std::fputs("", stderr); // keeps the arrays observable
  return bw;
}

// Triad on `threads` threads, each over its own arrays of n floats: GB/s from wall time (the
// best of 5 samples of all threads' passes).
double triad_threads_gbs(std::size_t n, int threads) {
  std::vector<std::vector<float>> a(threads, std::vector<float>(n, 1.0f)),
      b(threads, std::vector<float>(n, 2.0f)), c(threads, std::vector<float>(n, 0.5f));
  auto all = [&] {
    std::vector<std::thread> ts;
    for (int t = 0; t < threads; ++t)
      ts.emplace_back([&, t] {
        stream_triad(a[static_cast<std::size_t>(t)].data(), b[static_cast<std::size_t>(t)].data(),
                     c[static_cast<std::size_t>(t)].data(), 3.0f, n);
      });
    for (auto& t : ts) t.join();
  };
  all();
  std::vector<double> ms;
  for (int s = 0; s < 5; ++s) {
    const auto t0 = std::chrono::steady_clock::now();
    all();
    ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  return 12.0 * double(n) * threads / (*std::min_element(ms.begin(), ms.end()) * 1e-3) / 1e9;
}

// ---- micro-kernel peak ----

double kernel_peak_gflops(const ss::detail::MicroKernel& k, int samples, int K) {
  std::vector<float> a(static_cast<std::size_t>(K) * k.mr), b(static_cast<std::size_t>(K) * k.nr),
      out(static_cast<std::size_t>(k.mr) * k.nr);
  for (std::size_t i = 0; i < a.size(); ++i) a[i] = 1e-3f * float(i % 97);
  for (std::size_t i = 0; i < b.size(); ++i) b[i] = 1e-3f * float(i % 89);
  const double flop = 2.0 * k.mr * k.nr * K;
  const int calls = static_cast<int>(std::max(1.0, 1e8 / flop)); // about 0.1 GFLOP per sample
  float sink = 0;
  auto sample = [&] {
    for (int i = 0; i < calls; ++i) {
      k.fn(K, a.data(), b.data(), out.data());
      sink += out[static_cast<std::size_t>(i) % out.size()];
    }
  };
  sample();
  std::vector<double> ms;
  for (int s = 0; s < samples; ++s) {
    const double c0 = thread_cpu_ms();
    sample();
    ms.push_back(thread_cpu_ms() - c0);
  }
  if (sink == -1.0f) std::fputs("", stderr);
  return flop * calls / (*std::min_element(ms.begin(), ms.end()) * 1e-3) / 1e9; // best, as above
}

// ---- stages ----

enum class Level { l2, llc, dram };
const char* level_name(Level l) {
  return l == Level::l2 ? "L2" : l == Level::llc ? "LLC" : "DRAM";
}

struct Stage {
  std::string name;
  double bytes = 0, flops = 0, working_set = 0; // working_set: bytes of distinct arrays
  double executed = 0; // GEMM FLOPs as the library runs them (DenseNet stages; densenet_stages)
  double measured_ms = 0;
  // filled by the floor computation
  Level level = Level::dram;
  double memory_ms = 0, compute_ms = 0, floor_ms = 0;
  bool compute_bound = false;
  bool sum = false; // a sum of stages (forward, frame): floor = sum of its parts' floors
};

// The DenseNet stages' bytes and FLOPs at a 3 x h x w input (the bytes model above), and their
// GEMM FLOPs as the library executes them: the 3x3 convolutions by the method DenseNet's
// automatic choice takes per block (winograd.hpp): F(t x t, 3x3) is (t + 2)^2 GEMMs of growth
// x inner over the tile count, the direct method runs on the padded grid (2 extra columns per
// row); conv0 by F(3x3, 4x4) where DenseNet's automatic choice takes it (winograd_conv0_pays:
// 36 GEMMs of init_features x 12 phase planes over the 3 x 3 tiles), else on its grid of pitch
// w0 + 3. The partly empty last GEMM panels, the Winograd transforms and the element-wise work
// are not counted.
std::vector<Stage> densenet_stages(const ss::DenseNet& net, int h, int w) {
  const ss::DenseNetArchitecture& a = net.architecture();
  const int nr = ss::detail::select_micro_kernel(ss::GemmKernelKind::automatic).nr;
  constexpr double f = 4.0;
  std::vector<Stage> out;
  const int h0 = (h - 1) / 2 + 1, w0 = (w - 1) / 2 + 1;
  int H = (h0 - 1) / 2 + 1, W = (w0 - 1) / 2 + 1;
  {
    Stage s{"conv0+pool0"};
    const double in = 3.0 * h * w, wts = a.init_features * 147.0,
                 c0 = double(a.init_features) * h0 * w0, p0 = double(a.init_features) * H * W;
    s.bytes = f * (in + wts + 2 * c0 + p0);
    s.working_set = f * (in + wts + c0 + p0);
    s.flops = 2.0 * wts * h0 * w0;
    const double tiles = double((h0 + 2) / 3) * ((w0 + 2) / 3);
    s.executed = ss::detail::winograd_conv0_pays(h0, w0, nr)
                     ? 2.0 * 36 * a.init_features * 12 * tiles
                     : 2.0 * wts * h0 * (w0 + 3);
    out.push_back(s);
  }
  const int k = a.growth_rate, inner = a.bn_size * a.growth_rate;
  int c = a.init_features;
  for (std::size_t b = 0; b < a.block_config.size(); ++b) {
    Stage s{"block" + std::to_string(b + 1)};
    const double hw = double(H) * W;
    double wts = 0;
    const int tile = ss::detail::winograd_tile(H, W, k, nr, net.weights_stream());
    const double conv3x3 = tile ? 2.0 * (tile + 2) * (tile + 2) * k * inner *
                                      (double((H + tile - 1) / tile) * ((W + tile - 1) / tile))
                                : 2.0 * k * inner * 9.0 * H * (W + 2);
    for (int l = 0; l < a.block_config[b]; ++l) {
      const double cin = c + l * k;
      const double lw = inner * cin + k * inner * 9.0;
      wts += lw;
      s.bytes += f * (cin * hw + 2.0 * inner * hw + k * hw + lw);
      s.flops += 2.0 * (inner * cin * hw + k * inner * 9.0 * hw);
      s.executed += 2.0 * inner * cin * hw + conv3x3;
    }
    c += a.block_config[b] * k;
    s.working_set = f * (double(c) * hw + inner * hw + wts);
    out.push_back(s);
    if (b + 1 < a.block_config.size()) {
      Stage t{"transition" + std::to_string(b + 1)};
      const double ohw = double(H / 2) * (W / 2), tw = double(c / 2) * c;
      t.bytes = f * (double(c) * hw + double(c / 2) * ohw + tw);
      t.working_set = t.bytes;
      t.flops = 2.0 * tw * ohw;
      t.executed = t.flops;
      out.push_back(t);
      c /= 2;
      H /= 2;
      W /= 2;
    }
  }
  Stage hd{"head"};
  const double fc = double(a.num_classes) * c;
  hd.bytes = f * (double(c) * H * W + fc + a.num_classes);
  hd.working_set = hd.bytes;
  hd.flops = 2.0 * fc;
  hd.executed = hd.flops;
  out.push_back(hd);
  return out;
}

// "growth 12, blocks 4-4-4, ...; block1 22x40 F(4x4, 3x3), ..." at a 3 x h x w input.
std::string describe(const ss::DenseNet& net, int h, int w) {
  const ss::DenseNetArchitecture& a = net.architecture();
  const int nr = ss::detail::select_micro_kernel(ss::GemmKernelKind::automatic).nr;
  std::string blocks, sizes;
  int H = ((h - 1) / 2 + 1 - 1) / 2 + 1, W = ((w - 1) / 2 + 1 - 1) / 2 + 1;
  for (std::size_t b = 0; b < a.block_config.size(); ++b) {
    // Appended piece by piece: GCC 12 warns (-Wrestrict, a false positive) on the one-line sum.
    if (b) {
      blocks += '-';
      sizes += ", ";
    }
    blocks += std::to_string(a.block_config[b]);
    const int tile = ss::detail::winograd_tile(H, W, a.growth_rate, nr, net.weights_stream());
    sizes += "block";
    sizes += std::to_string(b + 1);
    sizes += ' ';
    sizes += std::to_string(H);
    sizes += 'x';
    sizes += std::to_string(W);
    if (tile) {
      sizes += " F(";
      sizes += std::to_string(tile);
      sizes += 'x';
      sizes += std::to_string(tile);
      sizes += ", 3x3)";
    } else {
      sizes += " direct 3x3";
    }
    H /= 2;
    W /= 2;
  }
  return "DenseNet growth " + std::to_string(a.growth_rate) + ", blocks " + blocks + ", " +
         std::to_string(a.init_features) + " initial features, bn_size " +
         std::to_string(a.bn_size) + ", " + std::to_string(a.num_classes) + " classes; " + sizes;
}

struct Result {
  std::string cpu, isa, compiler, date, load_before, load_after, model;
  std::size_t l2 = 0, llc = 0;
  Bandwidth bw_l2, bw_llc, bw_dram;
  double dram_2t_gbs = 0, peak_gflops = 0;
  int inner = 0;           // the dense layers' bottleneck width (the Winograd GEMMs' K)
  double inner_gflops = 0; // the micro-kernel at K = inner
  int frame_w = 0, frame_h = 0, in_w = 0, in_h = 0, frames = 0, rounds = 0;
  std::string architecture; // the network and each block's size and 3x3 method
  std::vector<Stage> stages;
  double staged_sum_ms = 0; // the DenseNet stages' medians added up
  double pipeline_ms = 0;   // TouchPipeline::update (segment + the rest)
};

void apply_floors(Result& r) {
  auto bw = [&](Level l) {
    return l == Level::l2 ? r.bw_l2.best() : l == Level::llc ? r.bw_llc.best() : r.bw_dram.best();
  };
  for (Stage& s : r.stages) {
    if (s.sum) continue;
    s.level = (r.l2 && s.working_set <= double(r.l2))     ? Level::l2
              : (r.llc && s.working_set <= double(r.llc)) ? Level::llc
                                                          : Level::dram;
    s.memory_ms = s.bytes / (bw(s.level) * 1e9) * 1e3;
    s.compute_ms = s.flops / (r.peak_gflops * 1e9) * 1e3;
    s.compute_bound = s.compute_ms > s.memory_ms;
    s.floor_ms = std::max(s.memory_ms, s.compute_ms);
  }
}

std::string fmt(const char* f, double v) {
  char s[64];
  std::snprintf(s, sizeof s, f, v);
  return s;
}

std::string markdown(const Result& r) {
  std::ostringstream o;
  o << begin_marker << "\n";
  o << "Generated by `bench/roofline` on " << r.date << "; do not edit by hand.\n\n";
  o << "- Machine: " << r.cpu << "; L2 " << (r.l2 >> 10) << " KiB, LLC " << (r.llc >> 10)
    << " KiB (per cpu0's sysfs); compiler " << r.compiler << ".\n";
  o << "- GEMM micro-kernel: **" << r.isa << "**, peak " << fmt("%.1f", r.peak_gflops)
    << " GFLOP/s on one core (K = 256 panels in cache, best of 25 samples); at K = " << r.inner
    << " (the bottleneck width: the K of every Winograd GEMM) " << fmt("%.1f", r.inner_gflops)
    << " GFLOP/s.\n";
  auto bwline = [&](const char* what, const Bandwidth& b) {
    o << "  - " << what << " (" << fmt("%.2f", double(b.array_bytes) / (1 << 20))
      << " MiB per array): copy " << fmt("%.1f", b.copy_gbs) << ", triad "
      << fmt("%.1f", b.triad_gbs) << " GB/s\n";
  };
  o << "- Memory bandwidth, one core (stream-style, best CPU time of the samples; the floors use "
       "the larger of copy and triad):\n";
  bwline("L2", r.bw_l2);
  bwline("LLC", r.bw_llc);
  bwline("DRAM", r.bw_dram);
  o << "  - DRAM triad on 2 threads (wall time; not used by the floors): "
    << fmt("%.1f", r.dram_2t_gbs) << " GB/s\n";
  o << "- Model " << r.model << ": frames " << r.frame_w << "x" << r.frame_h
    << " (robot rig generator), network input " << r.in_w << "x" << r.in_h << "; " << r.frames
    << " frames x " << r.rounds << " rounds, 1 thread, median CPU ms per frame.\n";
  o << "- Network: " << r.architecture << ".\n";
  o << "- Load average (1/5/15 min) before / after: " << r.load_before << " / " << r.load_after
    << ".\n\n";
  o << "| stage | MB moved | working set MB | MFLOP | bound | floor ms | measured ms | "
       "measured / floor | MFLOP executed | GFLOP/s executed | of kernel peak |\n";
  o << "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Stage& s : r.stages) {
    const bool rate = s.executed > 0 && s.name != "frame (whole)";
    const std::string name = s.sum ? "**" + s.name + "**" : s.name;
    const double gflops = s.executed / s.measured_ms / 1e6;
    o << "| " << name << " | " << fmt("%.3f", s.bytes / 1e6) << " | "
      << (s.sum ? std::string("-") : fmt("%.3f", s.working_set / 1e6)) << " | "
      << (s.flops > 0 ? fmt("%.2f", s.flops / 1e6) : std::string("-")) << " | "
      << (s.sum             ? std::string("sum of stages")
          : s.compute_bound ? std::string("compute")
                            : std::string("memory (") + level_name(s.level) + ")")
      << " | " << fmt("%.4f", s.floor_ms) << " | " << fmt("%.4f", s.measured_ms) << " | "
      << fmt("%.1f", s.measured_ms / s.floor_ms) << " | "
      << (rate ? fmt("%.2f", s.executed / 1e6) : std::string("-")) << " | "
      << (rate ? fmt("%.1f", gflops) : std::string("-")) << " | "
      << (rate ? fmt("%.0f%%", 100.0 * gflops / r.peak_gflops) : std::string("-")) << " |\n";
  }
  const Stage* fw = nullptr;
  for (const Stage& s : r.stages)
    if (s.name == "forward (whole)") fw = &s;
  o << "\nFloor = max(MB moved / bandwidth of the smallest level holding the working set, MFLOP "
       "/ kernel peak), the MFLOP counting the 3x3 convolutions as direct ones; forward and "
       "frame: the sums of their stages' floors. MFLOP executed: the GEMM work as the library "
       "runs it (Winograd's GEMMs at their tile counts, conv0's F(3x3, 4x4) over the input's "
       "phases, the direct 3x3 on its padded grid; transforms, partly empty last panels and "
       "element-wise work not "
       "counted), and its rate against the micro-kernel's peak. Bytes and FLOP model: the "
       "comment at the top of bench/roofline.cpp.\n\n";
  if (fw) {
    o << "- The DenseNet stages' medians add up to " << fmt("%.4f", r.staged_sum_ms)
      << " ms against " << fmt("%.4f", fw->measured_ms)
      << " ms for the whole forward pass (timed in the same rounds).\n";
    o << "- Forward pass: " << fmt("%.1f", fw->executed / fw->measured_ms / 1e6)
      << " GFLOP/s executed = **"
      << fmt("%.0f%%", 100.0 * fw->executed / fw->measured_ms / 1e6 / r.peak_gflops)
      << "** of the micro-kernel's peak on one core ("
      << fmt("%.1f", fw->flops / fw->measured_ms / 1e6)
      << " GFLOP/s = " << fmt("%.0f%%", 100.0 * fw->flops / fw->measured_ms / 1e6 / r.peak_gflops)
      << " counting direct-convolution FLOPs).\n";
  }
  o << "- TouchPipeline::update took " << fmt("%.4f", r.pipeline_ms)
    << " ms; \"pipeline (rest)\" is that minus the segmenter's median.\n";
  o << end_marker << "\n";
  return o.str();
}

std::string json(const Result& r) {
  std::ostringstream o;
  auto q = [](const std::string& s) {
    std::string t = "\"";
    for (char ch : s) {
      if (ch == '"' || ch == '\\') t += '\\';
      t += ch;
    }
    return t + "\"";
  };
  auto bwj = [&](const Bandwidth& b) {
    return "{\"array_bytes\": " + std::to_string(b.array_bytes) +
           ", \"copy_gbs\": " + fmt("%.3f", b.copy_gbs) +
           ", \"triad_gbs\": " + fmt("%.3f", b.triad_gbs) + "}";
  };
  o << "{\"cpu\": " << q(r.cpu) << ", \"kernel\": " << q(r.isa)
    << ", \"compiler\": " << q(r.compiler) << ", \"date\": " << q(r.date)
    << ", \"load_before\": " << q(r.load_before) << ", \"load_after\": " << q(r.load_after)
    << ", \"l2_bytes\": " << r.l2 << ", \"llc_bytes\": " << r.llc
    << ", \"bandwidth\": {\"l2\": " << bwj(r.bw_l2) << ", \"llc\": " << bwj(r.bw_llc)
    << ", \"dram\": " << bwj(r.bw_dram)
    << ", \"dram_triad_2_threads_gbs\": " << fmt("%.3f", r.dram_2t_gbs)
    << "}, \"kernel_peak_gflops\": " << fmt("%.3f", r.peak_gflops)
    << ", \"kernel_gflops_at_inner_k\": [" << r.inner << ", " << fmt("%.3f", r.inner_gflops) << "]"
    << ", \"model\": " << q(r.model) << ", \"frame\": [" << r.frame_w << ", " << r.frame_h
    << "], \"input\": [" << r.in_w << ", " << r.in_h << "], \"stages\": [";
  for (std::size_t i = 0; i < r.stages.size(); ++i) {
    const Stage& s = r.stages[i];
    o << (i ? ", " : "") << "{\"stage\": " << q(s.name) << ", \"bytes\": " << fmt("%.0f", s.bytes)
      << ", \"working_set_bytes\": " << fmt("%.0f", s.working_set)
      << ", \"flops\": " << fmt("%.0f", s.flops)
      << ", \"level\": " << q(s.sum ? "sum" : level_name(s.level))
      << ", \"memory_floor_ms\": " << fmt("%.5f", s.memory_ms)
      << ", \"compute_floor_ms\": " << fmt("%.5f", s.compute_ms)
      << ", \"floor_ms\": " << fmt("%.5f", s.floor_ms)
      << ", \"measured_cpu_ms\": " << fmt("%.5f", s.measured_ms) << "}";
  }
  o << "]}\n";
  return o.str();
}

// The document with its marked part replaced by `table` (a new file: the table alone).
std::string replace_marked(const std::filesystem::path& path, const std::string& table) {
  if (!std::filesystem::exists(path)) return table;
  std::ifstream f(path, std::ios::binary);
  if (!f) throw ss::IoError(path.string() + ": cannot be read");
  std::ostringstream buf;
  buf << f.rdbuf();
  const std::string doc = buf.str();
  const auto b = doc.find(begin_marker);
  const auto e = doc.find(end_marker);
  if (b == std::string::npos || e == std::string::npos || e < b)
    throw ss::InvalidArgument("--out " + path.string() + ": the file has no \"" + begin_marker +
                              "\" ... \"" + end_marker +
                              "\" lines to replace; expected them (or a new file)");
  auto after = e + std::string_view(end_marker).size();
  if (after < doc.size() && doc[after] == '\n') ++after;
  return doc.substr(0, b) + table + doc.substr(after);
}

} // namespace

int main(int argc, char** argv) {
  bench::FrameOptions options{.frames = 20};
  const std::string& model_path = options.model_path;
  const int &frames = options.frames, &rounds = options.rounds;
  const bool& want_json = options.json;
  std::string out_path;
  int dram_mb = 0;
  return cli::run("roofline", [&] {
    cli::Parser p("roofline", "");
    bench::declare_frame_options(p, usage, options);
    p.option("--dram-mb", "M", "MB per array of the DRAM stream loop", dram_mb).range(1, 100000);
    p.option("--out", "PATH", "replace the marked table in PATH", out_path)
        .check([](const std::string& path) {
          if (path.empty()) throw cli::UsageError("--out needs a non-empty path");
        });
    p.parse(argc, argv);
    if (!out_path.empty()) replace_marked(out_path, ""); // a bad --out fails before measuring

    Result r;
    r.load_before = load_average();
    r.date = utc_now();
    r.cpu = cpu_model();
    r.compiler = compiler();
    r.l2 = cache_bytes(2);
    r.llc = cache_bytes(3);
    if (!r.llc) r.llc = r.l2; // no L3: the L2 is the last level
    r.model = model_path;
    r.frames = frames;
    r.rounds = rounds;

    cv::setNumThreads(1);
    const ss::ModelFile model = ss::ModelFile::load(model_path);
    auto classifier = ss::make_densenet_classifier(model, {.threads = 1});
    ss::DenseNet& net = classifier.backend();
    r.isa = net.kernel_name();

    // Bandwidth: triad's 3 arrays fill half of the level (L2, LLC); DRAM arrays twice the LLC.
    const std::size_t l2 = r.l2 ? r.l2 : (256u << 10), llc = r.llc ? r.llc : (8u << 20);
    r.bw_l2 = measure_bandwidth(l2 / 2 / 3 / sizeof(float), 7);
    r.bw_llc = measure_bandwidth(llc / 2 / 3 / sizeof(float), 7);
    const std::size_t dram_bytes =
        dram_mb ? std::size_t(dram_mb) << 20 : std::max<std::size_t>(2 * llc, 32u << 20);
    r.bw_dram = measure_bandwidth(dram_bytes / sizeof(float), 5);
    r.dram_2t_gbs = triad_threads_gbs(dram_bytes / sizeof(float) / 2, 2);
    const ss::detail::MicroKernel mk =
        ss::detail::select_micro_kernel(ss::GemmKernelKind::automatic);
    r.peak_gflops = kernel_peak_gflops(mk, 25, 256);
    r.inner = model.architecture.bn_size * model.architecture.growth_rate;
    r.inner_gflops = kernel_peak_gflops(mk, 25, r.inner);

    // The frames and stages, as bench/frame_time.cpp.
    const bench::RobotFrames fixture(frames);
    const ss::SimCalibration& calibration = fixture.calibration;
    const std::vector<cv::Mat>& images = fixture.frames;
    ss::Segmenter segmenter = ss::segmenter_from(calibration);
    ss::Segmentation seg;
    ss::TouchPipeline pipeline(ss::segmenter_from(calibration));
    ss::FrameEncoder encoder(ss::FrameEncoder::Config{model.preprocess, ss::ChannelOrder::bgr});
    ss::Tensor input;
    encoder.run(images[0], input);
    r.frame_w = images[0].cols;
    r.frame_h = images[0].rows;
    r.in_w = input.w();
    r.in_h = input.h();
    ss::Classification result;
    double t_ms = 0;
    std::size_t sink = 0;
    auto frame = [&](int i) -> const cv::Mat& { return images[static_cast<std::size_t>(i)]; };

    const double px = double(r.frame_w) * r.frame_h;
    Stage segment{"segment"};
    segment.bytes = 26 * px;
    segment.working_set = 20 * px;
    Stage rest{"pipeline (rest)"};
    rest.bytes = double((r.frame_h + 3) / 4) * r.frame_w * 3;
    rest.working_set = rest.bytes;
    Stage encode{"encode"};
    encode.bytes = 3 * px + 12.0 * r.in_w * r.in_h;
    encode.working_set = encode.bytes;
    std::vector<Stage> net_stages = densenet_stages(net, input.h(), input.w());
    const int n_net = net.stage_count();
    for (int s = 0; s < n_net; ++s)
      if (net.stage_name(s) != net_stages[static_cast<std::size_t>(s)].name)
        throw ss::Error("roofline: stage " + std::to_string(s) + " is " + net.stage_name(s) +
                        ", the bytes model's is " + net_stages[static_cast<std::size_t>(s)].name);
    Stage forward{"forward (whole)"};
    forward.sum = true;
    for (const Stage& s : net_stages) {
      forward.bytes += s.bytes;
      forward.flops += s.flops;
      forward.executed += s.executed;
    }
    Stage whole{"frame (whole)"};
    whole.sum = true;
    whole.bytes = segment.bytes + rest.bytes + encode.bytes + forward.bytes;
    whole.flops = forward.flops;

    // Every measurement once per round, one after the other, so all of them see the same load;
    // one warm-up round first. The DenseNet stages are timed in sequence inside staged passes
    // (each stage's inputs as warm as in a forward pass), each stage with its own clock reads.
    // At least 20 passes per round: a round of the shortest stage is then not clock overhead.
    const int passes = std::max(frames, 20);
    std::vector<std::vector<double>> t_seg, t_pipe, t_enc, t_fwd, t_frame, t_net(n_net);
    std::vector<double> per_stage(static_cast<std::size_t>(n_net));
    auto timed = [](int calls, const std::function<void(int)>& step) {
      const double c0 = thread_cpu_ms();
      for (int i = 0; i < calls; ++i) step(i);
      return (thread_cpu_ms() - c0) / calls;
    };
    for (int round = -1; round < rounds; ++round) {
      const double seg_ms = timed(frames, [&](int i) {
        segmenter.segment(frame(i), seg);
        sink += seg.shadows.size();
      });
      const double pipe_ms = timed(
          frames, [&](int i) { sink += pipeline.update(frame(i), t_ms += 33.0).tracks.size(); });
      const double enc_ms = timed(frames, [&](int i) { encoder.run(frame(i), input); });
      encoder.run(images[0], input);
      std::fill(per_stage.begin(), per_stage.end(), 0.0);
      for (int p = 0; p < passes; ++p) {
        net.begin_stages(input);
        for (int s = 0; s < n_net; ++s) {
          const double c0 = thread_cpu_ms();
          net.run_stage(s);
          per_stage[static_cast<std::size_t>(s)] += thread_cpu_ms() - c0;
        }
        sink += static_cast<std::size_t>(net.stage_logits()[0] > 0);
      }
      const double fwd_ms =
          timed(passes, [&](int) { sink += static_cast<std::size_t>(net.logits(input)[0] > 0); });
      const double frame_ms = timed(frames, [&](int i) {
        sink += pipeline.update(frame(i), t_ms += 33.0).tracks.size();
        classifier.classify(frame(i), result);
        sink += static_cast<std::size_t>(result.index);
      });
      if (round < 0) continue; // warm-up
      t_seg.push_back({seg_ms});
      t_pipe.push_back({pipe_ms});
      t_enc.push_back({enc_ms});
      t_fwd.push_back({fwd_ms});
      t_frame.push_back({frame_ms});
      for (int s = 0; s < n_net; ++s)
        t_net[static_cast<std::size_t>(s)].push_back(per_stage[static_cast<std::size_t>(s)] /
                                                     passes);
    }
    auto med = [](const std::vector<std::vector<double>>& v) {
      std::vector<double> x;
      for (const auto& e : v) x.push_back(e[0]);
      return median(x);
    };
    segment.measured_ms = med(t_seg);
    rest.measured_ms = std::max(0.0, med(t_pipe) - segment.measured_ms);
    encode.measured_ms = med(t_enc);
    forward.measured_ms = med(t_fwd);
    whole.measured_ms = med(t_frame);
    r.staged_sum_ms = 0;
    for (int s = 0; s < n_net; ++s) {
      net_stages[static_cast<std::size_t>(s)].measured_ms =
          median(t_net[static_cast<std::size_t>(s)]);
      r.staged_sum_ms += net_stages[static_cast<std::size_t>(s)].measured_ms;
    }
    r.architecture = describe(net, input.h(), input.w());
    r.pipeline_ms = med(t_pipe);

    r.stages = {segment, rest, encode};
    r.stages.insert(r.stages.end(), net_stages.begin(), net_stages.end());
    r.stages.push_back(forward);
    r.stages.push_back(whole);
    apply_floors(r);
    // Sums: forward = the DenseNet stages' floors; frame = segment + rest + encode + forward.
    const auto nn = static_cast<std::size_t>(n_net);
    Stage& fw = r.stages[3 + nn];
    Stage& fr = r.stages[4 + nn];
    fw.floor_ms = 0;
    for (std::size_t i = 3; i < 3 + nn; ++i) fw.floor_ms += r.stages[i].floor_ms;
    fr.floor_ms = r.stages[0].floor_ms + r.stages[1].floor_ms + r.stages[2].floor_ms + fw.floor_ms;
    r.load_after = load_average();

    if (want_json) std::cout << json(r);
    const std::string table = markdown(r);
    if (!out_path.empty()) {
      ss::write_file_atomically(out_path, replace_marked(out_path, table));
      std::cerr << "roofline: wrote " << out_path << " (checksum " << sink << ")\n";
    } else if (!want_json) {
      std::cout << table;
    }
    return 0;
  });
}
