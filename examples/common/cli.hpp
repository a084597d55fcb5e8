// The command line of every shadowsense program: one small declarative parser and one way to
// report errors. No third-party dependency.
//
// A program binds each option to a variable that already holds its default, calls parse(), and
// wraps the body of main in cli::run():
//
//   int main(int argc, char** argv) {
//     return cli::run("ss_example", [&] {
//       std::string out;
//       int users = 4;
//       bool overwrite = false;
//       cli::Parser p("ss_example", "Writes an example dataset.");
//       p.option("--out", "DIR", "output folder", out).required();
//       p.option("--users", "N", "number of users", users).range(1, 1000);
//       p.flag("--overwrite", "replace an existing folder", overwrite);
//       p.parse(argc, argv);
//       ...
//       return 0;
//     });
//   }
//
// Conventions shared by every program:
//   --help, -h   usage and every option's description on stdout, exit status 0
//   --version    "<program> shadowsense <version>" on stdout, exit status 0
//   any error    one line "<program>: error: <message>" on stderr, exit status 2; the message
//                names the option and what was expected
// Values: "--opt value" or "--opt=value". Numbers are strict: the whole text must parse ("2.9"
// is no integer, "1e12" overflows an int, "-1" is no unsigned, "nan" and "inf" are no number),
// then the option's range is checked. An option may be given once, except list and repeated
// options: the first occurrence replaces the default, later ones append.
//
// Every program uses the default Style, so "--opt value" and "--opt=value" work everywhere; the
// input of a program that reads frames or a dataset is --input (older names stay as aliases,
// Parser::alias). A program may keep a help text of its own (Parser::help_text) and its own
// wording for a value's expectation or check (Declared::expected, Declared::check).
//
// Shared helpers below the Parser:
//   require_display(option)        --show without a display: UsageError (exit 2, one line)
//   parse_tuio_target(spec, ...)   --tuio HOST[:PORT], IPv6 in brackets ("[::1]:3334")
//   Progress                       a progress line on stderr at most once a second
//
// Threading: a Parser is used by one thread (declare, then parse once); the helpers are
// stateless except Progress (one thread).
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/core/version.hpp>
#include <shadowsense/output/udp_sender.hpp>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace cli {

// A command line the program does not accept: unknown option, missing or malformed value,
// missing required option, options that do not go together. Programs throw it too for checks
// that span options.
class UsageError : public shadowsense::InvalidArgument {
public:
  using InvalidArgument::InvalidArgument;
};

// Thrown by Parser::parse once --help or --version has been answered; run() returns `code`.
struct Exit {
  int code = 0;
};

namespace detail {

template <class T>
concept Integer = std::integral<T> && !std::same_as<T, bool>;
template <class T>
concept Number = Integer<T> || std::floating_point<T>;
template <class T>
concept Text = std::same_as<T, std::string> || std::same_as<T, std::filesystem::path>;

inline std::string show(const std::string& v) {
  return v;
}
inline std::string show(const std::filesystem::path& v) {
  return v.string();
}
template <Number T>
std::string show(T v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

template <class T>
std::string kind() {
  if constexpr (std::floating_point<T>)
    return "a number";
  else if constexpr (std::is_unsigned_v<T>)
    return "a non-negative integer";
  else
    return "an integer";
}

// What a value of T with these constraints must be, e.g. "an integer in [1, 256]".
template <class T>
struct Constraint {
  bool has_range = false;
  T lo{}, hi{};
  std::vector<std::string> choices;
  std::string expected_text;           // replaces the generated wording when not empty
  std::function<void(const T&)> check; // called on every value that passed the rest
  std::string expected() const {
    if (!expected_text.empty()) return expected_text;
    if (!choices.empty()) {
      std::string s = "one of ";
      for (std::size_t i = 0; i < choices.size(); ++i) s += (i ? ", " : "") + choices[i];
      return s;
    }
    if constexpr (Number<T>) {
      if (has_range) return kind<T>() + " in [" + show(lo) + ", " + show(hi) + "]";
      return kind<T>();
    } else {
      return "";
    }
  }
  // Parses the whole of `text` or throws UsageError naming `option`, the text and what was
  // expected.
  T parse(const std::string& option, std::string_view text) const {
    const auto fail = [&] {
      return UsageError(option + ": expected " + expected() + ", got '" + std::string(text) + "'");
    };
    if constexpr (Number<T>) {
      T v{};
      const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
      if (text.empty() || r.ec != std::errc() || r.ptr != text.data() + text.size()) throw fail();
      if constexpr (std::floating_point<T>)
        if (!std::isfinite(v)) throw fail();
      if (has_range && (v < lo || v > hi)) throw fail();
      if (check) check(v);
      return v;
    } else {
      if (!choices.empty() && std::find(choices.begin(), choices.end(), text) == choices.end())
        throw fail();
      T v(std::string{text});
      if (check) check(v);
      return v;
    }
  }
};

struct Option {
  std::string name, value_name, description, default_text;
  std::function<std::string()> expected; // what a value must be (unset for flags)
  bool takes_value = true, required = false, many = false, split = false, seen = false;
  std::function<void(std::string_view)> assign;
  Option* target = nullptr;         // an alias: the option it spells
  std::vector<std::string> aliases; // other spellings of this option
};

} // namespace detail

// What option() and list() return: refines the option just declared.
template <class T>
class Declared {
public:
  Declared(detail::Option& o, std::shared_ptr<detail::Constraint<T>> c)
      : o_(&o), c_(std::move(c)) {}
  // ensures: parse() throws UsageError unless the option was given.
  Declared& required() {
    o_->required = true;
    return *this;
  }
  // requires: lo <= hi. ensures: values outside [lo, hi] are rejected, naming the range.
  Declared& range(T lo, T hi) requires detail::Number<T> {
    if (!(lo <= hi)) throw shadowsense::InvalidArgument(o_->name + ": range needs lo <= hi");
    c_->has_range = true;
    c_->lo = lo;
    c_->hi = hi;
    return *this;
  }
  // ensures: only these exact values are accepted.
  Declared& choices(std::vector<std::string> values) requires detail::Text<T> {
    c_->choices = std::move(values);
    return *this;
  }
  // ensures: --help shows `text` as the default instead of the variable's initial value.
  Declared& default_text(std::string text) {
    o_->default_text = std::move(text);
    return *this;
  }
  // ensures: `text` replaces the generated description of an acceptable value (e.g. "an
  // integer in [1, 64]") in errors and --help; the checks themselves are unchanged.
  Declared& expected(std::string text) {
    c_->expected_text = std::move(text);
    return *this;
  }
  // ensures: every value that passed the option's other checks is handed to `f` before it is
  // stored (for a list, each item); `f` rejects a value by throwing UsageError with the message
  // the program wants. requires: f outlives parse().
  Declared& check(std::function<void(const T&)> f) {
    c_->check = std::move(f);
    return *this;
  }

private:
  detail::Option* o_;
  std::shared_ptr<detail::Constraint<T>> c_;
};

// How a Parser treats '=' and repeated options and words a missing value. The defaults are the
// conventions above.
struct Style {
  enum class Equals {
    value, // "--opt=value" gives the option its value; "--flag=x" is an error ("takes no value")
    cut,   // every argument starting with "--" is cut at its first '=' before it is matched:
           // "--opt=value" gives the value, "--help=x" is --help, "--flag=x" an unknown option
           // "--flag"
    none,  // '=' is part of the name: "--opt=value" is an unknown option
  };
  Equals equals = Equals::value;
  // An option given again replaces its earlier value (false: the error "given more than once").
  // List and repeated options append either way.
  bool repeat_replaces = false;
  // The error for an option whose value is missing, from the option's name (unset: "<name>:
  // missing value (expected VALUE, ...)").
  std::function<std::string(const std::string& name)> missing_value;
  // The error for an argument not starting with '-' when no positional() is declared, from the
  // argument (unset: "unexpected argument '<arg>'").
  std::function<std::string(std::string_view arg)> unexpected_argument;

  // The command line ss_track documented before every program shared the default style:
  // '=' cut, repeats replace, "<name>: needs a value", a stray argument "unknown option
  // '<arg>' (see --help)". No other program uses it; to be removed with ss_track's rewrite.
  static Style lenient() {
    return {.equals = Equals::cut,
            .repeat_replaces = true,
            .missing_value = [](const std::string& name) { return name + ": needs a value"; },
            .unexpected_argument =
                [](std::string_view arg) {
                  return "unknown option '" + std::string(arg) + "' (see --help)";
                }};
  }
};

class Parser {
public:
  // program: the name in --help, --version and errors (e.g. "ss_demo"); summary: what the
  // program does, shown by --help.
  Parser(std::string program, std::string summary)
      : program_(std::move(program)), summary_(std::move(summary)) {}

  // Usage lines shown by --help instead of "<program> [options]" (one per mode of the program).
  void usage(std::string line) { usage_.push_back(std::move(line)); }

  // ensures: --help prints `text` exactly as given instead of the generated help.
  void help_text(std::string text) { help_text_ = std::move(text); }

  // ensures: parse() follows `s` (see Style).
  void style(Style s) { style_ = std::move(s); }

  // An option with one value, parsed into `target` (whose current value is the default).
  // T: std::string, std::filesystem::path, an integer type or a floating-point type.
  // requires: name starts with "--"; target outlives parse().
  template <class T>
  Declared<T> option(std::string name, std::string value_name, std::string description, T& target) {
    auto c = std::make_shared<detail::Constraint<T>>();
    auto& o = add(std::move(name), std::move(value_name), std::move(description),
                  [c] { return c->expected(); });
    if (!detail::show(target).empty()) o.default_text = detail::show(target);
    o.assign = [c, &target, n = o.name](std::string_view v) { target = c->parse(n, v); };
    return {o, c};
  }

  // A comma-separated list ("--tables 1,3"), each item parsed and checked like option() does;
  // empty items are rejected. The first occurrence replaces `target`'s default, later ones append.
  template <class T>
  Declared<T> list(std::string name, std::string value_name, std::string description,
                   std::vector<T>& target) {
    return many(std::move(name), std::move(value_name), std::move(description), target, true);
  }

  // An option that may be given several times, each value one item (commas are kept).
  template <class T>
  Declared<T> repeated(std::string name, std::string value_name, std::string description,
                       std::vector<T>& target) {
    return many(std::move(name), std::move(value_name), std::move(description), target, false);
  }

  // An option without value: sets `target` to `value` when given.
  void flag(std::string name, std::string description, bool& target, bool value = true) {
    auto& o = add(std::move(name), "", std::move(description), nullptr);
    o.takes_value = false;
    o.assign = [&target, value](std::string_view) { target = value; };
  }

  // Another spelling of an option already declared (e.g. "--data" for "--input"): the same
  // value, checks and once-only rule; listed in --help under the option.
  // requires: `of` declared; `name` a new option name.
  void alias(std::string name, std::string_view of) {
    detail::Option* o = find(of);
    if (!o) throw shadowsense::InvalidArgument("cli::Parser::alias: no option " + std::string(of));
    auto& a = add(std::move(name), o->value_name, "", o->expected);
    a.takes_value = o->takes_value;
    a.target = o;
    o->aliases.push_back(a.name);
  }

  // Arguments that do not start with '-' are appended to `target` (without this, they are an
  // error).
  void positional(std::string value_name, std::string description,
                  std::vector<std::string>& target) {
    positional(std::move(value_name), std::move(description),
               [&target](std::string_view arg) { target.emplace_back(arg); });
  }
  // The same, each argument handed to `take` in command-line order; `take` may throw
  // UsageError (e.g. for one argument too many). requires: take outlives parse().
  void positional(std::string value_name, std::string description,
                  std::function<void(std::string_view)> take) {
    positional_name_ = std::move(value_name);
    positional_description_ = std::move(description);
    positional_ = std::move(take);
  }

  // Whether the option was on the command line (after parse()).
  bool given(std::string_view name) const {
    for (const auto& o : options_)
      if (o->name == name) return o->target ? o->target->seen : o->seen;
    throw shadowsense::InvalidArgument("given(): no option " + std::string(name));
  }

  // Parses argv[1..argc-1] into the bound variables.
  // ensures: on --help / -h or --version, prints to `out` and throws Exit{0}.
  // throws: UsageError for an unknown option, a missing or malformed value, an option given twice
  // (except list/repeated ones, or any with Style::repeat_replaces) or a missing required option.
  void parse(int argc, const char* const* argv, std::ostream& out = std::cout) {
    using Equals = Style::Equals;
    for (int i = 1; i < argc; ++i) {
      const std::string_view arg = argv[i];
      const std::size_t eq = arg.starts_with("--") && style_.equals != Equals::none
                                 ? arg.find('=')
                                 : std::string_view::npos;
      const std::string_view head = style_.equals == Equals::cut ? arg.substr(0, eq) : arg;
      if (head == "--help" || head == "-h") {
        out << help();
        throw Exit{0};
      }
      if (head == "--version") {
        out << program_ << " shadowsense " << shadowsense::version_string << "\n";
        throw Exit{0};
      }
      if (arg.size() < 2 || arg[0] != '-') {
        if (!positional_)
          throw UsageError(style_.unexpected_argument
                               ? style_.unexpected_argument(arg)
                               : "unexpected argument '" + std::string(arg) + "'");
        positional_(arg);
        continue;
      }
      const std::string name(arg.substr(0, eq));
      detail::Option* o = find(name);
      if (o && !o->takes_value && eq != std::string_view::npos && style_.equals == Equals::cut)
        o = nullptr; // "--flag=x": no option of that spelling
      if (!o) throw UsageError("unknown option '" + name + "' (see --help)");
      const detail::Option* spelled = o;
      if (o->target) o = o->target;
      if (o->seen && !o->many && !style_.repeat_replaces)
        throw UsageError(name + ": given more than once");
      // A value's error names the option as the user spelled it (an alias, not its target).
      const auto assign = [&](std::string_view value) {
        if (spelled == o) return o->assign(value);
        try {
          o->assign(value);
        } catch (const UsageError& e) {
          const std::string what = e.what();
          if (!what.starts_with(o->name + ":")) throw;
          throw UsageError(name + what.substr(o->name.size()));
        }
      };
      if (!o->takes_value) {
        if (eq != std::string_view::npos) throw UsageError(name + ": takes no value");
        assign({});
      } else if (eq != std::string_view::npos) {
        assign(arg.substr(eq + 1));
      } else {
        // "--out --max-side 512": the next word is an option, not the missing value (a value
        // that looks like an option can still be given as "--out=--max-side").
        const auto next_is_option = [&] {
          const std::string_view next = argv[i + 1];
          return next.starts_with("--") && find(next.substr(0, next.find('='))) != nullptr;
        };
        if (i + 1 >= argc || next_is_option())
          throw UsageError(style_.missing_value
                               ? style_.missing_value(name)
                               : name + ": missing value (expected " + o->value_name +
                                     (o->expected().empty() ? "" : ", " + o->expected()) + ")");
        assign(argv[++i]);
      }
      o->seen = true;
    }
    for (const auto& o : options_)
      if (o->required && !o->seen)
        throw UsageError("missing required option " + o->name + " " + o->value_name);
  }
  void parse(int argc, char** argv, std::ostream& out = std::cout) {
    parse(argc, const_cast<const char* const*>(argv), out);
  }

  // The --help text: the one given to help_text(), else usage lines, summary, then one entry
  // per option with its description, accepted values and default.
  std::string help() const {
    if (!help_text_.empty()) return help_text_;
    std::string s;
    if (usage_.empty())
      s += "usage: " + program_ + " [options]" +
           (positional_ ? " " + positional_name_ + "..." : "") + "\n";
    for (std::size_t i = 0; i < usage_.size(); ++i)
      s += (i ? "       " : "usage: ") + usage_[i] + "\n";
    s += "\n" + wrap(summary_, 0) + "\n\noptions:\n";
    const auto entry = [&](std::string left, const std::string& text) {
      left = "  " + left;
      s += left.size() < 28 ? left + std::string(28 - left.size(), ' ')
                            : left + "\n" + std::string(28, ' ');
      s += wrap(text, 28) + "\n";
    };
    if (positional_) entry(positional_name_ + "...", positional_description_);
    for (const auto& o : options_) {
      if (o->target) continue; // listed with the option it spells
      std::string text = o->description;
      std::vector<std::string> notes;
      if (!o->aliases.empty()) {
        std::string also = "also";
        for (const auto& a : o->aliases) also += " " + a;
        notes.push_back(also);
      }
      if (o->takes_value && !o->expected().empty())
        notes.push_back(o->split ? "a comma-separated list, each " + o->expected() : o->expected());
      if (o->many && !o->split) notes.push_back("may be repeated");
      if (o->required)
        notes.push_back("required");
      else if (!o->default_text.empty())
        notes.push_back("default " + o->default_text);
      for (std::size_t i = 0; i < notes.size(); ++i) text += (i ? "; " : " (") + notes[i];
      if (!notes.empty()) text += ")";
      entry(o->takes_value ? o->name + " " + o->value_name : o->name, text);
    }
    entry("-h, --help", "print this help and exit");
    entry("--version", "print the program and library version and exit");
    return s;
  }

private:
  // `text` broken at spaces into lines of at most 100 columns, continuation lines indented by
  // `indent` (the first line starts at column `indent` too).
  static std::string wrap(const std::string& text, std::size_t indent) {
    std::string out;
    std::size_t column = indent;
    for (std::size_t start = 0; start < text.size();) {
      std::size_t end = text.find(' ', start);
      if (end == std::string::npos) end = text.size();
      const std::size_t word = end - start;
      if (column > indent && column + 1 + word > 100) {
        out += '\n';
        out.append(indent, ' ');
        column = indent;
      } else if (column > indent) {
        out += ' ';
        ++column;
      }
      out.append(text, start, word);
      column += word;
      start = end + 1;
    }
    return out;
  }

  detail::Option& add(std::string name, std::string value_name, std::string description,
                      std::function<std::string()> expected) {
    if (!name.starts_with("--") || name.size() < 3 || name.find('=') != std::string::npos ||
        find(name) || name == "--help" || name == "--version")
      throw shadowsense::InvalidArgument("cli::Parser: bad or duplicate option name '" + name +
                                         "'");
    auto o = std::make_unique<detail::Option>();
    o->name = std::move(name);
    o->value_name = std::move(value_name);
    o->description = std::move(description);
    o->expected = std::move(expected);
    options_.push_back(std::move(o));
    return *options_.back();
  }
  template <class T>
  Declared<T> many(std::string name, std::string value_name, std::string description,
                   std::vector<T>& target, bool split) {
    auto c = std::make_shared<detail::Constraint<T>>();
    auto& o = add(std::move(name), std::move(value_name), std::move(description),
                  [c] { return c->expected(); });
    o.many = true;
    o.split = split;
    for (std::size_t i = 0; i < target.size(); ++i) {
      if (i) o.default_text += ',';
      o.default_text += detail::show(target[i]);
    }
    o.assign = [c, &target, &o, split](std::string_view v) {
      if (!o.seen) target.clear();
      if (!split) return target.push_back(c->parse(o.name, v));
      for (std::size_t start = 0;;) {
        const std::size_t comma = v.find(',', start);
        const std::string_view item = v.substr(start, comma - start);
        if (item.empty())
          throw UsageError(o.name + ": empty item in '" + std::string(v) + "' (expected " +
                           c->expected() + " per item)");
        target.push_back(c->parse(o.name, item));
        if (comma == std::string_view::npos) break;
        start = comma + 1;
      }
    };
    return {o, c};
  }

  detail::Option* find(std::string_view name) const {
    for (const auto& o : options_)
      if (o->name == name) return o.get();
    return nullptr;
  }

  std::string program_, summary_, positional_name_, positional_description_, help_text_;
  std::vector<std::string> usage_;
  std::vector<std::unique_ptr<detail::Option>> options_;
  std::function<void(std::string_view)> positional_; // unset: positional arguments are errors
  Style style_;
};

// Runs a program's body: returns what it returns; Exit{code} -> code; any exception -> one line
// "<program>: error: <what>" on stderr (line breaks in the message become spaces) and 2.
template <class Body>
int run(std::string_view program, Body&& body) noexcept {
  const auto report = [&](std::string what) {
    for (char& ch : what)
      if (ch == '\n' || ch == '\r') ch = ' ';
    std::cout.flush();
    std::cerr << program << ": error: " << what << "\n";
    return 2;
  };
  try {
    return body();
  } catch (const Exit& e) {
    return e.code;
  } catch (const std::exception& e) {
    return report(e.what());
  } catch (...) {
    return report("unknown exception");
  }
}

// Refuses a window option (e.g. "--show") when no window can open: this program built without
// OpenCV highgui, or (on X11/Wayland systems) neither DISPLAY nor WAYLAND_DISPLAY is set, where
// highgui would abort the program instead of failing.
// ensures: returns when a window can be tried. throws: UsageError "<option>: ..." naming why.
// display_problem(have_highgui): the reason as text, empty when a window can be tried.
inline std::string display_problem(bool have_highgui) {
  if (!have_highgui) return "this build has no OpenCV highgui (install libopencv-highgui-dev)";
#if !defined(_WIN32) && !defined(__APPLE__)
  const auto set = [](const char* name) {
    const char* v = std::getenv(name);
    return v && *v;
  };
  if (!set("DISPLAY") && !set("WAYLAND_DISPLAY"))
    return "no display to open a window on (DISPLAY and WAYLAND_DISPLAY are unset)";
#endif
  return {};
}
inline void require_display(std::string_view option) {
#ifdef SHADOWSENSE_HAVE_HIGHGUI
  const std::string why = display_problem(true);
#else
  const std::string why = display_problem(false);
#endif
  if (!why.empty()) throw UsageError(std::string(option) + ": " + why);
}

// Where TUIO goes: --tuio HOST[:PORT].
using TuioTarget = shadowsense::HostPort;
// Parses "HOST", "HOST:PORT", "[IPV6]", "[IPV6]:PORT" (e.g. "127.0.0.1", "localhost:3334",
// "[::1]:3334"); a bare IPv6 address ("::1") is taken whole, with the default port. The
// library's parser (output/udp_sender.hpp, try_parse_host_port) with a required host.
// ensures: host without brackets, non-empty; port in 1..65535 (default_port when not given).
// throws: UsageError "<option>: <reason> in '<spec>'; expected HOST[:PORT], ...".
inline TuioTarget parse_tuio_target(std::string_view spec, std::string_view option = "--tuio",
                                    std::uint16_t default_port = 3333) {
  TuioTarget t;
  const std::string why =
      shadowsense::try_parse_host_port(spec, {.host = {}, .port = default_port}, t);
  if (!why.empty()) throw UsageError(std::string(option) + ": " + why);
  return t;
}

// A progress line on stderr for long runs: "\r<program>: frame <i> of <n>" at most once a
// second while frames go by, then "<program>: <n> frames" on a line of its own at finish().
// enabled = false (e.g. --quiet) prints nothing. Programs show it when the input's length is
// unknown or above 100 frames (Progress::wanted). One thread.
class Progress {
public:
  Progress(std::string program, std::optional<std::size_t> total, bool enabled,
           std::ostream& err = std::cerr)
      : program_(std::move(program)), total_(total), enabled_(enabled), err_(&err),
        last_(std::chrono::steady_clock::now()) {}
  static bool wanted(bool quiet, std::optional<std::size_t> total) {
    return !quiet && (!total || *total > 100);
  }
  // After frame `done` (counted from 1).
  void update(std::size_t done) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    if (now - last_ < std::chrono::seconds(1)) return;
    last_ = now;
    *err_ << "\r" << program_ << ": frame " << done;
    if (total_) *err_ << " of " << *total_;
    *err_ << std::flush;
  }
  void finish(std::size_t done) {
    if (enabled_) *err_ << "\r" << program_ << ": " << done << " frames\n" << std::flush;
  }

private:
  std::string program_;
  std::optional<std::size_t> total_;
  bool enabled_;
  std::ostream* err_;
  std::chrono::steady_clock::time_point last_;
};

} // namespace cli
