// Writes the scene generator's three datasets in the documented format
// (docs/dataset_format.md): (a) gesture frames on the robot rig, (b) tracking frames on the
// test box, (c) slide sequences. Deterministic for a seed. The configuration is validated
// before anything is written, and every csv is written last via a temporary file + rename,
// so an interrupted run never leaves a dataset that looks complete.
#pragma once

#include <shadowsense/dataset.hpp>
#include <shadowsense/error.hpp>
#include <shadowsense/sim/gestures.hpp>
#include <shadowsense/sim/renderer.hpp>
#include <shadowsense/sim/tracking.hpp>

#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN
namespace sim {

struct GestureDatasetConfig {
  int users = 4;
  int frames_per_gesture = 3; // per user, lighting and gesture (paper: 85 -> 6,120 frames)
  std::vector<double> lighting_levels{1.0, 0.5, 0.0}; // daylight, dusk, night
  double fps = 10.0;
  double distractor_probability = 0.25;
  bool overwrite = false; // allow writing into a non-empty folder

  static GestureDatasetConfig paper() {
    GestureDatasetConfig c;
    c.frames_per_gesture = 85;
    return c;
  }
  int total_frames() const {
    return users * frames_per_gesture * static_cast<int>(all_gestures.size()) *
           static_cast<int>(lighting_levels.size());
  }
  void validate() const {
    detail::require(users >= 1 && users <= 1000,
                    "GestureDatasetConfig: users must be in [1, 1000], got " +
                        std::to_string(users));
    detail::require(frames_per_gesture >= 1 && frames_per_gesture <= 100000,
                    "GestureDatasetConfig: frames_per_gesture must be in [1, 100000], got " +
                        std::to_string(frames_per_gesture));
    detail::require(!lighting_levels.empty(),
                    "GestureDatasetConfig: lighting_levels must not be empty");
    for (double l : lighting_levels)
      detail::require(std::isfinite(l) && l >= 0 && l <= 1,
                      "GestureDatasetConfig: lighting level " + std::to_string(l) +
                          " is outside [0, 1]");
    GestureSessionConfig{.frames_per_gesture = frames_per_gesture,
                         .fps = fps,
                         .distractor_probability = distractor_probability}
        .validate();
  }
};

struct TrackingDatasetConfig {
  int frames_per_category = 10; // paper: 100 -> 500 frames
  int users = 4;
  TrackingSampleConfig sample{};
  bool overwrite = false;

  static TrackingDatasetConfig paper() {
    TrackingDatasetConfig c;
    c.frames_per_category = 100;
    return c;
  }
  int total_frames() const {
    return frames_per_category * static_cast<int>(all_track_categories.size());
  }
  void validate() const {
    detail::require(frames_per_category >= 1 && frames_per_category <= 1000000,
                    "TrackingDatasetConfig: frames_per_category must be in [1, 1000000], got " +
                        std::to_string(frames_per_category));
    detail::require(users >= 1 && users <= 1000,
                    "TrackingDatasetConfig: users must be in [1, 1000]");
    sample.validate();
  }
};

struct SlideDatasetConfig {
  int sequences_per_combination = 1; // per direction x gesture (paper: 20 -> 160 sequences)
  int users = 4;
  SlideConfig slide{};
  bool overwrite = false;

  static SlideDatasetConfig paper() {
    SlideDatasetConfig c;
    c.sequences_per_combination = 20;
    return c;
  }
  int total_sequences() const { return sequences_per_combination * 8; }
  void validate() const {
    detail::require(sequences_per_combination >= 1 && sequences_per_combination <= 100000,
                    "SlideDatasetConfig: sequences_per_combination must be in [1, 100000], got " +
                        std::to_string(sequences_per_combination));
    detail::require(users >= 1 && users <= 1000, "SlideDatasetConfig: users must be in [1, 1000]");
    slide.validate();
  }
};

struct DatasetSummary {
  std::filesystem::path root;
  int images = 0;
  int sequences = 0;
};

// The same person for a given (seed, id) in every dataset.
inline User dataset_user(std::uint64_t seed, int id) {
  Rng rng(derive_seed(seed, 0x05E40000ull + static_cast<std::uint64_t>(id)));
  return User::random(id, rng);
}

namespace internal {

// Makes `dir` ready to receive a dataset: it must be new/empty unless overwrite, in which case
// the old csv files are removed first so the old dataset no longer looks complete.
inline void prepare_output(const std::filesystem::path& dir, bool overwrite,
                           std::initializer_list<const char*> csv_names) {
  namespace fs = std::filesystem;
  detail::require(!dir.empty(), "dataset writer: the output folder path is empty");
  std::error_code ec;
  if (fs::exists(dir, ec)) {
    if (!fs::is_directory(dir, ec)) throw IoError(dir.string() + ": exists and is not a folder");
    if (!fs::is_empty(dir, ec)) {
      if (!overwrite)
        throw IoError(dir.string() +
                      ": folder is not empty; choose a new folder or allow overwriting");
      for (const char* name : csv_names) fs::remove(dir / name, ec);
    }
  }
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw IoError(dir.string() + ": cannot create the output folder: " + ec.message());
}

inline void make_dir(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw IoError(dir.string() + ": cannot create folder: " + ec.message());
}

inline void write_png(const std::filesystem::path& path, const cv::Mat& image) {
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), image);
  } catch (const cv::Exception& e) {
    throw IoError(path.string() + ": cannot write image: " + e.what());
  }
  if (!ok) throw IoError(path.string() + ": cannot write image");
}

inline std::string numbered(const char* fmt, int n) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, n);
  return buf;
}

inline MetadataRow row_from(const GroundTruth& gt) {
  MetadataRow r;
  r.shadow_box = gt.shadow_box;
  r.contact_box = gt.contact_box;
  r.contact_point = gt.contact_point;
  r.px_per_cm = gt.px_per_cm;
  return r;
}

} // namespace internal

// (a) gestures/<class>/<session>_<frame>.png + metadata.csv, 635x350 (robot rig).
inline DatasetSummary write_gesture_dataset(const std::filesystem::path& dir, std::uint64_t seed,
                                            const GestureDatasetConfig& config = {}) {
  config.validate();
  internal::prepare_output(dir, config.overwrite, {"metadata.csv"});
  for (Gesture g : all_gestures) internal::make_dir(dir / std::string(to_string(g)));
  Renderer renderer(Rig::robot());
  std::vector<MetadataRow> rows;
  Frame frame;
  for (int u = 1; u <= config.users; ++u) {
    const User user = dataset_user(seed, u);
    for (std::size_t li = 0; li < config.lighting_levels.size(); ++li) {
      const GestureSession session(
          derive_seed(seed, 0x6E570000ull + static_cast<std::uint64_t>(u) * 64 + li), user,
          config.lighting_levels[li],
          {.frames_per_gesture = config.frames_per_gesture,
           .fps = config.fps,
           .distractor_probability = config.distractor_probability});
      for (int i = 0; i < session.size(); ++i) {
        GestureFrameInfo info;
        session.render(renderer, i, frame, &info);
        MetadataRow r = internal::row_from(frame.gt);
        r.label = std::string(to_string(info.gesture));
        r.file_name = r.label + "/" + session.name() + internal::numbered("_%05d.png", i);
        r.user = user.id;
        r.lighting = info.light.label;
        r.lighting_level = info.light.level;
        r.session = session.name();
        r.frame_index = i;
        r.timestamp_ms = info.timestamp_ms;
        internal::write_png(dir / r.file_name, frame.image);
        rows.push_back(std::move(r));
      }
    }
  }
  write_metadata(dir / "metadata.csv", rows, false);
  return {dir, static_cast<int>(rows.size()), 0};
}

// (b) tracking/<class>/<class>_<n>.png + metadata.csv, 200x205 (tracking box).
inline DatasetSummary write_tracking_dataset(const std::filesystem::path& dir, std::uint64_t seed,
                                             const TrackingDatasetConfig& config = {}) {
  config.validate();
  internal::prepare_output(dir, config.overwrite, {"metadata.csv"});
  for (TrackCategory c : all_track_categories) internal::make_dir(dir / std::string(to_string(c)));
  Renderer renderer(Rig::tracking_box());
  std::vector<MetadataRow> rows;
  for (int k = 0; k < config.frames_per_category; ++k)
    for (std::size_t c = 0; c < all_track_categories.size(); ++c) {
      const int index = k * static_cast<int>(all_track_categories.size()) + static_cast<int>(c);
      const std::uint64_t s = derive_seed(seed, 0x7AC40000ull + static_cast<std::uint64_t>(index));
      const User user = dataset_user(
          seed, 1 + static_cast<int>(mix64(s) % static_cast<std::uint64_t>(config.users)));
      TrackingSample sample;
      const Frame frame = render_random_tracking_frame(renderer, all_track_categories[c], s,
                                                       config.sample, &sample, &user);
      MetadataRow r = internal::row_from(frame.gt);
      r.label = std::string(to_string(all_track_categories[c]));
      r.file_name = r.label + "/" + r.label + internal::numbered("_%04d.png", k);
      r.user = user.id;
      r.lighting = sample.light.label;
      r.lighting_level = sample.light.level;
      r.session = "tracking";
      r.frame_index = index;
      r.timestamp_ms = 1000.0 * index;
      internal::write_png(dir / r.file_name, frame.image);
      rows.push_back(std::move(r));
    }
  write_metadata(dir / "metadata.csv", rows, false);
  return {dir, static_cast<int>(rows.size()), 0};
}

// (c) slides/<direction>/<gesture>_<n>/frame_NNNN.png + per-sequence metadata.csv +
// slides/sequences.csv (written last).
inline DatasetSummary write_slide_dataset(const std::filesystem::path& dir, std::uint64_t seed,
                                          const SlideDatasetConfig& config = {}) {
  config.validate();
  internal::prepare_output(dir, config.overwrite, {"sequences.csv"});
  Renderer renderer(Rig::tracking_box());
  std::vector<SequenceRow> sequences;
  DatasetSummary summary{dir, 0, 0};
  Frame frame;
  int index = 0;
  for (int k = 0; k < config.sequences_per_combination; ++k)
    for (Direction d : all_directions)
      for (SlideGesture g : {SlideGesture::palm, SlideGesture::finger}) {
        const std::uint64_t s =
            derive_seed(seed, 0x511D0000ull + static_cast<std::uint64_t>(index));
        const User user = dataset_user(
            seed, 1 + static_cast<int>(mix64(s) % static_cast<std::uint64_t>(config.users)));
        const SlidePlan plan = plan_slide(s, g, d, config.slide, &user);
        const std::string folder = std::string(to_string(d)) + "/" + std::string(to_string(g)) +
                                   internal::numbered("_%04d", index);
        internal::make_dir(dir / folder);
        std::vector<MetadataRow> rows;
        for (int i = 0; i < plan.num_frames(); ++i) {
          render_slide_frame(renderer, plan, i, frame);
          MetadataRow r = internal::row_from(frame.gt);
          r.file_name = internal::numbered("frame_%04d.png", i);
          r.label = std::string(to_string(d));
          r.user = user.id;
          r.lighting = plan.light.label;
          r.lighting_level = plan.light.level;
          r.session = folder;
          r.frame_index = i;
          r.timestamp_ms = plan.timestamps_ms[static_cast<std::size_t>(i)];
          r.gesture = g;
          r.direction = d;
          internal::write_png(dir / folder / r.file_name, frame.image);
          rows.push_back(std::move(r));
        }
        write_metadata(dir / folder / "metadata.csv", rows, true);
        SequenceRow q;
        q.sequence = folder;
        q.gesture = g;
        q.direction = d;
        q.num_frames = plan.num_frames();
        q.distance_cm = plan.distance_cm;
        q.fps = plan.fps;
        q.user = user.id;
        q.lighting = plan.light.label;
        q.lighting_level = plan.light.level;
        sequences.push_back(q);
        summary.images += plan.num_frames();
        ++index;
      }
  write_sequences(dir / "sequences.csv", sequences);
  summary.sequences = static_cast<int>(sequences.size());
  return summary;
}

} // namespace sim
SHADOWSENSE_NAMESPACE_END
