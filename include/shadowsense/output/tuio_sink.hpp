// TUIO 1.1 output: contacts as /tuio/2Dcur cursors, shadows as /tuio/2Dblb blobs, OSC over UDP
// (default 127.0.0.1:3333, the port TUIO clients listen on).
//
// Per frame and per profile (2Dcur first, then 2Dblb) one OSC bundle, time tag "immediately":
//   /tuio/2Dcur source  "name@address"            (only when Config::source is set)
//   /tuio/2Dcur alive   s_id ...                  (int32: every contact alive in this frame)
//   /tuio/2Dcur set     s x y X Y m               (one per contact)
//   /tuio/2Dcur fseq    f                         (int32: OutputFrame::frame_index)
//   /tuio/2Dblb source  "name@address"
//   /tuio/2Dblb alive   s_id ...
//   /tuio/2Dblb set     s x y a w h f X Y A m r   (one per shadow)
//   /tuio/2Dblb fseq    f
// When the frame carries a classifier's reading (OutputFrame::gesture.available), the last
// bundle of the frame also holds, before its fseq, one message of the project's own (TUIO
// clients ignore addresses they do not know):
//   /shadowsense/gesture  label confidence frame [class probability]...
//   label: string, the hand shape ("" while the classifier is gated off: no shadow);
//   confidence: float32, its probability; frame: int32, the fseq it was computed on (0 when
//   gated off); then one (string, float32) pair per class in the model's order (none when gated
//   off, or when the pairs would not fit in max_packet_bytes).
// When the camera is faulted (OutputFrame::camera: dark, saturated or frozen; sense/
// camera_health.hpp), and on the frame it returns to none, one bundle of its own (time tag
// "immediately") follows the TUIO bundles with one message:
//   /shadowsense/camera  state before fseq
//   state, before: strings, the frame's fault state and the previous frame's (none, dark,
//   saturated, frozen); fseq: int32, OutputFrame::frame_index. It is repeated on every faulted
//   frame (a lost datagram is made good by the next frame), and a frame with no such message
//   comes from a healthy camera; a healthy stream sends nothing more than before.
// When the frame carries temporal gestures (OutputFrame::touch_gestures), they follow the TUIO
// (and camera) bundles in bundles of their own (time tag "immediately"), one message per gesture
// event, as many per bundle as fit in max_packet_bytes:
//   /shadowsense/touch_gesture  s_id gesture phase x y direction duration_ms latency_ms length
//                               speed repetitions hand_shape confidence fseq
//   s_id: int32, the track id (0: a whole-frame gesture, hug/punch/two_hands); gesture, phase,
//   direction, hand_shape: strings (docs/temporal_gestures.md); x, y: float32, where it began,
//   normalised as the cursors; duration_ms: end - start; latency_ms: the deciding frame's time
//   - end (0 for `began`); length, speed: float32, the contact path and its speed normalised by
//   the frame width (per second); repetitions: int32; confidence: float32; fseq: int32, the
//   frame_index of the frame that decided it.
// s: session id = track id (int32); so the cursor of a hand's contact and the blob of its
//    shadow share the session id. Every other argument is float32:
// x, y: position normalised to 0..1 by the frame size (cursor: the contact point; blob: the
//    centre of the shadow box); X, Y: velocity in normalised units per second; m: motion
//    acceleration (change of speed per second, normalised units / s^2); a: angle in radians
//    (0: the shadow box is axis-aligned); w, h: box width and height normalised by the frame
//    width and height; f: area normalised by the frame area (the shadow's area when given,
//    else the box's); A, r: rotation velocity and acceleration (0).
// Velocity and acceleration come from the previous frame that held the same session id:
//    v = (p - p_prev) / dt, m = (|v| - |v_prev|) / dt, dt in seconds from the frames'
//    timestamps; 0 for a new session id or when dt <= 0.
// Both profiles are sent every frame, also when empty (an empty alive list tells the client
// that every cursor / blob is gone), so clients never keep a stale contact.
// Large frames: when a bundle would exceed Config::max_packet_bytes (default 1472, the UDP
// payload of a 1500-byte Ethernet frame), the set messages are split over several bundles, each
// with the full source + alive list and the same fseq (as the reference TUIO 1.1 server does).
// The alive list itself cannot be split (TUIO takes every id not listed as gone): a profile with
// more ids than one bundle can list (5 bytes per id: 268 cursors or 262 blobs at the default)
// sends the first ones that fit, in frame order (the tracks' increasing ids: the oldest hands),
// and counts the rest in ids_left_out() - tracking and the other outputs never stop for it.
//
// TuioEncoder(config = {})
//   throws: InvalidArgument for max_packet_bytes < 128 or a source holding a NUL.
// encode(frame, send)
//   requires: frame.frame_size non-empty; 0 <= frame_index <= 2^31-1; ids unique per profile
//             and >= 0; finite positions; send callable as send(std::span<const uint8_t>).
//   ensures:  send called once per bundle, in order (2Dcur bundles, then 2Dblb bundles, then
//             the camera bundle, then the touch-gesture bundles); the span is valid only
//             during the call.
//             Ids beyond one bundle's alive list are left out (see above), counted in
//             ids_left_out() (the run's total) and last_left_out() (this frame's).
//   throws:   InvalidArgument for a broken requirement, or a max_packet_bytes too small for even
//             an empty bundle; nothing is sent then. What send throws.
//   Threading: one thread per instance. No allocation after warm-up (buffers are reused).
// TuioSink(host = "127.0.0.1", port = 3333, config = {}): an EventSink; write(frame) encodes
//   the frame and sends each bundle as one UDP datagram.
//   throws: IoError (host does not resolve, socket or send fails), InvalidArgument as above.
//   Threading: one thread per instance.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/output/event_sink.hpp>
#include <shadowsense/output/osc.hpp>
#include <shadowsense/output/udp_sender.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

class TuioEncoder {
public:
  struct Config {
    std::string source;                  // "name@address" for the source message; "" = none
    bool cursors = true;                 // send /tuio/2Dcur (contacts)
    bool blobs = true;                   // send /tuio/2Dblb (shadows)
    std::size_t max_packet_bytes = 1472; // largest bundle sent
  };

  TuioEncoder() : TuioEncoder(Config{}) {}
  explicit TuioEncoder(Config config) : config_(std::move(config)) {
    detail::require(config_.max_packet_bytes >= 128, "TuioEncoder: max_packet_bytes " +
                                                         std::to_string(config_.max_packet_bytes) +
                                                         " is too small; expected at least 128");
    detail::require(config_.source.find('\0') == std::string::npos,
                    "TuioEncoder: source holds a NUL byte");
    for (auto* v : {&cur_prev_, &cur_next_, &blb_prev_, &blb_next_}) v->reserve(16);
    ids_.reserve(16);
  }

  template <class Send>
  void encode(const OutputFrame& frame, Send&& send) {
    validate(frame);
    const double t = frame.timestamp_ms;
    const double w = frame.frame_size.width;
    const double h = frame.frame_size.height;
    const bool gesture_last = frame.gesture.available; // the gesture ends the last bundle
    last_left_out_ = 0;
    if (config_.cursors) {
      const std::size_t k = fitting(cursor_profile, frame.contacts.size(), 5,
                                    gesture_last && !config_.blobs ? &frame : nullptr);
      ids_.clear();
      cur_next_.clear();
      for (std::size_t i = 0; i < k; ++i) {
        const OutputContact& c = frame.contacts[i];
        ids_.push_back(c.id);
        cur_next_.push_back(motion(cur_prev_, c.id, c.position.x / w, c.position.y / h, t));
      }
      emit(cursor_profile, frame, send, gesture_last && !config_.blobs, [&](std::size_t i) {
        const Motion& m = cur_next_[i];
        writer_.begin_message(cursor_profile);
        writer_.add_string("set");
        writer_.add_int(m.id);
        for (double v : {m.x, m.y, m.vx, m.vy, m.accel}) writer_.add_float(static_cast<float>(v));
        writer_.end_message();
      });
      cur_prev_.swap(cur_next_);
    }
    if (config_.blobs) {
      const std::size_t k =
          fitting(blob_profile, frame.shadows.size(), 11, gesture_last ? &frame : nullptr);
      ids_.clear();
      blb_next_.clear();
      for (std::size_t i = 0; i < k; ++i) {
        const OutputShadow& s = frame.shadows[i];
        ids_.push_back(s.id);
        const double cx = (s.box.x + 0.5 * s.box.width) / w;
        const double cy = (s.box.y + 0.5 * s.box.height) / h;
        blb_next_.push_back(motion(blb_prev_, s.id, cx, cy, t));
      }
      emit(blob_profile, frame, send, gesture_last, [&](std::size_t i) {
        const Motion& m = blb_next_[i];
        const OutputShadow& s = frame.shadows[i];
        const double area = s.area > 0 ? s.area : static_cast<double>(s.box.area());
        writer_.begin_message(blob_profile);
        writer_.add_string("set");
        writer_.add_int(m.id);
        const double values[] = {
            m.x, m.y,     0.0, s.box.width / w, s.box.height / h, area / (w * h), m.vx, m.vy,
            0.0, m.accel, 0.0};
        for (double v : values) writer_.add_float(static_cast<float>(v));
        writer_.end_message();
      });
      blb_prev_.swap(blb_next_);
    }
    emit_camera(frame, send);
    emit_touch_gestures(frame, send);
    left_out_ += last_left_out_;
  }

  // Ids not listed because one bundle's alive list had no room for them: over the encoder's
  // life, and in the last encode.
  std::size_t ids_left_out() const { return left_out_; }
  std::size_t last_left_out() const { return last_left_out_; }

  static constexpr std::string_view cursor_profile = "/tuio/2Dcur";
  static constexpr std::string_view gesture_address = "/shadowsense/gesture";
  static constexpr std::string_view touch_gesture_address = "/shadowsense/touch_gesture";
  static constexpr std::string_view camera_address = "/shadowsense/camera";
  static constexpr std::string_view blob_profile = "/tuio/2Dblb";

private:
  struct Motion {
    std::int32_t id = 0;
    double x = 0, y = 0, vx = 0, vy = 0, accel = 0; // double so velocities keep their digits
    double t_ms = 0;
  };

  static std::size_t padded(std::size_t n) { return (n + 3) & ~std::size_t(3); }
  // Bytes of one bundle element: size field, address, type tags, arguments.
  static std::size_t element_bytes(std::string_view address, std::size_t tags,
                                   std::size_t arg_bytes) {
    return 4 + padded(address.size() + 1) + padded(tags + 2) + arg_bytes;
  }

  static Motion motion(const std::vector<Motion>& prev, int id, double x, double y, double t) {
    Motion m{id, x, y, 0, 0, 0, t};
    for (const Motion& p : prev) {
      if (p.id != id) continue;
      const double dt = (t - p.t_ms) / 1000.0;
      if (dt > 0) {
        m.vx = (x - p.x) / dt;
        m.vy = (y - p.y) / dt;
        m.accel = (std::hypot(m.vx, m.vy) - std::hypot(p.vx, p.vy)) / dt;
      }
      break;
    }
    return m;
  }

  [[noreturn]] static void fail(const std::string& what) {
    SHADOWSENSE_THROW(InvalidArgument("TuioEncoder: " + what));
  }

  void validate(const OutputFrame& f) const {
    if (f.frame_size.width <= 0 || f.frame_size.height <= 0)
      fail("frame_size is empty; expected the image size in pixels");
    if (f.frame_index < 0 || f.frame_index > std::numeric_limits<std::int32_t>::max())
      fail("frame_index " + std::to_string(f.frame_index) +
           " does not fit TUIO's int32 fseq; expected 0..2147483647");
    if (!std::isfinite(f.timestamp_ms)) fail("timestamp_ms is not finite");
    for (std::size_t i = 0; i < f.contacts.size(); ++i) {
      const OutputContact& c = f.contacts[i];
      if (c.id < 0)
        fail("contact id " + std::to_string(c.id) + " is negative; expected a track id");
      if (!std::isfinite(c.position.x) || !std::isfinite(c.position.y))
        fail("contact " + std::to_string(c.id) + " has a non-finite position");
      for (std::size_t j = 0; j < i; ++j)
        if (f.contacts[j].id == c.id)
          fail("contact id " + std::to_string(c.id) +
               " appears twice in one frame; expected unique session ids");
    }
    for (std::size_t i = 0; i < f.shadows.size(); ++i) {
      const OutputShadow& s = f.shadows[i];
      if (s.id < 0) fail("shadow id " + std::to_string(s.id) + " is negative; expected a track id");
      if (!std::isfinite(s.area) || s.area < 0)
        fail("shadow " + std::to_string(s.id) + " has a negative or non-finite area");
      for (std::size_t j = 0; j < i; ++j)
        if (f.shadows[j].id == s.id)
          fail("shadow id " + std::to_string(s.id) +
               " appears twice in one frame; expected unique session ids");
    }
    if (f.gesture.available) {
      const OutputGesture& g = f.gesture;
      if (g.label.find('\0') != std::string::npos) fail("gesture label holds a NUL byte");
      if (!std::isfinite(g.confidence)) fail("gesture confidence is not finite");
      if (g.frame_index < 0 || g.frame_index > std::numeric_limits<std::int32_t>::max())
        fail("gesture frame_index " + std::to_string(g.frame_index) +
             " does not fit an int32; expected 0..2147483647");
      if (!g.label.empty() && g.probabilities.size() != g.class_names.size())
        fail("gesture has " + std::to_string(g.probabilities.size()) + " probabilities for " +
             std::to_string(g.class_names.size()) + " classes; expected one per class");
      for (std::size_t i = 0; i < g.probabilities.size(); ++i) {
        if (!std::isfinite(g.probabilities[i])) fail("gesture probability is not finite");
        if (g.class_names[i].find('\0') != std::string::npos)
          fail("gesture class name holds a NUL byte");
      }
    }
    for (const GestureEvent& e : f.touch_gestures) {
      if (!std::isfinite(e.position.x) || !std::isfinite(e.position.y) ||
          !std::isfinite(e.start_ms) || !std::isfinite(e.end_ms) || !std::isfinite(e.decided_ms))
        fail("touch gesture of track " + std::to_string(e.track_id) +
             " has a non-finite position or time");
      if (e.track_id < 0)
        fail("touch gesture track id " + std::to_string(e.track_id) + " is negative");
      if (16 + touch_gesture_bytes(e) > config_.max_packet_bytes)
        fail("a touch gesture message does not fit in max_packet_bytes");
    }
    const bool cursor_last = f.gesture.available && !config_.blobs;
    if (config_.cursors) check_fits(cursor_profile, 0, 5, cursor_last ? &f : nullptr);
    if (config_.blobs) check_fits(blob_profile, 0, 11, f.gesture.available ? &f : nullptr);
  }

  // Bytes of the gesture message; with_pairs: with the (class, probability) pairs.
  static std::size_t gesture_bytes(const OutputGesture& g, bool with_pairs) {
    std::size_t tags = 3, args = padded(g.label.size() + 1) + 4 + 4;
    if (with_pairs && !g.label.empty())
      for (const std::string& c : g.class_names) tags += 2, args += padded(c.size() + 1) + 4;
    return element_bytes(gesture_address, tags, args);
  }
  // The gesture message's bytes as sent: with the pairs when a bundle of `profile` with no set
  // message has room for them.
  std::size_t gesture_bytes_sent(std::string_view profile, std::size_t alive,
                                 const OutputGesture& g) const {
    const std::size_t with = gesture_bytes(g, true);
    return bundle_overhead(profile, alive) + with <= config_.max_packet_bytes
               ? with
               : gesture_bytes(g, false);
  }
  void add_gesture(const OutputGesture& g, bool with_pairs) {
    writer_.begin_message(gesture_address);
    writer_.add_string(g.label);
    writer_.add_float(g.label.empty() ? 0.f : g.confidence);
    writer_.add_int(static_cast<std::int32_t>(g.label.empty() ? 0 : g.frame_index));
    if (with_pairs && !g.label.empty())
      for (std::size_t i = 0; i < g.class_names.size(); ++i) {
        writer_.add_string(g.class_names[i]);
        writer_.add_float(g.probabilities[i]);
      }
    writer_.end_message();
  }

  std::size_t bundle_overhead(std::string_view profile, std::size_t alive) const {
    std::size_t n = 16; // "#bundle" + time tag
    if (!config_.source.empty())
      n += element_bytes(profile, 2, padded(7) + padded(config_.source.size() + 1));
    n += element_bytes(profile, 1 + alive, padded(6) + 4 * alive); // alive s...
    n += element_bytes(profile, 2, padded(5) + 4);                 // fseq f
    return n;
  }
  static std::size_t set_bytes(std::string_view profile, std::size_t floats) {
    return element_bytes(profile, 2 + floats, padded(4) + 4 + 4 * floats);
  }
  std::size_t bundle_need(std::string_view profile, std::size_t alive, std::size_t floats,
                          const OutputFrame* with_gesture) const {
    return bundle_overhead(profile, alive) + (alive ? set_bytes(profile, floats) : 0) +
           (with_gesture ? gesture_bytes_sent(profile, alive, with_gesture->gesture) : 0);
  }
  // How many of n ids one bundle of `profile` can list (at most n); the rest are left out.
  std::size_t fitting(std::string_view profile, std::size_t n, std::size_t floats,
                      const OutputFrame* with_gesture) {
    std::size_t k = n;
    while (k > 0 && bundle_need(profile, k, floats, with_gesture) > config_.max_packet_bytes) --k;
    last_left_out_ += n - k;
    return k;
  }
  void check_fits(std::string_view profile, std::size_t alive, std::size_t floats,
                  const OutputFrame* with_gesture) const {
    const std::size_t need = bundle_need(profile, alive, floats, with_gesture);
    if (need > config_.max_packet_bytes)
      fail(std::to_string(alive) + " alive ids in " + std::string(profile) + " need a " +
           std::to_string(need) + "-byte bundle, more than max_packet_bytes (" +
           std::to_string(config_.max_packet_bytes) + ")");
  }

  // One or more bundles of `profile`; with_gesture: the last one ends with the gesture message.
  template <class Send, class AddSet>
  void emit(std::string_view profile, const OutputFrame& frame, Send& send, bool with_gesture,
            AddSet&& add_set) {
    const std::size_t n = ids_.size();
    const std::size_t floats = profile == cursor_profile ? 5 : 11;
    const std::size_t per_set = set_bytes(profile, floats);
    const std::size_t g_bytes = with_gesture ? gesture_bytes_sent(profile, n, frame.gesture) : 0;
    const bool g_pairs = with_gesture && g_bytes == gesture_bytes(frame.gesture, true);
    // Room kept in every bundle for the gesture message, so the last one always has it.
    const std::size_t fseq_bytes = element_bytes(profile, 2, padded(5) + 4) + g_bytes;
    std::size_t i = 0;
    do {
      writer_.clear();
      writer_.begin_bundle(osc_immediately);
      if (!config_.source.empty()) {
        writer_.begin_message(profile);
        writer_.add_string("source");
        writer_.add_string(config_.source);
        writer_.end_message();
      }
      writer_.begin_message(profile);
      writer_.add_string("alive");
      for (std::int32_t id : ids_) writer_.add_int(id);
      writer_.end_message();
      while (i < n && writer_.size() + per_set + fseq_bytes <= config_.max_packet_bytes)
        add_set(i++);
      if (with_gesture && i >= n) add_gesture(frame.gesture, g_pairs);
      writer_.begin_message(profile);
      writer_.add_string("fseq");
      writer_.add_int(static_cast<std::int32_t>(frame.frame_index));
      writer_.end_message();
      writer_.end_bundle();
      send(writer_.bytes());
    } while (i < n);
  }

  // The camera's fault state, in a bundle of its own: at most 76 bytes, so it always fits the
  // smallest max_packet_bytes (128).
  template <class Send>
  void emit_camera(const OutputFrame& frame, Send& send) {
    if (frame.camera == CameraFault::none && !frame.camera_changed()) return;
    writer_.clear();
    writer_.begin_bundle(osc_immediately);
    writer_.begin_message(camera_address);
    writer_.add_string(to_string(frame.camera));
    writer_.add_string(to_string(frame.camera_before));
    writer_.add_int(static_cast<std::int32_t>(frame.frame_index));
    writer_.end_message();
    writer_.end_bundle();
    send(writer_.bytes());
  }

  // Bytes of one /shadowsense/touch_gesture message.
  static std::size_t touch_gesture_bytes(const GestureEvent& e) {
    const std::size_t strings = padded(std::strlen(to_string(e.gesture)) + 1) +
                                padded(std::strlen(to_string(e.phase)) + 1) +
                                padded(std::strlen(to_string(e.direction)) + 1) +
                                padded(e.hand_shape.view().size() + 1);
    return element_bytes(touch_gesture_address, 14, strings + 10 * 4);
  }

  template <class Send>
  void emit_touch_gestures(const OutputFrame& frame, Send& send) {
    const auto& events = frame.touch_gestures;
    const double w = frame.frame_size.width;
    const double h = frame.frame_size.height;
    std::size_t i = 0;
    while (i < events.size()) {
      writer_.clear();
      writer_.begin_bundle(osc_immediately);
      // at least one message per bundle (validate() checked that one fits)
      do {
        const GestureEvent& e = events[i++];
        writer_.begin_message(touch_gesture_address);
        writer_.add_int(e.track_id);
        writer_.add_string(to_string(e.gesture));
        writer_.add_string(to_string(e.phase));
        writer_.add_float(static_cast<float>(e.position.x / w));
        writer_.add_float(static_cast<float>(e.position.y / h));
        writer_.add_string(to_string(e.direction));
        writer_.add_float(static_cast<float>(e.end_ms - e.start_ms));
        writer_.add_float(
            static_cast<float>(e.phase == GesturePhase::began ? 0.0 : e.decided_ms - e.end_ms));
        writer_.add_float(static_cast<float>(e.length_px / w));
        writer_.add_float(static_cast<float>(e.speed_px_s / w));
        writer_.add_int(e.repetitions);
        writer_.add_string(e.hand_shape.view());
        writer_.add_float(e.confidence);
        writer_.add_int(static_cast<std::int32_t>(frame.frame_index));
        writer_.end_message();
      } while (i < events.size() &&
               writer_.size() + touch_gesture_bytes(events[i]) <= config_.max_packet_bytes);
      writer_.end_bundle();
      send(writer_.bytes());
    }
  }

  Config config_;
  OscWriter writer_;
  std::size_t left_out_ = 0, last_left_out_ = 0;
  std::vector<std::int32_t> ids_;
  std::vector<Motion> cur_prev_, cur_next_, blb_prev_, blb_next_;
};

class TuioSink {
public:
  TuioSink() : TuioSink("127.0.0.1", 3333) {}
  TuioSink(const std::string& host, std::uint16_t port, TuioEncoder::Config config = {})
      : encoder_(std::move(config)), sender_(host, port) {}

  void write(const OutputFrame& frame) {
    encoder_.encode(frame, [this](std::span<const std::uint8_t> b) { sender_.send(b); });
  }

  const std::string& destination() const { return sender_.destination(); }
  // Ids left out of full alive lists so far (TuioEncoder::ids_left_out).
  std::size_t ids_left_out() const { return encoder_.ids_left_out(); }

private:
  TuioEncoder encoder_;
  UdpSender sender_;
};
static_assert(EventSink<TuioSink>);

SHADOWSENSE_NAMESPACE_END
