// GestureEvent: one temporal touch gesture (tap, double tap, pat, stroke, rub, hold, hit) or
// hand-shape interval (hug, punch, two hands), as TemporalGestureRecogniser
// (sense/temporal_gestures.hpp) reports it and the event sinks write it (docs/output.md, event
// schema 3). Its own header so the sinks need not include the recogniser.
//
// to_string(TouchGesture), touch_gesture_from_string(s) (throws InvalidArgument for an unknown
// name), to_string(GesturePhase). ShortLabel: a label in a fixed buffer (no allocation),
// truncated at 31 characters. Plain values; no shared state (any thread).
#pragma once

#include <shadowsense/core/direction.hpp>
#include <shadowsense/core/error.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cstring>
#include <string>
#include <string_view>

SHADOWSENSE_NAMESPACE_BEGIN

enum class TouchGesture { tap, double_tap, pat, stroke, rub, hold, hit, hug, punch, two_hands };
inline constexpr std::array<TouchGesture, 10> all_touch_gestures{
    TouchGesture::tap,   TouchGesture::double_tap, TouchGesture::pat, TouchGesture::stroke,
    TouchGesture::rub,   TouchGesture::hold,       TouchGesture::hit, TouchGesture::hug,
    TouchGesture::punch, TouchGesture::two_hands};

inline const char* to_string(TouchGesture g) {
  switch (g) {
  case TouchGesture::tap:
    return "tap";
  case TouchGesture::double_tap:
    return "double_tap";
  case TouchGesture::pat:
    return "pat";
  case TouchGesture::stroke:
    return "stroke";
  case TouchGesture::rub:
    return "rub";
  case TouchGesture::hold:
    return "hold";
  case TouchGesture::hit:
    return "hit";
  case TouchGesture::hug:
    return "hug";
  case TouchGesture::punch:
    return "punch";
  case TouchGesture::two_hands:
    return "two_hands";
  }
  return "?";
}

inline TouchGesture touch_gesture_from_string(std::string_view s) {
  for (TouchGesture g : all_touch_gestures)
    if (s == to_string(g)) return g;
  SHADOWSENSE_THROW(InvalidArgument("unknown touch gesture '" + std::string(s) +
                                    "'; expected tap, double_tap, pat, stroke, rub, hold, hit, "
                                    "hug, punch or two_hands"));
}

// complete: decided after it ended. began: decided while going on (an `ended` event follows).
// ended: the end of a `began` one. revised: replaces the last event with the same track and
// start (a tap becoming a double tap, one more pat).
enum class GesturePhase { complete, began, ended, revised };

inline const char* to_string(GesturePhase p) {
  switch (p) {
  case GesturePhase::complete:
    return "complete";
  case GesturePhase::began:
    return "began";
  case GesturePhase::ended:
    return "ended";
  case GesturePhase::revised:
    return "revised";
  }
  return "?";
}

// A label in a fixed buffer (no allocation), truncated at 31 characters.
struct ShortLabel {
  std::array<char, 32> text{};
  void assign(std::string_view s) {
    const std::size_t n = std::min(s.size(), text.size() - 1);
    if (n > 0) std::memcpy(text.data(), s.data(), n); // s.data() may be null when empty
    text[n] = '\0';
  }
  std::string_view view() const { return std::string_view(text.data()); }
  bool empty() const { return text[0] == '\0'; }
};

struct GestureEvent {
  TouchGesture gesture = TouchGesture::tap;
  GesturePhase phase = GesturePhase::complete;
  int track_id = 0;       // 0: the whole frame (hug, punch, two_hands)
  double start_ms = 0;    // first contact frame (first frame with the label)
  double end_ms = 0;      // lift frame (last frame with the label); = decided_ms for began
  double decided_ms = 0;  // the frame that emitted the event
  cv::Point2f position{}; // first contact point (image px); the mean shadow centroid for 0
  Direction direction = Direction::none; // stroke: dominant axis of the net displacement
  float length_px = 0;                   // stroke, rub: contact path length
  float speed_px_s = 0;                  // stroke, rub: length / duration
  int repetitions = 1;                   // taps, pats; reversals for rub
  ShortLabel hand_shape; // the classifier's most frequent label over the interval ("" none)
  float confidence = 0;  // see the header comment
};

SHADOWSENSE_NAMESPACE_END
