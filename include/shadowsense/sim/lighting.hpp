// Lighting of the scene generator: presets daylight / dusk / night and a continuous level in
// [0, 1] (0 = night, 0.5 = dusk, 1 = daylight) so unseen conditions can be generated.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/io/labels.hpp>
#include <shadowsense/sim/rng.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <string_view>

SHADOWSENSE_NAMESPACE_BEGIN
namespace sim {

// The dataset format's lighting label (io/labels.hpp).
using shadowsense::Lighting;
using shadowsense::lighting_from_string;
using shadowsense::lighting_level;
using shadowsense::to_string;

// Everything the renderer needs to light one frame.
struct Light {
  Lighting label = Lighting::daylight;
  double level = 1.0;            // 0 night .. 0.5 dusk .. 1 daylight
  double intensity = 250.0;      // lit fabric value (0..255 scale) at exposure 1, on-axis
  double colour_temp_k = 6000.0; // of the light passing through the skin
  double ambient = 0.30;         // fraction of the light left in a full shadow (diffuse light)
  double ambient_temp_k = 7500.0;
  double zenith_deg = 30.0;      // 0 = light straight above; larger shifts/stretches shadows
  double shadow_azimuth_deg = 0; // direction (image axes, from +x towards +y) shadows shift to
  double noise_sigma = 1.74;     // sensor noise at exposure 1, 8-bit units
  double exposure = 0.86;        // camera gain (auto-exposure): scales brightness and noise

  // What the camera records: lit fabric value (clipped at 255) and noise after the gain.
  double brightness() const { return std::min(intensity * exposure, 255.0); }
  double noise() const { return noise_sigma * exposure; }

  void validate() const {
    detail::require(std::isfinite(level) && level >= 0 && level <= 1,
                    "Light: level must be in [0, 1]");
    detail::require(label == Lighting::custom || level == (label == Lighting::daylight ? 1.0
                                                           : label == Lighting::dusk   ? 0.5
                                                                                       : 0.0),
                    "Light: level " + std::to_string(level) + " does not match the preset '" +
                        std::string(to_string(label)) + "'; use Lighting::custom for other levels");
    detail::require(std::isfinite(intensity) && intensity > 0 && intensity <= 2550,
                    "Light: intensity must be in (0, 2550]");
    detail::require(colour_temp_k >= 1000 && colour_temp_k <= 40000 && ambient_temp_k >= 1000 &&
                        ambient_temp_k <= 40000,
                    "Light: colour temperatures must be in [1000, 40000] K");
    detail::require(ambient >= 0 && ambient < 1, "Light: ambient must be in [0, 1)");
    detail::require(zenith_deg >= 0 && zenith_deg <= 75, "Light: zenith_deg must be in [0, 75]");
    detail::require(std::isfinite(shadow_azimuth_deg), "Light: shadow_azimuth_deg must be finite");
    detail::require(noise_sigma >= 0 && noise_sigma <= 64, "Light: noise_sigma must be in [0, 64]");
    detail::require(exposure > 0 && exposure <= 16, "Light: exposure must be in (0, 16]");
  }
};

namespace internal {
// Piecewise-linear through the night (0), dusk (0.5) and daylight (1) anchors.
inline double by_level(double level, double night, double dusk, double day) {
  return level < 0.5 ? night + (dusk - night) * (level / 0.5)
                     : dusk + (day - dusk) * ((level - 0.5) / 0.5);
}
} // namespace internal

// Light for a continuous level in [0, 1]. label is recorded in datasets (custom unless the
// level is exactly a preset's).
inline Light light_from_level(double level, double shadow_azimuth_deg = 0.0) {
  detail::require(std::isfinite(level) && level >= 0 && level <= 1,
                  "light_from_level: level " + std::to_string(level) + " is outside [0, 1]");
  Light l;
  l.level = level;
  l.label = level == 1.0   ? Lighting::daylight
            : level == 0.5 ? Lighting::dusk
            : level == 0.0 ? Lighting::night
                           : Lighting::custom;
  l.exposure = internal::by_level(level, 1.55, 1.2, 0.86);
  // Recorded brightness (intensity x exposure): 70 / 150 / 215; noise 6.5 / 3 / 1.5.
  l.intensity = internal::by_level(level, 70.0 / 1.55, 150.0 / 1.2, 215.0 / 0.86);
  l.colour_temp_k = internal::by_level(level, 3200.0, 2700.0, 6000.0);
  l.ambient_temp_k = internal::by_level(level, 5000.0, 8000.0, 7500.0);
  l.ambient = internal::by_level(level, 0.45, 0.36, 0.30);
  l.zenith_deg = internal::by_level(level, 15.0, 50.0, 30.0);
  l.noise_sigma = internal::by_level(level, 6.5 / 1.55, 3.0 / 1.2, 1.5 / 0.86);
  l.shadow_azimuth_deg = shadow_azimuth_deg;
  return l;
}
inline Light preset(Lighting l, double shadow_azimuth_deg = 0.0) {
  return light_from_level(lighting_level(l), shadow_azimuth_deg);
}

// Small per-frame variation (flicker, auto-exposure hunting) around a session's light.
inline Light jitter(Light l, Rng& rng, double amount = 1.0) {
  l.intensity = std::clamp(l.intensity * (1.0 + 0.04 * amount * rng.normal()), 1.0, 2550.0);
  l.exposure = std::clamp(l.exposure * (1.0 + 0.02 * amount * rng.normal()), 0.05, 16.0);
  l.colour_temp_k =
      std::clamp(l.colour_temp_k * (1.0 + 0.03 * amount * rng.normal()), 1000.0, 40000.0);
  l.zenith_deg = std::clamp(l.zenith_deg + 2.0 * amount * rng.normal(), 0.0, 75.0);
  l.shadow_azimuth_deg += 4.0 * amount * rng.normal();
  return l;
}

// Approximate RGB of a black body (Tanner Helland's fit), normalised so max channel = 1.
// Returned in BGR order like the frames.
inline cv::Vec3f colour_of_temperature(double kelvin) {
  const double t = std::clamp(kelvin, 1000.0, 40000.0) / 100.0;
  double r, g, b;
  if (t <= 66) {
    r = 255;
    g = 99.4708025861 * std::log(t) - 161.1195681661;
    b = t <= 19 ? 0 : 138.5177312231 * std::log(t - 10) - 305.0447927307;
  } else {
    r = 329.698727446 * std::pow(t - 60, -0.1332047592);
    g = 288.1221695283 * std::pow(t - 60, -0.0755148492);
    b = 255;
  }
  r = std::clamp(r, 1.0, 255.0);
  g = std::clamp(g, 1.0, 255.0);
  b = std::clamp(b, 1.0, 255.0);
  const double m = std::max({r, g, b});
  return {static_cast<float>(b / m), static_cast<float>(g / m), static_cast<float>(r / m)};
}

} // namespace sim
SHADOWSENSE_NAMESPACE_END
