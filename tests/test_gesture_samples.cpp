// Bad classification data gets a clear error naming the file (issue 5 robustness): an empty
// folder, a csv without frames, a class the model does not know, a corrupt or missing image.
#include <shadowsense/io/dataset.hpp>
#include <shadowsense/train/gesture_samples.hpp>

#include <doctest/doctest.h>

#include "common/files.hpp"
#include <filesystem>
#include <fstream>

namespace fs = std::filesystem;
using namespace shadowsense;

namespace {
const fs::path tiny_model_path = fs::path(SHADOWSENSE_TEST_DATA_DIR) / "densenet_tiny.ssdn";

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
  const fs::path dir = tests::fresh_dir("gesture_samples/empty");
  const std::string expected = (dir / "metadata.csv").string() + ": missing";
  CHECK_THROWS_WITH_AS(load_gesture_samples(dir, {"a", "b"}), doctest::Contains(expected.c_str()),
                       DatasetError);
}

TEST_CASE("a metadata.csv without frames is rejected") {
  const fs::path dir = tests::fresh_dir("gesture_samples/no_frames");
  write_metadata(dir / "metadata.csv", {}, false);
  CHECK_THROWS_WITH_AS(load_gesture_samples(dir, {"a", "b"}),
                       doctest::Contains("metadata.csv:2: no data rows"), DatasetError);
}

TEST_CASE("a class the model does not know is rejected naming file, line and class") {
  const ModelFile model = ModelFile::load(tiny_model_path.string());
  const fs::path dir = tests::fresh_dir("gesture_samples/unknown_class");
  write_metadata(dir / "metadata.csv",
                 {row("x/0.png", model.class_names.front(), 0), row("y/1.png", "no_such_class", 1)},
                 false);
  CHECK_THROWS_WITH_AS(load_gesture_samples(dir, model.class_names),
                       doctest::Contains("metadata.csv:3: class 'no_such_class' is not one of the "
                                         "model's classes"),
                       DatasetError);
}

TEST_CASE("corrupt and missing images are IoErrors naming the image; good frames encode") {
  const ModelFile model = ModelFile::load(tiny_model_path.string());
  const std::string cls = model.class_names.front();
  const fs::path dir = tests::fresh_dir("gesture_samples/images");
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

TEST_CASE("a plain class-per-folder tree: recursive, sorted, hidden files and non-images skipped") {
  const fs::path dir = tests::fresh_dir("gesture_samples/tree");
  const cv::Mat img(30, 40, CV_8UC3, cv::Scalar(10, 20, 30));
  for (const char* p : {"palm/b.png", "palm/a.PNG", "palm/deep/er/c.jpg", "fist/z.bmp",
                        "fist/.hidden.png", ".cache/x.png", "stray.png"}) {
    fs::create_directories((dir / p).parent_path());
    cv::imwrite((dir / p).string(), img);
  }
  std::ofstream(dir / "palm" / "notes.txt") << "not an image";
  const auto images = find_images(dir);
  std::vector<std::string> rel;
  for (const auto& p : images) rel.push_back(fs::relative(p, dir).string());
  CHECK(rel == std::vector<std::string>{"fist/z.bmp", "palm/a.PNG", "palm/b.png",
                                        "palm/deep/er/c.jpg", "stray.png"});
  CHECK_THROWS_WITH_AS(find_images(dir / "stray.png"), doctest::Contains("not a folder"), IoError);

  // Classes from the folder names (sorted) or in the model's order; stray.png has no class.
  const GestureSamples own = load_class_folders(dir, {});
  CHECK(own.class_names == std::vector<std::string>{"fist", "palm"});
  REQUIRE(own.frames.size() == 4);
  CHECK(own.frames[0].label == 0);
  CHECK(own.frames[3].path == dir / "palm/deep/er/c.jpg");
  CHECK(own.frames[3].label == 1);
  CHECK(own.frames[3].session == "palm");
  CHECK(own.frames[3].timestamp_ms == 2); // third palm frame in path order
  CHECK_FALSE(own.frames[3].from_metadata);
  const GestureSamples ordered = load_class_folders(dir, {"palm", "fist", "wave"});
  CHECK(ordered.frames[0].label == 1);
  CHECK_THROWS_WITH_AS(load_class_folders(dir, {"palm"}),
                       doctest::Contains("z.bmp: class folder 'fist' is not one of the model's"),
                       DatasetError);
  // load_gesture_folder takes metadata.csv when there is one, the tree otherwise.
  CHECK(load_gesture_folder(dir, {}).frames.size() == 4);
  const fs::path empty = tests::fresh_dir("gesture_samples/tree_empty");
  cv::imwrite((empty / "only_here.png").string(), img);
  CHECK_THROWS_WITH_AS(load_gesture_folder(empty, {}), doctest::Contains("no images in class"),
                       DatasetError);
}

TEST_CASE("frames without metadata are encoded with the model's dark-frame rule") {
  ModelFile model = ModelFile::load(tiny_model_path.string());
  model.preprocess.dark_luminance_threshold = 0.2f;
  const std::string cls = model.class_names.front();
  const fs::path dir = tests::fresh_dir("gesture_samples/tree_dark");
  fs::create_directories(dir / cls);
  const cv::Mat dark(60, 80, CV_8UC3, cv::Scalar::all(25)); // luminance 0.098 < 0.2
  cv::imwrite((dir / cls / "dark.png").string(), dark);
  const GestureSamples set = load_class_folders(dir, model.class_names);
  FeatureExtractor fx(model);
  FrameEncoder encoder(model.preprocess, false);
  const std::vector<std::size_t> first{0};
  const Eigen::MatrixXd got = extract_features(fx, encoder, set, first);
  Tensor t;
  encoder.run(dark, true, t); // brightened, as the rule says
  const auto v = fx.extract(t);
  for (int c = 0; c < fx.dim(); ++c) CHECK(got(0, c) == v[static_cast<std::size_t>(c)]);
  encoder.run(dark, false, t);
  const auto plain = fx.extract(t);
  bool differs = false;
  for (int c = 0; c < fx.dim(); ++c) differs |= got(0, c) != plain[static_cast<std::size_t>(c)];
  CHECK(differs);
}
