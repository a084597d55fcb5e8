// Writes the scene generator's three datasets in the documented format
// (docs/dataset_format.md): (a) gesture frames on the robot rig, (b) tracking frames on the
// test box, (c) slide sequences. Deterministic for a seed. The configuration is validated
// before anything is written, and every csv is written last via a temporary file + rename,
// so an interrupted run never leaves a dataset that looks complete.
#pragma once

#include <shadowsense/core/atomic_file.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/io/dataset.hpp>
#include <shadowsense/sim/gestures.hpp>
#include <shadowsense/sim/renderer.hpp>
#include <shadowsense/sim/tracking.hpp>

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <mutex>
#include <string>
#include <system_error>
#include <thread>
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
  int threads = 1;        // worker threads; the output is identical for any count

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
    detail::require(threads >= 1 && threads <= 256,
                    "GestureDatasetConfig: threads must be in [1, 256]");
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
  int threads = 1;

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
    detail::require(threads >= 1 && threads <= 256,
                    "TrackingDatasetConfig: threads must be in [1, 256]");
    sample.validate();
  }
};

struct SlideDatasetConfig {
  int sequences_per_combination = 1; // per direction x gesture (paper: 20 -> 160 sequences)
  int users = 4;
  SlideConfig slide{};
  bool overwrite = false;
  int threads = 1;

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
    detail::require(threads >= 1 && threads <= 256,
                    "SlideDatasetConfig: threads must be in [1, 256]");
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

inline void remove_csv(const std::filesystem::path& p) {
  std::error_code ec;
  std::filesystem::remove(p, ec);
  if (ec) SHADOWSENSE_THROW(IoError(p.string() + ": cannot remove the old csv: " + ec.message()));
}

// Makes `dir` ready to receive a dataset: it must be new/empty unless overwrite, in which case
// the old csv files (top-level first, then every nested metadata.csv) are removed before any
// frame is written, so the old dataset no longer looks complete.
inline void prepare_output(const std::filesystem::path& dir, bool overwrite,
                           std::initializer_list<const char*> csv_names) {
  namespace fs = std::filesystem;
  detail::require(!dir.empty(), "dataset writer: the output folder path is empty");
  std::error_code ec;
  if (fs::exists(dir, ec)) {
    if (!fs::is_directory(dir, ec))
      SHADOWSENSE_THROW(IoError(dir.string() + ": exists and is not a folder"));
    if (!fs::is_empty(dir, ec)) {
      if (!overwrite)
        SHADOWSENSE_THROW(IoError(
            dir.string() + ": folder is not empty; choose a new folder or allow overwriting"));
      // The top-level csv first (the dataset stops looking complete), then every nested
      // metadata.csv (slide sequences), so a run killed after this point never leaves an old
      // csv beside new frames.
      for (const char* name : csv_names) remove_csv(dir / name);
      std::vector<fs::path> nested;
      for (auto it = fs::recursive_directory_iterator(dir, ec);
           !ec && it != fs::recursive_directory_iterator(); it.increment(ec))
        if (it->path().filename() == "metadata.csv") nested.push_back(it->path());
      if (ec)
        SHADOWSENSE_THROW(
            IoError(dir.string() +
                    ": cannot list the old dataset to remove its csv files: " + ec.message()));
      for (const fs::path& p : nested) remove_csv(p);
    }
  }
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    SHADOWSENSE_THROW(IoError(dir.string() + ": cannot create the output folder: " + ec.message()));
}

inline void make_dir(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) SHADOWSENSE_THROW(IoError(dir.string() + ": cannot create folder: " + ec.message()));
}

// Encodes in memory, then writes atomically: a frame file is never half-written.
inline void write_png(const std::filesystem::path& path, const cv::Mat& image) {
  std::vector<unsigned char> bytes;
  bool ok = false;
  try {
    ok = cv::imencode(".png", image, bytes);
  } catch (const cv::Exception& e) {
    SHADOWSENSE_THROW(IoError(path.string() + ": cannot encode the image as PNG: " + e.what()));
  }
  if (!ok) SHADOWSENSE_THROW(IoError(path.string() + ": cannot encode the image as PNG"));
  // Deferred fsync: the dataset's csv, written last, follows one sync_filesystem().
  write_file_atomically(path,
                        std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()),
                        Sync::deferred);
}

inline std::string numbered(const char* fmt, int n) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, n);
  return buf;
}

// Runs job(i, renderer) for i in [0, n) on `threads` threads, each with its own Renderer
// (renderers keep scratch buffers). Every job writes only its own files and result slot, so
// the output does not depend on the thread count. The first exception stops the others and is
// rethrown.
template <class Job>
inline void parallel_jobs(int n, int threads, const Rig& rig, Job job) {
  std::atomic<int> next{0};
  std::atomic<bool> stop{false};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto work = [&] {
    try {
      Renderer renderer(rig);
      for (int i = next++; i < n && !stop; i = next++) job(i, renderer);
    } catch (...) {
      const std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
      stop = true;
    }
  };
  const int count = std::max(1, std::min(threads, n));
  std::vector<std::thread> pool;
  for (int t = 1; t < count; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
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
  // One job per session (user x lighting), in csv order.
  const int levels = static_cast<int>(config.lighting_levels.size());
  std::vector<std::vector<MetadataRow>> rows(static_cast<std::size_t>(config.users * levels));
  internal::parallel_jobs(
      config.users * levels, config.threads, Rig::robot(), [&](int job, Renderer& renderer) {
        const int u = 1 + job / levels;
        const auto li = static_cast<std::size_t>(job % levels);
        const User user = dataset_user(seed, u);
        const GestureSession session(
            derive_seed(seed, 0x6E570000ull + static_cast<std::uint64_t>(u) * 64 + li), user,
            config.lighting_levels[li],
            {.frames_per_gesture = config.frames_per_gesture,
             .fps = config.fps,
             .distractor_probability = config.distractor_probability});
        Frame frame;
        auto& out = rows[static_cast<std::size_t>(job)];
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
          out.push_back(std::move(r));
        }
      });
  std::vector<MetadataRow> all;
  for (auto& r : rows) all.insert(all.end(), r.begin(), r.end());
  sync_filesystem(dir);
  write_metadata(dir / "metadata.csv", all, false);
  return {dir, static_cast<int>(all.size()), 0};
}

// (b) tracking/<class>/<class>_<n>.png + metadata.csv, 200x205 (tracking box).
inline DatasetSummary write_tracking_dataset(const std::filesystem::path& dir, std::uint64_t seed,
                                             const TrackingDatasetConfig& config = {}) {
  config.validate();
  internal::prepare_output(dir, config.overwrite, {"metadata.csv"});
  for (TrackCategory c : all_track_categories) internal::make_dir(dir / std::string(to_string(c)));
  const int categories = static_cast<int>(all_track_categories.size());
  std::vector<MetadataRow> rows(static_cast<std::size_t>(config.frames_per_category * categories));
  internal::parallel_jobs(
      static_cast<int>(rows.size()), config.threads, Rig::tracking_box(),
      [&](int index, Renderer& renderer) {
        const int k = index / categories;
        const TrackCategory category =
            all_track_categories[static_cast<std::size_t>(index % categories)];
        const std::uint64_t s =
            derive_seed(seed, 0x7AC40000ull + static_cast<std::uint64_t>(index));
        const User user = dataset_user(
            seed, 1 + static_cast<int>(mix64(s) % static_cast<std::uint64_t>(config.users)));
        TrackingSample sample;
        const Frame frame =
            render_random_tracking_frame(renderer, category, s, config.sample, &sample, &user);
        MetadataRow r = internal::row_from(frame.gt);
        r.label = std::string(to_string(category));
        r.file_name = r.label + "/" + r.label + internal::numbered("_%04d.png", k);
        r.user = user.id;
        r.lighting = sample.light.label;
        r.lighting_level = sample.light.level;
        r.session = "tracking";
        r.frame_index = index;
        r.timestamp_ms = 1000.0 * index;
        internal::write_png(dir / r.file_name, frame.image);
        rows[static_cast<std::size_t>(index)] = std::move(r);
      });
  sync_filesystem(dir);
  write_metadata(dir / "metadata.csv", rows, false);
  return {dir, static_cast<int>(rows.size()), 0};
}

// (c) slides/<direction>/<gesture>_<n>/frame_NNNN.png + per-sequence metadata.csv +
// slides/sequences.csv (written last).
inline DatasetSummary write_slide_dataset(const std::filesystem::path& dir, std::uint64_t seed,
                                          const SlideDatasetConfig& config = {}) {
  config.validate();
  internal::prepare_output(dir, config.overwrite, {"sequences.csv"});
  // Sequence k * 8 + j: direction j / 2, gesture j % 2 (palm, finger). Folders first, so the
  // workers never race on creating shared parents.
  const int n = config.total_sequences();
  auto direction_of = [](int index) {
    return all_directions[static_cast<std::size_t>((index % 8) / 2)];
  };
  auto gesture_of = [](int index) {
    return index % 2 == 0 ? SlideGesture::palm : SlideGesture::finger;
  };
  auto folder_of = [&](int index) {
    return std::string(to_string(direction_of(index))) + "/" +
           std::string(to_string(gesture_of(index))) + internal::numbered("_%04d", index);
  };
  for (int index = 0; index < n; ++index) internal::make_dir(dir / folder_of(index));
  std::vector<SequenceRow> sequences(static_cast<std::size_t>(n));
  internal::parallel_jobs(
      n, config.threads, Rig::tracking_box(), [&](int index, Renderer& renderer) {
        const Direction d = direction_of(index);
        const SlideGesture g = gesture_of(index);
        const std::uint64_t s =
            derive_seed(seed, 0x511D0000ull + static_cast<std::uint64_t>(index));
        const User user = dataset_user(
            seed, 1 + static_cast<int>(mix64(s) % static_cast<std::uint64_t>(config.users)));
        const SlidePlan plan = plan_slide(s, g, d, config.slide, &user);
        const std::string folder = folder_of(index);
        std::vector<MetadataRow> rows;
        Frame frame;
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
        // Deferred like the frames: sequences.csv completes the dataset.
        write_metadata(dir / folder / "metadata.csv", rows, true, Sync::deferred);
        SequenceRow& q = sequences[static_cast<std::size_t>(index)];
        q.sequence = folder;
        q.gesture = g;
        q.direction = d;
        q.num_frames = plan.num_frames();
        q.distance_cm = plan.distance_cm;
        q.fps = plan.fps;
        q.user = user.id;
        q.lighting = plan.light.label;
        q.lighting_level = plan.light.level;
      });
  sync_filesystem(dir);
  write_sequences(dir / "sequences.csv", sequences);
  DatasetSummary summary{dir, 0, n};
  for (const SequenceRow& q : sequences) summary.images += q.num_frames;
  return summary;
}

} // namespace sim
SHADOWSENSE_NAMESPACE_END
