// The touch state machine of the paper's Fig. 7 (section 4.3): none -> appear -> touch <-> move
// -> lift -> none, driven by per-frame detections of a shadow and of a contact position, with a
// hysteresis window before lift and disappear, and slide direction from the mean contact
// displacement over a time window, voted over the windows of a sequence.
//
// Timestamps are inputs (milliseconds, strictly increasing), so a sequence replays identically at
// any frame rate. The machine follows ONE touch; for multi-touch run one machine per track of
// shadowsense::ContactTracker.
//
// Rules (all times inclusive at the window edge):
//  * none   -> appear    when a shadow is seen (a contact counts as a shadow too);
//                        -> appear and touch in the same frame when a contact is seen at once.
//  * appear/lift -> touch when a contact is seen (no delay: appearing is never debounced).
//  * touch  -> move      when the contact "differential" exceeds move_threshold_px: the distance
//                        between this frame's contact and the previous frame's contact (or,
//                        with differential_window_ms > 0, the oldest contact in that window).
//  * move   -> touch     when the differential is <= move_threshold_px.
//  * touch/move -> lift  when no contact has been seen for >= hysteresis_ms: the transition fires
//                        at the first frame whose timestamp t satisfies t - t_loss >=
//                        hysteresis_ms, where t_loss is the timestamp of the first frame without
//                        contact. A contact seen before that cancels the loss (flicker is
//                        suppressed, no event).
//  * appear/lift -> none ("disappear") likewise after no shadow for >= hysteresis_ms. If contact
//                        and shadow vanish together, lift and disappear fire in the same frame.
//  * Direction: in move, the mean per-frame displacement over the frames whose timestamps lie in
//    [t - direction_window_ms, t] (at least this and the previous contact frame) is mapped to
//    left/right/front/back by its dominant image axis (mapping configurable; default right=+x,
//    left=-x, front=-y, back=+y). An exact diagonal
//    (|dx| == |dy|) goes to the horizontal axis unless Config::diagonal_tie says vertical. Every
//    frame in move with a non-zero mean displacement casts one vote; the sequence direction is
//    the direction with most votes; a tie in votes goes to the direction whose votes carry the
//    larger summed displacement, then to the order right, left, front, back.
//
// Threading: one instance per thread; an owner check (core/thread_owner.hpp) throws
// ConcurrentUseError when one instance is updated from two threads at once.
#pragma once

#include <shadowsense/core/direction.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/thread_owner.hpp>

#include <opencv2/core.hpp>

#include <array>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

enum class TouchState { none, appear, touch, move, lift };

inline const char* to_string(TouchState s) {
  switch (s) {
  case TouchState::none:
    return "none";
  case TouchState::appear:
    return "appear";
  case TouchState::touch:
    return "touch";
  case TouchState::move:
    return "move";
  case TouchState::lift:
    return "lift";
  }
  return "?";
}

// Which robot-frame direction each image-axis sign means. Must be a permutation of the four.
struct AxisMapping {
  Direction positive_x = Direction::right;
  Direction negative_x = Direction::left;
  Direction negative_y = Direction::front;
  Direction positive_y = Direction::back;
};

enum class DiagonalTie { horizontal, vertical };

// What the machine sees in one frame.
struct TouchObservation {
  bool shadow = false;                  // an overall shadow is detected
  std::optional<cv::Point2f> contact{}; // contact position (image pixels), if a contact is detected
};

// One transition (from != to), or a change of the windowed direction while in move (from == to ==
// move). `to == none` is the paper's "disappear".
struct TouchEvent {
  double timestamp_ms = 0;
  TouchState from = TouchState::none;
  TouchState to = TouchState::none;
  Direction direction = Direction::none; // windowed direction (move events), else none
  std::optional<cv::Point2f> position{}; // contact position when the event has one
};

class TouchStateMachine {
public:
  struct Config {
    double hysteresis_ms = 150.0;       // before lift and disappear (paper: 150 ms)
    double move_threshold_px = 2.0;     // differential that means move (paper: 2 px)
    double direction_window_ms = 300.0; // averaging window for the direction (paper: 300 ms)
    // The differential compared with move_threshold_px is the displacement over this window
    // (at least since the previous contact frame). 0 = since the previous frame (the paper);
    // a longer window also catches slow slides at high frame rates.
    double differential_window_ms = 0.0;
    AxisMapping axes{};
    DiagonalTie diagonal_tie = DiagonalTie::horizontal;
  };

  TouchStateMachine() : TouchStateMachine(Config{}) {}
  explicit TouchStateMachine(const Config& config) : config_(config) {
    auto finite_nonneg = [](double v) { return std::isfinite(v) && v >= 0; };
    detail::require(finite_nonneg(config.hysteresis_ms),
                    "TouchStateMachine: hysteresis_ms must be finite and >= 0");
    detail::require(finite_nonneg(config.move_threshold_px),
                    "TouchStateMachine: move_threshold_px must be finite and >= 0");
    detail::require(std::isfinite(config.direction_window_ms) && config.direction_window_ms > 0,
                    "TouchStateMachine: direction_window_ms must be finite and > 0");
    detail::require(finite_nonneg(config.differential_window_ms),
                    "TouchStateMachine: differential_window_ms must be finite and >= 0");
    const std::array<Direction, 4> m{config.axes.positive_x, config.axes.negative_x,
                                     config.axes.negative_y, config.axes.positive_y};
    std::array<int, 5> seen{};
    for (Direction d : m) ++seen[static_cast<int>(d)];
    detail::require(seen[0] == 0 && seen[1] == 1 && seen[2] == 1 && seen[3] == 1 && seen[4] == 1,
                    "TouchStateMachine: axes must map the four image-axis signs to left, right, "
                    "front and back, each exactly once");
    events_.reserve(4);
    history_.reserve(64); // the direction window at up to ~200 fps: no growth while sliding
  }

  // Feeds one frame. Returns the events this frame caused (valid until the next call).
  // Throws InvalidArgument for a non-finite timestamp, one not greater than the previous one, or a
  // non-finite contact position.
  const std::vector<TouchEvent>& update(double timestamp_ms, const TouchObservation& obs) {
    const auto guard = owner_.enter("TouchStateMachine");
    detail::require(std::isfinite(timestamp_ms), "TouchStateMachine::update: timestamp_ms is not "
                                                 "finite; expected a finite time in milliseconds");
    if (last_t_)
      if (!(timestamp_ms > *last_t_))
        SHADOWSENSE_THROW(
            InvalidArgument("TouchStateMachine::update: timestamp " + std::to_string(timestamp_ms) +
                            " ms is not after the previous one (" + std::to_string(*last_t_) +
                            " ms); timestamps must be strictly increasing"));
    if (obs.contact)
      detail::require(std::isfinite(obs.contact->x) && std::isfinite(obs.contact->y),
                      "TouchStateMachine::update: contact position is not finite");
    last_t_ = timestamp_ms;
    events_.clear();
    const double t = timestamp_ms;
    const bool shadow = obs.shadow || obs.contact.has_value();

    // Loss bookkeeping first: a detection cancels a pending loss.
    if (obs.contact)
      contact_lost_since_.reset();
    else if (!contact_lost_since_)
      contact_lost_since_ = t;
    if (shadow)
      shadow_lost_since_.reset();
    else if (!shadow_lost_since_)
      shadow_lost_since_ = t;

    switch (state_) {
    case TouchState::none:
      if (shadow) emit(t, TouchState::appear, std::nullopt);
      if (obs.contact) begin_touch(t, *obs.contact);
      break;
    case TouchState::appear:
    case TouchState::lift:
      if (obs.contact)
        begin_touch(t, *obs.contact);
      else if (shadow_lost_since_ && t - *shadow_lost_since_ >= config_.hysteresis_ms)
        emit(t, TouchState::none, std::nullopt);
      break;
    case TouchState::touch:
    case TouchState::move:
      if (obs.contact) {
        continue_touch(t, *obs.contact);
      } else if (t - *contact_lost_since_ >= config_.hysteresis_ms) {
        emit(t, TouchState::lift, last_contact_);
        history_.clear();
        if (shadow_lost_since_ && t - *shadow_lost_since_ >= config_.hysteresis_ms)
          emit(t, TouchState::none, std::nullopt);
      }
      break;
    }
    return events_;
  }

  TouchState state() const { return state_; }
  // Windowed direction of the latest frame in move (none outside move).
  Direction direction() const {
    return state_ == TouchState::move ? window_direction_ : Direction::none;
  }
  // The sequence's direction so far by voting over windows (none if no vote was cast).
  Direction voted_direction() const {
    int best = -1;
    for (int i = 0; i < 4; ++i) {
      if (votes_[i] == 0) continue;
      if (best < 0 || votes_[i] > votes_[best] ||
          (votes_[i] == votes_[best] && vote_weight_[i] > vote_weight_[best]))
        best = i;
    }
    return best < 0 ? Direction::none : kVoteOrder[best];
  }
  // Votes cast so far, in the order right, left, front, back.
  std::array<int, 4> votes() const { return votes_; }
  std::optional<cv::Point2f> last_contact() const { return last_contact_; }

  // Back to the initial state (also forgets the previous timestamp and the votes). Keeps the
  // buffers' storage, so a reused machine allocates nothing.
  void reset() {
    state_ = TouchState::none;
    last_t_.reset();
    contact_lost_since_.reset();
    shadow_lost_since_.reset();
    last_contact_.reset();
    history_.clear();
    window_direction_ = Direction::none;
    votes_ = {};
    vote_weight_ = {};
    events_.clear();
  }

  const Config& config() const { return config_; }

private:
  static constexpr std::array<Direction, 4> kVoteOrder{Direction::right, Direction::left,
                                                       Direction::front, Direction::back};
  struct Sample {
    double t;
    cv::Point2f p;
  };

  void emit(double t, TouchState to, std::optional<cv::Point2f> p, Direction d = Direction::none) {
    events_.push_back(TouchEvent{t, state_, to, d, p});
    state_ = to;
  }

  void begin_touch(double t, cv::Point2f p) {
    history_.clear();
    history_.push_back({t, p});
    last_contact_ = p;
    emit(t, TouchState::touch, p);
  }

  void continue_touch(double t, cv::Point2f p) {
    history_.push_back({t, p});
    // Windows always keep the previous contact frame, so a step is never averaged away.
    const double keep = std::max(config_.direction_window_ms, config_.differential_window_ms);
    std::size_t old = 0; // samples out of the window (a vector: no node allocations per frame)
    while (history_.size() - old > 2 && t - history_[old].t > keep) ++old;
    history_.erase(history_.begin(), history_.begin() + static_cast<std::ptrdiff_t>(old));
    last_contact_ = p;
    const cv::Point2f step = p - oldest_within(config_.differential_window_ms).p;
    const double differential = std::hypot(step.x, step.y);
    const bool moving = differential > config_.move_threshold_px;
    if (state_ == TouchState::touch && moving) {
      window_direction_ = windowed_direction();
      emit(t, TouchState::move, p, window_direction_);
      cast_vote();
    } else if (state_ == TouchState::move && !moving) {
      emit(t, TouchState::touch, p);
    } else if (state_ == TouchState::move) {
      const Direction d = windowed_direction();
      if (d != window_direction_) {
        window_direction_ = d;
        emit(t, TouchState::move, p, d);
      }
      cast_vote();
    }
  }

  // The oldest sample within `window_ms` of the newest, but at least the one before the newest.
  const Sample& oldest_within(double window_ms) const {
    const double t = history_.back().t;
    std::size_t i = history_.size() - 1;
    if (i > 0) --i;
    while (i > 0 && t - history_[i - 1].t <= window_ms) --i;
    return history_[i];
  }

  // Mean per-frame displacement over the direction window; the sum telescopes to last - first.
  cv::Point2f window_displacement() const {
    if (history_.size() < 2) return {0, 0};
    const Sample& first = oldest_within(config_.direction_window_ms);
    const cv::Point2f total = history_.back().p - first.p;
    std::size_t steps = 0;
    for (std::size_t i = history_.size() - 1; i > 0 && &history_[i] != &first; --i) ++steps;
    return total * (1.0f / static_cast<float>(std::max<std::size_t>(steps, 1)));
  }

  Direction classify(cv::Point2f d) const {
    const float ax = std::abs(d.x), ay = std::abs(d.y);
    if (ax == 0 && ay == 0) return Direction::none;
    const bool horizontal =
        ax > ay || (ax == ay && config_.diagonal_tie == DiagonalTie::horizontal);
    if (horizontal) return d.x > 0 ? config_.axes.positive_x : config_.axes.negative_x;
    return d.y > 0 ? config_.axes.positive_y : config_.axes.negative_y;
  }

  Direction windowed_direction() const { return classify(window_displacement()); }

  void cast_vote() {
    const cv::Point2f d = window_displacement();
    const Direction dir = classify(d);
    if (dir == Direction::none) return;
    for (int i = 0; i < 4; ++i)
      if (kVoteOrder[i] == dir) {
        ++votes_[i];
        vote_weight_[i] += std::max(std::abs(d.x), std::abs(d.y));
      }
  }

  Config config_;
  TouchState state_ = TouchState::none;
  std::optional<double> last_t_;
  std::optional<double> contact_lost_since_;
  std::optional<double> shadow_lost_since_;
  std::optional<cv::Point2f> last_contact_;
  std::vector<Sample> history_; // the direction window's contact samples, oldest first
  Direction window_direction_ = Direction::none;
  std::array<int, 4> votes_{};
  std::array<double, 4> vote_weight_{};
  std::vector<TouchEvent> events_;
  ThreadOwner owner_;
};

// Replays a whole sequence (one observation per timestamp) and returns the voted direction.
// An empty sequence gives Direction::none. Throws InvalidArgument if the sizes differ or the
// timestamps are not strictly increasing.
inline Direction sequence_direction(const std::vector<double>& timestamps_ms,
                                    const std::vector<TouchObservation>& observations,
                                    const TouchStateMachine::Config& config = {}) {
  detail::require(timestamps_ms.size() == observations.size(),
                  "sequence_direction: " + std::to_string(timestamps_ms.size()) +
                      " timestamps but " + std::to_string(observations.size()) +
                      " observations; expected one timestamp per observation");
  TouchStateMachine fsm(config);
  for (std::size_t i = 0; i < observations.size(); ++i)
    fsm.update(timestamps_ms[i], observations[i]);
  return fsm.voted_direction();
}

SHADOWSENSE_NAMESPACE_END
