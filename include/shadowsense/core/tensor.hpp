// A dense NCHW float tensor: the value type passed between preprocessing, the DenseNet forward
// pass and classifier backends. A CHW image is a tensor with n == 1.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/core/version.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

class Tensor {
public:
  Tensor() = default;
  // Zero-filled tensor of shape n x c x h x w; every dimension must be >= 1.
  Tensor(int n, int c, int h, int w) { resize(n, c, h, w); }

  // Reshapes (reallocating only when the element count grows) and zero-fills.
  void resize(int n, int c, int h, int w) {
    if (!(n >= 1 && c >= 1 && h >= 1 && w >= 1))
      SHADOWSENSE_THROW(
          InvalidArgument("Tensor: every dimension must be >= 1, got " + shape_string(n, c, h, w)));
    if (!(static_cast<double>(n) * c * h * w < 4e9))
      SHADOWSENSE_THROW(
          InvalidArgument("Tensor: shape " + shape_string(n, c, h, w) + " is too large"));
    n_ = n;
    c_ = c;
    h_ = h;
    w_ = w;
    data_.assign(static_cast<std::size_t>(n) * c * h * w, 0.0f);
  }

  int n() const { return n_; }
  int c() const { return c_; }
  int h() const { return h_; }
  int w() const { return w_; }
  bool empty() const { return data_.empty(); }
  std::size_t size() const { return data_.size(); }
  // Elements of one image (c * h * w).
  std::size_t image_size() const { return static_cast<std::size_t>(c_) * h_ * w_; }

  float* data() { return data_.data(); }
  const float* data() const { return data_.data(); }
  std::span<float> values() { return data_; }
  std::span<const float> values() const { return data_; }
  // The c x h x w values of image i.
  std::span<float> image(int i) { return values().subspan(index(i, 0, 0, 0), image_size()); }
  std::span<const float> image(int i) const {
    return values().subspan(index(i, 0, 0, 0), image_size());
  }

  float& operator()(int i, int c, int y, int x) { return data_[index(i, c, y, x)]; }
  float operator()(int i, int c, int y, int x) const { return data_[index(i, c, y, x)]; }

  std::size_t index(int i, int c, int y, int x) const {
    return ((static_cast<std::size_t>(i) * c_ + c) * h_ + y) * w_ + x;
  }

  std::string shape_string() const { return shape_string(n_, c_, h_, w_); }
  static std::string shape_string(int n, int c, int h, int w) {
    return std::to_string(n) + "x" + std::to_string(c) + "x" + std::to_string(h) + "x" +
           std::to_string(w);
  }

  // True when every value is finite (no NaN, no +-Inf).
  // Blocks of 1024 without an early exit inside, so the compiler vectorises the test (the
  // exponent's bits all set: Inf or NaN); a per-element early exit kept it scalar, 3% of the
  // shipped model's forward pass.
  bool all_finite() const {
    const float* p = data_.data();
    const std::size_t n = data_.size();
    for (std::size_t i = 0; i < n; i += 1024) {
      const std::size_t end = std::min(n, i + 1024);
      std::uint32_t bad = 0;
      for (std::size_t j = i; j < end; ++j) {
        std::uint32_t bits;
        std::memcpy(&bits, p + j, sizeof bits);
        bad |= static_cast<std::uint32_t>((bits & 0x7f800000u) == 0x7f800000u);
      }
      if (bad != 0) return false;
    }
    return true;
  }

private:
  int n_ = 0, c_ = 0, h_ = 0, w_ = 0;
  std::vector<float> data_;
};

SHADOWSENSE_NAMESPACE_END
