// The flat, little-endian binary model file of a DenseNet classifier: architecture,
// preprocessing options (classify/preprocess_params.hpp: resize, crop, contrast, brightness,
// normalisation, lighting normalisation and the dark-frame rule), class names, the weights in
// torchvision's state_dict order and an optional self-test (input + torchvision logits),
// closed by a CRC-32 checksum. The byte layout is in docs/model_format.md;
// tools/densenet_to_model.py and tools/train.py write it.
//
// Versions: this library writes version 2, or version 3 when the model holds int8 weights
// (ModelFile::int8: version 2 plus an int8 section before the checksum), or version 4 when
// its input encoding is not colour (PreprocessParams::input_encoding: version 4 adds that
// field after the dark-frame threshold and an int8 flag before the optional int8 section), and
// reads versions 1..4 (a version-4 file recording colour is refused: every model has one
// byte form); a colour model is written as before, byte for byte. Version 1 files
// hold no
// lighting-normalisation flag and no dark-frame rule; they load with lighting_normalise = false
// and dark_luminance_threshold = 0 (no frame is dark by the rule: the caller decides, as with
// version 1), and ModelFile::format_version says 1. Upgrade one with
//   /usr/bin/python3 tools/densenet_to_model.py --upgrade OLD.ssm -o NEW.ssm [--lighting-normalise]
//       [--dark-threshold X]
// or in C++: ModelFile m = ModelFile::load(old); set m.preprocess's fields; m.save(new).
//
// ModelFile::validate() const
//   ensures: returns when the model is consistent (architecture, preprocessing, names, every
//            tensor's name, shape and finite values, the self-test, the int8 section: names,
//            shapes, scales > 0, codes in -127..127 that are the float weights rounded to
//            their scales); throws ModelFileError
//            naming what was wrong and what was expected otherwise.
// ModelFile::to_bytes() const / save(path) const
//   requires: validate() passes (else ModelFileError).
//   ensures: save writes the version-2 bytes (version 3 with an int8 section, version 4 with a
//            calibrated input encoding) atomically: a
//   temporary file in path's folder,
//            every write checked, fsync, then rename over path. On any failure (full disk,
//            file size limit, missing folder) it throws IoError, removes the temporary file and
//            leaves an existing file at path untouched.
// ModelFile::load(path) / from_bytes(bytes)
//   ensures: the model, validated. load checks before reading the body that path is a regular
//            file (a directory, FIFO or device such as /dev/zero is an IoError, never a hang),
//            reads the header only (magic, version, architecture), and rejects a file larger
//            than the most a model of that architecture can take (or than model_file_max_bytes)
//            with ModelFileError, so a huge file with a wrong magic costs 100 bytes of reading.
//            Every OS-level failure is an IoError naming the path; every format error a
//            ModelFileError naming the path, the section and what was expected.
// Threading: ModelFile is a plain value; const use from several threads is safe.
#pragma once

#include <shadowsense/classify/preprocess_params.hpp>
#include <shadowsense/core/atomic_file.hpp>
#include <shadowsense/core/crc32.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/tensor.hpp>
#include <shadowsense/core/version.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

SHADOWSENSE_NAMESPACE_BEGIN

static_assert(std::endian::native == std::endian::little || std::endian::native == std::endian::big,
              "shadowsense model files need a little- or big-endian host");
static_assert(sizeof(float) == 4 && std::numeric_limits<float>::is_iec559,
              "shadowsense model files store IEEE-754 binary32 floats");

// The 8 bytes every model file starts with.
inline constexpr std::array<char, 8> model_file_magic = {'S', 'S', 'D', 'N', 'M', 'O', 'D', '\n'};
// The format version this library writes; it reads model_file_min_version..model_file_version.
inline constexpr std::uint32_t model_file_version = 4;
// The version written for a colour model with int8 weights.
inline constexpr std::uint32_t model_file_int8_version = 3;
// The version written when a model has no int8 section (such files are byte for byte what
// earlier releases wrote, so readers of version 2 keep reading them).
inline constexpr std::uint32_t model_file_float_version = 2;
inline constexpr std::uint32_t model_file_min_version = 1;
// The largest model file load() reads (2 GiB; densenet201 takes 80 MB).
inline constexpr std::uint64_t model_file_max_bytes = std::uint64_t(1) << 31;
// The most float values a self-test input may hold (64 MB).
inline constexpr std::uint64_t model_self_test_max_values = std::uint64_t(1) << 24;

// The DenseNet hyper-parameters (torchvision.models.DenseNet's constructor arguments).
struct DenseNetArchitecture {
  int growth_rate = 32;
  std::vector<int> block_config = {6, 12, 24, 16};
  int init_features = 64;
  int bn_size = 4;
  int num_classes = 1000;
  float bn_eps = 1e-5f;

  static DenseNetArchitecture densenet121(int classes = 1000) {
    return {32, {6, 12, 24, 16}, 64, 4, classes, 1e-5f};
  }
  static DenseNetArchitecture densenet161(int classes = 1000) {
    return {48, {6, 12, 36, 24}, 96, 4, classes, 1e-5f};
  }
  static DenseNetArchitecture densenet169(int classes = 1000) {
    return {32, {6, 12, 32, 32}, 64, 4, classes, 1e-5f};
  }
  static DenseNetArchitecture densenet201(int classes = 1000) {
    return {32, {6, 12, 48, 32}, 64, 4, classes, 1e-5f};
  }

  // Channels entering the classifier (norm5's width).
  int final_features() const {
    long long c = init_features;
    for (std::size_t b = 0; b < block_config.size(); ++b) {
      c += static_cast<long long>(block_config[b]) * growth_rate;
      if (b + 1 < block_config.size()) c /= 2;
    }
    return static_cast<int>(c);
  }

  // Throws ModelFileError unless every value is in the range this library supports.
  void validate() const {
    auto in = [](long long v, long long lo, long long hi) { return v >= lo && v <= hi; };
    detail::require<ModelFileError>(in(growth_rate, 1, 4096),
                                    "model architecture: growth_rate is " +
                                        std::to_string(growth_rate) + ", expected 1..4096");
    detail::require<ModelFileError>(in(static_cast<long long>(block_config.size()), 1, 16),
                                    "model architecture: " + std::to_string(block_config.size()) +
                                        " dense blocks, expected 1..16");
    for (int layers : block_config)
      detail::require<ModelFileError>(in(layers, 1, 1024),
                                      "model architecture: a dense block has " +
                                          std::to_string(layers) + " layers, expected 1..1024");
    detail::require<ModelFileError>(in(init_features, 1, 65536),
                                    "model architecture: init_features is " +
                                        std::to_string(init_features) + ", expected 1..65536");
    detail::require<ModelFileError>(in(bn_size, 1, 64), "model architecture: bn_size is " +
                                                            std::to_string(bn_size) +
                                                            ", expected 1..64");
    detail::require<ModelFileError>(num_classes != 0,
                                    "model architecture: zero classes, expected at least 1");
    detail::require<ModelFileError>(in(num_classes, 1, 1 << 20),
                                    "model architecture: num_classes is " +
                                        std::to_string(num_classes) + ", expected 1..1048576");
    detail::require<ModelFileError>(std::isfinite(bn_eps) && bn_eps > 0.0f && bn_eps < 1.0f,
                                    "model architecture: bn_eps is " + std::to_string(bn_eps) +
                                        ", expected a finite value in (0, 1)");
    long long c = init_features;
    for (std::size_t b = 0; b < block_config.size(); ++b) {
      c += static_cast<long long>(block_config[b]) * growth_rate;
      detail::require<ModelFileError>(
          c <= (1 << 20), "model architecture: " + std::to_string(c) + " channels in dense block " +
                              std::to_string(b + 1) + ", expected at most 1048576");
      if (b + 1 < block_config.size()) c /= 2;
    }
  }

  // The tensors (name and shape) a model file must hold, in file order: torchvision's
  // state_dict order without the num_batches_tracked counters.
  struct TensorSpec {
    std::string name;
    std::vector<int> shape;
  };
  // The convolutions an int8 section quantises, in file order: every dense layer's conv1 and
  // conv2 and every transition's conv (conv0 and the classifier stay float), by the name and
  // shape of their weight tensor.
  std::vector<TensorSpec> expected_int8_convs() const {
    std::vector<TensorSpec> out;
    for (auto& t : expected_tensors())
      if (t.shape.size() == 4 && t.name != "features.conv0.weight") out.push_back(std::move(t));
    return out;
  }

  std::vector<TensorSpec> expected_tensors() const {
    std::vector<TensorSpec> out;
    auto bn = [&](const std::string& prefix, int c) {
      for (const char* p : {"weight", "bias", "running_mean", "running_var"})
        out.push_back({prefix + "." + p, {c}});
    };
    out.push_back({"features.conv0.weight", {init_features, 3, 7, 7}});
    bn("features.norm0", init_features);
    int c = init_features;
    const int inner = bn_size * growth_rate;
    for (std::size_t b = 0; b < block_config.size(); ++b) {
      const std::string block = "features.denseblock" + std::to_string(b + 1);
      for (int l = 0; l < block_config[b]; ++l) {
        const std::string layer = block + ".denselayer" + std::to_string(l + 1);
        const int cin = c + l * growth_rate;
        bn(layer + ".norm1", cin);
        out.push_back({layer + ".conv1.weight", {inner, cin, 1, 1}});
        bn(layer + ".norm2", inner);
        out.push_back({layer + ".conv2.weight", {growth_rate, inner, 3, 3}});
      }
      c += block_config[b] * growth_rate;
      if (b + 1 < block_config.size()) {
        const std::string t = "features.transition" + std::to_string(b + 1);
        bn(t + ".norm", c);
        out.push_back({t + ".conv.weight", {c / 2, c, 1, 1}});
        c /= 2;
      }
    }
    bn("features.norm5", c);
    out.push_back({"classifier.weight", {num_classes, c}});
    out.push_back({"classifier.bias", {num_classes}});
    return out;
  }
};

struct NamedTensor {
  std::string name;
  std::vector<int> shape;
  std::vector<float> values;
};

// An input and the logits the reference framework computed for it; DenseNet runs it at load
// time so a broken conversion is caught where the model is deployed.
struct ModelSelfTest {
  Tensor input;              // n x 3 x h x w, already preprocessed
  std::vector<float> logits; // n x num_classes
  float tolerance = 1e-4f;   // max |diff| allowed, scaled by max(1, |logit|)
};

// One convolution quantised for the int8 forward (docs/model_format.md, version 3): weights
// quantised symmetrically per output channel, code = round(w / weight_scales[o]) in
// -127..127 (never clipped: |w| <= 127 x scale), and the scale of the convolution's input
// (after its BatchNorm-ReLU, and the transitions' average pool), code = min(127,
// round(x / input_scale)), 7-bit because of the kernels' int16 pair sums (gemm_int8.hpp).
struct QuantisedConv {
  std::string name;             // the float weight tensor's name, e.g. "...conv1.weight"
  int rows = 0, row_length = 0; // output channels; input channels x kernel height x width
  float input_scale = 0.0f;
  std::vector<float> weight_scales; // rows
  std::vector<std::int8_t> weights; // rows x row_length, the float tensor's order
};

struct ModelFile {
  // The version the file was read from (load/from_bytes); save() writes version 4 when
  // preprocess.input_encoding is not colour, else 3 when int8 is set, else 2. A 1 here means
  // the preprocessing options are version-1 defaults.
  std::uint32_t format_version = model_file_version;
  DenseNetArchitecture architecture;
  PreprocessParams preprocess;
  std::vector<std::string> class_names;
  std::vector<NamedTensor> tensors; // in architecture.expected_tensors() order
  std::optional<ModelSelfTest> self_test;
  // Present in version-3 files (and version-4 files whose int8 flag is 1): the architecture's
  // expected_int8_convs(), in order.
  std::optional<std::vector<QuantisedConv>> int8;

  const NamedTensor& tensor(std::string_view name) const {
    for (const auto& t : tensors)
      if (t.name == name) return t;
    SHADOWSENSE_THROW(ModelFileError("model file: no tensor named '" + std::string(name) + "'"));
  }
  NamedTensor& tensor(std::string_view name) {
    return const_cast<NamedTensor&>(std::as_const(*this).tensor(name));
  }

  // Checks the whole model for consistency; save() and load() call it.
  void validate() const;

  std::vector<std::uint8_t> to_bytes() const;
  void save(const std::filesystem::path& path) const;
  static ModelFile from_bytes(std::span<const std::uint8_t> bytes);
  static ModelFile from_bytes(std::span<const std::byte> bytes) {
    return from_bytes(std::span<const std::uint8_t>(
        reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()));
  }
  static ModelFile load(const std::filesystem::path& path);
};

namespace detail {

inline constexpr std::size_t model_max_name_bytes = 1024;

class ModelWriter {
public:
  void u32(std::uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void u64(std::uint64_t v) {
    for (int i = 0; i < 8; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void f32(float v) { u32(std::bit_cast<std::uint32_t>(v)); }
  void floats(std::span<const float> v) {
    out.reserve(out.size() + 4 * v.size());
    for (float x : v) f32(x);
  }
  void str(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size()));
    out.insert(out.end(), s.begin(), s.end());
  }
  std::vector<std::uint8_t> out;
};

class ModelReader {
public:
  explicit ModelReader(std::span<const std::uint8_t> b) : bytes(b) {}

  void need(std::size_t n, const char* what) const {
    if (bytes.size() - pos < n)
      SHADOWSENSE_THROW(ModelFileError(
          "model file truncated in the " + std::string(section) + " section: " + what + " needs " +
          std::to_string(n) + " bytes at offset " + std::to_string(pos) +
          ", but the file has only " + std::to_string(bytes.size() - pos) + " left (" +
          std::to_string(bytes.size()) + " bytes in total)"));
  }
  std::uint32_t u32(const char* what) {
    need(4, what);
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(bytes[pos + i]) << (8 * i);
    pos += 4;
    return v;
  }
  std::uint64_t u64(const char* what) {
    need(8, what);
    std::uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(bytes[pos + i]) << (8 * i);
    pos += 8;
    return v;
  }
  float f32(const char* what) { return std::bit_cast<float>(u32(what)); }
  // A u32 that must lie in [lo, hi].
  int count(const char* what, std::uint32_t lo, std::uint32_t hi) {
    return count_value(u32(what), what, lo, hi);
  }
  int count_value(std::uint32_t v, const char* what, std::uint32_t lo, std::uint32_t hi) const {
    if (v < lo || v > hi)
      SHADOWSENSE_THROW(ModelFileError("model file " + std::string(section) + " section: " + what +
                                       " is " + std::to_string(v) + ", expected " +
                                       std::to_string(lo) + ".." + std::to_string(hi)));
    return static_cast<int>(v);
  }
  void floats(std::vector<float>& v, std::size_t n, const char* what) {
    if (n > (bytes.size() - pos) / 4) need(n * 4, what); // throws, without allocating first
    v.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      std::uint32_t u = 0;
      for (int k = 0; k < 4; ++k) u |= static_cast<std::uint32_t>(bytes[pos + k]) << (8 * k);
      v[i] = std::bit_cast<float>(u);
      pos += 4;
    }
  }
  std::string str(const char* what) {
    const int n = count(what, 0, model_max_name_bytes);
    need(static_cast<std::size_t>(n), what);
    std::string s(reinterpret_cast<const char*>(bytes.data() + pos), static_cast<std::size_t>(n));
    pos += static_cast<std::size_t>(n);
    return s;
  }

  std::span<const std::uint8_t> bytes;
  std::size_t pos = 0;
  const char* section = "header";
};

inline std::string shape_to_string(const std::vector<int>& s) {
  std::string r = "[";
  for (std::size_t i = 0; i < s.size(); ++i) r += (i ? ", " : "") + std::to_string(s[i]);
  return r + "]";
}

inline std::size_t shape_elements(const std::vector<int>& s) {
  std::size_t n = 1;
  for (int d : s) n *= static_cast<std::size_t>(d);
  return n;
}

inline bool is_running_var(const std::string& name) {
  constexpr std::string_view suffix = ".running_var";
  return name.size() >= suffix.size() &&
         std::string_view(name).substr(name.size() - suffix.size()) == suffix;
}

} // namespace detail

namespace detail {
inline void validate_int8(const ModelFile& m); // the int8 section (below)
} // namespace detail

inline void ModelFile::validate() const {
  architecture.validate();
  preprocess.validate<ModelFileError>();
  const auto n_classes = static_cast<std::size_t>(architecture.num_classes);
  detail::require<ModelFileError>(class_names.size() == n_classes,
                                  "model file: " + std::to_string(class_names.size()) +
                                      " class names, expected one per class (" +
                                      std::to_string(n_classes) + ")");
  for (const auto& name : class_names)
    detail::require<ModelFileError>(name.size() <= detail::model_max_name_bytes,
                                    "model file: a class name has " + std::to_string(name.size()) +
                                        " bytes, expected at most 1024");
  const auto expected = architecture.expected_tensors();
  detail::require<ModelFileError>(tensors.size() == expected.size(),
                                  "model file: " + std::to_string(tensors.size()) +
                                      " tensors, expected " + std::to_string(expected.size()) +
                                      " for this architecture");
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const auto& t = tensors[i];
    const auto& e = expected[i];
    detail::require<ModelFileError>(t.name == e.name, "model file: tensor " + std::to_string(i) +
                                                          " is named '" + t.name + "', expected '" +
                                                          e.name + "'");
    detail::require<ModelFileError>(t.shape == e.shape,
                                    "model file: tensor '" + t.name + "' has shape " +
                                        detail::shape_to_string(t.shape) + ", expected " +
                                        detail::shape_to_string(e.shape));
    detail::require<ModelFileError>(t.values.size() == detail::shape_elements(e.shape),
                                    "model file: tensor '" + t.name + "' holds " +
                                        std::to_string(t.values.size()) + " values, expected " +
                                        std::to_string(detail::shape_elements(e.shape)));
    const bool var = detail::is_running_var(t.name);
    for (std::size_t k = 0; k < t.values.size(); ++k) {
      const float v = t.values[k];
      if (!std::isfinite(v))
        SHADOWSENSE_THROW(ModelFileError("model file: tensor '" + t.name + "' value " +
                                         std::to_string(k) + " is " + std::to_string(v) +
                                         ", expected a finite number"));
      if (var && v < 0.0f)
        SHADOWSENSE_THROW(ModelFileError("model file: tensor '" + t.name + "' value " +
                                         std::to_string(k) + " is negative (" + std::to_string(v) +
                                         "), expected a variance >= 0"));
    }
  }
  if (self_test) {
    const auto& st = *self_test;
    detail::require<ModelFileError>(!st.input.empty() && st.input.c() == 3,
                                    "model file self-test: input " + st.input.shape_string() +
                                        ", expected n x 3 x h x w");
    detail::require<ModelFileError>(st.input.n() <= 64 && st.input.h() <= 4096 &&
                                        st.input.w() <= 4096 &&
                                        st.input.values().size() <= model_self_test_max_values,
                                    "model file self-test: input " + st.input.shape_string() +
                                        ", expected n <= 64, h and w <= 4096 and at most " +
                                        std::to_string(model_self_test_max_values) + " values");
    detail::require<ModelFileError>(st.input.all_finite(),
                                    "model file self-test: input holds NaN/Inf, expected finite");
    detail::require<ModelFileError>(
        st.logits.size() == static_cast<std::size_t>(st.input.n()) * n_classes,
        "model file self-test: " + std::to_string(st.logits.size()) +
            " logits, expected n x num_classes = " + std::to_string(st.input.n() * n_classes));
    for (float v : st.logits)
      detail::require<ModelFileError>(std::isfinite(v),
                                      "model file self-test: logits hold NaN/Inf, expected finite");
    detail::require<ModelFileError>(std::isfinite(st.tolerance) && st.tolerance > 0.0f,
                                    "model file self-test: tolerance " +
                                        std::to_string(st.tolerance) +
                                        ", expected a finite value > 0");
  }
  if (int8) detail::validate_int8(*this);
}

namespace detail {
inline void validate_int8(const ModelFile& m) {
  const auto expected = m.architecture.expected_int8_convs();
  const auto& convs = *m.int8;
  require<ModelFileError>(convs.size() == expected.size(),
                          "model file int8 section: " + std::to_string(convs.size()) +
                              " quantised convolutions, expected " +
                              std::to_string(expected.size()) + " for this architecture");
  for (std::size_t i = 0; i < convs.size(); ++i) {
    const auto& q = convs[i];
    const auto& e = expected[i];
    const std::string what = "model file int8 section: convolution " + std::to_string(i);
    require<ModelFileError>(q.name == e.name,
                            what + " is named '" + q.name + "', expected '" + e.name + "'");
    const int rows = e.shape[0], len = e.shape[1] * e.shape[2] * e.shape[3];
    require<ModelFileError>(q.rows == rows && q.row_length == len,
                            what + " ('" + q.name + "') is " + std::to_string(q.rows) + " x " +
                                std::to_string(q.row_length) + ", expected " +
                                std::to_string(rows) + " x " + std::to_string(len));
    require<ModelFileError>(std::isfinite(q.input_scale) && q.input_scale > 0.0f,
                            what + " ('" + q.name + "'): input scale " +
                                std::to_string(q.input_scale) + ", expected a finite value > 0");
    require<ModelFileError>(
        q.weight_scales.size() == static_cast<std::size_t>(rows) &&
            q.weights.size() == static_cast<std::size_t>(rows) * len,
        what + " ('" + q.name + "'): " + std::to_string(q.weight_scales.size()) + " scales and " +
            std::to_string(q.weights.size()) + " weights, expected " + std::to_string(rows) +
            " and " + std::to_string(static_cast<std::size_t>(rows) * len));
    const auto& w = m.tensor(q.name).values;
    for (int o = 0; o < rows; ++o) {
      const float s = q.weight_scales[static_cast<std::size_t>(o)];
      if (!(std::isfinite(s) && s > 0.0f))
        SHADOWSENSE_THROW(ModelFileError(what + " ('" + q.name + "'): weight scale of row " +
                                         std::to_string(o) + " is " + std::to_string(s) +
                                         ", expected a finite value > 0"));
      for (int k = 0; k < len; ++k) {
        const std::size_t at = static_cast<std::size_t>(o) * len + k;
        const int code = q.weights[at];
        // (The messages are built only on failure: a model has millions of weights.)
        if (code < -127)
          SHADOWSENSE_THROW(ModelFileError(what + " ('" + q.name + "'): weight code -128 at " +
                                           std::to_string(at) + ", expected -127..127"));
        // The codes must be the float weights rounded to the scale: a section written for
        // other weights (another model, an edited file) is refused here, not run.
        const double err = std::abs(double(code) * s - double(w[at]));
        if (!(err <= 0.5 * double(s) * (1.0 + 1e-4)))
          SHADOWSENSE_THROW(
              ModelFileError(what + " ('" + q.name + "'): weight " + std::to_string(at) +
                             " has code " + std::to_string(code) + " x scale " + std::to_string(s) +
                             ", expected round(" + std::to_string(w[at]) +
                             " / scale): the int8 section does not belong to these float weights"));
      }
    }
  }
}
} // namespace detail

inline std::vector<std::uint8_t> ModelFile::to_bytes() const {
  validate();
  detail::ModelWriter w;
  // header
  w.out.insert(w.out.end(), model_file_magic.begin(), model_file_magic.end());
  const bool encoded = preprocess.input_encoding != InputEncoding::colour;
  w.u32(encoded ? model_file_version : int8 ? model_file_int8_version : model_file_float_version);
  // architecture
  const auto& a = architecture;
  w.u32(static_cast<std::uint32_t>(a.growth_rate));
  w.u32(static_cast<std::uint32_t>(a.bn_size));
  w.u32(static_cast<std::uint32_t>(a.init_features));
  w.u32(static_cast<std::uint32_t>(a.num_classes));
  w.f32(a.bn_eps);
  w.u32(static_cast<std::uint32_t>(a.block_config.size()));
  for (int l : a.block_config) w.u32(static_cast<std::uint32_t>(l));
  // preprocessing
  const auto& p = preprocess;
  w.u32(static_cast<std::uint32_t>(p.resize_width));
  w.u32(static_cast<std::uint32_t>(p.resize_height));
  w.u32(static_cast<std::uint32_t>(p.crop_width));
  w.u32(static_cast<std::uint32_t>(p.crop_height));
  w.f32(p.contrast_factor);
  w.f32(p.dark_brightness_factor);
  w.floats(p.mean);
  w.floats(p.std);
  w.u32(static_cast<std::uint32_t>(p.network_channel_order));
  w.u32(p.lighting_normalise ? 1u : 0u); // version 2
  w.f32(p.lighting_target);
  w.f32(p.dark_luminance_threshold);
  if (encoded) w.u32(static_cast<std::uint32_t>(p.input_encoding)); // version 4
  // class names
  w.u32(static_cast<std::uint32_t>(class_names.size()));
  for (const auto& n : class_names) w.str(n);
  // tensors
  w.u32(static_cast<std::uint32_t>(tensors.size()));
  for (const auto& t : tensors) {
    w.str(t.name);
    w.u32(static_cast<std::uint32_t>(t.shape.size()));
    for (int d : t.shape) w.u32(static_cast<std::uint32_t>(d));
    w.floats(t.values);
  }
  // self-test
  w.u32(self_test ? 1u : 0u);
  if (self_test) {
    const auto& in = self_test->input;
    for (int d : {in.n(), in.c(), in.h(), in.w()}) w.u32(static_cast<std::uint32_t>(d));
    w.floats(in.values());
    w.floats(self_test->logits);
    w.f32(self_test->tolerance);
  }
  if (encoded) w.u32(int8 ? 1u : 0u); // version 4: the int8 flag
  if (int8) {                         // version 3 (version 4: after the flag)
    w.u32(static_cast<std::uint32_t>(int8->size()));
    for (const auto& q : *int8) {
      w.str(q.name);
      w.u32(static_cast<std::uint32_t>(q.rows));
      w.u32(static_cast<std::uint32_t>(q.row_length));
      w.f32(q.input_scale);
      w.floats(q.weight_scales);
      for (std::int8_t v : q.weights) w.out.push_back(static_cast<std::uint8_t>(v));
    }
  }
  w.u32(detail::crc32(w.out));
  return std::move(w.out);
}

namespace detail {

// Writes bytes to path atomically through core/atomic_file.hpp (the one atomic writer); a
// folder as path is refused first with a message naming what was being written.
inline void write_bytes_atomically(const std::filesystem::path& path,
                                   std::span<const std::uint8_t> bytes, const char* what) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    SHADOWSENSE_THROW(IoError(std::string(what) + " '" + path.string() +
                              "' is a directory, expected a file path to write"));
  write_file_atomically(
      path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

// Magic, version and architecture (the header: at most model_header_max_bytes bytes).
inline constexpr std::size_t model_header_max_bytes = 8 + 4 + 6 * 4 + 16 * 4;

inline void read_model_header(ModelReader& r, ModelFile& m) {
  r.section = "header";
  r.need(model_file_magic.size(), "the magic number");
  if (std::memcmp(r.bytes.data(), model_file_magic.data(), model_file_magic.size()) != 0)
    SHADOWSENSE_THROW(
        ModelFileError("not a shadowsense model file: wrong magic number, expected the "
                       "8 bytes \"SSDNMOD\\n\" at the start"));
  r.pos = model_file_magic.size();
  const std::uint32_t version = r.u32("the format version");
  if (version < model_file_min_version)
    SHADOWSENSE_THROW(ModelFileError("model file format version " + std::to_string(version) +
                                     " is too old, this library reads versions " +
                                     std::to_string(model_file_min_version) + ".." +
                                     std::to_string(model_file_version) +
                                     ": regenerate it with tools/densenet_to_model.py"));
  if (version > model_file_version)
    SHADOWSENSE_THROW(ModelFileError("model file format version " + std::to_string(version) +
                                     " is newer than this library (reads versions " +
                                     std::to_string(model_file_min_version) + ".." +
                                     std::to_string(model_file_version) + "): update shadowsense"));
  m.format_version = version;
  r.section = "architecture";
  auto& a = m.architecture;
  a.growth_rate = r.count("growth_rate", 1, 4096);
  a.bn_size = r.count("bn_size", 1, 64);
  a.init_features = r.count("init_features", 1, 65536);
  {
    const std::uint32_t classes = r.u32("num_classes");
    if (classes == 0)
      SHADOWSENSE_THROW(ModelFileError("model architecture: zero classes, expected at least 1"));
    a.num_classes = r.count_value(classes, "num_classes", 1, 1 << 20);
  }
  a.bn_eps = r.f32("bn_eps");
  const int blocks = r.count("the number of dense blocks", 1, 16);
  a.block_config.resize(static_cast<std::size_t>(blocks));
  for (auto& l : a.block_config) l = r.count("layers of a dense block", 1, 1024);
  a.validate();
}

// The most bytes a model file of this architecture can hold (longest names, largest
// self-test), saturating at UINT64_MAX.
inline std::uint64_t model_max_bytes(const DenseNetArchitecture& a) {
  constexpr std::uint64_t cap = std::numeric_limits<std::uint64_t>::max() / 4;
  std::uint64_t n = model_header_max_bytes + 4 * 4 + 2 * 4 + 6 * 4 + 4 + 3 * 4; // + preprocessing
  const auto classes = static_cast<std::uint64_t>(a.num_classes);
  n += 4 + classes * (4 + model_max_name_bytes);
  n += 4;
  for (const auto& t : a.expected_tensors()) {
    std::uint64_t e = 1;
    for (int d : t.shape) e = std::min(cap, e * static_cast<std::uint64_t>(d));
    n = std::min(cap, n + 4 + model_max_name_bytes + 4 + 4 * 4 + 4 * e);
  }
  n += 4;                                                                 // input encoding (v4)
  n += 4 + 4 * 4 + 4 * model_self_test_max_values + 4 * 64 * classes + 4; // self-test
  n = std::min(cap, n + 4 + 4); // int8 flag (v4) and section
  for (const auto& t : a.expected_int8_convs()) {
    const auto rows = static_cast<std::uint64_t>(t.shape[0]);
    const auto len = static_cast<std::uint64_t>(t.shape[1]) * t.shape[2] * t.shape[3];
    n = std::min(cap, n + 4 + model_max_name_bytes + 3 * 4 + 4 * rows + rows * len);
  }
  return std::min(cap, n + 4); // checksum
}

} // namespace detail

inline void ModelFile::save(const std::filesystem::path& path) const {
  const auto bytes = to_bytes();
  detail::write_bytes_atomically(path, bytes, "model file");
}

inline ModelFile ModelFile::load(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::error_code ec;
  const auto st = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(st))
    SHADOWSENSE_THROW(IoError("cannot open model file '" + name + "' for reading: " +
                              (ec ? ec.message() : std::string("no such file"))));
  if (std::filesystem::is_directory(st))
    SHADOWSENSE_THROW(IoError("model file '" + name + "' is a directory, expected a model file"));
  if (!std::filesystem::is_regular_file(st))
    SHADOWSENSE_THROW(
        IoError("model file '" + name +
                "' is not a regular file (a FIFO, socket or device), expected a model file"));
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec)
    SHADOWSENSE_THROW(
        IoError("cannot read the size of model file '" + name + "': " + ec.message()));
  std::ifstream f(path, std::ios::binary);
  if (!f) SHADOWSENSE_THROW(IoError("cannot open model file '" + name + "' for reading"));
  auto read = [&](std::vector<std::uint8_t>& into, std::size_t from, std::size_t n) {
    into.resize(from + n);
    f.read(reinterpret_cast<char*>(into.data() + from), static_cast<std::streamsize>(n));
    if (f.bad() || static_cast<std::size_t>(f.gcount()) != n)
      SHADOWSENSE_THROW(IoError("reading model file '" + name + "' failed after " +
                                std::to_string(from + static_cast<std::size_t>(f.gcount())) +
                                " of " + std::to_string(size) + " bytes"));
  };
  return detail::add_context<ModelFileError>(name + ": ", [&] {
    // The header alone first: a wrong magic, version or architecture, or a size no model of
    // this architecture can have, is rejected before the body is read.
    std::vector<std::uint8_t> bytes;
    const auto head =
        static_cast<std::size_t>(std::min<std::uintmax_t>(size, detail::model_header_max_bytes));
    read(bytes, 0, head);
    {
      detail::ModelReader r(bytes);
      ModelFile m;
      detail::read_model_header(r, m); // a file shorter than the header was read whole
      const std::uint64_t limit =
          std::min(model_file_max_bytes, detail::model_max_bytes(m.architecture));
      if (size > limit)
        SHADOWSENSE_THROW(
            ModelFileError("model file has " + std::to_string(size) + " bytes, expected at most " +
                           std::to_string(limit) +
                           " for its architecture (the file is not a model file or has data "
                           "appended)"));
    }
    read(bytes, head, static_cast<std::size_t>(size - head));
    return from_bytes(bytes);
  });
}

inline ModelFile ModelFile::from_bytes(std::span<const std::uint8_t> bytes) {
  detail::ModelReader r(bytes);
  ModelFile m;
  detail::read_model_header(r, m);
  const auto& a = m.architecture;
  // preprocessing
  r.section = "preprocessing";
  auto& p = m.preprocess;
  constexpr auto max_side = static_cast<std::uint32_t>(preprocess_max_side);
  p.resize_width = r.count("resize width", 0, max_side);
  p.resize_height = r.count("resize height", 0, max_side);
  p.crop_width = r.count("crop width", 0, max_side);
  p.crop_height = r.count("crop height", 0, max_side);
  p.contrast_factor = r.f32("contrast factor");
  p.dark_brightness_factor = r.f32("brightness factor");
  for (auto& v : p.mean) v = r.f32("mean");
  for (auto& v : p.std) v = r.f32("std");
  p.network_channel_order = static_cast<ChannelOrder>(r.count("channel order", 0, 1));
  if (m.format_version >= 2) {
    p.lighting_normalise = r.count("the lighting normalisation flag", 0, 1) == 1;
    p.lighting_target = r.f32("lighting target");
    p.dark_luminance_threshold = r.f32("dark luminance threshold");
  } else { // version 1: the behaviour of version-1 readers
    p.lighting_normalise = false;
    p.dark_luminance_threshold = 0.0f;
  }
  if (m.format_version >= 4) // colour is never written as version 4: one file per model
    p.input_encoding = static_cast<InputEncoding>(
        r.count("input encoding (version 4 records a calibrated one; colour models are version 2 "
                "or 3)",
                1, static_cast<std::uint32_t>(InputEncoding::darkness_contact)));
  p.validate<ModelFileError>();
  // class names
  r.section = "class names";
  const auto n_classes = static_cast<std::uint32_t>(a.num_classes);
  r.count("the number of class names (must equal num_classes)", n_classes, n_classes);
  m.class_names.reserve(n_classes);
  for (std::uint32_t i = 0; i < n_classes; ++i) m.class_names.push_back(r.str("a class name"));
  // tensors: names and shapes are checked against the architecture as they are read.
  r.section = "tensors";
  const auto expected = a.expected_tensors();
  const auto n_tensors = static_cast<std::uint32_t>(expected.size());
  r.count("the number of tensors", n_tensors, n_tensors);
  m.tensors.reserve(expected.size());
  for (const auto& e : expected) {
    NamedTensor t;
    t.name = r.str("a tensor name");
    if (t.name != e.name)
      SHADOWSENSE_THROW(ModelFileError("model file tensors section: tensor " +
                                       std::to_string(m.tensors.size()) + " is named '" + t.name +
                                       "', expected '" + e.name + "'"));
    const int ndim = r.count("a tensor's number of dimensions", 1, 4);
    for (int d = 0; d < ndim; ++d) t.shape.push_back(r.count("a tensor dimension", 1, 1u << 30));
    if (t.shape != e.shape)
      SHADOWSENSE_THROW(ModelFileError("model file tensors section: tensor '" + t.name +
                                       "' has shape " + detail::shape_to_string(t.shape) +
                                       ", expected " + detail::shape_to_string(e.shape) +
                                       " for this architecture"));
    r.floats(t.values, detail::shape_elements(t.shape), "tensor values");
    m.tensors.push_back(std::move(t));
  }
  // self-test
  r.section = "self-test";
  if (r.count("the self-test flag", 0, 1) == 1) {
    ModelSelfTest st;
    const int n = r.count("self-test batch size", 1, 64);
    const int c = r.count("self-test channels", 3, 3);
    const int h = r.count("self-test height", 1, 4096);
    const int w = r.count("self-test width", 1, 4096);
    const std::size_t count = static_cast<std::size_t>(n) * c * h * w;
    if (count > model_self_test_max_values)
      SHADOWSENSE_THROW(ModelFileError("model file self-test section: input of " +
                                       std::to_string(count) + " values, expected at most " +
                                       std::to_string(model_self_test_max_values)));
    r.need(count * 4, "self-test input");
    st.input.resize(n, c, h, w);
    std::vector<float> tmp;
    r.floats(tmp, count, "self-test input");
    std::copy(tmp.begin(), tmp.end(), st.input.data());
    r.floats(st.logits, static_cast<std::size_t>(n) * n_classes, "self-test logits");
    st.tolerance = r.f32("self-test tolerance");
    m.self_test = std::move(st);
  }
  bool has_int8 = m.format_version == 3;
  if (m.format_version >= 4) {
    r.section = "int8";
    has_int8 = r.count("the int8 flag", 0, 1) == 1;
  }
  if (has_int8) {
    r.section = "int8";
    const auto expected_convs = a.expected_int8_convs();
    const auto n_convs = static_cast<std::uint32_t>(expected_convs.size());
    r.count("the number of quantised convolutions", n_convs, n_convs);
    std::vector<QuantisedConv> convs;
    for (const auto& e : expected_convs) {
      QuantisedConv q;
      q.name = r.str("a quantised convolution's name");
      if (q.name != e.name)
        SHADOWSENSE_THROW(ModelFileError("model file int8 section: convolution " +
                                         std::to_string(convs.size()) + " is named '" + q.name +
                                         "', expected '" + e.name + "'"));
      const auto rows = static_cast<std::uint32_t>(e.shape[0]);
      const auto len = static_cast<std::uint32_t>(e.shape[1] * e.shape[2] * e.shape[3]);
      q.rows = r.count("a quantised convolution's rows (its output channels)", rows, rows);
      q.row_length = r.count("a quantised convolution's row length", len, len);
      q.input_scale = r.f32("an input scale");
      r.floats(q.weight_scales, rows, "weight scales");
      const std::size_t count = static_cast<std::size_t>(rows) * len;
      r.need(count, "int8 weights");
      q.weights.resize(count);
      std::memcpy(q.weights.data(), bytes.data() + r.pos, count);
      r.pos += count;
      convs.push_back(std::move(q));
    }
    m.int8 = std::move(convs);
  }
  // checksum
  r.section = "checksum";
  const std::size_t body = r.pos;
  const std::uint32_t stored = r.u32("the CRC-32 checksum");
  if (r.pos != bytes.size())
    SHADOWSENSE_THROW(
        ModelFileError("model file has " + std::to_string(bytes.size() - r.pos) +
                       " unexpected bytes after the checksum, expected the file to end at "
                       "byte " +
                       std::to_string(r.pos)));
  const std::uint32_t actual = detail::crc32(bytes.first(body));
  if (stored != actual)
    SHADOWSENSE_THROW(ModelFileError(
        "model file checksum mismatch: stored " + std::to_string(stored) + ", computed " +
        std::to_string(actual) + " (the file is corrupted or was edited)"));
  m.validate(); // NaN/Inf, negative variances, self-test consistency
  return m;
}

SHADOWSENSE_NAMESPACE_END
