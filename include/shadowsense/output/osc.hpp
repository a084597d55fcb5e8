// A small Open Sound Control 1.0 encoder and decoder: what TUIO 1.1 needs, nothing more.
//
// Encoding (OSC 1.0 specification): every item is big-endian and 4-byte aligned. A string is its
// bytes, a NUL, then NULs up to a multiple of 4. A message is its address pattern (a string
// starting with '/'), its type tag string (',' followed by one tag per argument) and the
// arguments: 'i' int32, 'f' IEEE-754 float32, 's' string. A bundle is the string "#bundle", a
// 64-bit NTP time tag (1 = "immediately") and elements, each an int32 byte size followed by a
// message or a bundle.
//
// OscWriter
//   Builds one packet (a message, or a bundle of messages and bundles) in a byte buffer that is
//   reused: after clear() no allocation happens unless the packet grows beyond every earlier one.
//   clear()                        ensures: empty buffer, no open bundle or message.
//   begin_bundle(timetag = 1)      requires: no open message; at top level, an empty buffer.
//   end_bundle()                   requires: an open bundle and no open message.
//   begin_message(address)         requires: no open message; at top level, an empty buffer;
//                                  address starts with '/' and holds no NUL.
//   add_int / add_float / add_string(s)   requires: an open message; s holds no NUL.
//   end_message()                  requires: an open message.
//   bytes()                        the packet; complete when no bundle or message is open
//                                  (complete() says so).
//   throws: InvalidArgument when a requirement above is broken (nothing is written then).
//   Threading: one instance per thread (no internal locking).
//
// osc_decode(bytes) -> OscPacket
//   requires: nothing (any bytes).
//   ensures:  the packet, bundles nested as sent; only 'i', 'f', 's' arguments are accepted, the
//             padding must be NULs and sizes must match exactly, so every packet that decodes
//             re-encodes (osc_encode) to the same bytes.
//   throws:   OscError naming the offset and what was expected, for anything else (truncated,
//             bad padding, unknown type tag, nesting deeper than osc_max_bundle_depth, ...).
// osc_encode(packet, writer)
//   requires: a packet as osc_decode returns it (addresses start with '/', strings hold no NUL).
//   ensures:  writer holds its bytes (writer is cleared first).
//   throws:   InvalidArgument as OscWriter does.
#pragma once

#include <shadowsense/core/error.hpp>

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// A packet could not be decoded as OSC 1.0.
class OscError : public Error {
public:
  using Error::Error;
};

// The OSC time tag that means "immediately" (seconds 0, fraction 1).
inline constexpr std::uint64_t osc_immediately = 1;
// Bundles nested deeper than this are refused by the decoder.
inline constexpr int osc_max_bundle_depth = 8;

using OscArgument = std::variant<std::int32_t, float, std::string>;

struct OscMessage {
  std::string address;
  std::vector<OscArgument> arguments;
};

// One decoded packet: a message, or a bundle of packets.
struct OscPacket {
  bool is_bundle = false;
  std::uint64_t timetag = 0;       // bundles only
  OscMessage message;              // when !is_bundle
  std::vector<OscPacket> elements; // when is_bundle, in the order sent
};

// All messages of a packet in the order sent (depth first).
inline void osc_collect_messages(const OscPacket& p, std::vector<OscMessage>& out) {
  if (!p.is_bundle) {
    out.push_back(p.message);
    return;
  }
  for (const OscPacket& e : p.elements) osc_collect_messages(e, out);
}

class OscWriter {
public:
  OscWriter() {
    bundle_starts_.reserve(osc_max_bundle_depth);
    tags_.reserve(64);
    args_.reserve(256);
  }

  void clear() {
    buf_.clear();
    bundle_starts_.clear();
    in_message_ = false;
  }

  void begin_bundle(std::uint64_t timetag = osc_immediately) {
    require_can_begin("begin_bundle");
    if (!bundle_starts_.empty()) {
      bundle_starts_.push_back(buf_.size());
      put_u32(0); // element size, patched by end_bundle
    } else {
      bundle_starts_.push_back(npos);
    }
    static constexpr char tag[8] = {'#', 'b', 'u', 'n', 'd', 'l', 'e', '\0'};
    buf_.insert(buf_.end(), tag, tag + 8);
    put_u32(static_cast<std::uint32_t>(timetag >> 32));
    put_u32(static_cast<std::uint32_t>(timetag & 0xffffffffu));
  }

  void end_bundle() {
    if (in_message_) fail("end_bundle: a message is still open; call end_message first");
    if (bundle_starts_.empty()) fail("end_bundle: no bundle is open");
    const std::size_t start = bundle_starts_.back();
    bundle_starts_.pop_back();
    if (start != npos) patch_size(start);
  }

  void begin_message(std::string_view address) {
    require_can_begin("begin_message");
    if (address.empty() || address.front() != '/')
      fail("begin_message: address '" + std::string(address) + "' must start with '/'");
    if (address.find('\0') != std::string_view::npos)
      fail("begin_message: address holds a NUL byte");
    message_start_ = npos;
    if (!bundle_starts_.empty()) {
      message_start_ = buf_.size();
      put_u32(0); // element size, patched by end_message
    }
    put_string(buf_, address);
    tags_.assign(1, ',');
    args_.clear();
    in_message_ = true;
  }

  void add_int(std::int32_t v) {
    require_message("add_int");
    tags_.push_back('i');
    put_u32(args_, static_cast<std::uint32_t>(v));
  }
  void add_float(float v) {
    require_message("add_float");
    tags_.push_back('f');
    put_u32(args_, std::bit_cast<std::uint32_t>(v));
  }
  void add_string(std::string_view s) {
    require_message("add_string");
    if (s.find('\0') != std::string_view::npos)
      fail("add_string: the string holds a NUL byte; OSC strings cannot");
    tags_.push_back('s');
    put_string(args_, s);
  }

  void end_message() {
    require_message("end_message");
    put_string(buf_, tags_);
    buf_.insert(buf_.end(), args_.begin(), args_.end());
    if (message_start_ != npos) patch_size(message_start_);
    in_message_ = false;
  }

  // True when the buffer holds one finished packet.
  bool complete() const { return !buf_.empty() && !in_message_ && bundle_starts_.empty(); }
  std::span<const std::uint8_t> bytes() const { return buf_; }
  std::size_t size() const { return buf_.size(); }
  // Bytes the open message would add to the buffer if ended now (its tags and arguments).
  std::size_t pending_message_size() const {
    return in_message_ ? padded(tags_.size() + 1) + args_.size() : 0;
  }

private:
  static constexpr std::size_t npos = static_cast<std::size_t>(-1);
  static std::size_t padded(std::size_t n) { return (n + 3) & ~std::size_t(3); }

  [[noreturn]] static void fail(const std::string& what) {
    SHADOWSENSE_THROW(InvalidArgument("OscWriter::" + what));
  }
  // "<call>: <problem>", appended in place: GCC 12 at -O2 reports a bogus -Warray-bounds on the
  // inlined std::string(what) + "literal" here in some translation units.
  [[noreturn]] static void fail(const char* call, const char* problem) {
    std::string what(call);
    what.append(": ").append(problem);
    fail(what);
  }
  void require_can_begin(const char* what) const {
    if (in_message_) fail(what, "a message is still open; call end_message first");
    if (bundle_starts_.empty() && !buf_.empty())
      fail(what, "the buffer already holds a finished packet; call clear() first");
  }
  void require_message(const char* what) const {
    if (!in_message_) fail(what, "no message is open; call begin_message first");
  }
  void put_u32(std::uint32_t v) { put_u32(buf_, v); }
  static void put_u32(std::vector<std::uint8_t>& b, std::uint32_t v) {
    b.push_back(static_cast<std::uint8_t>(v >> 24));
    b.push_back(static_cast<std::uint8_t>(v >> 16));
    b.push_back(static_cast<std::uint8_t>(v >> 8));
    b.push_back(static_cast<std::uint8_t>(v));
  }
  static void put_string(std::vector<std::uint8_t>& b, std::string_view s) {
    b.insert(b.end(), s.begin(), s.end());
    b.insert(b.end(), padded(s.size() + 1) - s.size(), std::uint8_t{0});
  }
  void patch_size(std::size_t at) {
    const auto n = static_cast<std::uint32_t>(buf_.size() - at - 4);
    buf_[at] = static_cast<std::uint8_t>(n >> 24);
    buf_[at + 1] = static_cast<std::uint8_t>(n >> 16);
    buf_[at + 2] = static_cast<std::uint8_t>(n >> 8);
    buf_[at + 3] = static_cast<std::uint8_t>(n);
  }

  std::vector<std::uint8_t> buf_;
  std::vector<std::size_t> bundle_starts_; // size-field offsets (npos for the top level)
  std::size_t message_start_ = npos;
  std::string tags_;
  std::vector<std::uint8_t> args_;
  bool in_message_ = false;
};

namespace detail {
class OscReader {
public:
  explicit OscReader(std::span<const std::uint8_t> b) : b_(b) {}

  OscPacket packet(std::size_t begin, std::size_t end, int depth) {
    OscPacket p;
    static constexpr char tag[8] = {'#', 'b', 'u', 'n', 'd', 'l', 'e', '\0'};
    if (end - begin >= 8 && std::memcmp(b_.data() + begin, tag, 8) == 0) {
      if (depth >= osc_max_bundle_depth)
        fail(begin, "bundles nested deeper than " + std::to_string(osc_max_bundle_depth));
      p.is_bundle = true;
      std::size_t at = begin + 8;
      const std::uint64_t hi = u32(at, end);
      const std::uint64_t lo = u32(at + 4, end);
      p.timetag = hi << 32 | lo;
      at += 8;
      while (at < end) {
        const std::uint32_t n = u32(at, end);
        at += 4;
        if (n == 0 || n % 4 != 0 || n > end - at)
          fail(at - 4, "bundle element size " + std::to_string(n) +
                           "; expected a positive multiple of 4 within the " +
                           std::to_string(end - at) + " bytes left");
        p.elements.push_back(packet(at, at + n, depth + 1));
        at += n;
      }
      return p;
    }
    std::size_t at = begin;
    p.message.address = string(at, end);
    if (p.message.address.empty() || p.message.address.front() != '/')
      fail(begin, "address '" + p.message.address + "'; expected one starting with '/'");
    if (at == end) fail(at, "end of packet; expected the type tag string");
    const std::size_t tags_at = at;
    const std::string tags = string(at, end);
    if (tags.empty() || tags.front() != ',')
      fail(tags_at, "type tag string without the leading ','");
    for (std::size_t i = 1; i < tags.size(); ++i) {
      switch (tags[i]) {
      case 'i':
        p.message.arguments.emplace_back(static_cast<std::int32_t>(u32(at, end)));
        at += 4;
        break;
      case 'f':
        p.message.arguments.emplace_back(std::bit_cast<float>(u32(at, end)));
        at += 4;
        break;
      case 's':
        p.message.arguments.emplace_back(string(at, end));
        break;
      default:
        fail(tags_at,
             std::string("type tag '") + printable(tags[i]) + "'; expected 'i', 'f' or 's'");
      }
    }
    if (at != end)
      fail(at, std::to_string(end - at) + " bytes after the last argument; expected none");
    return p;
  }

private:
  [[noreturn]] static void fail(std::size_t at, const std::string& what) {
    SHADOWSENSE_THROW(OscError("osc_decode: at byte " + std::to_string(at) + ": " + what));
  }
  static std::string printable(char c) {
    if (c >= 0x20 && c < 0x7f) return std::string(1, c);
    return "\\x" + std::string(1, "0123456789abcdef"[(c >> 4) & 15]) +
           std::string(1, "0123456789abcdef"[c & 15]);
  }
  std::uint32_t u32(std::size_t at, std::size_t end) const {
    if (end < 4 || at > end - 4) fail(at, "end of data; expected 4 more bytes");
    const std::uint8_t* p = b_.data() + at;
    return std::uint32_t(p[0]) << 24 | std::uint32_t(p[1]) << 16 | std::uint32_t(p[2]) << 8 |
           std::uint32_t(p[3]);
  }
  // Reads a NUL-terminated, NUL-padded string at `at` and advances past its padding.
  std::string string(std::size_t& at, std::size_t end) const {
    const std::uint8_t* first = b_.data() + at;
    const void* nul = std::memchr(first, 0, end - at);
    if (!nul) fail(at, "an unterminated string; expected a NUL before the end");
    const auto len = static_cast<std::size_t>(static_cast<const std::uint8_t*>(nul) - first);
    const std::size_t stop = at + ((len + 4) & ~std::size_t(3));
    if (stop > end) fail(at, "string padding past the end of the data");
    for (std::size_t i = at + len; i < stop; ++i)
      if (b_[i] != 0) fail(i, "a non-NUL padding byte");
    std::string s(reinterpret_cast<const char*>(first), len);
    at = stop;
    return s;
  }

  std::span<const std::uint8_t> b_;
};

inline void osc_encode_into(const OscPacket& p, OscWriter& w) {
  if (p.is_bundle) {
    w.begin_bundle(p.timetag);
    for (const OscPacket& e : p.elements) osc_encode_into(e, w);
    w.end_bundle();
    return;
  }
  w.begin_message(p.message.address);
  for (const OscArgument& a : p.message.arguments) {
    if (const auto* i = std::get_if<std::int32_t>(&a))
      w.add_int(*i);
    else if (const auto* f = std::get_if<float>(&a))
      w.add_float(*f);
    else
      w.add_string(std::get<std::string>(a));
  }
  w.end_message();
}
} // namespace detail

inline OscPacket osc_decode(std::span<const std::uint8_t> bytes) {
  if (bytes.empty() || bytes.size() % 4 != 0)
    SHADOWSENSE_THROW(OscError("osc_decode: packet of " + std::to_string(bytes.size()) +
                               " bytes; expected a positive multiple of 4"));
  return detail::OscReader(bytes).packet(0, bytes.size(), 0);
}

inline void osc_encode(const OscPacket& packet, OscWriter& writer) {
  writer.clear();
  detail::osc_encode_into(packet, writer);
}

SHADOWSENSE_NAMESPACE_END
