// Up-front validation of images handed to the library, with messages naming the argument.
#pragma once

#include <shadowsense/core/error.hpp>

#include <opencv2/core.hpp>

#include <string>

SHADOWSENSE_NAMESPACE_BEGIN

// Throws InvalidArgument unless `image` is a non-empty 8-bit, 3-channel (BGR or RGB) image.
inline void require_colour_image(const cv::Mat& image, const char* argument_name) {
  // The name is only turned into a std::string on failure (no allocation per checked frame).
  const auto name = [argument_name] { return std::string(argument_name); };
  if (image.empty())
    SHADOWSENSE_THROW(
        InvalidArgument(name() + ": image is empty; expected an 8-bit 3-channel image"));
  if (image.dims != 2)
    SHADOWSENSE_THROW(InvalidArgument(name() + ": image has " + std::to_string(image.dims) +
                                      " dimensions; expected 2 (rows x cols)"));
  if (image.type() != CV_8UC3)
    SHADOWSENSE_THROW(InvalidArgument(name() + ": image type is " + cv::typeToString(image.type()) +
                                      "; expected CV_8UC3 (8-bit, 3 channels)"));
}

SHADOWSENSE_NAMESPACE_END
