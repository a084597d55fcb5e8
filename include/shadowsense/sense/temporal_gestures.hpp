// Temporal touch gestures: what a touch does over time (tap, double tap, pat, stroke, rub, hold,
// hit), recognised per track from the TouchPipeline's per-frame result, plus the hand-shape
// gestures the classifier reads from a single frame (hug, punch, two hands) as intervals.
// docs/temporal_gestures.md says what a shadow camera observes for each and where the
// thresholds come from.
//
// Input per frame: the TouchFrame (tracks with id, contact point, contact area) and the
// classifier's reading of the frame (OutputGesture: label, confidence; `available` false or
// label "" when there is none). A track's *contact episode* runs from its first frame with a
// contact point to the first frame without one (the raw per-frame contact, not the touch state
// machine's debounced state: the hysteresis would hide the gap between two taps).
//
// Rules (times in ms, distances in cm converted with Config::px_per_cm; d = episode duration =
// lift frame time - first contact frame time; "still" = the contact never left a circle of
// still_radius_cm around its first point; the hand is a *palm* when the classifier said palm,
// punch, hug or two_hands in most contact frames, a *finger* when it said point, and otherwise,
// without a classifier reading, a palm when the contact area reached palm_min_area_cm2):
//  * rub       at lift: the contact moved back and forth, >= rub_min_reversals reversals of at
//              least rub_amplitude_cm along an image axis. repetitions = reversals.
//  * stroke    at lift: not a rub, the path is >= stroke_min_length_cm. direction = the net
//              displacement's dominant axis (+x right, -x left, -y front, +y back, as the touch
//              state machine's default), length (px) = path length, speed (px/s) = length / d.
//  * hold      still and d >= hold_min_ms: a `began` event in the first frame where that holds
//              (latency 0 after the threshold), an `ended` event at lift with the whole interval,
//              or in the first frame the contact leaves the still circle: from that frame on
//              the contact is a new episode (a stroke or rub at lift if it travels far enough,
//              never a tap, pat or hit).
//  * hit       at lift: still (or moved less than a stroke), d <= hit_max_contact_ms, a palm,
//              the first contact of the track and the contact began <= hit_max_approach_ms after
//              the track appeared (the shadow sharpened into a contact fast: a fast approach).
//  * tap       at lift: still, d <= tap_max_contact_ms, a finger. A further finger tap of the same
//              track starting <= double_tap_max_gap_ms after the previous lift and within
//              repeat_radius_cm of the first is the same gesture: at its lift a `revised` event
//              replaces the tap by a double_tap (repetitions 2, 3, ...; start_ms of the first).
//  * pat       at lift: still, d <= pat_max_contact_ms, a palm, not a hit. As taps: the first
//              pat is reported at its lift (repetitions 1) and each further pat starting
//              <= pat_max_gap_ms after the previous lift within repeat_radius_cm revises it
//              (repetitions n).
//  * none      a still contact longer than a tap/pat and shorter than a hold, or a moved one
//              shorter than a stroke, is a plain touch: no gesture event (the touch events have
//              it). A contact whose most frequent label is hug or two_hands belongs to that
//              whole-frame gesture: no track gesture (a punch's contact can be a hit).
//  * hug, punch, two_hands: the frame's classifier label. `began` in the first frame with the
//              label (track_id 0: the classifier reads the whole frame; position: the mean of
//              the live tracks' shadow centroids), `ended` in the first frame without it, with
//              end_ms the last frame that had it.
// Every event carries the emitting frame's time (decided_ms); latency = decided_ms - end_ms for
// ended/complete events. An event with phase `revised` replaces the last event of the same track
// with the same start_ms; a consumer keeping "the last word per (track_id, start_ms)" has the
// final reading.
// Confidence: the share of the episode's contact frames whose hand shape agrees with the
// gesture's (1 for stroke, rub and hold, which do not depend on the shape; the classifier's
// mean confidence over the interval for hug, punch and two_hands).
//
// TemporalGestureRecogniser(config = {})
//   requires: a valid Config (validate(): every duration > 0 and finite, px_per_cm > 0, ...),
//             else InvalidArgument naming the field.
// update(touch_frame, hand_shape) -> const std::vector<GestureEvent>&
//   requires: touch_frame.timestamp_ms finite and > the previous update/flush (else
//             InvalidArgument, nothing changed); track ids unique and > 0 in the frame; contact
//             points and areas finite (else InvalidArgument, nothing changed).
//   ensures:  the events decided in this frame, ordered by track id (0 first), then by
//             occurrence. A track that was in contact and is missing from the frame (it vanished
//             mid-gesture: the tracker dropped it) ends its episode without a tap, pat, stroke,
//             rub or hit (the evidence is cut off); a hold it had begun is ended at its last
//             contact frame. Its pending repetitions are forgotten. No heap allocation after
//             warm-up (slots for the largest number of simultaneous tracks are kept; labels are
//             held in fixed buffers, truncated at 31 characters).
// flush(timestamp_ms) -> const std::vector<GestureEvent>&
//   requires: as update's timestamp.
//   ensures:  the stream ends: every contact episode ends as if lifted at timestamp_ms (its
//             gesture is reported), label intervals end, and all state is cleared.
// Threading: one instance per thread; an owner check (core/thread_owner.hpp) throws
// ConcurrentUseError when one instance is used from two threads at once.
//
// TemporalRecogniser<R> (concept): what the Runtime composes - r.update(const TouchFrame&, const
// OutputGesture&) and r.flush(double) returning something whose elements are GestureEvent
// (a const std::vector<GestureEvent>&). TemporalRecogniserArchetype is the least such type.
#pragma once

#include <shadowsense/core/direction.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/thread_owner.hpp>
#include <shadowsense/output/event_sink.hpp>
#include <shadowsense/sense/gesture_event.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

struct TemporalGestureConfig {
  double px_per_cm = 7.6; // image scale at the skin (both generated rigs: ~7.6 px/cm at centre)
  double tap_max_contact_ms = 300;
  double pat_max_contact_ms = 350;
  double hit_max_contact_ms = 250;
  double hit_max_approach_ms = 200;   // track appearance -> first contact
  double hold_min_ms = 1000;          // issue 23: "a still contact of >= ~1 s"
  double double_tap_max_gap_ms = 300; // lift -> next contact (Android's DOUBLE_TAP_TIMEOUT)
  double pat_max_gap_ms = 600;
  double repeat_radius_cm = 4;
  double still_radius_cm = 1.5;
  double stroke_min_length_cm = 3;
  double rub_amplitude_cm = 1.5;
  int rub_min_reversals = 2;
  double palm_min_area_cm2 = 12; // without a classifier reading: palm vs fingertip

  void validate() const {
    auto positive = [](double v, const char* name) {
      detail::require(std::isfinite(v) && v > 0,
                      std::string("TemporalGestureConfig: ") + name + " must be finite and > 0");
    };
    positive(px_per_cm, "px_per_cm");
    positive(tap_max_contact_ms, "tap_max_contact_ms");
    positive(pat_max_contact_ms, "pat_max_contact_ms");
    positive(hit_max_contact_ms, "hit_max_contact_ms");
    positive(hit_max_approach_ms, "hit_max_approach_ms");
    positive(hold_min_ms, "hold_min_ms");
    positive(double_tap_max_gap_ms, "double_tap_max_gap_ms");
    positive(pat_max_gap_ms, "pat_max_gap_ms");
    positive(repeat_radius_cm, "repeat_radius_cm");
    positive(still_radius_cm, "still_radius_cm");
    positive(stroke_min_length_cm, "stroke_min_length_cm");
    positive(rub_amplitude_cm, "rub_amplitude_cm");
    positive(palm_min_area_cm2, "palm_min_area_cm2");
    detail::require(rub_min_reversals >= 1,
                    "TemporalGestureConfig: rub_min_reversals must be >= 1");
    detail::require(hold_min_ms >
                        std::max({tap_max_contact_ms, pat_max_contact_ms, hit_max_contact_ms}),
                    "TemporalGestureConfig: hold_min_ms must exceed the tap, pat and hit "
                    "contact limits");
  }
};

template <class R>
concept TemporalRecogniser = requires(R& r, const TouchFrame& f, const OutputGesture& g, double t) {
  { *r.update(f, g).begin() } -> std::convertible_to<const GestureEvent&>;
  { *r.flush(t).begin() } -> std::convertible_to<const GestureEvent&>;
  r.update(f, g).size();
};

// The least TemporalRecogniser: reports nothing.
struct TemporalRecogniserArchetype {
  const std::vector<GestureEvent>& update(const TouchFrame&, const OutputGesture&) { return none; }
  const std::vector<GestureEvent>& flush(double) { return none; }
  std::vector<GestureEvent> none;
};

class TemporalGestureRecogniser {
public:
  using Config = TemporalGestureConfig;

  explicit TemporalGestureRecogniser(const Config& config = {}) : config_(config) {
    config_.validate();
    slots_.resize(8);
    events_.reserve(32);
  }

  const Config& config() const { return config_; }

  const std::vector<GestureEvent>& update(const TouchFrame& frame, const OutputGesture& shape) {
    const auto guard = owner_.enter("TemporalGestureRecogniser");
    const double t = frame.timestamp_ms;
    check_time(t, "TemporalGestureRecogniser::update");
    check_frame(frame);
    events_.clear();
    const std::string_view label =
        shape.available ? std::string_view(shape.label) : std::string_view();
    update_label(t, label, shape.confidence, frame);
    for (Slot& s : slots_) s.seen = false;
    for (const TouchTrack& tr : frame.tracks) {
      Slot& s = slot_for(tr.id, t);
      s.seen = true;
      if (tr.contact)
        on_contact(s, t, *tr.contact, tr.contact_area, label);
      else if (s.in_contact)
        on_lift(s, t, false);
      expire_chain(s, t);
    }
    for (Slot& s : slots_)
      if (s.live && !s.seen) vanish(s, t);
    sort_events();
    last_t_ = t;
    has_t_ = true;
    return events_;
  }

  const std::vector<GestureEvent>& flush(double t) {
    const auto guard = owner_.enter("TemporalGestureRecogniser");
    check_time(t, "TemporalGestureRecogniser::flush");
    events_.clear();
    end_label(t);
    for (Slot& s : slots_) {
      if (s.live && s.in_contact) on_lift(s, t, false);
      s = Slot{};
    }
    sort_events();
    last_t_ = t;
    has_t_ = true;
    return events_;
  }

private:
  // One back-and-forth counter per image axis, with amplitude hysteresis.
  struct Swing {
    float start = 0, extreme = 0;
    int sign = 0, reversals = 0;
    void reset(float v) { start = extreme = v, sign = 0, reversals = 0; }
    void add(float v, float amplitude) {
      if (sign == 0) {
        if (std::abs(v - start) >= amplitude) sign = v > start ? 1 : -1, extreme = v;
      } else if ((v - extreme) * static_cast<float>(sign) > 0) {
        extreme = v;
      } else if ((extreme - v) * static_cast<float>(sign) >= amplitude) {
        ++reversals, sign = -sign, extreme = v;
      }
    }
  };

  // Votes for the interval's most frequent label (fixed buffers: no allocation).
  struct LabelVotes {
    static constexpr std::size_t n = 8;
    std::array<ShortLabel, n> labels{};
    std::array<int, n> counts{};
    std::size_t used = 0;
    void clear() { used = 0; }
    void add(std::string_view l) {
      if (l.empty()) return;
      for (std::size_t i = 0; i < used; ++i)
        if (labels[i].view() == l.substr(0, 31)) return void(++counts[i]);
      if (used == n) return; // more distinct labels than slots: the rest are not counted
      labels[used].assign(l);
      counts[used++] = 1;
    }
    std::string_view best() const {
      std::size_t b = n;
      for (std::size_t i = 0; i < used; ++i)
        if (b == n || counts[i] > counts[b]) b = i;
      return b == n ? std::string_view() : labels[b].view();
    }
  };

  struct Slot {
    int id = 0;
    bool live = false, seen = false;
    double appeared_ms = 0;
    bool had_contact = false; // any contact since the track appeared
    // The contact episode.
    bool in_contact = false, first_contact = false, hold_began = false, moved = false;
    bool after_hold = false; // the episode continues a hold that started to travel
    double c_start = 0, c_last = 0;
    cv::Point2f p_start{}, p_last{};
    double path = 0;
    Swing sx, sy;
    int frames = 0, palm_votes = 0;
    LabelVotes votes;
    // The repetition chain (taps or pats).
    bool chain = false, chain_palm = false;
    int chain_count = 0;
    double chain_start = 0, chain_lift = 0;
    cv::Point2f chain_pos{};
    float chain_conf = 0;
  };

  // By track id, stable (insertion sort: few events, and std::stable_sort may allocate).
  void sort_events() {
    for (std::size_t i = 1; i < events_.size(); ++i)
      for (std::size_t j = i; j > 0 && events_[j - 1].track_id > events_[j].track_id; --j)
        std::swap(events_[j - 1], events_[j]);
  }

  void check_time(double t, const char* where) const {
    if (!std::isfinite(t))
      SHADOWSENSE_THROW(InvalidArgument(std::string(where) + ": timestamp_ms is not finite"));
    if (has_t_ && !(t > last_t_))
      SHADOWSENSE_THROW(InvalidArgument(std::string(where) + ": timestamp " + std::to_string(t) +
                                        " ms is not after the previous one (" +
                                        std::to_string(last_t_) +
                                        " ms); timestamps must be strictly increasing"));
  }

  static void check_frame(const TouchFrame& f) {
    for (std::size_t i = 0; i < f.tracks.size(); ++i) {
      const TouchTrack& a = f.tracks[i];
      if (a.id <= 0)
        SHADOWSENSE_THROW(InvalidArgument("TemporalGestureRecogniser::update: track id " +
                                          std::to_string(a.id) + " is not positive"));
      for (std::size_t j = 0; j < i; ++j)
        if (f.tracks[j].id == a.id)
          SHADOWSENSE_THROW(InvalidArgument("TemporalGestureRecogniser::update: track id " +
                                            std::to_string(a.id) + " appears twice in one frame"));
      if (a.contact && (!std::isfinite(a.contact->x) || !std::isfinite(a.contact->y) ||
                        !std::isfinite(a.contact_area) || a.contact_area < 0))
        SHADOWSENSE_THROW(InvalidArgument(
            "TemporalGestureRecogniser::update: track " + std::to_string(a.id) +
            " has a non-finite contact point or a negative or non-finite contact area"));
    }
  }

  Slot& slot_for(int id, double t) {
    for (Slot& s : slots_)
      if (s.live && s.id == id) return s;
    Slot* free = nullptr;
    for (Slot& s : slots_)
      if (!s.live) {
        free = &s;
        break;
      }
    if (!free) free = &slots_.emplace_back(); // warm-up: more simultaneous tracks than before
    *free = Slot{};
    free->id = id;
    free->live = true;
    free->appeared_ms = t;
    return *free;
  }

  bool palm_shape(std::string_view label, double area_px) const {
    if (label == "point") return false;
    if (label == "palm" || label == "punch" || label == "hug" || label == "two_hands") return true;
    const double cm2 = area_px / (config_.px_per_cm * config_.px_per_cm);
    return cm2 >= config_.palm_min_area_cm2;
  }

  void on_contact(Slot& s, double t, cv::Point2f p, double area, std::string_view label) {
    const float amp = static_cast<float>(config_.rub_amplitude_cm * config_.px_per_cm);
    if (!s.in_contact) {
      s.in_contact = true;
      s.first_contact = !s.had_contact;
      s.had_contact = true;
      s.hold_began = s.moved = s.after_hold = false;
      s.c_start = t;
      s.p_start = s.p_last = p;
      s.path = 0;
      s.sx.reset(p.x);
      s.sy.reset(p.y);
      s.frames = s.palm_votes = 0;
      s.votes.clear();
    } else {
      s.path += std::hypot(p.x - s.p_last.x, p.y - s.p_last.y);
      s.p_last = p;
      s.sx.add(p.x, amp);
      s.sy.add(p.y, amp);
    }
    s.c_last = t;
    ++s.frames;
    if (palm_shape(label, area)) ++s.palm_votes;
    s.votes.add(label);
    if (std::hypot(p.x - s.p_start.x, p.y - s.p_start.y) >
        config_.still_radius_cm * config_.px_per_cm)
      s.moved = true;
    if (s.hold_began && s.moved) { // a hold that starts to travel: the hold ends here
      GestureEvent& e = emit(s, TouchGesture::hold, GesturePhase::ended, t);
      e.confidence = 1;
      // The contact goes on as a new episode from this frame: a stroke or rub if it travels on,
      // never a tap, pat or hit.
      s.hold_began = s.moved = s.first_contact = false;
      s.after_hold = true;
      s.c_start = t;
      s.p_start = s.p_last = p;
      s.path = 0;
      s.sx.reset(p.x);
      s.sy.reset(p.y);
    }
    if (!s.moved && !s.hold_began && t - s.c_start >= config_.hold_min_ms &&
        !whole_body(s.votes.best())) {
      s.hold_began = true;
      GestureEvent& e = emit(s, TouchGesture::hold, GesturePhase::began, t);
      e.end_ms = t;
      e.confidence = 1;
    }
  }

  GestureEvent& emit(const Slot& s, TouchGesture g, GesturePhase phase, double t) {
    GestureEvent& e = events_.emplace_back();
    e.gesture = g;
    e.phase = phase;
    e.track_id = s.id;
    e.start_ms = s.c_start;
    e.end_ms = t;
    e.decided_ms = t;
    e.position = s.p_start;
    e.hand_shape.assign(s.votes.best());
    return e;
  }

  // The episode ends at `t` (the first frame without contact, or a flush). With `vanished`, the
  // track is gone: only a begun hold is closed (at its last contact frame).
  void on_lift(Slot& s, double t, bool vanished) {
    s.in_contact = false;
    const double d = t - s.c_start;
    if (s.hold_began) {
      GestureEvent& e = emit(s, TouchGesture::hold, GesturePhase::ended, t);
      e.end_ms = vanished ? s.c_last : t;
      e.confidence = 1;
      s.chain = false;
      return;
    }
    if (vanished) return;
    if (whole_body(s.votes.best())) return void(s.chain = false); // a hug's or two hands' contact
    const int reversals = std::max(s.sx.reversals, s.sy.reversals);
    const double length_cm = s.path / config_.px_per_cm;
    const float palm_share = static_cast<float>(s.palm_votes) / static_cast<float>(s.frames);
    const bool palm = 2 * s.palm_votes > s.frames;
    if (s.moved && reversals >= config_.rub_min_reversals) {
      GestureEvent& e = emit(s, TouchGesture::rub, GesturePhase::complete, t);
      e.repetitions = reversals;
      motion(e, s, d);
      s.chain = false;
      return;
    }
    if (s.moved && length_cm >= config_.stroke_min_length_cm) {
      GestureEvent& e = emit(s, TouchGesture::stroke, GesturePhase::complete, t);
      motion(e, s, d);
      const cv::Point2f net = s.p_last - s.p_start;
      if (std::abs(net.x) >= std::abs(net.y))
        e.direction = net.x >= 0 ? Direction::right : Direction::left;
      else
        e.direction = net.y < 0 ? Direction::front : Direction::back;
      s.chain = false;
      return;
    }
    if (s.moved || s.after_hold) return void(s.chain = false); // a plain touch
    const float shape_conf = palm ? palm_share : 1 - palm_share;
    if (palm && s.first_contact && d <= config_.hit_max_contact_ms &&
        s.c_start - s.appeared_ms <= config_.hit_max_approach_ms) {
      GestureEvent& e = emit(s, TouchGesture::hit, GesturePhase::complete, t);
      e.confidence = shape_conf;
      s.chain = false;
      return;
    }
    const double max_d = palm ? config_.pat_max_contact_ms : config_.tap_max_contact_ms;
    if (d > max_d) return void(s.chain = false); // a plain touch
    const double gap = palm ? config_.pat_max_gap_ms : config_.double_tap_max_gap_ms;
    const bool continues = s.chain && s.chain_palm == palm && s.c_start - s.chain_lift <= gap &&
                           std::hypot(s.p_start.x - s.chain_pos.x, s.p_start.y - s.chain_pos.y) <=
                               config_.repeat_radius_cm * config_.px_per_cm;
    if (continues) {
      ++s.chain_count;
      s.chain_conf = std::min(s.chain_conf, shape_conf);
    } else {
      s.chain = true;
      s.chain_palm = palm;
      s.chain_count = 1;
      s.chain_start = s.c_start;
      s.chain_pos = s.p_start;
      s.chain_conf = shape_conf;
    }
    s.chain_lift = t;
    const TouchGesture g =
        palm ? TouchGesture::pat
             : (s.chain_count >= 2 ? TouchGesture::double_tap : TouchGesture::tap);
    GestureEvent& e =
        emit(s, g, s.chain_count >= 2 ? GesturePhase::revised : GesturePhase::complete, t);
    e.start_ms = s.chain_start;
    e.position = s.chain_pos;
    e.repetitions = s.chain_count;
    e.confidence = s.chain_conf;
  }

  void motion(GestureEvent& e, const Slot& s, double d) const {
    e.length_px = static_cast<float>(s.path);
    e.speed_px_s = d > 0 ? static_cast<float>(s.path / (d / 1000.0)) : 0.f;
    e.confidence = 1;
  }

  // A repetition chain ends when its gap has passed without a new contact.
  void expire_chain(Slot& s, double t) const {
    if (!s.chain || s.in_contact) return;
    const double gap = s.chain_palm ? config_.pat_max_gap_ms : config_.double_tap_max_gap_ms;
    if (t - s.chain_lift > gap) s.chain = false;
  }

  void vanish(Slot& s, double t) {
    if (s.in_contact) on_lift(s, t, true);
    s = Slot{};
  }

  // A contact seen mostly as a hug or two hands is part of that whole-frame gesture.
  static bool whole_body(std::string_view label) { return label == "hug" || label == "two_hands"; }

  // Hand-shape gestures of the whole frame, from the classifier's label.
  static bool frame_gesture(std::string_view label, TouchGesture& g) {
    if (label == "hug") return g = TouchGesture::hug, true;
    if (label == "punch") return g = TouchGesture::punch, true;
    if (label == "two_hands") return g = TouchGesture::two_hands, true;
    return false;
  }

  void update_label(double t, std::string_view label, float confidence, const TouchFrame& f) {
    TouchGesture g{};
    const bool is = frame_gesture(label, g);
    if (label_open_ && (!is || g != label_gesture_)) end_label(t);
    if (!is) return;
    if (!label_open_) {
      label_open_ = true;
      label_gesture_ = g;
      label_start_ = t;
      label_conf_sum_ = 0;
      label_frames_ = 0;
      label_pos_ = {};
      if (!f.tracks.empty()) {
        for (const TouchTrack& tr : f.tracks) label_pos_ += tr.position;
        label_pos_ *= 1.0f / static_cast<float>(f.tracks.size());
      }
      GestureEvent& e = events_.emplace_back();
      fill_label(e, GesturePhase::began, t, t, confidence);
      label_label_.assign(label);
      e.hand_shape = label_label_;
    }
    label_last_ = t;
    label_conf_sum_ += confidence;
    ++label_frames_;
  }

  void end_label(double t) {
    if (!label_open_) return;
    label_open_ = false;
    GestureEvent& e = events_.emplace_back();
    fill_label(e, GesturePhase::ended, label_last_, t,
               static_cast<float>(label_conf_sum_ / std::max(1, label_frames_)));
    e.hand_shape = label_label_;
  }

  void fill_label(GestureEvent& e, GesturePhase phase, double end, double t, float conf) const {
    e = GestureEvent{};
    e.gesture = label_gesture_;
    e.phase = phase;
    e.track_id = 0;
    e.start_ms = label_start_;
    e.end_ms = end;
    e.decided_ms = t;
    e.position = label_pos_;
    e.confidence = conf;
  }

  Config config_;
  std::vector<Slot> slots_;
  std::vector<GestureEvent> events_;
  double last_t_ = 0;
  bool has_t_ = false;
  bool label_open_ = false;
  TouchGesture label_gesture_ = TouchGesture::hug;
  double label_start_ = 0, label_last_ = 0, label_conf_sum_ = 0;
  int label_frames_ = 0;
  cv::Point2f label_pos_{};
  ShortLabel label_label_;
  ThreadOwner owner_;
};
static_assert(TemporalRecogniser<TemporalGestureRecogniser>);
static_assert(TemporalRecogniser<TemporalRecogniserArchetype>);

SHADOWSENSE_NAMESPACE_END
