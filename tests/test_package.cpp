// The package's own conventions: version, ABI namespace, error types and image validation.
#include <shadowsense/shadowsense.hpp>

#include <doctest/doctest.h>

#include <string>
#include <type_traits>

TEST_CASE("version macros and constants agree") {
  CHECK(shadowsense::version_major == SHADOWSENSE_VERSION_MAJOR);
  CHECK(shadowsense::version_minor == SHADOWSENSE_VERSION_MINOR);
  CHECK(std::string(shadowsense::version_string) ==
        std::to_string(SHADOWSENSE_VERSION_MAJOR) + "." +
            std::to_string(SHADOWSENSE_VERSION_MINOR) + "." +
            std::to_string(SHADOWSENSE_VERSION_PATCH));
}

TEST_CASE("the ABI namespace is inline and versioned") {
  // Spelled through the versioned namespace, the same entity as through shadowsense::.
  CHECK(&shadowsense::v0_1::version_major == &shadowsense::version_major);
}

TEST_CASE("every library exception derives from shadowsense::Error and std::runtime_error") {
  using namespace shadowsense;
  static_assert(std::is_base_of_v<std::runtime_error, Error>);
  static_assert(std::is_base_of_v<Error, InvalidArgument>);
  static_assert(std::is_base_of_v<Error, ModelFileError>);
  // A catch of ModelFileError still catches a bad calibration file (one type before).
  static_assert(std::is_base_of_v<ModelFileError, CalibrationFileError>);
  static_assert(std::is_base_of_v<Error, DatasetError>);
  static_assert(std::is_base_of_v<Error, IoError>);
  CHECK_THROWS_WITH_AS(detail::require(false, "what was wrong"), "what was wrong", InvalidArgument);
  CHECK_NOTHROW(detail::require(true, "unused"));
}

TEST_CASE("require_colour_image names the argument and the expected type") {
  using shadowsense::InvalidArgument;
  using shadowsense::require_colour_image;
  CHECK_THROWS_WITH_AS(require_colour_image(cv::Mat(), "frame"),
                       "frame: image is empty; expected an 8-bit 3-channel image", InvalidArgument);
  CHECK_THROWS_WITH_AS(require_colour_image(cv::Mat(4, 4, CV_8UC1), "frame"),
                       "frame: image type is CV_8UC1; expected CV_8UC3 (8-bit, 3 channels)",
                       InvalidArgument);
  CHECK_THROWS_AS(require_colour_image(cv::Mat(4, 4, CV_32FC3), "frame"), InvalidArgument);
  CHECK_NOTHROW(require_colour_image(cv::Mat(4, 4, CV_8UC3), "frame"));
}
