// Renders generated temporal gesture sequences (sim/touch_sequences.hpp) into images with the
// scene generator's renderer on the robot rig and writes them in the temporal dataset format
// (io/temporal_dataset.hpp, docs/dataset_format.md): the segmenter then sees what a camera would
// (its errors count in the evaluation, ss_track_eval --temporal), with the generator's timing,
// dropped and duplicated frames, hand-shape readings and truth.
//
// What a frame shows (render_touch_sequence_frame): every hand whose script is live at the
// frame's content time (a duplicated frame shows an earlier frame's content, byte for byte).
// A hand in contact lies on the skin (height 0) at the script's contact point, unprojected from
// the generator's pixels to the skin plane by the rig; between contacts it hovers at
// 1.5 cm + 0.04 cm per ms from the nearest contact (a lift clears the skin at once, a hand
// arriving or leaving rises to at most 12 cm) above the nearest contact's end point. The
// script's label picks the body: point -> pointing hand, palm -> open hand, punch -> fist,
// hug and two_hands -> the gesture generator's hug and two-hand scenes (touching while live).
// Per user: the body (dataset_user-like, from the seed), one light (level 0.5-1, a random
// azimuth) and per hand a rotation of -90 +- 25 degrees, all from seeds derived from the user's
// (the sequence generator's own random streams are untouched: the frames and truth are exactly
// make_touch_sequence's).
//
// write_touch_sequence_dataset(dir, first_user, config)
//   requires: config.validate() (fps values in [5, 240], users in [1, 10000], threads in
//             [1, 256]); dir new or empty unless config.overwrite.
//   ensures:  for each fps and each user seed first_user .. first_user + users - 1, the folder
//             fps<F>/user_<seed>/ with frame_<k>.png (k the nominal index: gaps are dropped
//             frames), frames.csv and gestures.csv; then dir/sequences.csv, written last after a
//             filesystem sync (a dataset without it is incomplete). Every file is written
//             atomically. Deterministic: the same arguments give the same bytes for any thread
//             count.
//   throws:  InvalidArgument for a bad config; IoError for a folder or file that cannot be
//            written (an interrupted run leaves no sequences.csv).
// Threading: plain functions; a renderer per worker thread.
#pragma once

#include <shadowsense/core/atomic_file.hpp>
#include <shadowsense/io/temporal_dataset.hpp>
#include <shadowsense/sim/dataset_writer.hpp>
#include <shadowsense/sim/gestures.hpp>
#include <shadowsense/sim/renderer.hpp>
#include <shadowsense/sim/touch_sequences.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN
namespace sim {

struct TouchSequenceDatasetConfig {
  std::vector<double> fps{15, 30, 60};
  int users = 2;
  TouchSequenceConfig sequence{}; // its fps is replaced by each of `fps`
  bool overwrite = false;
  int threads = 1;

  void validate() const {
    detail::require(!fps.empty(), "TouchSequenceDatasetConfig: fps must not be empty");
    for (double f : fps) {
      TouchSequenceConfig c = sequence;
      c.fps = f;
      c.validate();
    }
    detail::require(users >= 1 && users <= 10000,
                    "TouchSequenceDatasetConfig: users must be in [1, 10000]");
    detail::require(threads >= 1 && threads <= 256,
                    "TouchSequenceDatasetConfig: threads must be in [1, 256]");
    detail::require(sequence.image_size == Rig::robot().image_size,
                    "TouchSequenceDatasetConfig: the sequences are rendered on the robot rig; "
                    "sequence.image_size must be its 635x350");
  }
};

// The per-user look of a rendered sequence.
struct TouchSequenceLook {
  User user;
  Light light;
  double lighting_level = 1;
  std::vector<double> rotation_deg; // per hand script
};

inline TouchSequenceLook touch_sequence_look(std::uint64_t seed, std::size_t hands) {
  TouchSequenceLook look;
  Rng rng(derive_seed(seed, 0x7E4D3A11ull));
  look.user = User::random(static_cast<int>(seed % 1000000), rng);
  look.lighting_level = rng.uniform(0.5, 1.0);
  look.light = light_from_level(look.lighting_level, rng.uniform(-180, 180));
  for (std::size_t i = 0; i < hands; ++i) look.rotation_deg.push_back(-90 + rng.uniform(-25, 25));
  return look;
}

// The scene at time t (ms) of a generated sequence, rendered on `rig`.
inline Scene touch_sequence_scene(const TouchSequence& seq, const TouchSequenceLook& look,
                                  const Rig& rig, double t) {
  using namespace detail_touch;
  Scene scene;
  scene.skin_tone = look.user.skin_tone;
  for (std::size_t i = 0; i < seq.hands.size(); ++i) {
    const HandScript& h = seq.hands[i];
    if (t < h.appear || t >= h.leave) continue;
    if (h.label == "hug" || h.label == "two_hands") {
      GesturePose p;
      if (h.label == "hug") {
        p.rotation_deg = 90; // the person stands at the robot's back, as ss_demo's hug
        p.position_cm = {0, 19};
      } else {
        p.position_cm = rig.unproject(h.hover_at);
      }
      const Scene s =
          gesture_scene(h.label == "hug" ? Gesture::hug : Gesture::two_hands, look.user, p);
      scene.parts.insert(scene.parts.end(), s.parts.begin(), s.parts.end());
      continue;
    }
    double area = 0;
    std::optional<cv::Point2d> at = contact_at(h, t, area);
    double height = 0;
    if (!at) { // hovering above the nearest contact's end
      double nearest = 1e300;
      cv::Point2d where = h.hover_at;
      for (const Contact& c : h.contacts) {
        const double before = c.t0 - t, after = t - c.t1;
        double a = 0;
        if (before >= 0 && before < nearest) {
          nearest = before;
          where = contact_at(h, c.t0, a).value_or(h.hover_at);
        }
        if (after >= 0 && after < nearest) {
          nearest = after;
          // The end point: the script's position just before the lift.
          where = contact_at(h, std::max(c.t0, c.t1 - 1e-6), a).value_or(h.hover_at);
        }
      }
      height = std::min(12.0, 1.5 + 0.04 * (nearest < 1e299 ? nearest : 300.0));
      at = where;
    }
    HandPose pose;
    pose.position_cm = rig.unproject(*at);
    pose.height_cm = height;
    pose.rotation_deg = look.rotation_deg[i];
    pose.shape = h.label == "point"   ? HandShape::point
                 : h.label == "punch" ? HandShape::fist
                                      : HandShape::open;
    pose.spread = 0.6;
    pose.arm_elevation_deg = pose.shape == HandShape::fist ? 55 : 35;
    add_hand(scene.parts, look.user, pose);
  }
  return scene;
}

inline DatasetSummary write_touch_sequence_dataset(const std::filesystem::path& dir,
                                                   std::uint64_t first_user,
                                                   const TouchSequenceDatasetConfig& config) {
  config.validate();
  internal::prepare_output(dir, config.overwrite, {"sequences.csv"});
  const Rig rig = Rig::robot();
  const int n = static_cast<int>(config.fps.size()) * config.users;
  auto fps_of = [&](int job) { return config.fps[static_cast<std::size_t>(job / config.users)]; };
  auto seed_of = [&](int job) {
    return first_user + static_cast<std::uint64_t>(job % config.users);
  };
  auto folder_of = [&](int job) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "fps%g/user_%llu", fps_of(job),
                  static_cast<unsigned long long>(seed_of(job)));
    return std::string(buf);
  };
  for (int job = 0; job < n; ++job) internal::make_dir(dir / folder_of(job));
  std::vector<TemporalSequenceRow> rows(static_cast<std::size_t>(n));
  internal::parallel_jobs(n, config.threads, rig, [&](int job, Renderer& renderer) {
    TouchSequenceConfig c = config.sequence;
    c.fps = fps_of(job);
    const std::uint64_t seed = seed_of(job);
    const TouchSequence seq = make_touch_sequence(c, seed);
    const TouchSequenceLook look = touch_sequence_look(seed, seq.hands.size());
    const std::string folder = folder_of(job);
    std::vector<TemporalFrameRow> frames;
    Frame frame;
    std::int64_t rendered = -1; // the content index `frame` holds
    for (std::size_t i = 0; i < seq.frames.size(); ++i) {
      const std::int64_t content = seq.content_index[i];
      if (content != rendered) {
        const double tc = static_cast<double>(content) * 1000.0 / c.fps;
        renderer.render(touch_sequence_scene(seq, look, rig, tc), look.light,
                        derive_seed(seed, 0xF7A3E000ull + static_cast<std::uint64_t>(content)),
                        frame);
        rendered = content;
      }
      TemporalFrameRow f;
      f.frame = seq.frame_index[i];
      f.file_name = internal::numbered("frame_%06d.png", static_cast<int>(f.frame));
      f.timestamp_ms = seq.frames[i].timestamp_ms;
      f.duplicate = content != seq.frame_index[i];
      if (seq.shapes[i].available && !seq.shapes[i].label.empty()) {
        f.shape = seq.shapes[i].label;
        f.shape_confidence = static_cast<double>(seq.shapes[i].confidence);
      }
      internal::write_png(dir / folder / f.file_name, frame.image);
      frames.push_back(std::move(f));
    }
    std::vector<TemporalGestureRow> gestures;
    for (const TouchGestureTruth& t : seq.truth)
      gestures.push_back(
          {t.gesture, t.track_id, t.start_ms, t.end_ms, t.repetitions, t.direction, 0});
    write_temporal_frames(dir / folder / "frames.csv", frames, Sync::deferred);
    write_temporal_gestures(dir / folder / "gestures.csv", gestures, Sync::deferred);
    TemporalSequenceRow& r = rows[static_cast<std::size_t>(job)];
    r.sequence = folder;
    r.fps = c.fps;
    r.user = static_cast<int>(seed % 2147483647ull);
    r.frames = static_cast<int>(frames.size());
    r.gestures = static_cast<int>(gestures.size());
    r.lighting_level = look.lighting_level;
    r.px_per_cm = c.px_per_cm;
  });
  sync_filesystem(dir);
  write_temporal_sequences(dir / "sequences.csv", rows);
  DatasetSummary summary{dir, 0, n};
  for (const TemporalSequenceRow& r : rows) summary.images += r.frames;
  return summary;
}

} // namespace sim
SHADOWSENSE_NAMESPACE_END
