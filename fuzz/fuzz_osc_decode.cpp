// libFuzzer target for the OSC decoder: any byte string must either decode or throw OscError -
// never crash, hang, read out of bounds or recurse without bound. A packet that decodes must
// re-encode to exactly the same bytes (the decoder accepts only the canonical encoding), and the
// writer must accept everything the decoder produced. Seeds: fuzz/corpus/osc_decode/.
#include <shadowsense/output/osc.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> input(data, size);
  shadowsense::OscPacket packet;
  try {
    packet = shadowsense::osc_decode(input);
  } catch (const shadowsense::OscError&) {
    return 0;
  }
  shadowsense::OscWriter writer;
  shadowsense::osc_encode(packet, writer); // must not throw: decoded packets are encodable
  const auto bytes = writer.bytes();
  if (!writer.complete() || bytes.size() != size || !std::equal(bytes.begin(), bytes.end(), data))
    std::abort();
  return 0;
}
