// libFuzzer target for the model-file loader: any byte string must either load (and then
// re-serialise to the same bytes) or throw ModelFileError - never crash, hang, read out of
// bounds or allocate without bound. Built and run by .ci/steps/fuzz.sh.
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
    if (bytes.size() != size || !std::equal(bytes.begin(), bytes.end(), data)) std::abort();
  } catch (const shadowsense::ModelFileError&) {
  }
  return 0;
}
