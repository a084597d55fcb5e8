// Helpers shared by the benchmarks and timers in bench/: random DenseNet weights and inputs,
// the thread's CPU clock and the timers' strict integer arguments. Header-only; needs only the
// runtime target (shadowsense::shadowsense), so forward_time can use it too.
//
// ModelFile random_model(const DenseNetArchitecture& arch)
//   ensures: a model file of `arch` with every tensor arch.expected_tensors() names, values
//     drawn from N(0, 0.05) by std::mt19937 seeded 1 in tensor order (running_var: 1 + |x|, so
//     batch norm stays defined), class names "c0", "c1", ...; the same weights on every call
//     and every machine with the same standard library.
//
// Tensor random_input(int h, int w)
//   requires: h, w >= 1.
//   ensures: a 1 x 3 x h x w tensor of N(0, 1) values from std::mt19937 seeded 2.
//
// double thread_cpu_ms()
//   ensures: the calling thread's CPU time in ms (CLOCK_THREAD_CPUTIME_ID): the time it ran,
//     not the time other processes held the core.
//
// int positive_int(const char* text, const char* what)
//   ensures: the value of `text` when the whole text is a decimal integer in 1..100000.
//   throws: InvalidArgument "<what> '<text>': expected an integer 1..100000" otherwise.
//
// Threading: no shared state; every function may be called from any thread.
#pragma once

#include <shadowsense/backends/densenet/densenet.hpp>
#include <shadowsense/backends/densenet/model_file.hpp>
#include <shadowsense/core/error.hpp>

#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <random>
#include <string>
#include <utility>

#include <time.h>

namespace bench {

inline shadowsense::ModelFile random_model(const shadowsense::DenseNetArchitecture& arch) {
  shadowsense::ModelFile m;
  m.architecture = arch;
  for (int i = 0; i < arch.num_classes; ++i) m.class_names.push_back("c" + std::to_string(i));
  std::mt19937 rng(1);
  std::normal_distribution<float> nd(0.0f, 0.05f);
  for (const auto& s : arch.expected_tensors()) {
    shadowsense::NamedTensor t{s.name, s.shape, {}};
    std::size_t n = 1;
    for (int d : s.shape) n *= static_cast<std::size_t>(d);
    t.values.resize(n);
    for (auto& v : t.values)
      v = s.name.ends_with("running_var") ? 1.0f + std::abs(nd(rng)) : nd(rng);
    m.tensors.push_back(std::move(t));
  }
  return m;
}

inline shadowsense::Tensor random_input(int h, int w) {
  shadowsense::Tensor x(1, 3, h, w);
  std::mt19937 rng(2);
  std::normal_distribution<float> nd;
  for (float& v : x.values()) v = nd(rng);
  return x;
}

inline double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * double(ts.tv_sec) + 1e-6 * double(ts.tv_nsec);
}

inline int positive_int(const char* text, const char* what) {
  char* end = nullptr;
  const long v = std::strtol(text, &end, 10);
  if (end == text || *end != '\0' || v < 1 || v > 100000)
    throw shadowsense::InvalidArgument(std::string(what) + " '" + text +
                                       "': expected an integer 1..100000");
  return static_cast<int>(v);
}

} // namespace bench
