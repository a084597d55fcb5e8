// Multi-touch tracking: stable IDs for the blobs the segmenter reports, frame after frame.
// A small stateful class with one update(detections, timestamp) call, in the spirit of norfair:
// constant-velocity prediction, greedy nearest-neighbour association inside a distance gate,
// a hit counter before a track is confirmed and a time-out before it is dropped. The gate is
// measured from the predicted position or from the last position, whichever is nearer: a hand
// that turns back (a rub, a scrub) is near where it was, not where its velocity points, and at
// 15 fps that miss is larger than the gate.
//
// update(detections, timestamp_ms)
//   requires: a finite timestamp greater than the previous one; finite detection positions.
//   ensures:  see below; a step shorter than Config::min_velocity_dt_ms moves the track but does
//             not change its velocity (0.5 px of jitter over 0.1 ms would otherwise be 5 px/ms and
//             throw the next prediction far outside the gate).
//   throws:   InvalidArgument.
// Threading: one instance per thread; an owner check (core/thread_owner.hpp) throws
// ConcurrentUseError when one instance is updated from two threads at once.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/core/thread_owner.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <span>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// One thing seen in one frame (typically a contact or a shadow blob of the segmenter).
struct Detection {
  cv::Point2f position{}; // where the thing is (image pixels), e.g. the contact centroid
  cv::Rect box{};         // its bounding box (may be empty if unknown)
};

struct Track {
  int id = 0;             // unique per tracker, never reused, starting at 1
  cv::Point2f position{}; // last matched position
  cv::Point2f velocity{}; // pixels per millisecond, smoothed
  cv::Rect box{};         // last matched box
  int hits = 0;           // frames matched so far
  double first_seen_ms = 0;
  double last_seen_ms = 0;
  bool confirmed = false;    // hits >= Config::hits_to_confirm (once true, stays true)
  bool matched = false;      // matched in the latest update
  int detection_index = -1;  // index of the matched detection in the latest update, else -1
  bool has_velocity = false; // velocity estimated from a step >= Config::min_velocity_dt_ms
};

class ContactTracker {
public:
  struct Config {
    double max_distance_px = 40.0;   // association gate around the predicted or last position
    int hits_to_confirm = 1;         // matched frames before a track is reported as confirmed
    double max_missing_ms = 150.0;   // a track unseen this long (inclusive) is dropped
    double velocity_smoothing = 0.5; // weight of the new velocity estimate, (0, 1]
    double min_velocity_dt_ms = 5.0; // shorter steps do not update the velocity
  };

  ContactTracker() : ContactTracker(Config{}) {}
  explicit ContactTracker(const Config& c) : config_(c) {
    detail::require(std::isfinite(c.max_distance_px) && c.max_distance_px > 0,
                    "ContactTracker: max_distance_px must be finite and > 0");
    detail::require(c.hits_to_confirm >= 1, "ContactTracker: hits_to_confirm must be >= 1");
    detail::require(std::isfinite(c.max_missing_ms) && c.max_missing_ms >= 0,
                    "ContactTracker: max_missing_ms must be finite and >= 0");
    detail::require(c.velocity_smoothing > 0 && c.velocity_smoothing <= 1,
                    "ContactTracker: velocity_smoothing must be in (0, 1]");
    detail::require(std::isfinite(c.min_velocity_dt_ms) && c.min_velocity_dt_ms >= 0,
                    "ContactTracker: min_velocity_dt_ms must be finite and >= 0");
    // Flat vectors with room for typical scenes: no allocation per update once grown.
    tracks_.reserve(32);
    pairs_.reserve(256);
    det_used_.reserve(32);
  }

  // Associates this frame's detections with the live tracks and returns all live tracks (matched
  // or coasting), ordered by id. Unmatched detections start new tracks. Throws InvalidArgument for
  // a non-finite or non-increasing timestamp or a non-finite detection position.
  const std::vector<Track>& update(std::span<const Detection> detections, double timestamp_ms) {
    const auto guard = owner_.enter("ContactTracker");
    detail::require(std::isfinite(timestamp_ms),
                    "ContactTracker::update: timestamp_ms is not finite");
    if (last_t_)
      if (!(timestamp_ms > *last_t_))
        SHADOWSENSE_THROW(
            InvalidArgument("ContactTracker::update: timestamp " + std::to_string(timestamp_ms) +
                            " ms is not after the previous one (" + std::to_string(*last_t_) +
                            " ms); timestamps must be strictly increasing"));
    for (const Detection& d : detections)
      detail::require(std::isfinite(d.position.x) && std::isfinite(d.position.y),
                      "ContactTracker::update: a detection position is not finite");
    last_t_ = timestamp_ms;

    // Candidate pairs inside the gate, cheapest first (ties: older track, then lower index),
    // so the result does not depend on the order of the detections.
    pairs_.clear();
    for (std::size_t ti = 0; ti < tracks_.size(); ++ti) {
      const Track& tr = tracks_[ti];
      const double dt = timestamp_ms - tr.last_seen_ms;
      const cv::Point2f pred = tr.position + tr.velocity * static_cast<float>(dt);
      for (std::size_t di = 0; di < detections.size(); ++di) {
        const cv::Point2f to_pred = detections[di].position - pred;
        const cv::Point2f to_last = detections[di].position - tr.position;
        const double dist =
            std::min(std::hypot(to_pred.x, to_pred.y), std::hypot(to_last.x, to_last.y));
        if (dist <= config_.max_distance_px) pairs_.push_back({dist, ti, di});
      }
    }
    std::sort(pairs_.begin(), pairs_.end(), [&](const Pair& a, const Pair& b) {
      if (a.dist != b.dist) return a.dist < b.dist;
      if (tracks_[a.track].id != tracks_[b.track].id)
        return tracks_[a.track].id < tracks_[b.track].id;
      return a.det < b.det;
    });
    det_used_.assign(detections.size(), 0);
    for (Track& tr : tracks_) {
      tr.matched = false;
      tr.detection_index = -1;
    }
    for (const Pair& p : pairs_) {
      Track& tr = tracks_[p.track];
      if (tr.matched || det_used_[p.det]) continue;
      const Detection& d = detections[p.det];
      const double dt = timestamp_ms - tr.last_seen_ms;
      if (dt >= config_.min_velocity_dt_ms) {
        const cv::Point2f v = (d.position - tr.position) * static_cast<float>(1.0 / dt);
        const float a = static_cast<float>(config_.velocity_smoothing);
        tr.velocity = tr.has_velocity ? tr.velocity * (1 - a) + v * a : v;
        tr.has_velocity = true;
      }
      tr.position = d.position;
      tr.box = d.box;
      tr.last_seen_ms = timestamp_ms;
      ++tr.hits;
      tr.confirmed = tr.confirmed || tr.hits >= config_.hits_to_confirm;
      tr.matched = true;
      tr.detection_index = static_cast<int>(p.det);
      det_used_[p.det] = 1;
    }
    // Drop tracks unseen for too long.
    std::erase_if(tracks_, [&](const Track& tr) {
      return !tr.matched && timestamp_ms - tr.last_seen_ms >= config_.max_missing_ms;
    });
    // New tracks for the rest.
    for (std::size_t di = 0; di < detections.size(); ++di) {
      if (det_used_[di]) continue;
      Track tr;
      tr.id = next_id_++;
      tr.position = detections[di].position;
      tr.velocity = {0, 0};
      tr.box = detections[di].box;
      tr.hits = 1;
      tr.first_seen_ms = tr.last_seen_ms = timestamp_ms;
      tr.confirmed = config_.hits_to_confirm <= 1;
      tr.matched = true;
      tr.detection_index = static_cast<int>(di);
      tracks_.push_back(tr);
    }
    return tracks_;
  }

  const std::vector<Track>& tracks() const { return tracks_; }
  // The live track with this id, if any.
  std::optional<Track> find(int id) const {
    for (const Track& t : tracks_)
      if (t.id == id) return t;
    return std::nullopt;
  }
  // Drops every track and forgets the previous timestamp (a new stream) but keeps the ids
  // growing, so an id is never reused.
  void clear_tracks() {
    const auto guard = owner_.enter("ContactTracker");
    tracks_.clear();
    last_t_.reset();
  }
  // Back to the initial state (ids start at 1 again).
  void reset() {
    const auto guard = owner_.enter("ContactTracker");
    tracks_.clear();
    last_t_.reset();
    next_id_ = 1;
  }
  const Config& config() const { return config_; }

private:
  struct Pair {
    double dist;
    std::size_t track, det;
  };
  Config config_;
  std::vector<Track> tracks_;
  std::vector<Pair> pairs_;
  std::vector<unsigned char> det_used_;
  std::optional<double> last_t_;
  int next_id_ = 1;
  ThreadOwner owner_;
};

SHADOWSENSE_NAMESPACE_END
