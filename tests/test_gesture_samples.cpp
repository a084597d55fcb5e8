// Bad classification data gets a clear error naming the file (issue 5 robustness): an empty
// folder, a csv without frames, a class the model does not know, a corrupt or missing image.
#include <shadowsense/io/dataset.hpp>
#include <shadowsense/train/gesture_samples.hpp>

#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>

namespace fs = std::filesystem;
using namespace shadowsense;

namespace {
const fs::path tiny_model = fs::path(SHADOWSENSE_TEST_DATA_DIR) / "densenet_tiny.ssdn";

fs::path fresh_folder(const std::string& name) {
  const fs::path dir = fs::path(SHADOWSENSE_TEST_TMP_DIR) / "gesture_samples" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

MetadataRow row(const std::string& file, const std::string& label, double t) {
  MetadataRow r;
  r.file_name = file;
  r.label = label;
  r.session = "u0_daylight";
  r.timestamp_ms = t;
  r.px_per_cm = 7.58; // the robot rig's scale; the reader requires a positive one
  return r;
}
} // namespace

TEST_CASE("a folder without metadata.csv is rejected naming the csv it looked for") {
  const fs::path dir = fresh_folder("empty");
  const std::string expected = (dir / "metadata.csv").string() + ": missing";
  CHECK_THROWS_WITH_AS(load_gesture_samples(dir, {"a", "b"}), doctest::Contains(expected.c_str()),
                       DatasetError);
}

TEST_CASE("a metadata.csv without frames is rejected") {
  const fs::path dir = fresh_folder("no_frames");
  write_metadata(dir / "metadata.csv", {}, false);
  CHECK_THROWS_WITH_AS(load_gesture_samples(dir, {"a", "b"}),
                       doctest::Contains("metadata.csv:2: no data rows"), DatasetError);
}

TEST_CASE("a class the model does not know is rejected naming file, line and class") {
  const ModelFile model = ModelFile::load(tiny_model.string());
  const fs::path dir = fresh_folder("unknown_class");
  write_metadata(dir / "metadata.csv",
                 {row("x/0.png", model.class_names.front(), 0), row("y/1.png", "no_such_class", 1)},
                 false);
  CHECK_THROWS_WITH_AS(load_gesture_samples(dir, model.class_names),
                       doctest::Contains("metadata.csv:3: class 'no_such_class' is not one of the "
                                         "model's classes"),
                       DatasetError);
}

TEST_CASE("corrupt and missing images are IoErrors naming the image; good frames encode") {
  const ModelFile model = ModelFile::load(tiny_model.string());
  const std::string cls = model.class_names.front();
  const fs::path dir = fresh_folder("images");
  fs::create_directories(dir / cls);
  cv::imwrite((dir / cls / "good.png").string(),
              cv::Mat(60, 80, CV_8UC3, cv::Scalar(90, 120, 150)));
  std::ofstream(dir / cls / "corrupt.png") << "not a png";
  write_metadata(dir / "metadata.csv",
                 {row(cls + "/good.png", cls, 0), row(cls + "/corrupt.png", cls, 1),
                  row(cls + "/missing.png", cls, 2)},
                 false);
  const GestureSamples set = load_gesture_samples(dir, model.class_names);
  REQUIRE(set.frames.size() == 3);

  FeatureExtractor fx(model);
  FrameEncoder encoder(model.preprocess, false);
  const std::vector<std::size_t> good{0}, corrupt{1}, missing{2};
  const Eigen::MatrixXd features = extract_features(fx, encoder, set, good);
  CHECK(features.rows() == 1);
  CHECK(features.cols() == fx.dim());
  CHECK(features.allFinite());
  CHECK_THROWS_WITH_AS(extract_features(fx, encoder, set, corrupt),
                       doctest::Contains("corrupt.png: cannot read the image"), IoError);
  CHECK_THROWS_WITH_AS(extract_features(fx, encoder, set, missing),
                       doctest::Contains("missing.png: cannot read the image"), IoError);
}
