// One JSON writer for every program's --json output, so the output is always valid JSON:
// strings are escaped (quotes, backslashes, control characters; bytes that are not UTF-8 become
// U+FFFD), numbers must be finite (NaN and infinity have no JSON form), commas and nesting are
// placed by the writer, and save() replaces the file atomically.
//
//   cli::JsonWriter j;
//   j.begin_object();
//   j.field("data", path.string()).field("frames", 120);
//   j.key("accuracy").begin_object(cli::JsonWriter::compact);
//   j.field("daylight", 0.95).end_object();
//   j.end_object();
//   j.save("score.json");
//
// Layout: containers opened `pretty` (the default) put each member on its own line, indented by
// two spaces per level; containers opened `compact` (and everything inside them) stay on one
// line. Doubles are written in the shortest form that reads back to the same value.
// Threading: one writer per thread.
#pragma once

#include <shadowsense/core/atomic_file.hpp>

#include <shadowsense/core/error.hpp>
#include <shadowsense/output/text_format.hpp>

#include <charconv>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace cli {

class JsonWriter {
public:
  enum Layout { pretty, compact };

  // requires: inside an object, before its value. throws std::logic_error otherwise.
  JsonWriter& key(std::string_view k) {
    if (stack_.empty() || !stack_.back().object || expect_value_)
      throw std::logic_error("JsonWriter: key \"" + std::string(k) + "\" outside an object");
    separate();
    string(k);
    out_ += ": ";
    expect_value_ = true;
    key_ = k;
    return *this;
  }

  // Opens a container as the next value. requires: a value is allowed here (top level once, an
  // array member, or after key()).
  JsonWriter& begin_object(Layout layout = pretty) { return open('{', true, layout); }
  JsonWriter& begin_array(Layout layout = pretty) { return open('[', false, layout); }
  // requires: the innermost open container is an object / array, with no key left dangling.
  JsonWriter& end_object() { return close('}', true); }
  JsonWriter& end_array() { return close(']', false); }

  JsonWriter& value(std::string_view s) {
    before_value();
    string(s);
    return *this;
  }
  JsonWriter& value(const std::string& s) { return value(std::string_view(s)); }
  JsonWriter& value(const char* s) { return value(std::string_view(s)); }
  JsonWriter& value(bool b) {
    before_value();
    out_ += b ? "true" : "false";
    return *this;
  }
  JsonWriter& value(std::nullptr_t) {
    before_value();
    out_ += "null";
    return *this;
  }
  template <std::integral T>
  requires(!std::same_as<T, bool>) JsonWriter& value(T v) {
    before_value();
    char buf[32];
    out_.append(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
    return *this;
  }
  // throws: shadowsense::InvalidArgument naming the key if v is NaN or infinite.
  JsonWriter& value(double v) {
    if (!std::isfinite(v))
      throw shadowsense::InvalidArgument("JSON output: the value of \"" + key_ + "\" is " +
                                         std::to_string(v) + "; expected a finite number");
    before_value();
    char buf[64];
    out_.append(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
    return *this;
  }
  JsonWriter& value(float v) { return value(static_cast<double>(v)); }

  // key(k).value(v).
  template <class T>
  JsonWriter& field(std::string_view k, const T& v) {
    return key(k).value(v);
  }

  // The document. requires: exactly one complete top-level value. throws std::logic_error.
  const std::string& str() const {
    if (!done_) throw std::logic_error("JsonWriter: the document is not complete");
    return out_;
  }
  // Writes str() plus a final newline to `path` with write_file_atomically (throws IoError).
  void save(const std::filesystem::path& path) const {
    shadowsense::write_file_atomically(path, str() + "\n");
  }

private:
  struct Level {
    bool object, compact, empty = true;
  };

  void separate() {
    Level& l = stack_.back();
    if (!l.empty) out_ += ',';
    if (l.compact) {
      if (!l.empty) out_ += ' ';
    } else {
      out_ += '\n';
      out_.append(2 * stack_.size(), ' ');
    }
    l.empty = false;
  }
  void before_value() {
    if (done_) throw std::logic_error("JsonWriter: a second top-level value");
    if (stack_.empty()) {
      done_ = true;
    } else if (stack_.back().object) {
      if (!expect_value_) throw std::logic_error("JsonWriter: a value in an object needs a key");
      expect_value_ = false;
    } else {
      separate();
    }
  }
  JsonWriter& open(char c, bool object, Layout layout) {
    const bool top = stack_.empty();
    before_value();
    if (top) done_ = false;
    out_ += c;
    stack_.push_back({object, layout == compact || (!top && stack_.back().compact)});
    return *this;
  }
  JsonWriter& close(char c, bool object) {
    if (stack_.empty() || stack_.back().object != object || expect_value_)
      throw std::logic_error(std::string("JsonWriter: unbalanced '") + c + "'");
    const Level l = stack_.back();
    stack_.pop_back();
    if (!l.compact && !l.empty) {
      out_ += '\n';
      out_.append(2 * stack_.size(), ' ');
    }
    out_ += c;
    if (stack_.empty()) done_ = true;
    return *this;
  }
  // A JSON string, escaped by the library's one escaper (output/text_format.hpp: valid UTF-8
  // kept, every byte of an invalid sequence becomes U+FFFD).
  void string(std::string_view s) { shadowsense::detail::append_json_string(out_, s); }

  std::string out_, key_;
  std::vector<Level> stack_;
  bool expect_value_ = false, done_ = false;
};

} // namespace cli
