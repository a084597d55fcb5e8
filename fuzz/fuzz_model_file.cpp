// libFuzzer target for the model-file loader: any byte string must either load or throw
// ModelFileError - never crash, hang, read out of bounds or allocate without bound. A file that
// loads re-serialises to the same bytes when it is the current version; an older version is
// upgraded once, and the upgraded bytes must then round-trip exactly. Built and run by
// .ci/steps/fuzz.sh.
#include <shadowsense/backends/densenet/model_file.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const auto model =
        shadowsense::ModelFile::from_bytes(std::span<const std::uint8_t>(data, size));
    const auto bytes = model.to_bytes();
    if (model.format_version >= shadowsense::model_file_float_version &&
        (bytes.size() != size || !std::equal(bytes.begin(), bytes.end(), data)))
      std::abort();
    if (shadowsense::ModelFile::from_bytes(bytes).to_bytes() != bytes) std::abort();
  } catch (const shadowsense::ModelFileError&) {
  }
  return 0;
}
