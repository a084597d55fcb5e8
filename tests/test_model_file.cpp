// The model file: round trips, and every kind of bad file rejected with a message that names
// what was wrong (truncation at every byte, magic, version, shapes, NaN, checksum, classes).
#include <shadowsense/backends/densenet/model_file.hpp>

#include <doctest/doctest.h>

#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>

#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

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
  at += 4 * 4 + 4 + 4 + 6 * 4 + 4 + 3 * 4;                      // preprocessing (v2)
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
  const std::size_t names_start = pre_start + 4 * 4 + 2 * 4 + 6 * 4 + 4 + 3 * 4;
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

namespace {
// The version-1 bytes of a model: the version-2 bytes without the three preprocessing fields
// version 2 added (lighting flag, lighting target, dark threshold), version 1, CRC fixed.
std::vector<std::uint8_t> as_version_1(const ModelFile& m) {
  auto b = m.to_bytes();
  const std::size_t extra = tensors_offset(m) - 4 - 4;
  std::size_t at = 4; // the class count and names precede the tensor count
  for (const auto& n : m.class_names) at += 4 + n.size();
  const std::size_t v2_fields = extra - at - 12 + 4; // start of the 12 added bytes
  b.erase(b.begin() + static_cast<long>(v2_fields), b.begin() + static_cast<long>(v2_fields + 12));
  write_u32(b, 8, 1);
  fix_crc(b);
  return b;
}

std::filesystem::path tmp_dir(const std::string& name) {
  const auto dir = std::filesystem::path(SHADOWSENSE_TEST_TMP_DIR) / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

std::vector<std::uint8_t> file_bytes(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

std::string load_path_error(const std::filesystem::path& p) {
  try {
    (void)ModelFile::load(p);
  } catch (const IoError& e) {
    return std::string("IoError: ") + e.what();
  } catch (const ModelFileError& e) {
    return std::string("ModelFileError: ") + e.what();
  }
  return "(no error)";
}
} // namespace

TEST_CASE("version 2 records lighting normalisation and the dark-frame rule") {
  ModelFile m = tiny_model(true);
  m.preprocess.lighting_normalise = true;
  m.preprocess.lighting_target = 0.4f;
  m.preprocess.dark_luminance_threshold = 0.125f;
  const auto bytes = m.to_bytes();
  CHECK(read_u32(bytes, 8) == 2);
  const ModelFile back = ModelFile::from_bytes(bytes);
  CHECK(back.format_version == 2);
  CHECK(back.preprocess.lighting_normalise);
  CHECK(back.preprocess.lighting_target == 0.4f);
  CHECK(back.preprocess.dark_luminance_threshold == 0.125f);
  CHECK(back.to_bytes() == bytes);
  // The three fields sit right before the class count.
  const std::size_t flag = tensors_offset(m) - 4 - 4 - (4 + 4) - (4 + 4) - 12;
  REQUIRE(read_u32(bytes, flag) == 1);
  auto bad = bytes;
  write_u32(bad, flag, 2);
  fix_crc(bad);
  CHECK(load_error(bad).find("lighting normalisation flag is 2, expected 0..1") !=
        std::string::npos);
  bad = bytes;
  write_u32(bad, flag + 8, std::bit_cast<std::uint32_t>(1.5f));
  fix_crc(bad);
  CHECK(load_error(bad).find("dark luminance threshold 1.5") != std::string::npos);
  bad = bytes;
  write_u32(bad, flag + 4, std::bit_cast<std::uint32_t>(0.0f));
  fix_crc(bad);
  CHECK(load_error(bad).find("lighting target 0.0") != std::string::npos);
}

TEST_CASE("version-1 files still load, with the documented defaults, and save as version 2") {
  ModelFile m = tiny_model(true);
  m.preprocess.lighting_normalise = true; // not representable in version 1
  m.preprocess.dark_luminance_threshold = 0.3f;
  const auto v1 = as_version_1(m);
  CHECK(v1.size() + 12 == m.to_bytes().size());
  const ModelFile old = ModelFile::from_bytes(v1);
  CHECK(old.format_version == 1);
  CHECK_FALSE(old.preprocess.lighting_normalise);
  CHECK(old.preprocess.dark_luminance_threshold == 0.0f);
  CHECK(old.preprocess.resize_width == m.preprocess.resize_width);
  CHECK(old.tensors[0].values == m.tensors[0].values);
  // Upgrading in C++: set the options, save (always the current version).
  ModelFile up = old;
  up.preprocess.lighting_normalise = true;
  up.preprocess.dark_luminance_threshold = 0.3f;
  CHECK(up.to_bytes() == m.to_bytes());
  // The committed version-1 fixture (tools/make_densenet_fixture.py) loads as version 1.
  CHECK(ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn").format_version == 1);
}

TEST_CASE("version 4 records the input encoding; colour models stay version 2 byte for byte") {
  const ModelFile colour = tiny_model(true);
  const auto v2 = colour.to_bytes();
  CHECK(read_u32(v2, 8) == 2);
  ModelFile m = colour;
  m.preprocess.input_encoding = InputEncoding::skin_relative;
  const auto bytes = m.to_bytes();
  CHECK(read_u32(bytes, 8) == 4);
  CHECK(bytes.size() == v2.size() + 8); // the encoding and the int8 flag
  const ModelFile back = ModelFile::from_bytes(bytes);
  CHECK(back.format_version == 4);
  CHECK(back.preprocess.input_encoding == InputEncoding::skin_relative);
  CHECK_FALSE(back.int8);
  CHECK(back.to_bytes() == bytes);
  // The encoding sits right before the class count; the int8 flag right before the checksum.
  const std::size_t at = tensors_offset(m) - 4 - 4 - (4 + 4) - (4 + 4);
  REQUIRE(read_u32(bytes, at) == 1);
  CHECK(read_u32(bytes, bytes.size() - 8) == 0);
  // Apart from those two fields (and the version), the bytes are version 2's.
  CHECK(std::equal(v2.begin() + 12, v2.begin() + static_cast<long>(at), bytes.begin() + 12));
  CHECK(std::equal(v2.begin() + static_cast<long>(at), v2.end() - 4,
                   bytes.begin() + static_cast<long>(at) + 4));
  auto bad = bytes;
  write_u32(bad, at, 5);
  fix_crc(bad);
  CHECK(load_error(bad).find("colour models are version 2 or 3) is 5, expected 1..4") !=
        std::string::npos);
  // Code 2, darkness_warmth: refused with lighting normalisation (it takes none), loaded
  // without.
  ModelFile normalised = m;
  normalised.preprocess.lighting_normalise = true;
  auto dw = normalised.to_bytes();
  write_u32(dw, at, 2);
  fix_crc(dw);
  CHECK(load_error(dw).find("takes no lighting normalisation") != std::string::npos);
  ModelFile plain = m;
  plain.preprocess.lighting_normalise = false;
  plain.preprocess.input_encoding = InputEncoding::darkness_warmth;
  const auto dw_bytes = plain.to_bytes();
  CHECK(read_u32(dw_bytes, at) == 2);
  CHECK(ModelFile::from_bytes(dw_bytes).preprocess.input_encoding ==
        InputEncoding::darkness_warmth);
  // Code 3, masks: likewise light-independent.
  auto mk = normalised.to_bytes();
  write_u32(mk, at, 3);
  fix_crc(mk);
  CHECK(load_error(mk).find("masks input encoding is already independent") != std::string::npos);
  plain.preprocess.input_encoding = InputEncoding::masks;
  const auto mk_bytes = plain.to_bytes();
  CHECK(read_u32(mk_bytes, at) == 3);
  CHECK(ModelFile::from_bytes(mk_bytes).preprocess.input_encoding == InputEncoding::masks);
  plain.preprocess.input_encoding = InputEncoding::darkness_contact; // code 4
  const auto dc_bytes = plain.to_bytes();
  CHECK(read_u32(dc_bytes, at) == 4);
  CHECK(ModelFile::from_bytes(dc_bytes).preprocess.input_encoding ==
        InputEncoding::darkness_contact);
  auto dcn = normalised.to_bytes(); // with lighting normalisation: refused like masks
  write_u32(dcn, at, 4);
  fix_crc(dcn);
  CHECK(load_error(dcn).find("darkness_contact input encoding is already independent") !=
        std::string::npos);
  bad = bytes;
  write_u32(bad, bad.size() - 8, 2);
  fix_crc(bad);
  CHECK(load_error(bad).find("int8 flag is 2, expected 0..1") != std::string::npos);
  // A version-4 file recording colour is refused: a colour model has one byte form (version
  // 2 or 3), so every file that loads saves to its own bytes (fuzz/fuzz_model_file.cpp).
  bad = bytes;
  write_u32(bad, at, 0);
  fix_crc(bad);
  CHECK(load_error(bad).find("input encoding (version 4 records a calibrated one; colour models "
                             "are version 2 or 3) is 0, expected 1..4") != std::string::npos);
  // The truncation check covers the new fields too.
  for (std::size_t cut : {at + 2, bytes.size() - 6})
    CHECK(load_error({bytes.begin(), bytes.begin() + static_cast<long>(cut)}).find("truncated") !=
          std::string::npos);
}

TEST_CASE("a resize or crop beyond 4096 per side is rejected before any image is made") {
  ModelFile m = tiny_model(false);
  m.preprocess.resize_width = m.preprocess.resize_height = 65536;
  CHECK_THROWS_WITH_AS(m.to_bytes(), doctest::Contains("both in 1..4096"), ModelFileError);
  auto bytes = tiny_model(false).to_bytes();
  write_u32(bytes, 12 + 6 * 4 + 2 * 4, 65536); // resize width
  write_u32(bytes, 12 + 6 * 4 + 2 * 4 + 4, 65536);
  fix_crc(bytes);
  CHECK(load_error(bytes).find("resize width is 65536, expected 0..4096") != std::string::npos);
  PreprocessParams p;
  p.crop_width = p.crop_height = 5000;
  CHECK_THROWS_WITH_AS(p.validate(), doctest::Contains("both in 1..4096"), InvalidArgument);
}

TEST_CASE("directories, devices and FIFOs as model paths are IoErrors, never a hang") {
  const auto dir = tmp_dir("model_paths");
  CHECK(load_path_error(dir).starts_with("IoError: "));
  CHECK(load_path_error(dir).find("is a directory") != std::string::npos);
  CHECK(load_path_error("/dev/zero")
            .find("IoError: model file '/dev/zero' is not a regular "
                  "file") != std::string::npos);
  const auto fifo = dir / "model.fifo";
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  CHECK(load_path_error(fifo).find("not a regular file") != std::string::npos);
  CHECK_THROWS_WITH_AS(tiny_model(false).save(dir), doctest::Contains("is a directory"), IoError);
}

TEST_CASE("a huge file is rejected from its header, before the body is read") {
  const auto dir = tmp_dir("model_huge");
  // 1 GB sparse file with a wrong magic: only the header is read.
  const auto junk = dir / "junk.ssm";
  { std::ofstream(junk, std::ios::binary) << "NOTAMODEL"; }
  std::filesystem::resize_file(junk, std::uintmax_t(1) << 30);
  CHECK(load_path_error(junk).find("ModelFileError: " + junk.string() +
                                   ": not a shadowsense "
                                   "model file: wrong magic") != std::string::npos);
  // A valid header followed by 1 GB: larger than any model of that architecture can be.
  const auto big = dir / "big.ssm";
  tiny_model(false).save(big);
  std::filesystem::resize_file(big, std::uintmax_t(1) << 30);
  const auto msg = load_path_error(big);
  CHECK(msg.find("ModelFileError") == 0);
  CHECK(msg.find("model file has 1073741824 bytes, expected at most") != std::string::npos);
  std::filesystem::remove(junk);
  std::filesystem::remove(big);
}

TEST_CASE("save is atomic: a failed write leaves the old file and no temporary file") {
  const auto dir = tmp_dir("model_atomic");
  const auto path = dir / "model.ssm";
  const ModelFile small = tiny_model(false);
  small.save(path);
  const auto good = file_bytes(path);
  CHECK(ModelFile::load(path).to_bytes() == good);
  // A file-size limit below the new model's size (as on a full disk): the write fails.
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    std::signal(SIGXFSZ, SIG_IGN);
    const rlimit lim{static_cast<rlim_t>(good.size()), static_cast<rlim_t>(good.size())};
    ::setrlimit(RLIMIT_FSIZE, &lim);
    try {
      tiny_model(true).save(path); // larger: holds a self-test
    } catch (const IoError& e) {
      _exit(std::string(e.what()).find("unchanged") != std::string::npos ? 0 : 3);
    } catch (...) {
      _exit(4);
    }
    _exit(5);
  }
  int status = 0;
  REQUIRE(::waitpid(pid, &status, 0) == pid);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
  CHECK(file_bytes(path) == good);
  int files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++files;
  CHECK(files == 1); // no temporary file left
  CHECK_THROWS_WITH_AS(small.save(dir / "missing" / "model.ssm"),
                       doctest::Contains("cannot create a temporary file"), IoError);
  tiny_model(true).save(path); // and a successful save replaces it
  CHECK(ModelFile::load(path).self_test.has_value());
}
