// TouchPipeline: segmenter + multi-touch tracker + one touch state machine per track, one call
// per frame.
//
// Each frame: the Segmenter finds shadow blobs (one per hand or arm) and contact blobs; every
// shadow blob is one Detection (its centroid and box) for the ContactTracker, which gives it a
// stable id; every contact blob belongs to the shadow blob its box overlaps most (the segmenter
// guarantees each contact lies in a shadow blob), and the track's contact point is the
// area-weighted centroid of its contact blobs (several fingers of one hand are one touch). The
// TouchStateMachine of each track is fed {shadow: track matched this frame, contact: that point}.
// A track the tracker no longer reports keeps its machine, fed "nothing seen", until that machine
// is back in `none` (so every touch ends with lift and disappear after the hysteresis), then the
// machine is dropped (kept for reuse by a later track). Events are reported per track, in
// increasing track id. After warm-up (buffers grown to the scene's number of blobs and
// simultaneous tracks) update() makes no heap allocation.
//
// A camera fault (sense/camera_health.hpp: a dark, saturated or frozen camera) is judged before
// the segmenter: on such a frame nothing is segmented (no blobs, empty masks, the adaptive
// empty-skin model untouched), so the tracks end with their lift and disappear as when the hands
// leave, and TouchFrame::camera says which fault it is (camera_before: the previous frame's, so
// a change is seen on the frame it happens).
//
// BasicTouchPipeline<Rule>(segmenter, tracker_config, touch_config, camera_config)
//   requires: valid configs (see ContactTracker, TouchStateMachine). With the calibrated rule
//             (TouchPipeline): a calibrated segmenter - an empty-skin model (a calibration file
//             from ss_calibrate, or set_empty_skin), Config::adaptive (the first frame is taken
//             as the empty skin), or the paper's fixed colour ranges (SegmentMode::fixed_ranges,
//             chosen by name). A relative-mode segmenter with none of these judges every frame
//             against itself and reports phantom shadows on an empty skin: refused with
//             InvalidArgument, unless the caller opts in by name with
//             BasicTouchPipeline(uncalibrated, segmenter, ...).
//             camera_config: see CameraHealthConfig (its validate(); enabled = false turns the
//             check off).
//   ensures:  the pipeline owns a copy of `segmenter` (with its empty-skin model).
// update(frame, timestamp_ms) -> const TouchFrame&
//   requires: a frame the segmenter accepts; a finite timestamp greater than the previous one.
//   ensures:  the frame's tracks (live ones, matched or coasting, each with its contact point
//             and contact area), shadow boxes, contact points,
//             the events this frame caused and the blob counts the segmenter's cap dropped. The
//             reference stays valid until the next update/flush.
//   throws:   InvalidArgument (bad frame or timestamp), with nothing changed for a bad timestamp.
// flush(timestamp_ms) -> const TouchFrame&
//   requires: a finite timestamp greater than the last frame's.
//   ensures:  ends the stream: every machine sees "nothing" at timestamp_ms and, if still not in
//             none, again at timestamp_ms + hysteresis_ms, so every pending lift / disappear is
//             reported (with those timestamps); then tracks and machines are cleared and the next
//             update starts a new stream (track ids continue to grow; the segmenter keeps its
//             model).
// Threading: one instance per thread; an owner check (core/thread_owner.hpp) throws
// ConcurrentUseError when one instance is used from two threads at once - update, flush and the
// accessors (segmentation(), segmenter(), tracker(), camera_health()) alike. The references
// they return are the owning thread's: read them in that thread, before its next update.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/core/thread_owner.hpp>
#include <shadowsense/sense/camera_health.hpp>
#include <shadowsense/sense/segmenter.hpp>
#include <shadowsense/sense/touch_state_machine.hpp>
#include <shadowsense/sense/tracker.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// One tracked hand in one frame.
struct TouchTrack {
  int id = 0;                           // ContactTracker id (stable, never reused)
  bool matched = false;                 // seen in this frame (else coasting)
  cv::Rect shadow_box{};                // its shadow blob's box (last seen)
  cv::Point2f position{};               // its shadow blob's centroid (last seen)
  std::optional<cv::Point2f> contact{}; // contact point this frame, if touching
  TouchState state = TouchState::none;  // its state machine after this frame
  double contact_area = 0;              // its contact blobs' total area this frame (px)
};

// One event with the track it belongs to.
struct TrackEvent {
  int track_id = 0;
  TouchEvent event{};
};

// Everything one frame produced. A plain struct: sinks read it.
struct TouchFrame {
  double timestamp_ms = 0;
  std::vector<TouchTrack> tracks;          // increasing id
  std::vector<cv::Rect> shadow_boxes;      // every shadow blob (segmenter order: largest first)
  std::vector<cv::Point2f> contact_points; // every contact blob's centroid (largest first)
  std::vector<TrackEvent> events;          // increasing track id, then order of occurrence
  std::size_t dropped_shadow_blobs = 0;    // see Segmentation
  std::size_t dropped_contact_blobs = 0;
  CameraFault camera = CameraFault::none;        // this frame's camera fault (none: healthy)
  CameraFault camera_before = CameraFault::none; // the previous frame's
};

// The opt-in, by name, to a TouchPipeline whose segmenter has no calibration.
struct Uncalibrated {
  explicit Uncalibrated() = default;
};
inline constexpr Uncalibrated uncalibrated{};

template <PixelRule Rule>
class BasicTouchPipeline {
public:
  explicit BasicTouchPipeline(BasicSegmenter<Rule> segmenter,
                              const ContactTracker::Config& tracker = {},
                              const TouchStateMachine::Config& touch = {},
                              const CameraHealthConfig& camera = {})
      : BasicTouchPipeline(uncalibrated, std::move(segmenter), tracker, touch, camera) {
    if constexpr (std::is_same_v<Rule, CalibratedRule>) {
      const SegmenterConfig& c = segmenter_.config();
      if (c.calibration.mode == SegmentMode::relative && !segmenter_.has_empty_skin() &&
          !c.adaptive)
        SHADOWSENSE_THROW(InvalidArgument(
            "TouchPipeline: the segmenter is not calibrated (no empty-skin model); an "
            "uncalibrated segmenter reports phantom shadows on an empty skin. Load a calibration "
            "(load_calibration of a file made by ss_calibrate), call set_empty_skin, set "
            "SegmenterConfig::adaptive, or choose the paper's fixed colour ranges "
            "(SegmentMode::fixed_ranges); to run uncalibrated anyway, construct it as "
            "TouchPipeline(uncalibrated, segmenter)"));
    }
  }
  BasicTouchPipeline(Uncalibrated, BasicSegmenter<Rule> segmenter,
                     const ContactTracker::Config& tracker = {},
                     const TouchStateMachine::Config& touch = {},
                     const CameraHealthConfig& camera = {})
      : segmenter_(std::move(segmenter)), tracker_(tracker), touch_config_(touch), camera_(camera) {
    TouchStateMachine check(touch); // validates the config now
    (void)check;
    // Room for typical scenes up front; beyond this the buffers grow once and are kept.
    constexpr std::size_t typical = 32;
    slots_.reserve(typical);
    for (int i = 0; i < 8; ++i) // machines for up to 8 simultaneous tracks, built now
      slots_.push_back(Slot{0, false, TouchStateMachine(touch)});
    order_.reserve(typical);
    detections_.reserve(typical);
    result_.tracks.reserve(typical);
    result_.shadow_boxes.reserve(typical);
    result_.contact_points.reserve(typical);
    result_.events.reserve(4 * typical);
  }

  const TouchFrame& update(const cv::Mat& frame, double timestamp_ms) {
    const auto guard = owner_.enter("TouchPipeline");
    require_time(timestamp_ms, "TouchPipeline::update");
    // The camera is judged on a copy, kept once the segmenter has accepted the frame: a bad
    // frame is refused with the segmenter's message and leaves the camera check as it was (it is
    // not judged a fault), and the frame is checked once (segment() checks it; a faulted frame is
    // not segmented, so check_frame does). The copy is a few words, no heap.
    CameraHealth judged = camera_;
    if (judged.update(frame) == CameraFault::none) {
      segmenter_.segment(frame, seg_);
    } else {
      segmenter_.check_frame(frame);
      clear_segmentation(frame.size());
    }
    const CameraFault before = camera_.fault();
    camera_ = judged;
    reset_result(timestamp_ms); // keeps the vectors' storage: no allocation per frame
    result_.camera = camera_.fault();
    result_.camera_before = before;
    result_.dropped_shadow_blobs = seg_.dropped_shadow_blobs;
    result_.dropped_contact_blobs = seg_.dropped_contact_blobs;
    detections_.clear();
    for (const Blob& s : seg_.shadows) {
      detections_.push_back({s.centroid, s.box});
      result_.shadow_boxes.push_back(s.box);
    }
    for (const Blob& c : seg_.contacts) result_.contact_points.push_back(c.centroid);
    const std::vector<std::optional<cv::Point2f>>& contact_of = contacts_per_shadow();
    const std::vector<double>& contact_area_of = sa_;
    const std::vector<Track>& tracks = tracker_.update(detections_, timestamp_ms);
    last_t_ = timestamp_ms;
    for (const Track& t : tracks)
      if (!find_slot(t.id)) start_machine(t.id);
    order_slots();
    for (const std::size_t i : order_) {
      Slot& slot = slots_[i];
      const Track* t = find_track(tracks, slot.id);
      TouchObservation obs;
      double area = 0;
      if (t && t->matched) {
        area = contact_area_of[static_cast<std::size_t>(t->detection_index)];
        obs.shadow = true;
        obs.contact = contact_of[static_cast<std::size_t>(t->detection_index)];
      }
      for (const TouchEvent& e : slot.machine.update(timestamp_ms, obs))
        result_.events.push_back({slot.id, e});
      if (t)
        result_.tracks.push_back(
            {t->id, t->matched, t->box, t->position, obs.contact, slot.machine.state(), area});
      else if (slot.machine.state() == TouchState::none)
        slot.live = false; // the machine is kept for the next new track
    }
    return result_;
  }

  const TouchFrame& flush(double timestamp_ms) {
    const auto guard = owner_.enter("TouchPipeline");
    require_time(timestamp_ms, "TouchPipeline::flush");
    reset_result(timestamp_ms);
    order_slots();
    for (const std::size_t i : order_) {
      Slot& slot = slots_[i];
      TouchStateMachine& m = slot.machine;
      for (const TouchEvent& e : m.update(timestamp_ms, {})) result_.events.push_back({slot.id, e});
      if (m.state() != TouchState::none)
        for (const TouchEvent& e : m.update(timestamp_ms + touch_config_.hysteresis_ms, {}))
          result_.events.push_back({slot.id, e});
      slot.live = false;
    }
    tracker_.clear_tracks(); // a new stream; ids keep growing
    result_.camera = result_.camera_before = camera_.fault();
    camera_.reset();
    last_t_ = timestamp_ms;
    return result_;
  }

  // The last frame's segmentation (masks, blobs; empty on a camera fault).
  // The accessors take the owner check too: reading them while another thread is inside
  // update() is the same misuse as two updates at once (a data race), so it throws.
  const Segmentation& segmentation() const {
    const auto guard = owner_.enter("TouchPipeline");
    return seg_;
  }
  const CameraHealth& camera_health() const {
    const auto guard = owner_.enter("TouchPipeline");
    return camera_;
  }
  BasicSegmenter<Rule>& segmenter() {
    const auto guard = owner_.enter("TouchPipeline");
    return segmenter_;
  }
  const ContactTracker& tracker() const {
    const auto guard = owner_.enter("TouchPipeline");
    return tracker_;
  }

private:
  void require_time(double t, const char* where) const {
    if (!(std::isfinite(t)))
      SHADOWSENSE_THROW(InvalidArgument(std::string(where) + ": timestamp_ms is not finite"));
    if (last_t_)
      if (!(t > *last_t_))
        SHADOWSENSE_THROW(InvalidArgument(std::string(where) + ": timestamp " + std::to_string(t) +
                                          " ms is not after the previous one (" +
                                          std::to_string(*last_t_) +
                                          " ms); timestamps must be strictly increasing"));
  }

  // A faulty frame: no blobs, all-zero masks of the frame's size (storage kept when it fits).
  void clear_segmentation(cv::Size size) {
    seg_.shadows.clear();
    seg_.contacts.clear();
    seg_.shadow_box.reset();
    seg_.contact_box.reset();
    seg_.contact_point.reset();
    seg_.dropped_shadow_blobs = seg_.dropped_contact_blobs = 0;
    for (cv::Mat* m : {&seg_.shadow_mask, &seg_.contact_mask}) {
      m->create(size, CV_8UC1);
      m->setTo(0);
    }
  }

  void reset_result(double timestamp_ms) {
    result_.timestamp_ms = timestamp_ms;
    result_.tracks.clear();
    result_.shadow_boxes.clear();
    result_.contact_points.clear();
    result_.events.clear();
    result_.dropped_shadow_blobs = result_.dropped_contact_blobs = 0;
  }

  // For each shadow blob, the area-weighted centroid of the contact blobs that overlap it most
  // (in member buffers, reused from frame to frame).
  const std::vector<std::optional<cv::Point2f>>& contacts_per_shadow() {
    const std::size_t n = seg_.shadows.size();
    std::vector<double>&sx = sx_, &sy = sy_, &sa = sa_;
    sx.assign(n, 0);
    sy.assign(n, 0);
    sa.assign(n, 0);
    for (const Blob& c : seg_.contacts) {
      int best = -1, best_area = 0;
      for (std::size_t i = 0; i < n; ++i) {
        const int a = (seg_.shadows[i].box & c.box).area();
        if (a > best_area) best_area = a, best = static_cast<int>(i);
      }
      if (best < 0) continue;
      const auto b = static_cast<std::size_t>(best);
      sx[b] += c.centroid.x * c.area;
      sy[b] += c.centroid.y * c.area;
      sa[b] += c.area;
    }
    std::vector<std::optional<cv::Point2f>>& out = contact_of_;
    out.assign(n, std::nullopt);
    for (std::size_t i = 0; i < n; ++i)
      if (sa[i] > 0)
        out[i] = cv::Point2f(static_cast<float>(sx[i] / sa[i]), static_cast<float>(sy[i] / sa[i]));
    return out;
  }

  // One state machine per track id. Slots are never freed: a slot whose track has ended is
  // reset and reused for the next new track, so machines are only constructed while the number
  // of simultaneous tracks grows (warm-up), never per frame.
  struct Slot {
    int id = 0;
    bool live = false;
    TouchStateMachine machine;
  };

  Slot* find_slot(int id) {
    for (Slot& s : slots_)
      if (s.live && s.id == id) return &s;
    return nullptr;
  }

  void start_machine(int id) {
    for (Slot& s : slots_)
      if (!s.live) {
        s.machine.reset();
        s.id = id;
        s.live = true;
        return;
      }
    slots_.push_back(Slot{id, true, TouchStateMachine(touch_config_)});
  }

  // order_: the live slots by increasing id (events are reported in that order).
  void order_slots() {
    order_.clear();
    for (std::size_t i = 0; i < slots_.size(); ++i)
      if (slots_[i].live) order_.push_back(i);
    std::sort(order_.begin(), order_.end(),
              [&](std::size_t a, std::size_t b) { return slots_[a].id < slots_[b].id; });
  }

  static const Track* find_track(const std::vector<Track>& tracks, int id) {
    for (const Track& t : tracks)
      if (t.id == id) return &t;
    return nullptr;
  }

  BasicSegmenter<Rule> segmenter_;
  ContactTracker tracker_;
  TouchStateMachine::Config touch_config_;
  CameraHealth camera_;
  std::vector<Slot> slots_;
  std::vector<std::size_t> order_;
  Segmentation seg_;
  std::vector<Detection> detections_;
  TouchFrame result_;
  std::vector<double> sx_, sy_, sa_;
  std::vector<std::optional<cv::Point2f>> contact_of_;
  std::optional<double> last_t_;
  mutable ThreadOwner owner_; // mutable: the read accessors check too
};

// The pipeline users have: with the Segmenter (calibrated rule).
using TouchPipeline = BasicTouchPipeline<CalibratedRule>;

SHADOWSENSE_NAMESPACE_END
