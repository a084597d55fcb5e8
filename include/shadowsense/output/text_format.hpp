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
// append_json_string(out, s) ensures: s as a JSON string literal: quote, backslash and control
//                         characters escaped (\" \\ \b \f \n \r \t, \u00XX for the rest); other
//                         bytes copied as they are (UTF-8 passes through).
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

inline void append_json_string(std::string& out, std::string_view s) {
  out.push_back('"');
  for (char c : s) {
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
      if (static_cast<unsigned char>(c) < 0x20) {
        static constexpr char hex[] = "0123456789abcdef";
        out += "\\u00";
        out.push_back(hex[(c >> 4) & 0xf]);
        out.push_back(hex[c & 0xf]);
      } else {
        out.push_back(c);
      }
    }
  }
  out.push_back('"');
}

} // namespace detail
SHADOWSENSE_NAMESPACE_END
