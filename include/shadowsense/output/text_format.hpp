// Text formatting shared by the CSV and JSON-lines sinks: locale-independent shortest
// round-trip numbers, CSV field quoting (RFC 4180) and JSON string escaping (RFC 8259).
//
// append_number(out, v)   ensures: v's shortest decimal form that reads back to the same value
//                         (float overload: the same float, so 0.1f is written 0.1)
//                         ("nan"/"inf" never appear: the JSON sink writes null for them, the CSV
//                         sink an empty field). Independent of the C and C++ locales.
// append_csv_field(out, s) ensures: s as one CSV field: unchanged when it holds no comma, quote,
//                         CR or LF and no leading or trailing space; otherwise in double quotes
//                         with every quote doubled.
// append_json_string(out, s) ensures: s as a JSON string literal, always valid JSON and UTF-8:
//                         quote, backslash and control characters escaped (\" \\ \b \f \n \r
//                         \t, \u00XX for the rest and for DEL); valid UTF-8 copied as it is;
//                         every byte of an invalid UTF-8 sequence (overlong forms, surrogates,
//                         code points above U+10FFFF, truncated sequences) becomes \ufffd. The
//                         one JSON string escaper of the project (sinks and programs' --json).
// utf8_length(s)          the length of the valid UTF-8 sequence at the start of s (first byte
//                         >= 0x80), 0 when it is invalid.
// None of them throws except std::bad_alloc.
#pragma once

#include <shadowsense/core/version.hpp>

#include <charconv>
#include <cmath>
#include <string>
#include <string_view>

SHADOWSENSE_NAMESPACE_BEGIN
namespace detail {

inline void append_number(std::string& out, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

inline void append_number(std::string& out, float v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

inline void append_integer(std::string& out, long long v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

inline void append_csv_field(std::string& out, std::string_view s) {
  const bool quote = s.find_first_of(",\"\r\n") != std::string_view::npos ||
                     (!s.empty() && (s.front() == ' ' || s.back() == ' '));
  if (!quote) {
    out.append(s);
    return;
  }
  out.push_back('"');
  for (char c : s) {
    if (c == '"') out.push_back('"');
    out.push_back(c);
  }
  out.push_back('"');
}

inline std::size_t utf8_length(std::string_view s) {
  const auto b = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char c = b(0);
  const std::size_t n = c >= 0xf0 ? 4 : c >= 0xe0 ? 3 : c >= 0xc0 ? 2 : 0;
  if (n == 0 || c > 0xf4 || c == 0xc0 || c == 0xc1 || s.size() < n) return 0;
  for (std::size_t k = 1; k < n; ++k)
    if ((b(k) & 0xc0) != 0x80) return 0;
  if ((c == 0xe0 && b(1) < 0xa0) || (c == 0xed && b(1) > 0x9f) || (c == 0xf0 && b(1) < 0x90) ||
      (c == 0xf4 && b(1) > 0x8f))
    return 0;
  return n;
}

inline void append_json_string(std::string& out, std::string_view s) {
  out.push_back('"');
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    switch (c) {
    case '"':
      out += "\\\"";
      break;
    case '\\':
      out += "\\\\";
      break;
    case '\b':
      out += "\\b";
      break;
    case '\f':
      out += "\\f";
      break;
    case '\n':
      out += "\\n";
      break;
    case '\r':
      out += "\\r";
      break;
    case '\t':
      out += "\\t";
      break;
    default:
      if (c < 0x20 || c == 0x7f) {
        static constexpr char hex[] = "0123456789abcdef";
        out += "\\u00";
        out.push_back(hex[c >> 4]);
        out.push_back(hex[c & 0xf]);
      } else if (c >= 0x80) {
        const std::size_t n = utf8_length(s.substr(i));
        if (n == 0) {
          out += "\\ufffd";
        } else {
          out.append(s.substr(i, n));
          i += n;
          continue;
        }
      } else {
        out.push_back(static_cast<char>(c));
      }
    }
    ++i;
  }
  out.push_back('"');
}

} // namespace detail
SHADOWSENSE_NAMESPACE_END
