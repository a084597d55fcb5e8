// libFuzzer target for the calibration-file parser (sense/calibration_file.hpp): any byte string
// must either parse or throw CalibrationFileError - never crash, hang, read out of bounds or
// allocate without bound (an empty_skin line claiming a huge image must not allocate it). A text
// that parses re-serialises (version 2) to a file that parses to the same calibration. Built and
// run by .ci/steps/fuzz.sh.
#include <shadowsense/sense/calibration_file.hpp>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const shadowsense::SegmenterCalibration c = shadowsense::calibration_from_string(text, "fuzz");
    const std::string again = shadowsense::calibration_to_string(c);
    if (!(shadowsense::calibration_from_string(again, "fuzz") == c)) std::abort();
  } catch (const shadowsense::CalibrationFileError&) {
  }
  return 0;
}
