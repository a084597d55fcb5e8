// Labelled gesture frames for training and evaluation: a dataset folder (docs/dataset_format.md)
// read into frames with a class index, the paper's metadata splits (by user, lighting and
// collection time), and feature extraction through the FrameEncoder every classifier entry
// point shares (classify/frame_encoder.hpp), so ss_train_head, ss_eval_classify, ss_classify,
// ss_demo and tools/train.py see identical tensors.
#pragma once

#include <shadowsense/classify/frame_encoder.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/version.hpp>
#include <shadowsense/io/dataset.hpp>
#include <shadowsense/io/image_file.hpp>
#include <shadowsense/io/image_folder.hpp>
#include <shadowsense/train/head_trainer.hpp>

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <functional>
#include <iterator>
#include <map>
#include <span>
#include <string>
#include <tuple>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

struct GestureSample {
  std::filesystem::path path;
  int label = -1; // index into GestureSamples::class_names
  int user = 0;
  Lighting lighting = Lighting::daylight;
  double lighting_level = 1.0;
  std::string session;
  double timestamp_ms = 0;
  // false for a plain class-per-folder tree: user and lighting unknown, 'dark' is then decided
  // by the model's dark-frame rule (FrameEncoder::run without a flag).
  bool from_metadata = true;
};

struct GestureSamples {
  std::vector<std::string> class_names;
  std::vector<GestureSample> frames;
};

// Images taken in the dark get the brightness factor (paper 5.1.2): the night preset, or a
// custom level below 0.25. tools/train.py uses the same rule.
inline bool is_dark(const GestureSample& f) {
  return f.lighting == Lighting::night ||
         (f.lighting == Lighting::custom && f.lighting_level < 0.25);
}

// Reads folder/metadata.csv. Every class must be one of class_names (the model's order).
inline GestureSamples load_gesture_samples(const std::filesystem::path& folder,
                                           std::vector<std::string> class_names) {
  const auto csv = folder / "metadata.csv";
  detail::require<DatasetError>(std::filesystem::is_regular_file(csv),
                                csv.string() + ": missing; expected a dataset folder with a "
                                               "metadata.csv (docs/dataset_format.md)");
  const Metadata md = read_metadata(csv);
  detail::require<DatasetError>(!md.rows.empty(), csv.string() + ": no frames");
  GestureSamples out;
  out.class_names = std::move(class_names);
  for (const auto& r : md.rows) {
    const auto it = std::find(out.class_names.begin(), out.class_names.end(), r.label);
    detail::require<DatasetError>(it != out.class_names.end(),
                                  csv.string() + ":" + std::to_string(r.line) + ": class '" +
                                      r.label + "' is not one of the model's classes");
    out.frames.push_back({md.image_path(r), static_cast<int>(it - out.class_names.begin()), r.user,
                          r.lighting, r.lighting_level, r.session, r.timestamp_ms});
  }
  return out;
}

// find_images (the one rule for a folder of images): io/image_folder.hpp.

// A plain class-per-folder tree without metadata.csv: folder/<class>/**/<image>. The class of
// an image is the name of the first folder below `folder` on its path. class_names: the
// model's order (every class found must be one of them), or empty for the sorted folder
// names. Frames of a class keep path order as their collection order (session = class,
// timestamp_ms = index), user 0, from_metadata false. Throws DatasetError when no image is
// found or a class is unknown.
inline GestureSamples load_class_folders(const std::filesystem::path& folder,
                                         std::vector<std::string> class_names) {
  const auto images = find_images(folder);
  std::vector<std::pair<std::string, std::filesystem::path>> labelled;
  for (const auto& p : images) {
    const auto rel = std::filesystem::relative(p, folder);
    if (std::distance(rel.begin(), rel.end()) < 2) continue; // an image directly in folder
    labelled.emplace_back(rel.begin()->string(), p);
  }
  detail::require<DatasetError>(!labelled.empty(),
                                folder.string() + ": no metadata.csv and no images in class "
                                                  "sub-folders, expected folder/<class>/*.png");
  if (class_names.empty()) {
    for (const auto& [c, p] : labelled)
      if (std::find(class_names.begin(), class_names.end(), c) == class_names.end())
        class_names.push_back(c);
    std::sort(class_names.begin(), class_names.end());
  }
  GestureSamples out;
  out.class_names = std::move(class_names);
  std::map<std::string, int> index_in_class;
  for (const auto& [c, p] : labelled) {
    const auto it = std::find(out.class_names.begin(), out.class_names.end(), c);
    detail::require<DatasetError>(it != out.class_names.end(),
                                  p.string() + ": class folder '" + c +
                                      "' is not one of the model's classes");
    GestureSample f;
    f.path = p;
    f.label = static_cast<int>(it - out.class_names.begin());
    f.session = c;
    f.timestamp_ms = index_in_class[c]++;
    f.from_metadata = false;
    out.frames.push_back(std::move(f));
  }
  return out;
}

// folder/metadata.csv when it exists (load_gesture_samples), else a plain class-per-folder
// tree (load_class_folders).
inline GestureSamples load_gesture_folder(const std::filesystem::path& folder,
                                          std::vector<std::string> class_names) {
  if (std::filesystem::exists(folder / "metadata.csv"))
    return load_gesture_samples(folder, std::move(class_names));
  return load_class_folders(folder, std::move(class_names));
}

// Indices of the frames passing `keep`.
inline std::vector<std::size_t>
select_samples(const GestureSamples& set, const std::function<bool(const GestureSample&)>& keep) {
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < set.frames.size(); ++i)
    if (keep(set.frames[i])) out.push_back(i);
  return out;
}

// The paper's split by collection time: within every session x class block, the last
// `fraction` of the frames (by timestamp) go to .second, the rest to .first.
inline std::pair<std::vector<std::size_t>, std::vector<std::size_t>>
time_split(const GestureSamples& set, std::span<const std::size_t> indices, double fraction) {
  detail::require(fraction >= 0 && fraction <= 1, "time_split: fraction must be in [0, 1]");
  std::map<std::pair<std::string, int>, std::vector<std::size_t>> blocks;
  for (std::size_t i : indices) blocks[{set.frames[i].session, set.frames[i].label}].push_back(i);
  std::pair<std::vector<std::size_t>, std::vector<std::size_t>> out;
  for (auto& [key, b] : blocks) {
    std::stable_sort(b.begin(), b.end(), [&](std::size_t a, std::size_t c) {
      return set.frames[a].timestamp_ms < set.frames[c].timestamp_ms;
    });
    // Python's round(fraction * n) (tools/train.py): half to even.
    const double want = fraction * double(b.size());
    double r = std::round(want);
    if (std::abs(want - std::floor(want) - 0.5) < 1e-12)
      r = std::fmod(std::floor(want), 2.0) == 0 ? std::floor(want) : std::ceil(want);
    const std::size_t cut = b.size() - static_cast<std::size_t>(r);
    out.first.insert(out.first.end(), b.begin(), b.begin() + static_cast<std::ptrdiff_t>(cut));
    out.second.insert(out.second.end(), b.begin() + static_cast<std::ptrdiff_t>(cut), b.end());
  }
  return out;
}

// Reads a colour image; a missing or corrupt file is an IoError naming it. PNG, JPEG and BMP
// are checked from their header (io/image_file.hpp: at most 8192 px per side) before any pixel
// is decoded, so a small file claiming a huge image is refused cheaply.
inline cv::Mat read_colour_image(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp")
    return read_image_file(path, cv::IMREAD_COLOR);
  cv::Mat img = cv::imread(path.string(), cv::IMREAD_COLOR);
  detail::require<IoError>(!img.empty(), path.string() +
                                             ": cannot read the image (missing, corrupt or not "
                                             "an image format OpenCV reads)");
  return img;
}

// Pooled features of the given frames (row per index, in order). progress(done, total) is
// called every 100 frames.
inline Eigen::MatrixXd
extract_features(FeatureExtractor& fx, FrameEncoder& enc, const GestureSamples& set,
                 std::span<const std::size_t> indices,
                 const std::function<void(std::size_t, std::size_t)>& progress = {}) {
  Eigen::MatrixXd out(static_cast<Eigen::Index>(indices.size()), fx.dim());
  Tensor t;
  for (std::size_t k = 0; k < indices.size(); ++k) {
    const auto& f = set.frames[indices[k]];
    std::span<const float> v;
    try {
      const cv::Mat image = read_colour_image(f.path);
      if (f.from_metadata)
        enc.run(image, is_dark(f), t);
      else
        enc.run(image, t); // the model's dark-frame rule

      v = fx.extract(t);
    } catch (const IoError&) {
      throw;
    } catch (const Error& e) { // name the frame: wrong geometry for the model, bad pixels
      SHADOWSENSE_THROW(DatasetError(f.path.string() + ": " + e.what()));
    }
    for (int c = 0; c < fx.dim(); ++c)
      out(static_cast<Eigen::Index>(k), c) = v[static_cast<std::size_t>(c)];
    if (progress && ((k + 1) % 100 == 0 || k + 1 == indices.size()))
      progress(k + 1, indices.size());
  }
  return out;
}

inline std::vector<int> labels_of(const GestureSamples& set, std::span<const std::size_t> indices) {
  std::vector<int> y;
  for (std::size_t i : indices) y.push_back(set.frames[i].label);
  return y;
}

SHADOWSENSE_NAMESPACE_END
