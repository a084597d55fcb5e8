// The model file: round trips, and every kind of bad file rejected with a message that names
// what was wrong (truncation at every byte, magic, version, shapes, NaN, checksum, classes).
#include <shadowsense/backends/densenet/model_file.hpp>

#include <doctest/doctest.h>

#include <cstring>
#include <filesystem>
#include <limits>
#include <string>

using namespace shadowsense;

namespace {

// A tiny, complete model built in C++ (deterministic pseudo-random values).
ModelFile tiny_model(bool with_self_test) {
  ModelFile m;
  m.architecture = {.growth_rate = 2,
                    .block_config = {1, 1},
                    .init_features = 2,
                    .bn_size = 1,
                    .num_classes = 2,
                    .bn_eps = 1e-5f};
  m.class_names = {"palm", "fist"};
  unsigned state = 12345;
  auto next = [&] {
    state = state * 1103515245u + 12345u;
    return static_cast<float>((state >> 9) & 0xFFFF) / 65536.0f - 0.5f;
  };
  for (const auto& spec : m.architecture.expected_tensors()) {
    NamedTensor t{spec.name, spec.shape, {}};
    std::size_t n = 1;
    for (int d : spec.shape) n *= static_cast<std::size_t>(d);
    for (std::size_t i = 0; i < n; ++i)
      t.values.push_back(spec.name.ends_with("running_var") ? 1.0f + next() : next());
    m.tensors.push_back(std::move(t));
  }
  if (with_self_test) {
    ModelSelfTest st;
    st.input.resize(1, 3, 16, 16);
    for (float& v : st.input.values()) v = next();
    st.logits = {0.25f, -0.5f};
    m.self_test = std::move(st);
  }
  return m;
}

std::uint32_t read_u32(const std::vector<std::uint8_t>& b, std::size_t at) {
  return static_cast<std::uint32_t>(b[at]) | static_cast<std::uint32_t>(b[at + 1]) << 8 |
         static_cast<std::uint32_t>(b[at + 2]) << 16 | static_cast<std::uint32_t>(b[at + 3]) << 24;
}
void write_u32(std::vector<std::uint8_t>& b, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}
// Rewrites the trailing CRC so a deliberate edit is seen by the check it targets.
void fix_crc(std::vector<std::uint8_t>& b) {
  write_u32(b, b.size() - 4, detail::crc32(std::span(b).first(b.size() - 4)));
}

std::string load_error(const std::vector<std::uint8_t>& bytes) {
  try {
    (void)ModelFile::from_bytes(bytes);
  } catch (const ModelFileError& e) {
    return e.what();
  }
  return "(no error)";
}

// Byte offset of the first tensor's name-length field in tiny_model's serialisation.
std::size_t tensors_offset(const ModelFile& m) {
  std::size_t at = 8 + 4;                                       // magic, version
  at += 4 * 4 + 4 + 4 + 4 * m.architecture.block_config.size(); // architecture
  at += 4 * 4 + 4 + 4 + 6 * 4 + 4;                              // preprocessing
  at += 4;                                                      // class count
  for (const auto& n : m.class_names) at += 4 + n.size();
  return at + 4; // tensor count
}

} // namespace

TEST_CASE("a model round-trips through bytes, a file and a memory span unchanged") {
  const ModelFile m = tiny_model(true);
  const auto bytes = m.to_bytes();
  const ModelFile back = ModelFile::from_bytes(bytes);
  CHECK(back.to_bytes() == bytes);
  CHECK(back.class_names == m.class_names);
  CHECK(back.architecture.block_config == m.architecture.block_config);
  CHECK(back.tensor("classifier.bias").values == m.tensor("classifier.bias").values);
  REQUIRE(back.self_test.has_value());
  CHECK(back.self_test->logits == m.self_test->logits);

  std::filesystem::create_directories(SHADOWSENSE_TEST_TMP_DIR);
  const auto path = std::filesystem::path(SHADOWSENSE_TEST_TMP_DIR) / "tiny.ssdn";
  m.save(path);
  CHECK(ModelFile::load(path).to_bytes() == bytes);

  // Firmware path: the bytes as an embedded std::byte array.
  std::vector<std::byte> raw(bytes.size());
  std::memcpy(raw.data(), bytes.data(), bytes.size());
  CHECK(ModelFile::from_bytes(std::span<const std::byte>(raw)).to_bytes() == bytes);
}

TEST_CASE("the committed fixture loads and holds what its generator wrote") {
  const auto m = ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  CHECK(m.architecture.growth_rate == 8);
  CHECK(m.architecture.block_config == std::vector<int>{2, 3, 2});
  CHECK(m.architecture.init_features == 16);
  CHECK(m.architecture.bn_size == 2);
  CHECK(m.class_names.size() == 7);
  CHECK(m.class_names[2] == "palm");
  CHECK(m.preprocess.contrast_factor == 3.0f);
  CHECK(m.preprocess.dark_brightness_factor == 2.0f);
  CHECK(m.preprocess.mean[0] == doctest::Approx(0.485));
  CHECK(m.preprocess.std[2] == doctest::Approx(0.225));
  REQUIRE(m.self_test.has_value());
  CHECK(m.self_test->input.n() == 2);
  CHECK(m.self_test->input.h() == 45);
  CHECK(m.self_test->input.w() == 61);
}

TEST_CASE("truncation at every byte is rejected, naming the section it happened in") {
  const ModelFile m = tiny_model(true);
  const auto bytes = m.to_bytes();
  const std::size_t arch_start = 12, pre_start = arch_start + 6 * 4 + 2 * 4;
  const std::size_t names_start = pre_start + 4 * 4 + 2 * 4 + 6 * 4 + 4;
  const std::size_t tensors_start = tensors_offset(m) - 4;
  for (std::size_t len = 0; len < bytes.size(); ++len) {
    const std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<long>(len));
    const std::string msg = load_error(cut);
    CAPTURE(len);
    CAPTURE(msg);
    REQUIRE(msg.find("truncated") != std::string::npos);
    const char* section = len < arch_start          ? "header"
                          : len < pre_start         ? "architecture"
                          : len < names_start       ? "preprocessing"
                          : len < tensors_start     ? "class names"
                          : len >= bytes.size() - 4 ? "checksum"
                                                    : nullptr;
    if (section)
      CHECK(msg.find(std::string("in the ") + section + " section") != std::string::npos);
  }
  // The last byte cut still leaves the whole body: the checksum section reports it.
  CHECK(load_error({bytes.begin(), bytes.end() - 1}).find("checksum section") != std::string::npos);
  // Cuts inside the tensors and the self-test name those sections.
  const std::size_t mid_tensors = tensors_offset(m) + 40;
  CHECK(load_error({bytes.begin(), bytes.begin() + static_cast<long>(mid_tensors)})
            .find("tensors section") != std::string::npos);
  CHECK(load_error({bytes.begin(), bytes.end() - 20}).find("self-test section") !=
        std::string::npos);
}

TEST_CASE("wrong magic and versions are rejected with a regenerate / update hint") {
  auto bytes = tiny_model(false).to_bytes();
  auto bad = bytes;
  bad[0] = 'X';
  CHECK(load_error(bad).find("wrong magic") != std::string::npos);
  bad = bytes;
  write_u32(bad, 8, 0);
  fix_crc(bad);
  const auto old = load_error(bad);
  CHECK(old.find("too old") != std::string::npos);
  CHECK(old.find("regenerate") != std::string::npos);
  write_u32(bad, 8, model_file_version + 1);
  fix_crc(bad);
  CHECK(load_error(bad).find("newer than this library") != std::string::npos);
  CHECK(load_error({}).find("truncated in the header") != std::string::npos);
}

TEST_CASE("checksum mismatches, trailing bytes and zero classes are rejected") {
  const ModelFile m = tiny_model(false);
  const auto bytes = m.to_bytes();
  auto bad = bytes;
  bad[tensors_offset(m) + 60] ^= 0x01; // a bit flip in conv0's values
  CHECK(load_error(bad).find("checksum mismatch") != std::string::npos);
  bad = bytes;
  bad.push_back(0);
  CHECK(load_error(bad).find("unexpected bytes after the checksum") != std::string::npos);
  bad = bytes;
  write_u32(bad, 12 + 12, 0); // num_classes
  fix_crc(bad);
  CHECK(load_error(bad).find("zero classes") != std::string::npos);
  ModelFile zero = m;
  zero.architecture.num_classes = 0;
  CHECK_THROWS_WITH_AS(zero.to_bytes(), doctest::Contains("zero classes"), ModelFileError);
}

TEST_CASE("shape, name and count mismatches are named with the expected value") {
  const ModelFile m = tiny_model(false);
  const auto bytes = m.to_bytes();
  const std::size_t t0 = tensors_offset(m);
  const std::uint32_t name_len = read_u32(bytes, t0);
  REQUIRE(name_len == std::string("features.conv0.weight").size());
  auto bad = bytes;
  const std::size_t dim0 = t0 + 4 + name_len + 4;
  write_u32(bad, dim0, read_u32(bad, dim0) + 1); // conv0 out channels 2 -> 3
  fix_crc(bad);
  const auto msg = load_error(bad);
  CHECK(msg.find("'features.conv0.weight' has shape [3, 3, 7, 7], expected [2, 3, 7, 7]") !=
        std::string::npos);
  bad = bytes;
  bad[t0 + 4] = 'g'; // "features..." -> "geatures..."
  fix_crc(bad);
  CHECK(load_error(bad).find("expected 'features.conv0.weight'") != std::string::npos);
  bad = bytes;
  // The block count (offset 32) stays 2; the first block (offset 36) gets 0 layers.
  write_u32(bad, 12 + 24, 0);
  fix_crc(bad);
  CHECK(load_error(bad).find("layers of a dense block is 0") != std::string::npos);

  ModelFile shape = m;
  shape.tensors[3].shape = {5};
  CHECK_THROWS_WITH_AS(shape.to_bytes(), doctest::Contains("expected [2]"), ModelFileError);
  ModelFile names = m;
  names.class_names.pop_back();
  CHECK_THROWS_WITH_AS(names.to_bytes(), doctest::Contains("1 class names, expected one per class"),
                       ModelFileError);
}

TEST_CASE("NaN/Inf weights and negative variances are rejected on save and on load") {
  const ModelFile m = tiny_model(false);
  for (float bad_value :
       {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    ModelFile bad = m;
    bad.tensor("features.norm5.bias").values[1] = bad_value;
    CHECK_THROWS_WITH_AS(bad.to_bytes(), doctest::Contains("expected a finite number"),
                         ModelFileError);
  }
  // Same through the loader: patch conv0's first value to NaN and fix the CRC.
  auto bytes = m.to_bytes();
  const std::size_t first_value = tensors_offset(m) + 4 + 21 + 4 + 16;
  write_u32(bytes, first_value, 0x7FC00000u);
  fix_crc(bytes);
  CHECK(load_error(bytes).find("'features.conv0.weight' value 0 is nan, expected a finite") !=
        std::string::npos);

  ModelFile neg = m;
  neg.tensor("features.norm0.running_var").values[0] = -1.0f;
  CHECK_THROWS_WITH_AS(neg.to_bytes(), doctest::Contains("expected a variance >= 0"),
                       ModelFileError);
}

TEST_CASE("loading a missing path is an IoError naming the path") {
  CHECK_THROWS_WITH_AS(ModelFile::load("/nonexistent/model.ssdn"),
                       doctest::Contains("/nonexistent/model.ssdn"), IoError);
}
