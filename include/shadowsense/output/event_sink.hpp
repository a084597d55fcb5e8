// Event sinks: where touch events go once the pipeline has produced them (a CSV or JSON-lines
// stream, TUIO over UDP, or a type of the user's own).
//
// OutputFrame is what a sink receives, once per camera frame: a plain struct the caller fills
// (OutputFrameBuilder fills it from the TouchPipeline's per-frame result). It holds
//   * frame_index   increasing per frame (TUIO's fseq; 1 for the first frame),
//   * timestamp_ms  the frame's time (milliseconds, as fed to the pipeline),
//   * frame_size    the image size in pixels (TUIO normalises positions by it),
//   * contacts      the contacts alive in this frame (TUIO cursors): one per track whose touch
//                   state machine is in touch or move, at its contact point (pixels),
//   * shadows       the shadows alive in this frame (TUIO blobs): one per live track, with its
//                   shadow box (pixels),
//   * events        the frame's touch events, each with the track it belongs to,
//   * touch_gestures the temporal gestures decided in this frame (GestureEvent,
//                   sense/gesture_event.hpp; docs/temporal_gestures.md), empty when the run has
//                   no recogniser,
//   * camera        the camera's fault state (sense/camera_health.hpp; none = healthy) and
//     camera_before the previous frame's: sinks report a change (a CSV / JSON `camera` row),
//   * gesture       the hand-shape classifier's reading of the frame (OutputGesture):
//                   `available` is false when the run has no classifier (sinks then write no
//                   gesture); otherwise `label` is the class with the highest probability, or ""
//                   while the classifier is gated off (no shadow), with its confidence, the
//                   frame it was computed on, and every class's probability.
// Ids are the tracker's track ids (positive, never reused), so a contact and the shadow of the
// same hand share an id.
//
// EventSink<S> (concept)
//   requires: s.write(frame) for a const OutputFrame& frame.
//   A sink is stateful and not thread-safe unless it says otherwise: one thread writes to it.
//   write() may throw (an IoError when its stream or socket fails); the frame is then lost for
//   that sink only.
// EventSinkArchetype: the least type that models EventSink (for documentation and checks).
// publish(frame, sinks...)
//   ensures: frame written to every sink, in argument order.
//   throws:  what a sink's write throws (the sinks after it are not written).
//
// OutputFrameBuilder
//   build(touch_frame, frame_size) -> const OutputFrame&
//     requires: touch_frame shaped like the TouchPipeline's TouchFrame (see TouchFrameLike:
//               timestamp_ms; tracks with id, shadow_box, contact (optional point), state;
//               events with track_id and event), a non-empty frame_size.
//     ensures:  frame_index = previous + 1 (1 first); camera and camera_before copied when the
//               touch frame has them (else none); contacts: tracks in touch or move, at this
//               frame's contact point or, during the hysteresis before a lift (no contact seen
//               yet the machine still touching), at the last contact point seen for that track;
//               shadows: every track with its shadow box; events copied. The reference stays
//               valid until the next build.
//     throws:   InvalidArgument for an empty frame_size.
//   build(touch_frame, frame_size, gesture)
//     the same, with frame.gesture = gesture (copied into reused storage).
//   build(touch_frame, frame_size, gesture, touch_gestures)
//     the same, with frame.touch_gestures = touch_gestures (copied into reused storage).
//   Threading: one instance per thread. No allocation after warm-up (buffers are reused).
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sense/camera_health.hpp>
#include <shadowsense/sense/gesture_event.hpp>
#include <shadowsense/sense/touch_state_machine.hpp>

#include <opencv2/core.hpp>

#include <concepts>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// The version of the event schema the CSV and JSON-lines sinks write (docs/output.md): the
// `schema` field of every row / object. 2: one schema for every program, frames counted from 1,
// the gesture fields. 3: a `kind` per row (touch or gesture) and the temporal gestures' fields.
// 4: rows of kind `camera` when the camera's fault state changes (from, to: none, dark,
// saturated, frozen).
inline constexpr int event_schema_version = 4;
// The CSV header of that schema (CsvSink writes it; JsonLinesSink uses the same names).
inline constexpr const char* event_csv_header =
    "schema,kind,source,frame,timestamp_ms,track_id,from,to,direction,x,y,gesture,confidence,"
    "gesture_frame,touch_gesture,phase,start_ms,end_ms,length_px,speed_px_s,repetitions,"
    "hand_shape,gesture_confidence";

// A contact alive in this frame (a TUIO cursor).
struct OutputContact {
  int id = 0;             // track id (TUIO session id)
  cv::Point2f position{}; // contact point, image pixels
};

// A shadow alive in this frame (a TUIO blob).
struct OutputShadow {
  int id = 0;      // track id (TUIO session id)
  cv::Rect box{};  // shadow bounding box, image pixels
  double area = 0; // shadow area in pixels; 0 = unknown (the box area is used)
};

// A touch event with the track it belongs to.
struct OutputEvent {
  int track_id = 0;
  TouchEvent event{};
};

// The hand-shape classifier's reading of a frame.
struct OutputGesture {
  bool available = false;               // the run has a classifier (else no gesture is written)
  std::string label;                    // class with the highest probability; "" = gated off
  float confidence = 0;                 // its probability (0 when gated off)
  std::int64_t frame_index = 0;         // the frame it was computed on (0 when gated off)
  std::vector<std::string> class_names; // the model's classes, in its order
  std::vector<float> probabilities;     // one per class (empty when gated off)
};

struct OutputFrame {
  std::int64_t frame_index = 0;
  double timestamp_ms = 0;
  cv::Size frame_size{};
  std::vector<OutputContact> contacts;
  std::vector<OutputShadow> shadows;
  std::vector<OutputEvent> events;
  OutputGesture gesture{};
  std::vector<GestureEvent> touch_gestures;
  CameraFault camera = CameraFault::none;
  CameraFault camera_before = CameraFault::none;
  bool camera_changed() const { return camera != camera_before; }
};

template <class S>
concept EventSink = requires(S& sink, const OutputFrame& frame) {
  sink.write(frame);
};

// The least type that is an EventSink.
struct EventSinkArchetype {
  void write(const OutputFrame&) {}
};
static_assert(EventSink<EventSinkArchetype>);

template <EventSink... Sinks>
void publish(const OutputFrame& frame, Sinks&... sinks) {
  (sinks.write(frame), ...);
}

// The shape of the TouchPipeline's per-frame result that OutputFrameBuilder reads.
template <class F>
concept TouchFrameLike = requires(const F& f) {
  { f.timestamp_ms } -> std::convertible_to<double>;
  { f.tracks.begin()->id } -> std::convertible_to<int>;
  { f.tracks.begin()->shadow_box } -> std::convertible_to<cv::Rect>;
  { f.tracks.begin()->contact } -> std::convertible_to<std::optional<cv::Point2f>>;
  { f.tracks.begin()->state } -> std::convertible_to<TouchState>;
  { f.events.begin()->track_id } -> std::convertible_to<int>;
  { f.events.begin()->event } -> std::convertible_to<TouchEvent>;
};

class OutputFrameBuilder {
public:
  OutputFrameBuilder() {
    frame_.contacts.reserve(16);
    frame_.shadows.reserve(16);
    frame_.events.reserve(32);
    frame_.touch_gestures.reserve(32);
    last_contacts_.reserve(16);
    next_contacts_.reserve(16);
  }

  template <TouchFrameLike F>
  const OutputFrame& build(const F& touch_frame, cv::Size frame_size,
                           const OutputGesture& gesture) {
    build(touch_frame, frame_size);
    OutputGesture& g = frame_.gesture;
    g.available = gesture.available;
    g.label = gesture.label; // assignments reuse the strings' and vectors' storage
    g.confidence = gesture.confidence;
    g.frame_index = gesture.frame_index;
    g.class_names.resize(gesture.class_names.size());
    for (std::size_t i = 0; i < gesture.class_names.size(); ++i)
      if (g.class_names[i] != gesture.class_names[i]) g.class_names[i] = gesture.class_names[i];
    g.probabilities.assign(gesture.probabilities.begin(), gesture.probabilities.end());
    return frame_;
  }

  template <TouchFrameLike F>
  const OutputFrame& build(const F& touch_frame, cv::Size frame_size, const OutputGesture& gesture,
                           const std::vector<GestureEvent>& touch_gestures) {
    build(touch_frame, frame_size, gesture);
    frame_.touch_gestures.assign(touch_gestures.begin(), touch_gestures.end());
    return frame_;
  }

  template <TouchFrameLike F>
  const OutputFrame& build(const F& touch_frame, cv::Size frame_size) {
    if (frame_size.width <= 0 || frame_size.height <= 0)
      SHADOWSENSE_THROW(InvalidArgument(
          "OutputFrameBuilder::build: frame_size " + std::to_string(frame_size.width) + "x" +
          std::to_string(frame_size.height) + " is empty; expected the image size in pixels"));
    frame_.frame_index = ++index_;
    frame_.timestamp_ms = touch_frame.timestamp_ms;
    frame_.frame_size = frame_size;
    frame_.camera = frame_.camera_before = CameraFault::none;
    if constexpr (requires {
                    { touch_frame.camera } -> std::convertible_to<CameraFault>;
                    { touch_frame.camera_before } -> std::convertible_to<CameraFault>;
                  }) {
      frame_.camera = touch_frame.camera;
      frame_.camera_before = touch_frame.camera_before;
    }
    frame_.contacts.clear();
    frame_.shadows.clear();
    frame_.events.clear();
    frame_.touch_gestures.clear();
    frame_.gesture.available = false;
    frame_.gesture.label.clear();
    frame_.gesture.confidence = 0;
    frame_.gesture.frame_index = 0;
    frame_.gesture.probabilities.clear();
    next_contacts_.clear();
    for (const auto& t : touch_frame.tracks) {
      frame_.shadows.push_back({t.id, t.shadow_box, 0.0});
      const bool touching = t.state == TouchState::touch || t.state == TouchState::move;
      std::optional<cv::Point2f> at = t.contact;
      if (!at && touching) at = last_contact(t.id);
      if (at) next_contacts_.push_back({t.id, *at});
      if (touching && at) frame_.contacts.push_back({t.id, *at});
    }
    last_contacts_.swap(next_contacts_);
    for (const auto& e : touch_frame.events) frame_.events.push_back({e.track_id, e.event});
    return frame_;
  }

  // The frame index the next build() will use minus one (0 before the first build).
  std::int64_t frames_built() const { return index_; }

private:
  std::optional<cv::Point2f> last_contact(int id) const {
    for (const OutputContact& c : last_contacts_)
      if (c.id == id) return c.position;
    return std::nullopt;
  }

  OutputFrame frame_;
  std::int64_t index_ = 0;
  std::vector<OutputContact> last_contacts_, next_contacts_;
};

SHADOWSENSE_NAMESPACE_END
