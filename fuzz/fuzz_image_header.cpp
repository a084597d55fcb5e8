// libFuzzer target for the header-first image reader (io/image_file.hpp): any file must give a
// header within the limits or an IoError naming the file - never a crash, a hang or an
// out-of-bounds read - and read_image_file must agree with the header or throw (it decodes only
// what the header allows: at most 256 x 256 pixels here). Each input is written to a file in
// the working folder, as the reader takes paths. Built and run by .ci/steps/fuzz.sh.
#include <shadowsense/io/image_file.hpp>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const char* path = "fuzz_image_input.bin";
  std::FILE* f = std::fopen(path, "wb");
  if (!f) std::abort();
  if (size && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  shadowsense::ImageLimits limits;
  limits.max_width = limits.max_height = 256;
  limits.max_file_bytes = 1 << 20;
  try {
    const shadowsense::ImageHeader h = shadowsense::read_image_header(path, limits);
    if (h.width < 1 || h.height < 1 || h.width > 256 || h.height > 256) std::abort();
    try {
      const cv::Mat m = shadowsense::read_image_file(path, cv::IMREAD_COLOR, limits);
      if (m.empty() || m.cols > 256 || m.rows > 256) std::abort();
    } catch (const shadowsense::IoError&) {
    }
  } catch (const shadowsense::IoError&) {
  }
  return 0;
}
