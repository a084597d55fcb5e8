// The labels of the dataset format (docs/dataset_format.md) that are enums: the lighting of a
// frame and the gesture of a slide (the direction of a slide is core/direction.hpp). They live
// here, with the format, so the dataset reader depends on nothing of the scene generator;
// the generator (sim/) uses these same types (sim::Lighting is shadowsense::Lighting).
//
// API
//   to_string(Lighting) / lighting_from_string(s)        "daylight", "dusk", "night", "custom"
//   lighting_level(Lighting)                              preset level: 1, 0.5, 0
//     throws InvalidArgument for custom (it has no preset level).
//   to_string(SlideGesture) / slide_gesture_from_string(s) "palm", "finger"
//   *_from_string throw InvalidArgument naming the value and the accepted ones.
//
// THREADING
//   Stateless.
#pragma once

#include <shadowsense/core/direction.hpp>
#include <shadowsense/core/error.hpp>

#include <array>
#include <string>
#include <string_view>

SHADOWSENSE_NAMESPACE_BEGIN

// Scene lighting: the three presets of the paper and `custom` (any level in [0, 1]).
enum class Lighting { daylight, dusk, night, custom };
inline constexpr std::array<Lighting, 4> all_lightings{Lighting::daylight, Lighting::dusk,
                                                       Lighting::night, Lighting::custom};

inline std::string_view to_string(Lighting l) {
  switch (l) {
  case Lighting::daylight:
    return "daylight";
  case Lighting::dusk:
    return "dusk";
  case Lighting::night:
    return "night";
  case Lighting::custom:
    return "custom";
  }
  return "custom";
}
inline Lighting lighting_from_string(std::string_view s) {
  if (s == "daylight") return Lighting::daylight;
  if (s == "dusk") return Lighting::dusk;
  if (s == "night") return Lighting::night;
  if (s == "custom") return Lighting::custom;
  SHADOWSENSE_THROW(InvalidArgument("unknown lighting '" + std::string(s) +
                                    "'; expected daylight, dusk, night or custom"));
}
// The level of each preset.
inline double lighting_level(Lighting l) {
  switch (l) {
  case Lighting::daylight:
    return 1.0;
  case Lighting::dusk:
    return 0.5;
  case Lighting::night:
    return 0.0;
  case Lighting::custom:
    break;
  }
  SHADOWSENSE_THROW(
      InvalidArgument("lighting_level: 'custom' has no preset level; pass a level in [0,1]"));
}

// The hand part of a slide (paper 5.2.3).
enum class SlideGesture { palm, finger };
inline constexpr std::array<SlideGesture, 2> all_slide_gestures{SlideGesture::palm,
                                                                SlideGesture::finger};

inline std::string_view to_string(SlideGesture g) {
  return g == SlideGesture::palm ? "palm" : "finger";
}
inline SlideGesture slide_gesture_from_string(std::string_view s) {
  if (s == "palm") return SlideGesture::palm;
  if (s == "finger") return SlideGesture::finger;
  SHADOWSENSE_THROW(
      InvalidArgument("unknown slide gesture '" + std::string(s) + "'; expected palm or finger"));
}

SHADOWSENSE_NAMESPACE_END
