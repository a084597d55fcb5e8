// What a classifier does to a camera frame before the network sees it (paper 5.1.2, plus the
// lighting normalisation and the dark-frame rule), as plain values: a model file records them
// (backends/densenet/model_file.hpp, docs/model_format.md) and FrameEncoder applies them.
//
// ChannelOrder
//   The order of the three colour channels of an image or of the network's input.
//
// InputEncoding
//   What the network sees of a frame before lighting normalisation and the Preprocessor
//   (classify/frame_encoder.hpp has the arithmetic):
//   colour         the camera frame as it is (every model file before version 4).
//   skin_relative  the frame over the calibration's empty-skin model (flat-field correction:
//                  vignetting and the skin's own pattern divided out, the light level kept);
//                  needs a calibration with an empty-skin model (needs_calibration).
//   darkness_warmth the relative pixel rule's own features (sense/pixel_rule.hpp): each skin
//                  pixel over the empty skin there and over the frame's reference, as darkness
//                  and warmth maps beside the skin mask; independent of the light level, so a
//                  model with it never takes lighting normalisation or the brightness factor.
//                  Needs a calibration with an empty-skin model.
//   masks          what the calibrated segmenter decides (sense/segmenter.hpp): its shadow and
//                  contact masks (after the mask blur and threshold) beside the skin mask, as
//                  0 / 1; independent of the light level like darkness_warmth. Needs a
//                  calibration with an empty-skin model.
//   darkness_contact a combination: darkness_warmth's darkness map, the masks encoding's contact
//                  mask in place of warmth, and the skin mask; light-independent. Needs a
//                  calibration with an empty-skin model.
//   to_string(e) / parse_input_encoding(name) -> optional: the names above.
//
// PreprocessParams
//   resize_width/height   bilinear resize target; 0x0 = no resize; else both in 1..4096
//   crop_width/height     centre crop; 0x0 = no crop; else both in 1..4096
//   contrast_factor       torchvision adjust_contrast factor, finite, >= 0
//   dark_brightness_factor adjust_brightness factor for dark frames, finite, >= 0
//   mean, std             Normalize, per network channel; std > 0
//   network_channel_order the network's channel order (torchvision: RGB)
//   lighting_normalise    scale every channel's mean to lighting_target first (and never
//                         apply the brightness factor: the normalisation replaces it)
//   lighting_target       the channel mean after normalisation, in (0, 1]
//   input_encoding        InputEncoding above (0 colour, 1 skin_relative, 2 darkness_warmth,
//                         3 masks, 4 darkness_contact); a light-independent one
//                         (light_independent: all but colour and skin_relative) with
//                         lighting_normalise is refused
//   dark_luminance_threshold
//                         the dark-frame rule: a frame is dark (gets the brightness factor)
//                         exactly when the mean of 0.2989 R + 0.587 G + 0.114 B over the whole
//                         input frame, in 0..1, is below this value. 0 = no frame is dark by the
//                         rule. In [0, 1]. Ignored when lighting_normalise is on.
//   Defaults: the paper's values, no lighting normalisation, dark rule threshold
//   default_dark_luminance_threshold.
//
//   template <class E = InvalidArgument> void validate() const
//     ensures: returns when every value is in the range above; throws E naming the field, its
//              value and the expected range otherwise (the model file loader passes
//              ModelFileError).
//
// preprocess_max_side (4096): the largest resize or crop side accepted, so a malformed model
// cannot ask for a 65536 x 65536 intermediate image (51 GB per frame); 4096 x 4096 float
// RGB is 201 MB.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/core/version.hpp>

#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

SHADOWSENSE_NAMESPACE_BEGIN

// Channel order of an image (the network's own order is RGB for torchvision models).
enum class ChannelOrder : std::uint32_t { rgb = 0, bgr = 1 };

// What the network sees of a frame (see the header comment).
enum class InputEncoding : std::uint32_t {
  colour = 0,
  skin_relative = 1,
  darkness_warmth = 2,
  masks = 3,
  darkness_contact = 4
};

inline constexpr const char* to_string(InputEncoding e) {
  return e == InputEncoding::colour             ? "colour"
         : e == InputEncoding::skin_relative    ? "skin_relative"
         : e == InputEncoding::darkness_warmth  ? "darkness_warmth"
         : e == InputEncoding::masks            ? "masks"
         : e == InputEncoding::darkness_contact ? "darkness_contact"
                                                : "unknown";
}
inline std::optional<InputEncoding> parse_input_encoding(std::string_view name) {
  if (name == "colour") return InputEncoding::colour;
  if (name == "skin_relative") return InputEncoding::skin_relative;
  if (name == "darkness_warmth") return InputEncoding::darkness_warmth;
  if (name == "masks") return InputEncoding::masks;
  if (name == "darkness_contact") return InputEncoding::darkness_contact;
  return std::nullopt;
}
// True when the encoding has the light level divided out: no lighting normalisation, never dark.
inline constexpr bool light_independent(InputEncoding e) {
  return e == InputEncoding::darkness_warmth || e == InputEncoding::masks ||
         e == InputEncoding::darkness_contact;
}
// True when frames can only be encoded with a calibration's empty-skin model.
inline constexpr bool needs_calibration(InputEncoding e) {
  return e != InputEncoding::colour;
}

inline constexpr int preprocess_max_side = 4096;

// Mean luminance (0..1) below which a frame counts as dark under the default rule: midway
// between the generator's night frames (0.104..0.134) and its dusk frames (0.201..0.269;
// daylight 0.323..0.462), measured on every fifth frame of
// `ss_gesture_data --users 6 --frames 20 --seed 1` (docs/model_format.md, "The dark-frame rule").
inline constexpr float default_dark_luminance_threshold = 0.165f;

struct PreprocessParams {
  int resize_width = 318;
  int resize_height = 235;
  int crop_width = 220;
  int crop_height = 150;
  float contrast_factor = 3.0f;
  float dark_brightness_factor = 2.0f;
  std::array<float, 3> mean = {0.485f, 0.456f, 0.406f};
  std::array<float, 3> std = {0.229f, 0.224f, 0.225f};
  ChannelOrder network_channel_order = ChannelOrder::rgb;
  bool lighting_normalise = false;
  float lighting_target = 0.35f;
  float dark_luminance_threshold = default_dark_luminance_threshold;
  InputEncoding input_encoding = InputEncoding::colour;

  template <class E = InvalidArgument>
  void validate() const {
    auto sz = [](int v) { return v >= 0 && v <= preprocess_max_side; };
    const std::string range = "1.." + std::to_string(preprocess_max_side);
    detail::require<E>(
        sz(resize_width) && sz(resize_height) && (resize_width == 0) == (resize_height == 0),
        "preprocessing: resize " + std::to_string(resize_width) + "x" +
            std::to_string(resize_height) + ", expected both 0 (no resize) or both in " + range);
    detail::require<E>(sz(crop_width) && sz(crop_height) && (crop_width == 0) == (crop_height == 0),
                       "preprocessing: crop " + std::to_string(crop_width) + "x" +
                           std::to_string(crop_height) + ", expected both 0 (no crop) or both in " +
                           range);
    detail::require<E>(std::isfinite(contrast_factor) && contrast_factor >= 0.0f,
                       "preprocessing: contrast factor " + std::to_string(contrast_factor) +
                           ", expected a finite value >= 0");
    detail::require<E>(std::isfinite(dark_brightness_factor) && dark_brightness_factor >= 0.0f,
                       "preprocessing: brightness factor " +
                           std::to_string(dark_brightness_factor) +
                           ", expected a finite value >= 0");
    for (int i = 0; i < 3; ++i) {
      detail::require<E>(std::isfinite(mean[static_cast<std::size_t>(i)]),
                         "preprocessing: mean is not finite, expected finite");
      const float s = std[static_cast<std::size_t>(i)];
      detail::require<E>(std::isfinite(s) && s > 0.0f, "preprocessing: std " + std::to_string(s) +
                                                           ", expected a finite value > 0");
    }
    detail::require<E>(network_channel_order == ChannelOrder::rgb ||
                           network_channel_order == ChannelOrder::bgr,
                       "preprocessing: channel order code " +
                           std::to_string(static_cast<std::uint32_t>(network_channel_order)) +
                           ", expected 0 (RGB) or 1 (BGR)");
    detail::require<E>(std::isfinite(lighting_target) && lighting_target > 0.0f &&
                           lighting_target <= 1.0f,
                       "preprocessing: lighting target " + std::to_string(lighting_target) +
                           ", expected a value in (0, 1]");
    detail::require<E>(std::isfinite(dark_luminance_threshold) &&
                           dark_luminance_threshold >= 0.0f && dark_luminance_threshold <= 1.0f,
                       "preprocessing: dark luminance threshold " +
                           std::to_string(dark_luminance_threshold) +
                           ", expected a value in [0, 1] (0 = no frame is dark)");
    detail::require<E>(input_encoding == InputEncoding::colour ||
                           input_encoding == InputEncoding::skin_relative ||
                           input_encoding == InputEncoding::darkness_warmth ||
                           input_encoding == InputEncoding::masks ||
                           input_encoding == InputEncoding::darkness_contact,
                       "preprocessing: input encoding code " +
                           std::to_string(static_cast<std::uint32_t>(input_encoding)) +
                           ", expected 0 (colour), 1 (skin_relative), 2 (darkness_warmth), 3 "
                           "(masks) or 4 (darkness_contact)");
    detail::require<E>(!(light_independent(input_encoding) && lighting_normalise),
                       std::string("preprocessing: the ") + to_string(input_encoding) +
                           " input encoding is already independent of the light level and takes "
                           "no lighting normalisation (turn it off)");
  }
};

SHADOWSENSE_NAMESPACE_END
