// libFuzzer target for the dataset csv parser (io/dataset.hpp) on in-memory text: any bytes
// must either parse (and then re-serialise and parse again to the same rows) or throw
// DatasetError - never crash, hang, read out of bounds or throw anything else. The first byte
// chooses metadata.csv (even) or sequences.csv (odd). Built and run by .ci/steps/fuzz.sh.
#include <shadowsense/io/dataset.hpp>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
  try {
    if (data[0] % 2 == 0) {
      const auto md = shadowsense::parse_metadata(text, "fuzz/metadata.csv");
      const auto again = shadowsense::parse_metadata(
          shadowsense::metadata_csv(md.rows, md.slide_columns), "fuzz/metadata.csv");
      if (again.rows.size() != md.rows.size()) std::abort();
      for (std::size_t i = 0; i < md.rows.size(); ++i)
        if (again.rows[i].file_name != md.rows[i].file_name ||
            again.rows[i].shadow_box != md.rows[i].shadow_box ||
            again.rows[i].contact_box != md.rows[i].contact_box)
          std::abort();
    } else {
      const auto rows = shadowsense::parse_sequences(text, "fuzz/sequences.csv");
      const auto again =
          shadowsense::parse_sequences(shadowsense::sequences_csv(rows), "fuzz/sequences.csv");
      if (again.size() != rows.size()) std::abort();
    }
  } catch (const shadowsense::DatasetError&) {
  }
  return 0;
}
