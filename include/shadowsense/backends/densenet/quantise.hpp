// Post-training int8 quantisation of a DenseNet model file, and the plain reference forward
// pass it calibrates with and the int8 forward is checked against (activations are coded with
// gemm_int8.hpp's int8_code, as in the int8 forward).
//
// ReferenceForward(model)
//   A DenseNet forward pass written for obviousness: BatchNorm, ReLU, convolution as in
//   torchvision, BatchNorm not folded, direct convolutions accumulated in double; the
//   transitions pool before their convolution (the same up to rounding, and where the int8
//   path quantises). Slow; for tests and calibration.
//   logits(image, h, w, observe, fake_quant) -> num_classes logits of one 3 x h x w image.
//     observe (optional): called with (i, values, count) for the input of the i-th quantised
//       convolution (ArchitectureDenseNet::expected_int8_convs order) as it is computed.
//     fake_quant (optional): quantised convolutions; then every quantised convolution's input
//       is replaced by int8_code(x, 1 / input_scale) x input_scale and its weights by code x
//       weight scale ("fake quantisation": the int8 forward's arithmetic in floating point).
//   requires: h, w that DenseNet::accepts (else InvalidArgument: a stage would be empty).
//
// Int8Calibration(model, percentile = 99.99)
//   add(image, h, w): runs ReferenceForward in float and keeps a sample (every 7th value, at
//     most 2^22 per convolution) of every quantised convolution's input.
//   quantise() -> the int8 section: weights quantised symmetrically per output channel
//     (scale = max |w| / 127, codes round(w / scale): never clipped), input scales =
//     the percentile of the sampled inputs / 127 (the largest input if that percentile is 0;
//     1 if every input was 0). requires at least one add() (else InvalidArgument).
// quantise_weights(model, input_scales) -> the int8 section for given input scales.
//
// Threading: ReferenceForward and Int8Calibration are plain values used by one thread at a
// time; the functions are stateless.
#pragma once

#include <shadowsense/backends/densenet/gemm_int8.hpp>
#include <shadowsense/backends/densenet/model_file.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/version.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

class ReferenceForward {
public:
  using Observer = std::function<void(int, const float*, std::size_t)>;

  explicit ReferenceForward(const ModelFile& model) : m_(model) { model.validate(); }

  std::vector<float> logits(const float* image, int h, int w, const Observer& observe = {},
                            const std::vector<QuantisedConv>* fake_quant = nullptr) const {
    const auto& a = m_.architecture;
    conv_index_ = 0;
    observe_ = &observe;
    fq_ = fake_quant;
    Map x{3, h, w, std::vector<float>(image, image + static_cast<std::size_t>(3) * h * w)};
    x = conv(x, "features.conv0.weight", 7, 2, 3, false);
    bn_relu(x, "features.norm0");
    x = maxpool(x);
    for (std::size_t b = 0; b < a.block_config.size(); ++b) {
      const std::string bn = "features.denseblock" + std::to_string(b + 1);
      for (int l = 0; l < a.block_config[b]; ++l) {
        const std::string p = bn + ".denselayer" + std::to_string(l + 1);
        Map y = x;
        bn_relu(y, p + ".norm1");
        y = conv(y, p + ".conv1.weight", 1, 1, 0, true);
        bn_relu(y, p + ".norm2");
        y = conv(y, p + ".conv2.weight", 3, 1, 1, true);
        x.v.insert(x.v.end(), y.v.begin(), y.v.end()); // concatenate channels
        x.c += y.c;
      }
      if (b + 1 < a.block_config.size()) {
        const std::string t = "features.transition" + std::to_string(b + 1);
        bn_relu(x, t + ".norm");
        x = avgpool(x);
        x = conv(x, t + ".conv.weight", 1, 1, 0, true);
      }
    }
    bn_relu(x, "features.norm5");
    const auto& wc = m_.tensor("classifier.weight").values;
    const auto& bc = m_.tensor("classifier.bias").values;
    const std::size_t n = static_cast<std::size_t>(x.h) * x.w;
    std::vector<double> pooled(static_cast<std::size_t>(x.c));
    for (int c = 0; c < x.c; ++c) {
      double s = 0;
      for (std::size_t i = 0; i < n; ++i) s += x.v[c * n + i];
      pooled[static_cast<std::size_t>(c)] = s / double(n);
    }
    std::vector<float> out(static_cast<std::size_t>(a.num_classes));
    for (int o = 0; o < a.num_classes; ++o) {
      double s = bc[static_cast<std::size_t>(o)];
      for (int c = 0; c < x.c; ++c)
        s +=
            double(wc[static_cast<std::size_t>(o) * x.c + c]) * pooled[static_cast<std::size_t>(c)];
      out[static_cast<std::size_t>(o)] = static_cast<float>(s);
    }
    return out;
  }

private:
  struct Map {
    int c = 0, h = 0, w = 0;
    std::vector<float> v;
  };

  void bn_relu(Map& x, const std::string& prefix) const {
    const auto& g = m_.tensor(prefix + ".weight").values;
    const auto& b = m_.tensor(prefix + ".bias").values;
    const auto& mu = m_.tensor(prefix + ".running_mean").values;
    const auto& var = m_.tensor(prefix + ".running_var").values;
    const std::size_t n = static_cast<std::size_t>(x.h) * x.w;
    for (int c = 0; c < x.c; ++c) {
      const auto k = static_cast<std::size_t>(c);
      const double s = double(g[k]) / std::sqrt(double(var[k]) + double(m_.architecture.bn_eps));
      for (std::size_t i = 0; i < n; ++i) {
        const double v = (double(x.v[k * n + i]) - double(mu[k])) * s + double(b[k]);
        x.v[k * n + i] = v < 0 ? 0.0f : static_cast<float>(v);
      }
    }
  }

  static Map maxpool(const Map& x) { // 3x3, stride 2, pad 1 (inputs >= 0)
    Map y{x.c, (x.h - 1) / 2 + 1, (x.w - 1) / 2 + 1, {}};
    y.v.assign(static_cast<std::size_t>(y.c) * y.h * y.w, 0.0f);
    for (int c = 0; c < x.c; ++c)
      for (int i = 0; i < y.h; ++i)
        for (int j = 0; j < y.w; ++j) {
          float m = 0;
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int yy = 2 * i + dy, xx = 2 * j + dx;
              if (yy >= 0 && yy < x.h && xx >= 0 && xx < x.w)
                m = std::max(m, x.v[(static_cast<std::size_t>(c) * x.h + yy) * x.w + xx]);
            }
          y.v[(static_cast<std::size_t>(c) * y.h + i) * y.w + j] = m;
        }
    return y;
  }

  static Map avgpool(const Map& x) { // 2x2, stride 2, floor
    Map y{x.c, x.h / 2, x.w / 2, {}};
    detail::require(y.h >= 1 && y.w >= 1, "ReferenceForward: the input is too small for the "
                                          "transitions' pooling");
    y.v.assign(static_cast<std::size_t>(y.c) * y.h * y.w, 0.0f);
    for (int c = 0; c < x.c; ++c)
      for (int i = 0; i < y.h; ++i)
        for (int j = 0; j < y.w; ++j) {
          const float* r = x.v.data() + (static_cast<std::size_t>(c) * x.h + 2 * i) * x.w + 2 * j;
          y.v[(static_cast<std::size_t>(c) * y.h + i) * y.w + j] =
              ((r[0] + r[1]) + (r[x.w] + r[x.w + 1])) * 0.25f;
        }
    return y;
  }

  // A convolution without bias. quantised: it is one of expected_int8_convs (observed, and
  // fake-quantised when fq_ is set).
  Map conv(Map x, const std::string& name, int k, int stride, int pad, bool quantised) const {
    const auto& t = m_.tensor(name);
    std::vector<double> w(t.values.begin(), t.values.end());
    if (quantised) {
      const int i = conv_index_++;
      if (*observe_) (*observe_)(i, x.v.data(), x.v.size());
      if (fq_) {
        const QuantisedConv& q = (*fq_)[static_cast<std::size_t>(i)];
        const float inv = 1.0f / q.input_scale;
        for (float& v : x.v) v = float(detail::int8_code(v, inv)) * q.input_scale;
        for (std::size_t j = 0; j < w.size(); ++j)
          w[j] = double(q.weights[j]) *
                 double(q.weight_scales[j / static_cast<std::size_t>(q.row_length)]);
      }
    }
    const int co = t.shape[0];
    Map y{co, (x.h + 2 * pad - k) / stride + 1, (x.w + 2 * pad - k) / stride + 1, {}};
    y.v.assign(static_cast<std::size_t>(co) * y.h * y.w, 0.0f);
    for (int o = 0; o < co; ++o)
      for (int i = 0; i < y.h; ++i)
        for (int j = 0; j < y.w; ++j) {
          double s = 0;
          for (int c = 0; c < x.c; ++c)
            for (int ky = 0; ky < k; ++ky) {
              const int yy = i * stride + ky - pad;
              if (yy < 0 || yy >= x.h) continue;
              for (int kx = 0; kx < k; ++kx) {
                const int xx = j * stride + kx - pad;
                if (xx < 0 || xx >= x.w) continue;
                s += w[((static_cast<std::size_t>(o) * x.c + c) * k + ky) * k + kx] *
                     double(x.v[(static_cast<std::size_t>(c) * x.h + yy) * x.w + xx]);
              }
            }
          y.v[(static_cast<std::size_t>(o) * y.h + i) * y.w + j] = static_cast<float>(s);
        }
    return y;
  }

  const ModelFile& m_;
  mutable int conv_index_ = 0;
  mutable const Observer* observe_ = nullptr;
  mutable const std::vector<QuantisedConv>* fq_ = nullptr;
};

inline std::vector<QuantisedConv> quantise_weights(const ModelFile& model,
                                                   std::span<const float> input_scales) {
  const auto convs = model.architecture.expected_int8_convs();
  detail::require(input_scales.size() == convs.size(),
                  "quantise_weights: " + std::to_string(input_scales.size()) +
                      " input scales, expected one per quantised convolution (" +
                      std::to_string(convs.size()) + ")");
  std::vector<QuantisedConv> out;
  for (std::size_t i = 0; i < convs.size(); ++i) {
    const auto& e = convs[i];
    const auto& w = model.tensor(e.name).values;
    QuantisedConv q;
    q.name = e.name;
    q.rows = e.shape[0];
    q.row_length = e.shape[1] * e.shape[2] * e.shape[3];
    q.input_scale = input_scales[i];
    q.weights.resize(w.size());
    for (int o = 0; o < q.rows; ++o) {
      const std::size_t r0 = static_cast<std::size_t>(o) * q.row_length;
      float mx = 0;
      for (int k = 0; k < q.row_length; ++k) mx = std::max(mx, std::abs(w[r0 + k]));
      const float s = mx > 0 ? mx / float(detail::int8_weight_max) : 1.0f;
      q.weight_scales.push_back(s);
      for (int k = 0; k < q.row_length; ++k) {
        const long code = std::lround(double(w[r0 + k]) / double(s));
        q.weights[r0 + k] = static_cast<std::int8_t>(std::clamp(code, -127L, 127L));
      }
    }
    out.push_back(std::move(q));
  }
  return out;
}

class Int8Calibration {
public:
  static constexpr std::size_t sample_stride = 7, max_samples = std::size_t(1) << 22;

  explicit Int8Calibration(const ModelFile& model, double percentile = 99.99)
      : model_(model), forward_(model), percentile_(percentile),
        samples_(model.architecture.expected_int8_convs().size()) {
    detail::require(percentile > 0 && percentile <= 100, "Int8Calibration: percentile " +
                                                             std::to_string(percentile) +
                                                             ", expected a value in (0, 100]");
  }

  void add(const float* image, int h, int w) {
    forward_.logits(image, h, w, [&](int i, const float* v, std::size_t n) {
      auto& s = samples_[static_cast<std::size_t>(i)];
      for (std::size_t k = phase_ % sample_stride; k < n && s.size() < max_samples;
           k += sample_stride)
        s.push_back(v[k]);
    });
    ++phase_;
    ++frames_;
  }
  int frames() const { return frames_; }

  std::vector<float> input_scales() const {
    detail::require(frames_ > 0, "Int8Calibration: no calibration frame was added");
    std::vector<float> scales;
    for (auto s : samples_) {
      float v = 0, mx = 0;
      if (!s.empty()) {
        mx = *std::max_element(s.begin(), s.end());
        const auto at = static_cast<std::size_t>(
            std::min(double(s.size() - 1), std::floor(percentile_ / 100.0 * double(s.size() - 1))));
        std::nth_element(s.begin(), s.begin() + static_cast<std::ptrdiff_t>(at), s.end());
        v = s[at];
      }
      if (!(v > 0)) v = mx;
      scales.push_back(v > 0 ? v / float(detail::int8_act_max) : 1.0f);
    }
    return scales;
  }

  std::vector<QuantisedConv> quantise() const { return quantise_weights(model_, input_scales()); }

private:
  const ModelFile& model_;
  ReferenceForward forward_;
  double percentile_;
  std::vector<std::vector<float>> samples_;
  std::size_t phase_ = 0;
  int frames_ = 0;
};

SHADOWSENSE_NAMESPACE_END
