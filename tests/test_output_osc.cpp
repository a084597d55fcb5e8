// OSC 1.0 encoder byte for byte against hand-computed bytes (the specification's own examples),
// the decoder on the same bytes, and the decoder's refusals.
#include <shadowsense/output/osc.hpp>

#include <doctest/doctest.h>

#include <cstdint>
#include <string>
#include <vector>

using namespace shadowsense;

namespace {
std::vector<std::uint8_t> bytes_of(const OscWriter& w) {
  return {w.bytes().begin(), w.bytes().end()};
}

OscPacket decode(const std::vector<std::uint8_t>& b) {
  return osc_decode(b);
}

void check_throws_osc(std::vector<std::uint8_t> b, const std::string& needle) {
  try {
    (void)osc_decode(b);
    FAIL("decoded bytes that should have been refused (" << needle << ")");
  } catch (const OscError& e) {
    CHECK_MESSAGE(std::string(e.what()).find(needle) != std::string::npos, e.what());
  }
}
} // namespace

TEST_CASE("a message with one float is the specification's example, byte for byte") {
  OscWriter w;
  w.begin_message("/oscillator/4/frequency");
  w.add_float(440.0f);
  w.end_message();
  const std::vector<std::uint8_t> expected{0x2f, 0x6f, 0x73, 0x63, 0x69, 0x6c, 0x6c, 0x61,
                                           0x74, 0x6f, 0x72, 0x2f, 0x34, 0x2f, 0x66, 0x72,
                                           0x65, 0x71, 0x75, 0x65, 0x6e, 0x63, 0x79, 0x00,
                                           0x2c, 0x66, 0x00, 0x00, 0x43, 0xdc, 0x00, 0x00};
  CHECK(w.complete());
  CHECK(bytes_of(w) == expected);
  const OscPacket p = decode(expected);
  REQUIRE_FALSE(p.is_bundle);
  CHECK(p.message.address == "/oscillator/4/frequency");
  REQUIRE(p.message.arguments.size() == 1);
  CHECK(std::get<float>(p.message.arguments[0]) == 440.0f);
}

TEST_CASE("ints, a string and floats are the specification's second example, byte for byte") {
  OscWriter w;
  w.begin_message("/foo");
  w.add_int(1000);
  w.add_int(-1);
  w.add_string("hello");
  w.add_float(1.234f);
  w.add_float(5.678f);
  w.end_message();
  const std::vector<std::uint8_t> expected{
      0x2f, 0x66, 0x6f, 0x6f, 0x00, 0x00, 0x00, 0x00, 0x2c, 0x69, 0x69, 0x73, 0x66, 0x66,
      0x00, 0x00, 0x00, 0x00, 0x03, 0xe8, 0xff, 0xff, 0xff, 0xff, 0x68, 0x65, 0x6c, 0x6c,
      0x6f, 0x00, 0x00, 0x00, 0x3f, 0x9d, 0xf3, 0xb6, 0x40, 0xb5, 0xb2, 0x2d};
  CHECK(bytes_of(w) == expected);
  const OscPacket p = decode(expected);
  REQUIRE(p.message.arguments.size() == 5);
  CHECK(std::get<std::int32_t>(p.message.arguments[0]) == 1000);
  CHECK(std::get<std::int32_t>(p.message.arguments[1]) == -1);
  CHECK(std::get<std::string>(p.message.arguments[2]) == "hello");
  CHECK(std::get<float>(p.message.arguments[3]) == 1.234f);
  CHECK(std::get<float>(p.message.arguments[4]) == 5.678f);
}

TEST_CASE("strings of length 3 and 4 pad to 4 and 8 bytes; no arguments still has ','") {
  OscWriter w;
  w.begin_message("/abc");
  w.add_string("xyz");
  w.end_message();
  CHECK(bytes_of(w) == std::vector<std::uint8_t>{'/', 'a', 'b', 'c', 0, 0, 0, 0, ',', 's', 0, 0,
                                                 'x', 'y', 'z', 0});
  w.clear();
  w.begin_message("/ab");
  w.end_message();
  CHECK(bytes_of(w) == std::vector<std::uint8_t>{'/', 'a', 'b', 0, ',', 0, 0, 0});
}

TEST_CASE("a bundle with time tag immediately holds size-prefixed elements, nested bundles too") {
  OscWriter w;
  w.begin_bundle();
  w.begin_message("/a");
  w.add_int(7);
  w.end_message();
  w.begin_bundle(0x0102030405060708ull);
  w.begin_message("/b");
  w.end_message();
  w.end_bundle();
  w.end_bundle();
  const std::vector<std::uint8_t> expected{
      '#', 'b', 'u', 'n', 'd', 'l', 'e', 0, 0,   0,   0, 0, 0, 0, 0, 1, // header, immediately
      0,   0,   0,   12,  '/', 'a', 0,   0, ',', 'i', 0, 0, 0, 0, 0, 7, // element: /a 7
      0,   0,   0,   28,                                                // element: nested bundle
      '#', 'b', 'u', 'n', 'd', 'l', 'e', 0, 1,   2,   3, 4, 5, 6, 7, 8, // its header
      0,   0,   0,   8,   '/', 'b', 0,   0, ',', 0,   0, 0};            // its element: /b
  CHECK(bytes_of(w) == expected);
  const OscPacket p = decode(expected);
  REQUIRE(p.is_bundle);
  CHECK(p.timetag == osc_immediately);
  REQUIRE(p.elements.size() == 2);
  CHECK(p.elements[0].message.address == "/a");
  REQUIRE(p.elements[1].is_bundle);
  CHECK(p.elements[1].timetag == 0x0102030405060708ull);
  CHECK(p.elements[1].elements.at(0).message.address == "/b");
  std::vector<OscMessage> all;
  osc_collect_messages(p, all);
  REQUIRE(all.size() == 2);
  CHECK(all[1].address == "/b");
  OscWriter again;
  osc_encode(p, again);
  CHECK(bytes_of(again) == expected);
}

TEST_CASE("the writer refuses misuse with a message and writes nothing") {
  OscWriter w;
  CHECK_THROWS_AS(w.begin_message("noslash"), InvalidArgument);
  CHECK_THROWS_AS(w.begin_message(std::string("/a\0b", 4)), InvalidArgument);
  CHECK_THROWS_AS(w.add_int(1), InvalidArgument);
  CHECK_THROWS_AS(w.end_message(), InvalidArgument);
  CHECK_THROWS_AS(w.end_bundle(), InvalidArgument);
  CHECK(w.size() == 0);
  w.begin_message("/a");
  CHECK_THROWS_AS(w.add_string(std::string("x\0y", 3)), InvalidArgument);
  CHECK_THROWS_AS(w.begin_message("/b"), InvalidArgument);
  CHECK_THROWS_AS(w.begin_bundle(), InvalidArgument);
  w.end_message();
  CHECK_THROWS_AS(w.begin_message("/c"), InvalidArgument); // one packet per buffer
  w.clear();
  CHECK_NOTHROW(w.begin_message("/c"));
}

TEST_CASE("the decoder refuses malformed packets, naming what it expected") {
  const std::vector<std::uint8_t> good{'/', 'a', 0, 0, ',', 'i', 0, 0, 0, 0, 0, 7};
  CHECK_NOTHROW(osc_decode(good));
  check_throws_osc({}, "positive multiple of 4");
  check_throws_osc({'/', 'a', 0}, "positive multiple of 4");
  check_throws_osc({'/', 'a', 0, 0, ',', 'i', 0, 0}, "expected 4 more bytes"); // truncated int
  check_throws_osc({'/', 'a', 0, 1, ',', 0, 0, 0}, "non-NUL padding");
  check_throws_osc({'a', 'a', 0, 0, ',', 0, 0, 0}, "starting with '/'");
  check_throws_osc({'/', 'a', 0, 0, 'i', 0, 0, 0}, "leading ','");
  check_throws_osc({'/', 'a', 0, 0, ',', 'd', 0, 0, 0, 0, 0, 0, 0, 0, 0, 0}, "type tag 'd'");
  check_throws_osc({'/', 'a', 0, 0, ',', 0, 0, 0, 0, 0, 0, 0}, "after the last argument");
  check_throws_osc({'/', 'a', 'b', 'c'}, "unterminated string");
  check_throws_osc({'/', 'a', 0, 0}, "type tag string");
  // Bundle element sizes: zero, not a multiple of 4, past the end.
  std::vector<std::uint8_t> bundle{'#', 'b', 'u', 'n', 'd', 'l', 'e', 0, 0, 0, 0, 0, 0, 0, 0, 1};
  auto with_size = [&](std::uint8_t n) {
    auto b = bundle;
    b.insert(b.end(), {0, 0, 0, n});
    b.insert(b.end(), good.begin(), good.end());
    return b;
  };
  CHECK_NOTHROW(osc_decode(with_size(12)));
  check_throws_osc(with_size(0), "bundle element size 0");
  check_throws_osc(with_size(6), "bundle element size 6");
  check_throws_osc(with_size(16), "bundle element size 16");
  check_throws_osc({'#', 'b', 'u', 'n', 'd', 'l', 'e', 0, 0, 0, 0, 0}, "expected 4 more bytes");
}

TEST_CASE("bundles nested deeper than the limit are refused") {
  // Build depth `levels` of bundles around one message, innermost first.
  auto nested = [](int levels) {
    std::vector<std::uint8_t> b{'/', 'a', 0, 0, ',', 0, 0, 0};
    for (int i = 0; i < levels; ++i) {
      const auto n = static_cast<std::uint32_t>(b.size());
      std::vector<std::uint8_t> outer{'#',
                                      'b',
                                      'u',
                                      'n',
                                      'd',
                                      'l',
                                      'e',
                                      0,
                                      0,
                                      0,
                                      0,
                                      0,
                                      0,
                                      0,
                                      0,
                                      1,
                                      static_cast<std::uint8_t>(n >> 24),
                                      static_cast<std::uint8_t>(n >> 16),
                                      static_cast<std::uint8_t>(n >> 8),
                                      static_cast<std::uint8_t>(n)};
      outer.insert(outer.end(), b.begin(), b.end());
      b = std::move(outer);
    }
    return b;
  };
  CHECK_NOTHROW(osc_decode(nested(osc_max_bundle_depth)));
  check_throws_osc(nested(osc_max_bundle_depth + 1), "nested deeper than 8");
}
