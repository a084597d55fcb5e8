// The reference DenseNet forward pass over a ModelFile, equal to torchvision's DenseNet up to
// float rounding: conv0-norm0-relu0-pool0, dense blocks of norm1-relu1-conv1(1x1)-norm2-relu2-
// conv2(3x3) layers whose outputs are concatenated, transitions norm-relu-conv(1x1)-avgpool(2),
// then norm5-relu-global average pool-classifier.
//
// How it is fast without changing results beyond rounding:
// - norm0 is folded into conv0 and norm2 into conv1 (they directly follow the convolution);
//   norm1, the transition norms and norm5 precede a ReLU on the concatenated input, so they are
//   applied as per-channel affine + ReLU while the convolution's input panel is packed.
// - each dense block keeps its features in one pre-allocated buffer: a layer writes its new
//   channels behind the existing ones, concatenation copies nothing.
// - im2col is fused into GEMM panel packing (no im2col matrix); 3x3 inputs live in a zero-padded
//   buffer so packing needs no bounds checks. conv0's input is kept as the four stride-2 phases
//   of the padded image, so each of its 147 taps is one offset from the output's position: a
//   contiguous copy when packing, or read in place by the AVX-512 kernel. Read as 12 planes,
//   the phases make conv0 a stride-1 4x4 correlation, which runs by Winograd F(3x3, 4x4)
//   (winograd_conv4x4: a third of the multiply-adds) on every input but tiny ones
//   (Config::conv0).
// - the dense layers' 3x3 convolutions use Winograd F(4x4, 3x3) or F(2x2, 3x3) (winograd.hpp:
//   4x or 2.25x fewer multiply-adds) where the image has enough tiles to fill the GEMM panels
//   and the layer has at least 12 output channels; the small late-block images and narrow
//   models use the direct padded-grid convolution (Config::conv3x3). The transformed weights
//   of a tile size are built when a block first uses it (the first input of a new size).
// - a transition's average pool is applied before its 1x1 convolution (both are linear, so the
//   result is the same up to rounding) which costs 4x fewer multiply-adds.
// - all buffers are sized at construction for the largest input seen so far and reused.
//
// Profiling: stage_count(), begin_stages(), run_stage() and stage_logits() run one pass a
// stage at a time (conv0+pool0, each dense block, each transition, the head) so each can be
// timed alone (bench/roofline.cpp); specified at their declarations below. logits() does not
// use them.
// The int8 path (Config::precision; automatic = int8 exactly when the model file has an int8
// section, docs/model_format.md version 3): every dense layer's 1x1 and 3x3 convolution and
// every transition's convolution runs as an int8 GEMM (gemm_int8.hpp: int8 weights per output
// channel, 7-bit unsigned activations, exact int32 sums) on an im2col panel: each input is
// quantised while it is packed (after its BatchNorm-ReLU, and the transitions' pool, which stay
// float), and the int32 sums are dequantised into the same float buffers as the float path
// (with the folded norm2 and relu2 of conv1). conv0 (on the normalised image, 3 input
// channels) and the classifier stay float. Winograd does not apply (its transforms leave the
// integers; the 3x3 convolutions are direct). The float weights are kept too: the model's
// self-test (torchvision's float logits) runs on the float path at construction.
#pragma once

#include <shadowsense/backends/densenet/gemm.hpp>
#include <shadowsense/backends/densenet/gemm_int8.hpp>
#include <shadowsense/backends/densenet/model_file.hpp>
#include <shadowsense/backends/densenet/winograd.hpp>
#include <shadowsense/core/codegen.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/tensor.hpp>
#include <shadowsense/core/version.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// One instance per thread of the caller: logits()/features() and a staged run
// (begin_stages/run_stage) reuse internal buffers, so concurrent calls on the same instance are
// not allowed (the instance's own worker threads, Config::threads, are managed internally).
// Movable, not copyable.
class DenseNet {
public:
  // How the dense layers' 3x3 convolutions are computed: automatic picks per block what
  // detail::winograd_tile(h, w, growth_rate, nr, weights_stream) says (direct, F(2x2, 3x3) or
  // F(4x4, 3x3); weights_stream: the model's weights exceed detail::winograd_stream_bytes);
  // direct, winograd (F(2x2, 3x3)) and winograd4x4 (F(4x4, 3x3)) force one method on every
  // block (tests, benchmarks; direct also saves the memory of the transformed weights, 16/9 of
  // the 3x3 weights for F(2x2) and 36/9 for F(4x4)).
  enum class Conv3x3 { automatic, direct, winograd, winograd4x4 };
  // conv0 (7x7, stride 2): automatic takes Winograd F(3x3, 4x4) over the input's four stride-2
  // phases where detail::winograd_conv0_pays(h0, w0, nr) says so (a third of the multiply-adds
  // of the direct convolution on every input size but tiny ones); direct and winograd force one.
  enum class Conv0 { automatic, direct, winograd };
  // The 1x1 convolutions (the dense layers' and the transitions') on the AVX-512 kernel:
  // channel_rows puts 8 output channels on the kernel's rows and 32 pixels on its columns;
  // pixel_rows the transpose (8 pixels, 32 channels: detail::gemm_pixel_rows_avx512), which
  // fills the kernel where there are few pixels; automatic takes pixel rows where
  // detail::pixel_rows_pay(channels, pixels) says so (DenseNet-121 at 3 x 150 x 220: blocks
  // 3-4 and transitions 2-3). Every choice gives the same logits bit for bit; other kernels
  // ignore it.
  enum class Conv1x1 { automatic, channel_rows, pixel_rows };
  // float32: every convolution in float; int8: the quantised convolutions of the model file's
  // int8 section (InvalidArgument without one); automatic: int8 when the file has the section.
  enum class Precision { automatic, float32, int8 };

  struct Config {
    int threads = 1; // worker threads incl. the caller
    // How long idle workers poll for the next layer before they sleep (detail::ThreadPool):
    // 0 when the machine's cores are busy with other work (threads > 1 only).
    int spin_us = detail::ThreadPool::default_spin_us;
    GemmKernelKind kernel = GemmKernelKind::automatic;
    Conv3x3 conv3x3 = Conv3x3::automatic;
    Conv0 conv0 = Conv0::automatic;
    Conv1x1 conv1x1 = Conv1x1::automatic;
    bool run_self_test = true; // run the model file's embedded self-test in the constructor
    // For benchmarks of kernels kept outside the library: when micro_kernel.fn is set, it and
    // vector_ops (the four required ones set) are used instead of `kernel`.
    detail::MicroKernel micro_kernel{};
    detail::VectorOps vector_ops{};
    Precision precision = Precision::automatic;
    // The int8 GEMM (gemm_int8.hpp; automatic: VNNI, AVX2 or NEON where present, else the
    // reference; every kind gives the same logits).
    detail::Int8KernelKind int8_kernel = detail::Int8KernelKind::automatic;
  };

  explicit DenseNet(const ModelFile& model) : DenseNet(model, Config{}) {}
  DenseNet(const ModelFile& model, Config config)
      : config_(config), arch_(model.architecture), class_names_(model.class_names),
        preprocess_(model.preprocess) {
    model.validate();
    if (config.micro_kernel.fn) {
      detail::require(config.micro_kernel.mr >= 1 && config.micro_kernel.nr >= 1 &&
                          config.vector_ops.affine_relu && config.vector_ops.bias_relu &&
                          config.vector_ops.pool_affine_relu && config.vector_ops.pack3x3,
                      "DenseNet: a custom micro-kernel needs mr, nr >= 1 and all four vector "
                      "ops set");
      kernel_ = config.micro_kernel;
      ops_ = config.vector_ops;
    } else {
      kernel_ = detail::select_micro_kernel(config.kernel);
      ops_ = detail::select_vector_ops(kernel_.kind);
    }
    winograd_ops_ = detail::select_winograd_ops(kernel_.kind);
    fused_ = detail::has_fused_stores(kernel_);
    in_place_avx2_ = detail::has_in_place_avx2(kernel_);
    pool_ = std::make_unique<detail::ThreadPool>(config.threads, config.spin_us);
    std::size_t weight_bytes = 0;
    for (const auto& t : model.tensors) weight_bytes += t.values.size() * sizeof(float);
    weights_stream_ = weight_bytes > detail::winograd_stream_bytes;
    build(model);
    if (config.run_self_test && model.self_test) check_self_test(*model.self_test);
    if (config.precision == Precision::int8 ||
        (config.precision == Precision::automatic && model.int8)) {
      if (!model.int8)
        SHADOWSENSE_THROW(InvalidArgument(
            "DenseNet: Config::precision is int8 but the model file has no int8 section "
            "(quantise it with ss_quantise)"));
      int8_gemm_ = detail::select_int8_gemm(config.int8_kernel);
      build_int8(*model.int8);
      int8_ = true;
      in_h_ = in_w_ = 0; // the buffers of the int8 path (direct 3x3, int8 panels) on next use
    }
  }

  const DenseNetArchitecture& architecture() const { return arch_; }
  const std::vector<std::string>& class_names() const { return class_names_; }
  const PreprocessParams& preprocess_params() const { return preprocess_; }
  int num_classes() const { return arch_.num_classes; }
  const char* kernel_name() const { return kernel_.name; }
  // Whether the quantised convolutions run in int8, and with which kernel ("" when not).
  bool int8() const { return int8_; }
  const char* int8_kernel_name() const { return int8_ ? int8_gemm_.name : ""; }
  int threads() const { return pool_->size(); }
  // Whether the model's weights exceed detail::winograd_stream_bytes (read from memory on every
  // pass), which the automatic 3x3 method counts (detail::winograd_tile).
  bool weights_stream() const { return weights_stream_; }

  // Whether an h x w input survives conv0 (stride 2), pool0 (stride 2) and every
  // transition's 2x2 pool (floor) with at least one pixel, as torchvision requires.
  bool accepts(int h, int w) const {
    const int transitions = static_cast<int>(arch_.block_config.size()) - 1;
    auto ok = [&](int s) {
      if (s < 1) return false;
      s = (s - 1) / 2 + 1; // conv0
      s = (s - 1) / 2 + 1; // pool0
      return (s >> transitions) >= 1;
    };
    return ok(h) && ok(w);
  }

  // Logits for an n x 3 x h x w tensor (n x num_classes values, row per image). The returned
  // span stays valid until the next call.
  // requires: input is n x 3 x h x w with accepts(h, w) and only finite values (else
  //           InvalidArgument naming the problem).
  // ensures:  every logit is finite; a NaN or Inf produced inside the pass (weights or input
  //           magnitudes that overflow float) throws Error naming the image index and logit.
  std::span<const float> logits(const Tensor& input) {
    run(input);
    return logits_;
  }

  // The features entering the classifier (norm5, ReLU, global average pool): n x
  // final_features() values, row per image - what a new classifier head is trained on. The
  // span stays valid until the next call.
  std::span<const float> features(const Tensor& input) {
    run(input);
    return features_;
  }
  int feature_size() const { return blocks_.back().c_out; }

  // The classifier the logits come from (num_classes x feature_size(), row-major, and bias).
  std::span<const float> classifier_weight() const { return classifier_w_; }
  std::span<const float> classifier_bias() const { return classifier_b_; }

  // Stages of one forward pass, to time each alone (bench/roofline.cpp). The pass is stages
  // 0 .. stage_count() - 1 in order: "conv0+pool0" (the input into conv0's phases, conv0 +
  // norm0 + relu0, pool0), then per dense block b "block<b+1>" (its dense layers) and, after
  // every block but the last, "transition<b+1>", then "head" (norm5, ReLU, global average
  // pool, classifier). logits() does not go through these functions: it calls the same
  // private steps directly, so the hook costs it one pointer store per call.
  // stage_count() -> 2 * blocks + 1.
  // stage_name(s)
  //   requires: 0 <= s < stage_count() (else InvalidArgument).
  // begin_stages(input)
  //   requires: what logits() requires, and input.n() == 1 (else InvalidArgument). `input`
  //             stays alive and unchanged while stage 0 may run.
  //   ensures:  the buffers are sized for the input; run_stage() may be called.
  // run_stage(s)
  //   requires: 0 <= s < stage_count() (else InvalidArgument); begin_stages() called and no
  //             logits()/features() since (they end a staged run), and stages 0 .. s - 1 ran
  //             since begin_stages() (else Error naming the problem).
  //   ensures:  stage s recomputed from what the earlier stages left in the buffers. A stage
  //             run again repeats the same work with the same result (so it can be timed
  //             alone). After stages 0 .. stage_count() - 1, stage_logits() holds bit for bit
  //             what logits(input) returns (same threads, kernel and 3x3 method).
  // stage_logits() -> the logits the last "head" stage wrote (num_classes values; unchecked
  //   for NaN/Inf, which logits() checks).
  int stage_count() const { return 2 * static_cast<int>(blocks_.size()) + 1; }
  std::string stage_name(int s) const {
    require_stage(s, "stage_name");
    if (s == 0) return "conv0+pool0";
    if (s == stage_count() - 1) return "head";
    return (s % 2 ? "block" : "transition") + std::to_string((s + 1) / 2);
  }
  void begin_stages(const Tensor& input) {
    if (!(!input.empty() && input.n() == 1))
      SHADOWSENSE_THROW(
          InvalidArgument("DenseNet::begin_stages: input is " +
                          (input.empty() ? std::string("empty") : input.shape_string()) +
                          ", expected one image (1 x 3 x h x w)"));
    run_checks(input);
    logits_.resize(static_cast<std::size_t>(arch_.num_classes));
    features_.resize(static_cast<std::size_t>(feature_size()));
    stage_input_ = input.image(0).data();
    stages_done_ = 0;
  }
  void run_stage(int s) {
    require_stage(s, "run_stage");
    if (!stage_input_)
      SHADOWSENSE_THROW(Error("DenseNet::run_stage: no staged run (call begin_stages() first; "
                              "logits() and features() end a staged run)"));
    if (s > stages_done_)
      SHADOWSENSE_THROW(Error("DenseNet::run_stage: stage " + std::to_string(s) + " before stage " +
                              std::to_string(stages_done_) + " ran; expected the stages in order"));
    if (s == 0) {
      load_input(stage_input_);
      conv0();
      pool0();
    } else if (s == stage_count() - 1) {
      head(features_, logits_);
    } else if (const auto b = static_cast<std::size_t>((s - 1) / 2); s % 2) {
      for (std::size_t l = 0; l < blocks_[b].layers.size(); ++l) {
        if (int8_) {
          bottleneck_int8(b, l);
          growth_int8(b, l);
        } else {
          bottleneck_conv(b, l);
          growth_conv(b, l);
        }
      }
    } else if (int8_) {
      transition_int8(b);
    } else {
      transition(b);
    }
    stages_done_ = std::max(stages_done_, s + 1);
  }
  std::span<const float> stage_logits() const { return logits_; }

private:
  void run(const Tensor& input) {
    stage_input_ = nullptr; // ends a staged run (run_stage)
    run_checks(input);
    const auto classes = static_cast<std::size_t>(arch_.num_classes);
    const auto c = static_cast<std::size_t>(feature_size());
    logits_.resize(static_cast<std::size_t>(input.n()) * classes);
    features_.resize(static_cast<std::size_t>(input.n()) * c);
    for (int i = 0; i < input.n(); ++i) {
      const auto k = static_cast<std::size_t>(i);
      forward_one(input.image(i).data(), std::span<float>(features_).subspan(k * c, c),
                  std::span<float>(logits_).subspan(k * classes, classes));
      if (int8_ && std::any_of(int8_nan_.begin(), int8_nan_.end(), [](char f) { return f; }))
        SHADOWSENSE_THROW(Error("DenseNet: a NaN reached a quantised convolution's input in "
                                "image " +
                                std::to_string(i) +
                                " for a finite input, expected finite numbers: the model's "
                                "weights (or the input's magnitude) overflow float"));
      // A NaN or Inf anywhere in the pass reaches the logits (ReLU and the pools propagate
      // NaN), so checking these few values is enough.
      for (std::size_t o = 0; o < classes; ++o)
        if (!(std::isfinite(logits_[k * classes + o])))
          SHADOWSENSE_THROW(Error("DenseNet: logit " + std::to_string(o) + " of image " +
                                  std::to_string(i) + " is " +
                                  std::to_string(logits_[k * classes + o]) +
                                  " for a finite input, expected a finite number: the model's "
                                  "weights (or the input's magnitude) overflow float"));
    }
  }

  // The input checks of logits(), then the buffers sized for the input.
  void run_checks(const Tensor& input) {
    if (!(!input.empty() && input.c() == 3))
      SHADOWSENSE_THROW(InvalidArgument(
          "DenseNet: input is " + (input.empty() ? std::string("empty") : input.shape_string()) +
          ", expected n x 3 x h x w"));
    if (!(accepts(input.h(), input.w())))
      SHADOWSENSE_THROW(
          InvalidArgument("DenseNet: input " + input.shape_string() +
                          " is too small for the pooling stages, expected h and w with "
                          "ceil(ceil(size / 2) / 2) >= " +
                          std::to_string(1 << (arch_.block_config.size() - 1))));
    detail::require(input.all_finite(),
                    "DenseNet: input holds NaN or Inf values, expected finite numbers");
    ensure_buffers(input.h(), input.w());
  }

public:
  // Bytes held for the packed weights, and for the activations and scratch of the current
  // input size (the whole working memory of a forward pass: nothing else is allocated).
  std::size_t weight_bytes() const {
    std::size_t n = conv0_.data.size() + bias0_.size() + classifier_w_.size() +
                    classifier_b_.size() + 2 * norm5_.scale.size();
    for (const auto& u : conv0_winograd_.u) n += u.data.size();
    for (const auto& b : blocks_) {
      n += b.transition.data.size() + b.transition_pixels.data.size() +
           2 * b.transition_norm.scale.size();
      for (const auto& l : b.layers) {
        n += l.conv1.data.size() + l.conv2.data.size() + l.bias1.size() + 2 * l.norm1.scale.size();
        n += l.conv1_pixels.data.size();
        for (const auto* wg : {&l.winograd2, &l.winograd4})
          for (const auto& u : wg->u) n += u.data.size();
      }
    }
    for (const auto& b : blocks_) {
      n += b.qt.deq.size() + b.qt.w.size() / sizeof(float);
      for (const auto& l : b.layers)
        n += l.q1.deq.size() + l.q2.deq.size() + (l.q1.w.size() + l.q2.w.size()) / sizeof(float);
    }
    return n * sizeof(float);
  }
  std::size_t activation_bytes() const {
    std::size_t n = phases_.size() + conv0_out_.size() + features_.size() + logits_.size() +
                    transition_in_.size();
    for (const auto& b : block_buf_) n += b.size();
    for (const auto& b : bottleneck_) n += b.size();
    for (const auto& s : scratch_)
      n += s.panel.size() + s.tile.size() + s.index.size() + s.shared.size();
    for (const auto& s : winograd_scratch_) n += s.v.size() + s.m.size() + s.y.size();
    return n * sizeof(float) + xq_.size() + q3_.size() + acc_.size() * sizeof(std::int32_t);
  }

  // Multiply-adds of one forward pass at h x w (for GFLOP/s reports; 1 MAC = 2 FLOP).
  double macs(int h, int w) const {
    double total = 0;
    int H = (h - 1) / 2 + 1, W = (w - 1) / 2 + 1;
    total += double(arch_.init_features) * 147 * H * W;
    H = (H - 1) / 2 + 1;
    W = (W - 1) / 2 + 1;
    int c = arch_.init_features;
    const int inner = arch_.bn_size * arch_.growth_rate;
    for (std::size_t b = 0; b < arch_.block_config.size(); ++b) {
      for (int l = 0; l < arch_.block_config[b]; ++l) {
        const int cin = c + l * arch_.growth_rate;
        total += double(inner) * cin * H * W + double(arch_.growth_rate) * inner * 9 * H * W;
      }
      c += arch_.block_config[b] * arch_.growth_rate;
      if (b + 1 < arch_.block_config.size()) {
        total += double(c / 2) * c * H * W; // as torchvision computes it (conv before pool)
        c /= 2;
        H /= 2;
        W /= 2;
      }
    }
    return total + double(arch_.num_classes) * c;
  }

private:
  struct Affine { // y = max(0, x * scale + shift)
    std::vector<float> scale, shift;
  };
  // A quantised convolution as the int8 GEMM reads it: m rows of kp codes (k used, the rest
  // 0); 3x3 rows in tap-major order (k = tap * inner + channel) to match the im2col panel.
  // Output o of the int32 sum is dequantised as sum * deq[o].
  struct QConv {
    std::vector<std::int8_t> w;
    int m = 0, k = 0, kp = 0;
    float inv_in = 0.0f; // 1 / input scale
    std::vector<float> deq;
  };
  struct Layer {
    QConv q1, q2; // int8 path: conv1 (norm2's scale in deq), conv2
    Affine norm1;
    detail::PackedMatrix conv1; // norm2 folded in
    // conv1 laid out for pixel rows; built when a block first uses them
    detail::PixelRowWeights conv1_pixels;
    std::vector<float> bias1;
    std::vector<float> norm2_scale; // folded into conv1 (and into q1's deq)
    detail::PackedMatrix conv2;
    // conv2 transformed for F(2x2) and F(4x4); each built when a block first uses it
    detail::WinogradWeights winograd2, winograd4;
  };
  struct Block {
    std::vector<Layer> layers;
    Affine transition_norm;                    // empty for the last block
    detail::PackedMatrix transition;           // (c/2) x c
    detail::PixelRowWeights transition_pixels; // the same, where pixel rows pay (Config::conv1x1)
    QConv qt;                                  // int8 path: the transition's convolution
    int c_in = 0, c_out = 0;
  };

  // Whether any block may use Winograd: forced, or automatic with enough output channels
  // (detail::winograd_tile); otherwise no scratch is made for it.
  bool builds_winograd() const {
    return config_.conv3x3 == Conv3x3::winograd || config_.conv3x3 == Conv3x3::winograd4x4 ||
           (config_.conv3x3 == Conv3x3::automatic &&
            arch_.growth_rate >= detail::winograd_min_outputs);
  }

  // The 3x3 method of an H x W block: 0 (direct) or the Winograd tile size.
  int conv3x3_tile(int H, int W) const {
    if (int8_) return 0;
    switch (config_.conv3x3) {
    case Conv3x3::direct:
      return 0;
    case Conv3x3::winograd:
      return 2;
    case Conv3x3::winograd4x4:
      return 4;
    case Conv3x3::automatic:
      break;
    }
    return detail::winograd_tile(H, W, arch_.growth_rate, kernel_.nr, weights_stream_);
  }

  Affine affine(const ModelFile& m, const std::string& prefix) const {
    const auto& g = m.tensor(prefix + ".weight").values;
    const auto& b = m.tensor(prefix + ".bias").values;
    const auto& mu = m.tensor(prefix + ".running_mean").values;
    const auto& var = m.tensor(prefix + ".running_var").values;
    Affine a;
    for (std::size_t i = 0; i < g.size(); ++i) {
      const double s = double(g[i]) / std::sqrt(double(var[i]) + double(arch_.bn_eps));
      a.scale.push_back(static_cast<float>(s));
      a.shift.push_back(static_cast<float>(double(b[i]) - double(mu[i]) * s));
    }
    return a;
  }

  // Weights (out x in...) scaled per output row by the following BatchNorm; returns the bias.
  std::vector<float> fold(const ModelFile& m, const std::string& conv, const std::string& norm,
                          std::vector<float>& w) const {
    w = m.tensor(conv).values;
    const Affine a = affine(m, norm);
    const std::size_t per_row = w.size() / a.scale.size();
    const auto& g = m.tensor(norm + ".weight").values;
    const auto& var = m.tensor(norm + ".running_var").values;
    for (std::size_t o = 0; o < a.scale.size(); ++o) {
      const double s = double(g[o]) / std::sqrt(double(var[o]) + double(arch_.bn_eps));
      for (std::size_t k = 0; k < per_row; ++k)
        w[o * per_row + k] = static_cast<float>(double(w[o * per_row + k]) * s);
    }
    return a.shift;
  }

  void build(const ModelFile& m) {
    std::vector<float> w;
    bias0_ = fold(m, "features.conv0.weight", "features.norm0", w);
    conv0_.pack(w.data(), arch_.init_features, 3 * 49, kernel_.mr);
    if (config_.conv0 != Conv0::direct) {
      // conv0 as a stride-1 4x4 correlation over the 12 phase planes (phase (py, px) of
      // channel c: plane (py * 2 + px) * 3 + c, as load_input writes them): tap (a, b) of
      // plane (py, px, c) is tap (2a + py, 2b + px) of channel c, 0 past the 7x7 kernel.
      std::vector<float> w4(static_cast<std::size_t>(arch_.init_features) * 12 * 16, 0.0f);
      for (int o = 0; o < arch_.init_features; ++o)
        for (int py = 0; py < 2; ++py)
          for (int px = 0; px < 2; ++px)
            for (int c = 0; c < 3; ++c)
              for (int a = 0; 2 * a + py < 7; ++a)
                for (int b = 0; 2 * b + px < 7; ++b)
                  w4[((static_cast<std::size_t>(o) * 12 + (py * 2 + px) * 3 + c) * 4 + a) * 4 + b] =
                      w[static_cast<std::size_t>(o) * 147 + (c * 7 + 2 * a + py) * 7 + 2 * b + px];
      conv0_winograd_.set(w4.data(), arch_.init_features, 12, kernel_.mr, 3);
    }
    int c = arch_.init_features;
    const int k = arch_.growth_rate, inner = arch_.bn_size * arch_.growth_rate;
    max_k_ = std::max(147, inner * 9);
    for (std::size_t b = 0; b < arch_.block_config.size(); ++b) {
      Block blk;
      blk.c_in = c;
      const std::string bname = "features.denseblock" + std::to_string(b + 1);
      for (int l = 0; l < arch_.block_config[b]; ++l) {
        const std::string p = bname + ".denselayer" + std::to_string(l + 1);
        Layer layer;
        const int cin = c + l * k;
        layer.norm1 = affine(m, p + ".norm1");
        layer.bias1 = fold(m, p + ".conv1.weight", p + ".norm2", w);
        layer.norm2_scale = affine(m, p + ".norm2").scale;
        layer.conv1.pack(w.data(), inner, cin, kernel_.mr);
        const auto& w2 = m.tensor(p + ".conv2.weight").values;
        layer.conv2.pack(w2.data(), k, inner * 9, kernel_.mr);
        max_k_ = std::max(max_k_, cin);
        blk.layers.push_back(std::move(layer));
      }
      c += arch_.block_config[b] * k;
      blk.c_out = c;
      max_k_ = std::max(max_k_, c);
      if (b + 1 < arch_.block_config.size()) {
        const std::string t = "features.transition" + std::to_string(b + 1);
        blk.transition_norm = affine(m, t + ".norm");
        const auto& wt = m.tensor(t + ".conv.weight").values;
        blk.transition.pack(wt.data(), c / 2, c, kernel_.mr);
        c /= 2;
      }
      blocks_.push_back(std::move(blk));
    }
    norm5_ = affine(m, "features.norm5");
    classifier_w_ = m.tensor("classifier.weight").values;
    classifier_b_ = m.tensor("classifier.bias").values;
    scratch_.resize(static_cast<std::size_t>(pool_->size()));
    for (auto& s : scratch_) {
      s.panel.assign(static_cast<std::size_t>(max_k_) * kernel_.nr, 0.0f);
      s.tile.assign(static_cast<std::size_t>(kernel_.mr) * kernel_.nr, 0.0f);
      s.index.assign(static_cast<std::size_t>(kernel_.nr), 0);
    }
    if (builds_winograd() || !conv0_winograd_.empty())
      winograd_scratch_.assign(
          static_cast<std::size_t>(pool_->size()),
          detail::make_winograd_scratch(std::max(inner, conv0_winograd_.c),
                                        std::max(arch_.growth_rate, conv0_winograd_.m), kernel_));
  }

  // The int8 section (validated by ModelFile) as the GEMM reads it.
  QConv make_qconv(const QuantisedConv& q, const std::vector<float>* fold, bool taps) const {
    // int32 sums of up to k products of at most 127 x 127 must not overflow.
    detail::require(q.row_length <= std::numeric_limits<std::int32_t>::max() / (127 * 127),
                    "DenseNet: convolution '" + q.name + "' has " + std::to_string(q.row_length) +
                        " inputs per output, too many for int32 sums of int8 products (at most " +
                        std::to_string(std::numeric_limits<std::int32_t>::max() / (127 * 127)) +
                        ")");
    QConv r;
    r.m = q.rows;
    r.k = q.row_length;
    r.kp = detail::int8_padded_k(r.k);
    r.inv_in = 1.0f / q.input_scale;
    r.w.assign(static_cast<std::size_t>(r.m) * r.kp, 0);
    const int inner = r.k / 9;
    for (int o = 0; o < r.m; ++o) {
      for (int k = 0; k < r.k; ++k) {
        const int to = taps ? (k % 9) * inner + k / 9 : k; // (channel, tap) -> tap-major
        r.w[static_cast<std::size_t>(o) * r.kp + to] =
            q.weights[static_cast<std::size_t>(o) * r.k + k];
      }
      const double f = fold ? double((*fold)[static_cast<std::size_t>(o)]) : 1.0;
      r.deq.push_back(static_cast<float>(double(q.weight_scales[static_cast<std::size_t>(o)]) *
                                         double(q.input_scale) * f));
    }
    return r;
  }

  void build_int8(const std::vector<QuantisedConv>& convs) {
    std::size_t i = 0;
    for (auto& blk : blocks_) {
      for (auto& layer : blk.layers) {
        layer.q1 = make_qconv(convs[i++], &layer.norm2_scale, false);
        layer.q2 = make_qconv(convs[i++], nullptr, true);
      }
      if (&blk != &blocks_.back()) blk.qt = make_qconv(convs[i++], nullptr, false);
    }
  }

  // The int8 path's buffers for the current size: the im2col panel (pixels x kp codes), the
  // int32 sums (rows x pixels) and the 3x3 input as codes, pixel-major with channels
  // contiguous on the zero-padded grid.
  void ensure_int8_buffers() {
    std::size_t x = 0, acc = 0, q3 = 0;
    for (std::size_t b = 0; b < blocks_.size(); ++b) {
      const auto n = static_cast<std::size_t>(block_h_[b]) * block_w_[b];
      const auto& blk = blocks_[b];
      for (const auto& l : blk.layers)
        for (const QConv* q : {&l.q1, &l.q2}) {
          x = std::max(x, n * static_cast<std::size_t>(q->kp));
          acc = std::max(acc, n * static_cast<std::size_t>(q->m));
        }
      if (!blk.qt.w.empty()) {
        x = std::max(x, n * static_cast<std::size_t>(blk.qt.kp));
        acc = std::max(acc, n * static_cast<std::size_t>(blk.qt.m));
      }
      q3 = std::max(q3,
                    block_plane_[b] * static_cast<std::size_t>(arch_.bn_size * arch_.growth_rate));
    }
    xq_.assign(x, 0);
    acc_.assign(acc, 0);
    q3_.assign(q3, 0);
    int8_nan_.assign(static_cast<std::size_t>(pool_->size()), 0);
  }

  // Runs task(p0, p1, t) on the pool's threads over pixel ranges covering [0, n).
  template <class F>
  void over_pixels(int n, F&& task) {
    const int tasks = std::max(1, std::min(pool_->size(), n));
    auto fn = [&](int t) {
      const int p0 = static_cast<int>(static_cast<long>(n) * t / tasks);
      const int p1 = static_cast<int>(static_cast<long>(n) * (t + 1) / tasks);
      if (p0 < p1) task(p0, p1, t);
    };
    pool_->run(tasks, fn);
  }

  // Activation codes of `channels` input channels at positions [p0, p1) into a pixel-major
  // array: the code of channel c at position p goes to dst[p * stride + c]. values(c, b0, b1,
  // scratch) returns the floats of channel c at positions [b0, b1) (in scratch, 64 floats, or
  // elsewhere). Computed channel by channel over blocks of 64 positions (contiguous,
  // vectorised); channels in groups of 16 go to a small tile first, then each position's 16
  // bytes are written together (one run of bytes per position and group instead of one byte per
  // position and channel at the array's stride). nan is set when a value is NaN.
  template <class Values>
  static void transpose_codes(int p0, int p1, int channels, float inv_in, Values&& values,
                              std::uint8_t* dst, std::size_t stride, bool& nan) {
    constexpr int block = 64, group = 16;
    float scratch[block];
    std::uint8_t tile[group][block];
    for (int b0 = p0; b0 < p1; b0 += block) {
      const int b1 = std::min(p1, b0 + block), nb = b1 - b0;
      for (int c0 = 0; c0 < channels; c0 += group) {
        const int ng = std::min(group, channels - c0);
        for (int g = 0; g < ng; ++g) {
          const float* v = values(c0 + g, b0, b1, scratch);
          bool bad = false;
          for (int j = 0; j < nb; ++j) {
            bad |= v[j] != v[j];
            tile[g][j] = detail::int8_code(v[j], inv_in);
          }
          nan |= bad;
        }
        std::uint8_t* d =
            dst + static_cast<std::size_t>(b0) * stride + static_cast<std::size_t>(c0);
        for (int j = 0; j < nb; ++j, d += stride)
          for (int g = 0; g < ng; ++g) d[g] = tile[g][j];
      }
    }
  }

  // Panel rows [p0, p1) of q: the codes of input channel c at pixels [b0, b1) are those of the
  // floats value(c, b0, b1, v) writes to v, transposed into the pixel-major panel
  // (transpose_codes); the panel's columns k..kp-1 are 0.
  template <class Value>
  void pack_codes(int p0, int p1, const QConv& q, Value&& value, bool& nan) {
    const std::size_t kp = static_cast<std::size_t>(q.kp);
    std::uint8_t* x = xq_.data();
    for (int p = p0; p < p1; ++p)
      std::memset(x + p * kp + q.k, 0, kp - static_cast<std::size_t>(q.k));
    transpose_codes(
        p0, p1, q.k, q.inv_in,
        [&](int c, int b0, int b1, float* v) {
          value(c, b0, b1, v);
          return static_cast<const float*>(v);
        },
        x, kp, nan);
  }

  // The int32 sums of q over panel rows [p0, p1) into acc_ (row stride n).
  void int8_gemm(const QConv& q, int p0, int p1, int n) {
    int8_gemm_.fn(q.w.data(), q.m, xq_.data() + static_cast<std::size_t>(p0) * q.kp, p1 - p0, q.kp,
                  acc_.data() + p0, static_cast<std::size_t>(n));
  }

  // int8 conv1: codes of relu(norm1(features)) -> sums -> + folded norm2, relu2 -> bottleneck.
  void bottleneck_int8(std::size_t b, std::size_t l) {
    const int bw = block_w_[b], n = block_h_[b] * bw, pw = block_pw_[b];
    const Layer& layer = blocks_[b].layers[l];
    const QConv& q = layer.q1;
    const float* feat = block_buf_[b].data();
    float* bott = bottleneck_[b].data();
    const std::size_t plane = block_plane_[b];
    over_pixels(n, [&](int p0, int p1, int t) {
      bool nan = false;
      pack_codes(
          p0, p1, q,
          [&](int c, int b0, int b1, float* v) {
            const float* s = feat + static_cast<std::size_t>(c) * n;
            const float sc = layer.norm1.scale[static_cast<std::size_t>(c)];
            const float sh = layer.norm1.shift[static_cast<std::size_t>(c)];
            for (int p = b0; p < b1; ++p) v[p - b0] = detail::relu_reference(s[p] * sc + sh);
          },
          nan);
      int8_gemm(q, p0, p1, n);
      for (int o = 0; o < q.m; ++o) {
        const std::int32_t* a = acc_.data() + static_cast<std::size_t>(o) * n;
        float* d = bott + static_cast<std::size_t>(o) * plane;
        const float deq = q.deq[static_cast<std::size_t>(o)];
        const float bias = layer.bias1[static_cast<std::size_t>(o)];
        for (int p = p0; p < p1;) { // runs within one image row
          const int y = p / bw, x = p % bw, run = std::min(p1 - p, bw - x);
          float* dr = d + (y + 1) * pw + x + 1;
          for (int j = 0; j < run; ++j)
            dr[j] = detail::relu_reference(float(a[p + j]) * deq + bias);
          p += run;
        }
      }
      if (nan) int8_nan_[static_cast<std::size_t>(t)] = 1;
    });
  }

  // int8 conv2: the padded bottleneck as codes (pixel-major), im2col of the 3x3 taps, sums ->
  // the block buffer behind the existing channels.
  void growth_int8(std::size_t b, std::size_t l) {
    const int bh = block_h_[b], bw = block_w_[b], n = bh * bw, pw = block_pw_[b];
    const Block& blk = blocks_[b];
    const QConv& q = blk.layers[l].q2;
    const int inner = q.k / 9;
    const float* bott = bottleneck_[b].data();
    const std::size_t plane = block_plane_[b], kp = static_cast<std::size_t>(q.kp);
    const auto in = static_cast<std::size_t>(inner);
    std::uint8_t* q3 = q3_.data();
    over_pixels((bh + 2) * pw, [&](int p0, int p1, int t) { // padded positions
      bool nan = false;
      transpose_codes(
          p0, p1, inner, q.inv_in,
          [&](int c, int b0, int, float*) {
            return bott + static_cast<std::size_t>(c) * plane + b0;
          },
          q3, in, nan);
      if (nan) int8_nan_[static_cast<std::size_t>(t)] = 1;
    });
    const int cin = blk.c_in + static_cast<int>(l) * arch_.growth_rate;
    float* outp = block_buf_[b].data() + static_cast<std::size_t>(cin) * n;
    over_pixels(n, [&](int p0, int p1, int) {
      for (int p = p0; p < p1; ++p) {
        std::uint8_t* row = xq_.data() + p * kp;
        const int y = p / bw, x = p % bw;
        for (int tap = 0; tap < 9; ++tap)
          std::memcpy(row + tap * in, q3 + ((y + tap / 3) * pw + x + tap % 3) * in, in);
        std::memset(row + 9 * in, 0, kp - 9 * in);
      }
      int8_gemm(q, p0, p1, n);
      for (int o = 0; o < q.m; ++o) {
        const std::int32_t* a = acc_.data() + static_cast<std::size_t>(o) * n;
        float* d = outp + static_cast<std::size_t>(o) * n;
        const float deq = q.deq[static_cast<std::size_t>(o)];
        for (int p = p0; p < p1; ++p) d[p] = float(a[p]) * deq;
      }
    });
  }

  // int8 transition: codes of avgpool(relu(norm(features))) -> sums -> block b+1's buffer.
  void transition_int8(std::size_t b) {
    const int bw = block_w_[b], n = block_h_[b] * bw;
    const Block& blk = blocks_[b];
    const QConv& q = blk.qt;
    const Affine& a = blk.transition_norm;
    const float* feat = block_buf_[b].data();
    const int ow = block_w_[b + 1], on = block_h_[b + 1] * ow;
    float* next = block_buf_[b + 1].data();
    over_pixels(on, [&](int p0, int p1, int t) {
      bool nan = false;
      pack_codes(
          p0, p1, q,
          [&](int c, int b0, int b1, float* v) {
            const float* s = feat + static_cast<std::size_t>(c) * n;
            const float sc = a.scale[static_cast<std::size_t>(c)];
            const float sh = a.shift[static_cast<std::size_t>(c)];
            for (int p = b0; p < b1;) { // runs within one output row
              const int y = p / ow, x = p % ow, run = std::min(b1 - p, ow - x);
              const float* r = s + 2 * y * bw + 2 * x;
              detail::pool_affine_relu_reference(r, r + bw, v + (p - b0), run, sc, sh);
              p += run;
            }
          },
          nan);
      int8_gemm(q, p0, p1, on);
      for (int o = 0; o < q.m; ++o) {
        const std::int32_t* acc = acc_.data() + static_cast<std::size_t>(o) * on;
        float* d = next + static_cast<std::size_t>(o) * on;
        const float deq = q.deq[static_cast<std::size_t>(o)];
        for (int p = p0; p < p1; ++p) d[p] = float(acc[p]) * deq;
      }
      if (nan) int8_nan_[static_cast<std::size_t>(t)] = 1;
    });
  }

  void ensure_buffers(int h, int w) {
    if (h == in_h_ && w == in_w_) return;
    in_h_ = h;
    in_w_ = w;
    h0_ = (h - 1) / 2 + 1;
    w0_ = (w - 1) / 2 + 1;
    {
      // conv0 reads its taps from the padded input split into its four stride-2
      // phases (even/odd rows x even/odd columns): in phase (ky % 2, kx % 2) tap (ky, kx) of
      // output (y, x) is at row y + ky / 2, column x + kx / 2, so every tap is one offset from
      // the output's position on a grid of pitch w0 + 3 (+ 64 floats of slack: the fused
      // kernel's last panel reads a whole 32-wide row from its last tap, 3 columns into the
      // plane's last row).
      // With conv0 by Winograd (winograd_conv0_pays), the planes reach as far as its last
      // tiles read (winograd_padded) and are readable winograd_read_slack floats past the
      // last one.
      conv0_tile_ =
          config_.conv0 == Conv0::winograd || (config_.conv0 == Conv0::automatic &&
                                               detail::winograd_conv0_pays(h0_, w0_, kernel_.nr))
              ? 3
              : 0;
      const int rows = conv0_tile_ ? detail::winograd_padded(h0_, 3) : h0_ + 3;
      phase_pitch_ = conv0_tile_ ? detail::winograd_padded(w0_, 3) : w0_ + 3;
      phase_plane_ = static_cast<std::size_t>(rows) * phase_pitch_;
      phases_.assign(12 * phase_plane_ + std::max(64, detail::winograd_read_slack), 0.0f);
      conv0_taps_.resize(147);
      for (int c = 0; c < 3; ++c)
        for (int ky = 0; ky < 7; ++ky)
          for (int kx = 0; kx < 7; ++kx)
            conv0_taps_[static_cast<std::size_t>((c * 7 + ky) * 7 + kx)] = static_cast<int>(
                static_cast<std::size_t>(((ky % 2) * 2 + kx % 2) * 3 + c) * phase_plane_ +
                static_cast<std::size_t>(ky / 2) * phase_pitch_ + static_cast<std::size_t>(kx / 2));
    }
    conv0_out_.assign(static_cast<std::size_t>(arch_.init_features) * h0_ * w0_, 0.0f);
    int H = (h0_ - 1) / 2 + 1, W = (w0_ - 1) / 2 + 1;
    block_h_.clear();
    block_w_.clear();
    block_buf_.clear();
    bottleneck_.clear();
    tap_offsets_.clear();
    block_tile_.clear();
    block_pw_.clear();
    block_plane_.clear();
    block_pixel_rows_.clear();
    transition_pixel_rows_.clear();
    std::size_t transition_in_size = 0;
    for (std::size_t b = 0; b < blocks_.size(); ++b) {
      block_h_.push_back(H);
      block_w_.push_back(W);
      block_buf_.emplace_back(static_cast<std::size_t>(blocks_[b].c_out) * H * W, 0.0f);
      // Bottleneck output, zero-padded by one pixel for the 3x3 convolution (Winograd: more
      // where its last tiles reach past the image, detail::winograd_padded); one buffer per
      // block so each border stays 0.
      // (+ one row of slack: the padded-grid conv2 reads 2 floats past the last plane.)
      // (+ nr + 2 more: a tail panel read in place reads a whole nr-wide row; Winograd's
      // transform reads up to winograd_read_slack floats.)
      const int inner = arch_.bn_size * arch_.growth_rate;
      const int tile = conv3x3_tile(H, W);
      const int pw = tile ? detail::winograd_padded(W, tile) : W + 2;
      const int rows = tile ? detail::winograd_padded(H, tile) : H + 2;
      const std::size_t plane = static_cast<std::size_t>(rows) * pw;
      block_tile_.push_back(tile);
      block_pw_.push_back(pw);
      block_plane_.push_back(plane);
      bottleneck_.emplace_back(
          static_cast<std::size_t>(inner) * plane + pw +
              static_cast<std::size_t>(std::max(kernel_.nr + 2, detail::winograd_read_slack)),
          0.0f);
      // Offsets of the 3x3 taps in the padded bottleneck, in the packed weights' k order.
      std::vector<int> taps(static_cast<std::size_t>(inner) * 9);
      for (int c = 0; c < inner; ++c)
        for (int t = 0; t < 9; ++t)
          taps[static_cast<std::size_t>(c * 9 + t)] =
              static_cast<int>(static_cast<std::size_t>(c) * plane) + (t / 3) * pw + t % 3;
      tap_offsets_.push_back(std::move(taps));
      // The 1x1 convolutions' layout (Config::conv1x1), and its weights once.
      const bool pixel_rows = conv1x1_pixel_rows(inner, H * W);
      block_pixel_rows_.push_back(pixel_rows);
      if (pixel_rows)
        for (Layer& layer : blocks_[b].layers)
          if (layer.conv1_pixels.empty())
            layer.conv1_pixels.set(layer.conv1.unpack().data(), layer.conv1.m, layer.conv1.k);
      if (tile) // this block's transformed weights, once per tile size
        for (Layer& layer : blocks_[b].layers) {
          detail::WinogradWeights& u = tile == 2 ? layer.winograd2 : layer.winograd4;
          if (u.empty())
            u.set(layer.conv2.unpack().data(), layer.conv2.m, layer.conv2.k / 9, kernel_.mr, tile);
        }
      H /= 2;
      W /= 2;
      if (b + 1 < blocks_.size()) { // the transition's 1x1 convolution, at the pooled size
        Block& blk = blocks_[b];
        transition_in_size =
            std::max(transition_in_size, static_cast<std::size_t>(blk.c_out) * H * W);
        const bool t_pixel_rows = conv1x1_pixel_rows(blk.transition.m, H * W);
        transition_pixel_rows_.push_back(t_pixel_rows);
        if (t_pixel_rows && blk.transition_pixels.empty())
          blk.transition_pixels.set(blk.transition.unpack().data(), blk.transition.m,
                                    blk.transition.k);
      }
    }
    transition_in_.assign(int8_ ? 0 : transition_in_size, 0.0f);
    if (int8_) ensure_int8_buffers();
  }

  // One image through the network, as the named steps of torchvision's DenseNet.
  void forward_one(const float* in, std::span<float> pooled, std::span<float> out) {
    load_input(in);
    conv0();
    pool0();
    if (int8_) {
      std::fill(int8_nan_.begin(), int8_nan_.end(), char(0));
      for (std::size_t b = 0; b < blocks_.size(); ++b) {
        for (std::size_t l = 0; l < blocks_[b].layers.size(); ++l) {
          bottleneck_int8(b, l);
          growth_int8(b, l);
        }
        if (b + 1 < blocks_.size()) transition_int8(b);
      }
      head(pooled, out);
      return;
    }
    for (std::size_t b = 0; b < blocks_.size(); ++b) {
      for (std::size_t l = 0; l < blocks_[b].layers.size(); ++l) {
        bottleneck_conv(b, l);
        growth_conv(b, l);
      }
      if (b + 1 < blocks_.size()) transition(b);
    }
    head(pooled, out);
  }

  // The image into the four stride-2 phases of its zero-padded (pad 3) copy, which conv0
  // reads (see ensure_buffers). Borders stay 0.
  void load_input(const float* in) {
    const int H = in_h_, W = in_w_;
    for (int py = 0; py < 2; ++py)
      for (int px = 0; px < 2; ++px)
        for (int c = 0; c < 3; ++c) {
          float* d =
              phases_.data() + static_cast<std::size_t>((py * 2 + px) * 3 + c) * phase_plane_;
          // padded row 2r + py is image row 2r + py - 3; padded column 2u + px likewise
          const int u0 = (4 - px) / 2, u1 = (W + 4 - px) / 2; // image columns 0 .. W - 1
          for (int r = (4 - py) / 2; 2 * r + py - 3 < H; ++r) {
            const float* s = in + (static_cast<std::size_t>(c) * H + 2 * r + py - 3) * W;
            float* dr = d + static_cast<std::size_t>(r) * phase_pitch_;
            for (int u = u0; u < u1; ++u) dr[u] = s[2 * u + px - 3];
          }
        }
  }

  // conv0 (7x7, stride 2, pad 3) + folded norm0 + relu0 -> conv0_out_.
  void conv0() {
    const int nr = kernel_.nr, n = h0_ * w0_, w0 = w0_, pitch = phase_pitch_;
    const float* src = phases_.data();
    const int* taps = conv0_taps_.data();
    // Output (y, x) is grid column y * pitch + x; every tap is one offset from it in the
    // phases (ensure_buffers), so a panel row is one contiguous copy. The grid's last 3
    // columns per row are computed and dropped by the store.
    auto pack = [&](float* dst, int n0, int cols, int*) {
      for (std::size_t k = 0; k < 147; ++k) {
        float* d = dst + k * static_cast<std::size_t>(nr);
        std::copy_n(src + taps[k] + n0, cols, d);
        std::fill(d + cols, d + nr, 0.0f);
      }
    };
    float* out0 = conv0_out_.data();
    if (conv0_tile_ == 3) { // F(3x3, 4x4) over the phases, bias and ReLU in its output
      detail::winograd_conv4x4(kernel_, winograd_ops_, conv0_winograd_, src, pitch, phase_plane_,
                               h0_, w0, bias0_.data(), out0, *pool_, winograd_scratch_);
      return;
    }
#if SHADOWSENSE_X86_KERNELS
    if (fused_) { // B read in place: nothing packed
      detail::gemm_fused_avx512(
          conv0_, h0_ * pitch, pack, src, taps,
          [&](int n0, int cols, detail::TileSegments& seg) {
            detail::image_row_segments(n0, cols, pitch, w0, w0, 0, seg);
          },
          out0, static_cast<std::size_t>(n), bias0_.data(), true, *pool_, scratch_);
      return;
    }
#endif
    auto store = [&](int m, int n0, int cols, const float* v) {
      float* d = out0 + static_cast<std::size_t>(m) * n;
      const float b = bias0_[static_cast<std::size_t>(m)];
      int y = n0 / pitch, x = n0 % pitch;
      for (int j = 0; j < cols;) { // runs within one grid row; columns >= w0 dropped
        const int run = std::min(cols - j, pitch - x);
        if (x < w0) ops_.bias_relu(v + j, d + y * w0 + x, std::min(run, w0 - x), b);
        j += run;
        x = 0;
        ++y;
      }
    };
#if SHADOWSENSE_X86_KERNELS
    if (in_place_avx2_) { // B read in place: nothing packed (the phases hold 64 floats of slack)
      detail::gemm_in_place_avx2(conv0_, h0_ * pitch, src, taps, store, *pool_, scratch_);
      return;
    }
#endif
    detail::gemm(kernel_, conv0_, h0_ * pitch, pack, store, *pool_, scratch_);
  }

  // pool0: max 3x3, stride 2, pad 1 -> the first block's buffer (inputs are >= 0 after ReLU,
  // padding never wins). A NaN in the window wins, so it reaches the logits check.
  void pool0() {
    // Separable: the max (and the NaN probe: a sum of >= 0 terms, NaN exactly when a NaN is
    // in the window) over the valid rows of each window first, contiguous and vectorised, then
    // over the three columns. Channels are split over the pool's threads.
    const int bh = block_h_[0], bw = block_w_[0];
    float* dst = block_buf_[0].data();
    const int tasks = std::min(pool_->size(), arch_.init_features);
    // Each thread's row a cache line clear of the next thread's: rows w0_ floats apart shared
    // a line, and pool0 at 2 threads took as long as at 1 (DenseNet-161: 0.42 / 0.41 ms).
    // Each row buffer holds w0_ + 2 floats from vm[-1] (VectorOps::max_pool3s2's contract).
    const std::size_t stride = (static_cast<std::size_t>(w0_) + 2 + 15) / 16 * 16 + 16;
    pool_max_.resize(stride * tasks);
    pool_sum_.resize(stride * tasks);
    const auto pool = ops_.max_pool3s2 ? ops_.max_pool3s2 : &detail::max_pool3s2_portable;
    auto task = [&](int t) {
      float* vm = pool_max_.data() + stride * t + 1;
      float* vs = pool_sum_.data() + stride * t + 1;
      const int c0 = arch_.init_features * t / tasks, c1 = arch_.init_features * (t + 1) / tasks;
      for (int c = c0; c < c1; ++c)
        pool(conv0_out_.data() + static_cast<std::size_t>(c) * h0_ * w0_, h0_, w0_, bh, bw, vm, vs,
             dst + static_cast<std::size_t>(c) * bh * bw);
    };
    pool_->run(tasks, task);
  }

  // Dense layer l of block b, first half: conv1 (1x1) on relu(norm1(features)), + folded norm2,
  // relu2 -> the block's zero-padded bottleneck buffer.
  void bottleneck_conv(std::size_t b, std::size_t l) {
    const int nr = kernel_.nr, bh = block_h_[b], bw = block_w_[b], n = bh * bw;
    const Block& blk = blocks_[b];
    const Layer& layer = blk.layers[l];
    const int cin = blk.c_in + static_cast<int>(l) * arch_.growth_rate;
    const float* feat = block_buf_[b].data();
    const int pw = block_pw_[b];
    float* bott = bottleneck_[b].data();
    const std::size_t plane = block_plane_[b];
    auto pack = [&](float* dst, int n0, int cols, int*) {
      if (ops_.pack_affine_relu) {
        ops_.pack_affine_relu(feat + n0, static_cast<std::size_t>(n), cin, layer.norm1.scale.data(),
                              layer.norm1.shift.data(), dst, cols, nr);
        return;
      }
      for (int c = 0; c < cin; ++c) {
        const float* s = feat + static_cast<std::size_t>(c) * n + n0;
        float* d = dst + static_cast<std::size_t>(c) * nr;
        const float sc = layer.norm1.scale[static_cast<std::size_t>(c)];
        const float sh = layer.norm1.shift[static_cast<std::size_t>(c)];
        ops_.affine_relu(s, d, cols, sc, sh);
        if (cols < nr) std::fill(d + cols, d + nr, 0.0f); // (a zero-length fill is a call)
      }
    };
#if SHADOWSENSE_X86_KERNELS
    // pixel (y, x) to the padded position (y + 1, x + 1)
    auto segments = [&](int n0, int cols, detail::TileSegments& seg) {
      detail::image_row_segments(n0, cols, bw, bw, pw, pw + 1, seg);
    };
    if (fused_ && block_pixel_rows_[b]) {
      detail::gemm_pixel_rows_avx512(layer.conv1_pixels, n, pack, segments, bott, plane,
                                     layer.bias1.data(), true, *pool_, scratch_);
      return;
    }
    if (fused_) {
      detail::gemm_fused_avx512(layer.conv1, n, pack, nullptr, nullptr, segments, bott, plane,
                                layer.bias1.data(), true, *pool_, scratch_);
      return;
    }
#endif
    auto store = [&](int m, int n0, int cols, const float* v) {
      float* d = bott + static_cast<std::size_t>(m) * plane;
      const float bias = layer.bias1[static_cast<std::size_t>(m)];
      int y = n0 / bw, x = n0 % bw;
      for (int j = 0; j < cols;) { // runs within one image row
        const int run = std::min(cols - j, bw - x);
        ops_.bias_relu(v + j, d + (y + 1) * pw + x + 1, run, bias);
        j += run;
        x = 0;
        ++y;
      }
    };
    detail::gemm(kernel_, layer.conv1, n, pack, store, *pool_, scratch_);
  }

  // Dense layer l of block b, second half: conv2 (3x3, pad 1) -> the block buffer behind the
  // existing channels (concatenation without a copy). Computed on the padded grid (bh x pw,
  // the 2 extra columns per row are discarded): there, tap (ky, kx) of output q reads padded
  // position q + ky * pw + kx, so every packed row is a contiguous copy instead of a gather.
  void growth_conv(std::size_t b, std::size_t l) {
    const int nr = kernel_.nr, bh = block_h_[b], bw = block_w_[b], n = bh * bw;
    const Block& blk = blocks_[b];
    const Layer& layer = blk.layers[l];
    const int cin = blk.c_in + static_cast<int>(l) * arch_.growth_rate;
    const int pw = block_pw_[b];
    const float* bott = bottleneck_[b].data();
    const std::size_t plane = block_plane_[b];
    const int inner = layer.conv1.m;
    auto pack = [&](float* dst, int n0, int cols, int*) {
      for (int c = 0; c < inner; ++c)
        ops_.pack3x3(bott + c * plane + n0, dst + static_cast<std::size_t>(c) * 9 * nr, cols, nr,
                     pw);
    };
    float* outp = block_buf_[b].data() + static_cast<std::size_t>(cin) * n;
    if (block_tile_[b]) {
      detail::winograd_conv3x3(kernel_, winograd_ops_,
                               block_tile_[b] == 2 ? layer.winograd2 : layer.winograd4, bott, pw,
                               plane, bh, bw, outp, *pool_, winograd_scratch_);
      return;
    }
    auto store = [&](int m, int n0, int cols, const float* v) {
      float* d = outp + static_cast<std::size_t>(m) * n;
      int y = n0 / pw, x = n0 % pw;
      for (int j = 0; j < cols;) { // runs within one padded row; columns >= bw dropped
        const int run = std::min(cols - j, pw - x);
        if (x < bw) std::copy_n(v + j, std::min(run, bw - x), d + y * bw + x);
        j += run;
        x = 0;
        ++y;
      }
    };
#if SHADOWSENSE_X86_KERNELS
    if (fused_) { // B read in place: nothing packed; the pad columns dropped by the store
      detail::gemm_fused_avx512(
          layer.conv2, bh * pw, pack, bott, tap_offsets_[b].data(),
          [&](int n0, int cols, detail::TileSegments& seg) {
            detail::image_row_segments(n0, cols, pw, bw, bw, 0, seg);
          },
          outp, static_cast<std::size_t>(n), nullptr, false, *pool_, scratch_);
      return;
    }
#endif
    detail::gemm(kernel_, layer.conv2, bh * pw, pack, store, *pool_, scratch_);
  }

  // Whether a 1x1 convolution of m output channels over n pixels runs by pixel rows
  // (Config::conv1x1; the fused AVX-512 float path only).
  bool conv1x1_pixel_rows(int m, int n) const {
    return fused_ && !int8_ &&
           (config_.conv1x1 == Conv1x1::pixel_rows ||
            (config_.conv1x1 == Conv1x1::automatic && detail::pixel_rows_pay(m, n)));
  }

  // Transition after block b: relu(norm) -> avgpool 2x2 -> conv 1x1 -> block b+1's buffer
  // (pool first: both are linear after the ReLU, 4x cheaper, equal up to rounding). The pool
  // runs first over whole planes, channel after channel, into transition_in_, and the GEMM's
  // panels are copied from there: pooling inside the packing read two short runs from each of
  // hundreds of planes per panel, an access the prefetchers do not follow, and waited on the
  // cache for each (on a host with a slow last-level cache, two to three times the GEMM's own
  // time). The pool is called on whole rows (its AVX-512 loop's values do not depend on the
  // length of a call; the packing's runs once depended on where panels cut the rows).
  void transition(std::size_t b) {
    const int nr = kernel_.nr, bw = block_w_[b], n = block_h_[b] * bw;
    const Block& blk = blocks_[b];
    const float* feat = block_buf_[b].data();
    const int oh = block_h_[b + 1], ow = block_w_[b + 1], on = oh * ow;
    const Affine& a = blk.transition_norm;
    float* pooled = transition_in_.data();
    const int pool_tasks = std::min(pool_->size(), blk.c_out);
    auto pool_planes = [&](int t) {
      for (int c = blk.c_out * t / pool_tasks; c < blk.c_out * (t + 1) / pool_tasks; ++c) {
        const float* s = feat + static_cast<std::size_t>(c) * n;
        float* d = pooled + static_cast<std::size_t>(c) * on;
        const float sc = a.scale[static_cast<std::size_t>(c)];
        const float sh = a.shift[static_cast<std::size_t>(c)];
        for (int y = 0; y < oh; ++y) {
          const float* r0 = s + static_cast<std::size_t>(2 * y) * bw;
          ops_.pool_affine_relu(r0, r0 + bw, d + static_cast<std::size_t>(y) * ow, ow, sc, sh);
        }
      }
    };
    pool_->run(pool_tasks, pool_planes);
    auto pack = [&](float* dst, int n0, int cols, int*) {
      for (int c = 0; c < blk.c_out; ++c) {
        float* d = dst + static_cast<std::size_t>(c) * nr;
        std::copy_n(pooled + static_cast<std::size_t>(c) * on + n0, cols, d);
        if (cols < nr) std::fill(d + cols, d + nr, 0.0f); // (a zero-length fill is a call)
      }
    };
    float* next = block_buf_[b + 1].data();
#if SHADOWSENSE_X86_KERNELS
    auto segments = [&](int n0, int cols, detail::TileSegments& seg) {
      detail::image_row_segments(n0, cols, on, on, on, 0, seg);
    };
    if (fused_ && transition_pixel_rows_[b]) {
      detail::gemm_pixel_rows_avx512(blk.transition_pixels, on, pack, segments, next,
                                     static_cast<std::size_t>(on), nullptr, false, *pool_,
                                     scratch_);
      return;
    }
    if (fused_) {
      detail::gemm_fused_avx512(blk.transition, on, pack, nullptr, nullptr, segments, next,
                                static_cast<std::size_t>(on), nullptr, false, *pool_, scratch_);
      return;
    }
#endif
    auto store = [&](int m, int n0, int cols, const float* v) {
      std::copy_n(v, cols, next + static_cast<std::size_t>(m) * on + n0);
    };
    detail::gemm(kernel_, blk.transition, on, pack, store, *pool_, scratch_);
  }

  // norm5, relu, global average pool -> pooled; classifier -> out (accumulated in double: it
  // is tiny). Channels, then classes, are split over the pool's threads.
  void head(std::span<float> pooled, std::span<float> out) {
    const Block& last = blocks_.back();
    const int n = block_h_.back() * block_w_.back();
    const float* feat = block_buf_.back().data();
    const int c_out = last.c_out, classes = arch_.num_classes;
    const int threads = pool_->size();
    const int gap_tasks = std::min(threads, c_out);
    auto gap = [&](int t) {
      for (int c = c_out * t / gap_tasks; c < c_out * (t + 1) / gap_tasks; ++c) {
        const float* s = feat + static_cast<std::size_t>(c) * n;
        const float sc = norm5_.scale[static_cast<std::size_t>(c)];
        const float sh = norm5_.shift[static_cast<std::size_t>(c)];
        double sum = 0;
        for (int j = 0; j < n; ++j) {
          const float v = s[j] * sc + sh;
          sum += v < 0.0f ? 0.0f : v;
        }
        pooled[static_cast<std::size_t>(c)] = static_cast<float>(sum / n);
      }
    };
    pool_->run(gap_tasks, gap);
    // Eight interleaved double sums: one serial chain of additions made the 1000-class head
    // latency-bound (about 1 ms of DenseNet-121); the order differs only in double rounding.
    const int c8 = c_out / 8 * 8;
    const int fc_tasks = std::min(threads, classes);
    auto fc = [&](int t) {
      for (int o = classes * t / fc_tasks; o < classes * (t + 1) / fc_tasks; ++o) {
        const float* wr = classifier_w_.data() + static_cast<std::size_t>(o) * c_out;
        double part[8] = {0, 0, 0, 0, 0, 0, 0, 0};
        for (int c = 0; c < c8; c += 8)
          for (int j = 0; j < 8; ++j)
            part[j] += double(wr[c + j]) * pooled[static_cast<std::size_t>(c + j)];
        double acc = classifier_b_[static_cast<std::size_t>(o)];
        for (int c = c8; c < c_out; ++c) acc += double(wr[c]) * pooled[static_cast<std::size_t>(c)];
        acc += ((part[0] + part[1]) + (part[2] + part[3])) +
               ((part[4] + part[5]) + (part[6] + part[7]));
        out[static_cast<std::size_t>(o)] = static_cast<float>(acc);
      }
    };
    pool_->run(fc_tasks, fc);
  }

  void check_self_test(const ModelSelfTest& st) {
    const auto got = logits(st.input);
    for (std::size_t i = 0; i < got.size(); ++i) {
      const double ref = st.logits[i];
      const double diff = std::abs(double(got[i]) - ref);
      if (!(diff <= double(st.tolerance) * std::max(1.0, std::abs(ref))))
        SHADOWSENSE_THROW(ModelFileError(
            "model self-test failed: logit " + std::to_string(i) + " is " + std::to_string(got[i]) +
            ", expected " + std::to_string(ref) + " (+-" + std::to_string(st.tolerance) +
            " x max(1, |logit|)); the conversion or this build is broken"));
    }
  }

  void require_stage(int s, const char* what) const {
    if (!(s >= 0 && s < stage_count()))
      SHADOWSENSE_THROW(InvalidArgument("DenseNet::" + std::string(what) + ": stage " +
                                        std::to_string(s) + ", expected 0.." +
                                        std::to_string(stage_count() - 1)));
  }

  Config config_;
  DenseNetArchitecture arch_;
  std::vector<std::string> class_names_;
  PreprocessParams preprocess_;
  detail::MicroKernel kernel_{};
  detail::VectorOps ops_{};
  detail::WinogradOps winograd_ops_{};
  bool weights_stream_ = false; // the weights exceed detail::winograd_stream_bytes
  bool fused_ = false;         // the AVX-512 kernel writes C from its registers (gemm_fused_avx512)
  bool in_place_avx2_ = false; // the AVX2 kernel reads conv0's taps in place (gemm_in_place_avx2)
  bool int8_ = false;          // the quantised convolutions run in int8 (set after the self-test)
  detail::Int8Gemm int8_gemm_{};
  std::vector<std::uint8_t> xq_, q3_; // int8 path: im2col panel, 3x3 input codes
  std::vector<std::int32_t> acc_;     // int8 path: the int32 sums
  std::vector<char> int8_nan_;        // int8 path: per task, a NaN was quantised
  std::unique_ptr<detail::ThreadPool> pool_;
  std::vector<detail::GemmScratch> scratch_;
  std::vector<detail::WinogradScratch> winograd_scratch_;
  detail::PackedMatrix conv0_;
  detail::WinogradWeights conv0_winograd_; // conv0 over the phases (empty: Conv0::direct)
  int conv0_tile_ = 0;                     // 3: conv0 by winograd_conv4x4 at this input size
  std::vector<float> bias0_;
  std::vector<Block> blocks_;
  Affine norm5_;
  std::vector<float> classifier_w_, classifier_b_;
  int max_k_ = 0;
  // Buffers sized for the current input size.
  int in_h_ = 0, in_w_ = 0, h0_ = 0, w0_ = 0;
  std::vector<float> conv0_out_, features_, logits_;
  // conv0's input: the padded image's four stride-2 phases, each 3 planes of
  // (h0 + 3) x phase_pitch_, and the 147 taps' offsets into them (ensure_buffers).
  std::vector<float> phases_;
  std::vector<int> conv0_taps_;
  int phase_pitch_ = 0;
  std::size_t phase_plane_ = 0;
  std::vector<float> pool_max_, pool_sum_; // pool0's column maxima and NaN probes (a row/thread)
  std::vector<int> block_h_, block_w_;
  std::vector<std::vector<float>> block_buf_, bottleneck_;
  std::vector<std::vector<int>> tap_offsets_; // per block: the 3x3 taps' offsets (inner x 9)
  std::vector<int> block_tile_;        // per block: its 3x3 method, 0 (direct) or the Winograd tile
  std::vector<int> block_pw_;          // per block: the padded bottleneck's row stride
  std::vector<char> block_pixel_rows_; // per block: its 1x1 convolutions by pixel rows
  std::vector<char> transition_pixel_rows_; // per transition: its convolution by pixel rows
  std::vector<float> transition_in_;        // a transition's pooled input, channels x pooled pixels
  std::vector<std::size_t>
      block_plane_;                    // per block: floats from one bottleneck channel to the next
  const float* stage_input_ = nullptr; // the staged run's image (begin_stages), or none
  int stages_done_ = 0;                // stages of the staged run done so far
};

SHADOWSENSE_NAMESPACE_END
