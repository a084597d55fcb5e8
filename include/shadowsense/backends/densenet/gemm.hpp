// Packed single-precision GEMM for the DenseNet forward pass: C (M x N) = A (M x K) * B (K x N)
// with A (the weights) packed once at load time and B produced panel by panel by a caller's
// "packer" (fused im2col / BatchNorm+ReLU / average pooling), so no im2col matrix is ever
// materialised. Micro-kernels for AVX-512 and AVX2+FMA are compiled with function-level target
// attributes and picked at run time, so the library needs no -march flag; a portable kernel is
// the fallback. Summation order differs from PyTorch's only by float rounding.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/core/version.hpp>

#include <algorithm>
#include <condition_variable>
#include <cstddef>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define SHADOWSENSE_X86_KERNELS 1
#include <immintrin.h>
#else
#define SHADOWSENSE_X86_KERNELS 0
#endif

SHADOWSENSE_NAMESPACE_BEGIN

// Which GEMM micro-kernel the forward pass uses. automatic picks the best one the CPU runs.
enum class GemmKernelKind { automatic, avx512, avx2, portable };

namespace detail {

using MicroKernelFn = void (*)(int K, const float* a, const float* b, float* out);

struct MicroKernel {
  GemmKernelKind kind;
  int mr; // rows of C per tile (A panel height)
  int nr; // columns of C per tile (B panel width)
  MicroKernelFn fn;
  const char* name;
};

// out (MR x NR, row-major) = A panel (K x MR interleaved) * B panel (K x NR).
template <int MR, int NR>
inline void micro_kernel_portable(int K, const float* a, const float* b, float* out) {
  float acc[MR][NR] = {};
  for (int k = 0; k < K; ++k, a += MR, b += NR)
    for (int r = 0; r < MR; ++r)
      for (int j = 0; j < NR; ++j) acc[r][j] += a[r] * b[j];
  std::memcpy(out, acc, sizeof(acc));
}

#if SHADOWSENSE_X86_KERNELS
__attribute__((target("avx512f"))) inline void micro_kernel_avx512(int K, const float* a,
                                                                   const float* b, float* out) {
  constexpr int MR = 8;
  __m512 c00 = _mm512_setzero_ps(), c01 = c00, c10 = c00, c11 = c00, c20 = c00, c21 = c00,
         c30 = c00, c31 = c00, c40 = c00, c41 = c00, c50 = c00, c51 = c00, c60 = c00, c61 = c00,
         c70 = c00, c71 = c00;
  for (int k = 0; k < K; ++k, a += MR, b += 32) {
    const __m512 b0 = _mm512_loadu_ps(b);
    const __m512 b1 = _mm512_loadu_ps(b + 16);
    __m512 x = _mm512_set1_ps(a[0]);
    c00 = _mm512_fmadd_ps(x, b0, c00);
    c01 = _mm512_fmadd_ps(x, b1, c01);
    x = _mm512_set1_ps(a[1]);
    c10 = _mm512_fmadd_ps(x, b0, c10);
    c11 = _mm512_fmadd_ps(x, b1, c11);
    x = _mm512_set1_ps(a[2]);
    c20 = _mm512_fmadd_ps(x, b0, c20);
    c21 = _mm512_fmadd_ps(x, b1, c21);
    x = _mm512_set1_ps(a[3]);
    c30 = _mm512_fmadd_ps(x, b0, c30);
    c31 = _mm512_fmadd_ps(x, b1, c31);
    x = _mm512_set1_ps(a[4]);
    c40 = _mm512_fmadd_ps(x, b0, c40);
    c41 = _mm512_fmadd_ps(x, b1, c41);
    x = _mm512_set1_ps(a[5]);
    c50 = _mm512_fmadd_ps(x, b0, c50);
    c51 = _mm512_fmadd_ps(x, b1, c51);
    x = _mm512_set1_ps(a[6]);
    c60 = _mm512_fmadd_ps(x, b0, c60);
    c61 = _mm512_fmadd_ps(x, b1, c61);
    x = _mm512_set1_ps(a[7]);
    c70 = _mm512_fmadd_ps(x, b0, c70);
    c71 = _mm512_fmadd_ps(x, b1, c71);
  }
  _mm512_storeu_ps(out + 0, c00);
  _mm512_storeu_ps(out + 16, c01);
  _mm512_storeu_ps(out + 32, c10);
  _mm512_storeu_ps(out + 48, c11);
  _mm512_storeu_ps(out + 64, c20);
  _mm512_storeu_ps(out + 80, c21);
  _mm512_storeu_ps(out + 96, c30);
  _mm512_storeu_ps(out + 112, c31);
  _mm512_storeu_ps(out + 128, c40);
  _mm512_storeu_ps(out + 144, c41);
  _mm512_storeu_ps(out + 160, c50);
  _mm512_storeu_ps(out + 176, c51);
  _mm512_storeu_ps(out + 192, c60);
  _mm512_storeu_ps(out + 208, c61);
  _mm512_storeu_ps(out + 224, c70);
  _mm512_storeu_ps(out + 240, c71);
}

__attribute__((target("avx2,fma"))) inline void micro_kernel_avx2(int K, const float* a,
                                                                  const float* b, float* out) {
  constexpr int MR = 4;
  __m256 c00 = _mm256_setzero_ps(), c01 = c00, c02 = c00, c10 = c00, c11 = c00, c12 = c00,
         c20 = c00, c21 = c00, c22 = c00, c30 = c00, c31 = c00, c32 = c00;
  for (int k = 0; k < K; ++k, a += MR, b += 24) {
    const __m256 b0 = _mm256_loadu_ps(b);
    const __m256 b1 = _mm256_loadu_ps(b + 8);
    const __m256 b2 = _mm256_loadu_ps(b + 16);
    __m256 x = _mm256_broadcast_ss(a + 0);
    c00 = _mm256_fmadd_ps(x, b0, c00);
    c01 = _mm256_fmadd_ps(x, b1, c01);
    c02 = _mm256_fmadd_ps(x, b2, c02);
    x = _mm256_broadcast_ss(a + 1);
    c10 = _mm256_fmadd_ps(x, b0, c10);
    c11 = _mm256_fmadd_ps(x, b1, c11);
    c12 = _mm256_fmadd_ps(x, b2, c12);
    x = _mm256_broadcast_ss(a + 2);
    c20 = _mm256_fmadd_ps(x, b0, c20);
    c21 = _mm256_fmadd_ps(x, b1, c21);
    c22 = _mm256_fmadd_ps(x, b2, c22);
    x = _mm256_broadcast_ss(a + 3);
    c30 = _mm256_fmadd_ps(x, b0, c30);
    c31 = _mm256_fmadd_ps(x, b1, c31);
    c32 = _mm256_fmadd_ps(x, b2, c32);
  }
  _mm256_storeu_ps(out + 0, c00);
  _mm256_storeu_ps(out + 8, c01);
  _mm256_storeu_ps(out + 16, c02);
  _mm256_storeu_ps(out + 24, c10);
  _mm256_storeu_ps(out + 32, c11);
  _mm256_storeu_ps(out + 40, c12);
  _mm256_storeu_ps(out + 48, c20);
  _mm256_storeu_ps(out + 56, c21);
  _mm256_storeu_ps(out + 64, c22);
  _mm256_storeu_ps(out + 72, c30);
  _mm256_storeu_ps(out + 80, c31);
  _mm256_storeu_ps(out + 88, c32);
}
#endif

// Element-wise loops of the forward pass (BatchNorm+ReLU packing, bias+ReLU epilogues,
// pooled packing), compiled once per instruction set like the micro-kernels: at AVX-512 GEMM
// speed, SSE2 versions of these loops would cost as much as the convolutions.
#define SHADOWSENSE_DEFINE_VECTOR_OPS(SUFFIX, ATTR)                                                \
  ATTR inline void affine_relu_##SUFFIX(const float* s, float* d, int n, float sc, float sh) {     \
    for (int i = 0; i < n; ++i) {                                                                  \
      const float v = s[i] * sc + sh;                                                              \
      d[i] = v > 0.0f ? v : 0.0f;                                                                  \
    }                                                                                              \
  }                                                                                                \
  ATTR inline void bias_relu_##SUFFIX(const float* s, float* d, int n, float b) {                  \
    for (int i = 0; i < n; ++i) {                                                                  \
      const float v = s[i] + b;                                                                    \
      d[i] = v > 0.0f ? v : 0.0f;                                                                  \
    }                                                                                              \
  }                                                                                                \
  /* the 9 taps of a 3x3 convolution on the padded grid: row t = s[ky * pw + kx + j] */            \
  ATTR inline void pack3x3_##SUFFIX(const float* s, float* d, int cols, int nr, int pw) {          \
    for (int ky = 0; ky < 3; ++ky)                                                                 \
      for (int kx = 0; kx < 3; ++kx, d += nr) {                                                    \
        const float* r = s + ky * pw + kx;                                                         \
        for (int j = 0; j < cols; ++j) d[j] = r[j];                                                \
        for (int j = cols; j < nr; ++j) d[j] = 0.0f;                                               \
      }                                                                                            \
  }                                                                                                \
  /* d[j] = mean of relu(affine) over the 2x2 window at columns 2j, 2j+1 of rows r0, r1 */         \
  ATTR inline void pool_affine_relu_##SUFFIX(const float* r0, const float* r1, float* d, int n,    \
                                             float sc, float sh) {                                 \
    for (int j = 0; j < n; ++j) {                                                                  \
      float a = r0[2 * j] * sc + sh, b = r0[2 * j + 1] * sc + sh;                                  \
      float c = r1[2 * j] * sc + sh, e = r1[2 * j + 1] * sc + sh;                                  \
      a = a > 0.0f ? a : 0.0f;                                                                     \
      b = b > 0.0f ? b : 0.0f;                                                                     \
      c = c > 0.0f ? c : 0.0f;                                                                     \
      e = e > 0.0f ? e : 0.0f;                                                                     \
      d[j] = ((a + b) + (c + e)) * 0.25f;                                                          \
    }                                                                                              \
  }

SHADOWSENSE_DEFINE_VECTOR_OPS(portable, )
#if SHADOWSENSE_X86_KERNELS
SHADOWSENSE_DEFINE_VECTOR_OPS(avx512, __attribute__((target("avx512f"))))
SHADOWSENSE_DEFINE_VECTOR_OPS(avx2, __attribute__((target("avx2,fma"))))
#endif
#undef SHADOWSENSE_DEFINE_VECTOR_OPS

struct VectorOps {
  void (*affine_relu)(const float*, float*, int, float, float);
  void (*bias_relu)(const float*, float*, int, float);
  void (*pool_affine_relu)(const float*, const float*, float*, int, float, float);
  void (*pack3x3)(const float*, float*, int, int, int);
};

inline VectorOps select_vector_ops(GemmKernelKind kind) {
  switch (kind) {
#if SHADOWSENSE_X86_KERNELS
  case GemmKernelKind::avx512:
    return {&affine_relu_avx512, &bias_relu_avx512, &pool_affine_relu_avx512, &pack3x3_avx512};
  case GemmKernelKind::avx2:
    return {&affine_relu_avx2, &bias_relu_avx2, &pool_affine_relu_avx2, &pack3x3_avx2};
#endif
  default:
    return {&affine_relu_portable, &bias_relu_portable, &pool_affine_relu_portable,
            &pack3x3_portable};
  }
}

inline bool cpu_has(GemmKernelKind kind) {
  switch (kind) {
  case GemmKernelKind::portable:
    return true;
#if SHADOWSENSE_X86_KERNELS
  case GemmKernelKind::avx512:
    return __builtin_cpu_supports("avx512f");
  case GemmKernelKind::avx2:
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#endif
  default:
    return false;
  }
}

inline MicroKernel select_micro_kernel(GemmKernelKind wanted) {
  if (wanted == GemmKernelKind::automatic) {
    for (auto k : {GemmKernelKind::avx512, GemmKernelKind::avx2})
      if (cpu_has(k)) return select_micro_kernel(k);
    return select_micro_kernel(GemmKernelKind::portable);
  }
  require(cpu_has(wanted), "GEMM kernel: the requested kernel is not supported by this CPU or "
                           "compiler, expected automatic or one the CPU runs");
  switch (wanted) {
#if SHADOWSENSE_X86_KERNELS
  case GemmKernelKind::avx512:
    return {wanted, 8, 32, &micro_kernel_avx512, "avx512"};
  case GemmKernelKind::avx2:
    return {wanted, 4, 24, &micro_kernel_avx2, "avx2+fma"};
#endif
  default:
    return {GemmKernelKind::portable, 4, 16, &micro_kernel_portable<4, 16>, "portable"};
  }
}

// Weights (M x K, row-major) packed into MR-row panels, K x MR interleaved, zero-padded.
struct PackedMatrix {
  int m = 0, k = 0, mr = 0;
  std::vector<float> data;

  void pack(const float* w, int rows, int cols, int panel_rows) {
    m = rows;
    k = cols;
    mr = panel_rows;
    const int panels = (m + mr - 1) / mr;
    data.assign(static_cast<std::size_t>(panels) * mr * k, 0.0f);
    for (int p = 0; p < panels; ++p)
      for (int r = 0; r < mr && p * mr + r < m; ++r)
        for (int c = 0; c < k; ++c)
          data[(static_cast<std::size_t>(p) * k + c) * mr + r] =
              w[static_cast<std::size_t>(p * mr + r) * k + c];
  }
  const float* panel(int p) const { return data.data() + static_cast<std::size_t>(p) * k * mr; }
};

// A persistent pool: run(tasks, fn) calls fn(t) for t in [0, tasks) on the calling thread and
// the workers, and returns when all are done. No allocation per call.
class ThreadPool {
public:
  explicit ThreadPool(int threads) {
    require(threads >= 1 && threads <= 256,
            "threads is " + std::to_string(threads) + ", expected 1..256");
    for (int i = 1; i < threads; ++i) workers_.emplace_back([this] { work(); });
  }
  ~ThreadPool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (auto& t : workers_) t.join();
  }
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int size() const { return static_cast<int>(workers_.size()) + 1; }

  template <class F>
  void run(int tasks, F& fn) {
    if (workers_.empty() || tasks <= 1) {
      for (int t = 0; t < tasks; ++t) fn(t);
      return;
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ctx_ = &fn;
      call_ = [](void* c, int t) { (*static_cast<F*>(c))(t); };
      tasks_ = tasks;
      next_ = 0;
      pending_ = tasks;
      ++generation_;
    }
    wake_.notify_all();
    drain();
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return pending_ == 0; });
  }

private:
  void drain() {
    for (;;) {
      int t;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (next_ >= tasks_) return;
        t = next_++;
      }
      call_(ctx_, t);
      std::lock_guard<std::mutex> lock(mutex_);
      if (--pending_ == 0) done_.notify_all();
    }
  }
  void work() {
    unsigned long seen = 0;
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
      }
      drain();
    }
  }

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  void* ctx_ = nullptr;
  void (*call_)(void*, int) = nullptr;
  int tasks_ = 0, next_ = 0, pending_ = 0;
  unsigned long generation_ = 0;
  bool stop_ = false;
};

// Per-thread scratch of the GEMM driver.
struct GemmScratch {
  std::vector<float> panel; // K x NR
  std::vector<float> tile;  // MR x NR
  std::vector<int> index;   // NR ints for packers (pixel offsets)
};

// C = A * B where B is produced by pack(float* dst, int n0, int nr, int* index_scratch): it
// writes B[:, n0 : n0+nr] as a K x NR panel (columns >= nr zero). store(m, n0, nr, row) writes
// the nr results of row m. Work is split over threads by column panels, or by row panels when
// there are too few column panels.
template <class Pack, class Store>
inline void gemm(const MicroKernel& kernel, const PackedMatrix& a, int n, Pack&& pack,
                 Store&& store, ThreadPool& pool, std::vector<GemmScratch>& scratch) {
  const int nr = kernel.nr, mr = kernel.mr;
  const int n_panels = (n + nr - 1) / nr;
  const int m_panels = (a.m + mr - 1) / mr;
  const int threads = pool.size();
  const bool split_n = n_panels >= 2 * threads || m_panels < threads;
  const int tasks = split_n ? std::min(threads, n_panels) : threads;
  auto task = [&](int t) {
    auto& s = scratch[static_cast<std::size_t>(t)];
    int np0 = 0, np1 = n_panels, mp0 = 0, mp1 = m_panels;
    if (split_n) {
      np0 = n_panels * t / tasks;
      np1 = n_panels * (t + 1) / tasks;
    } else {
      mp0 = m_panels * t / tasks;
      mp1 = m_panels * (t + 1) / tasks;
    }
    for (int np = np0; np < np1; ++np) {
      const int n0 = np * nr;
      const int cols = std::min(nr, n - n0);
      pack(s.panel.data(), n0, cols, s.index.data());
      for (int mp = mp0; mp < mp1; ++mp) {
        kernel.fn(a.k, a.panel(mp), s.panel.data(), s.tile.data());
        const int rows = std::min(mr, a.m - mp * mr);
        for (int r = 0; r < rows; ++r) store(mp * mr + r, n0, cols, s.tile.data() + r * nr);
      }
    }
  };
  pool.run(tasks, task);
}

} // namespace detail

SHADOWSENSE_NAMESPACE_END
