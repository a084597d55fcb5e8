// The programs' shared command line (examples/common/cli.hpp), JSON writer (json.hpp) and
// ss_calibrate's memory plan (calibrate_budget.hpp); the atomic file replacement they use is
// core/atomic_file.hpp (tests/test_atomic_file.cpp).
#include <doctest/doctest.h>

#include "common/calibrate_budget.hpp"
#include "common/cli.hpp"
#include "common/json.hpp"

#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "common/files.hpp"
#include <sys/resource.h>

namespace fs = std::filesystem;

namespace {

// Parses `args` (without the program name) with the options every test declares.
struct Fixture {
  std::string out;
  fs::path model = "models/default.ssm";
  int users = 4;
  std::uint64_t seed = 1;
  unsigned frames = 20;
  double level = 0.5;
  bool overwrite = false, normalise = true;
  std::string mode = "relative";
  std::vector<int> tables{1, 2, 3, 4};
  std::vector<std::string> speed, images;
  cli::Parser p{"ss_test", "Tests the parser."};
  std::ostringstream printed;

  Fixture() {
    p.option("--out", "DIR", "output folder", out).required();
    p.option("--model", "PATH", "model file", model);
    p.option("--users", "N", "number of users", users).range(1, 1000);
    p.option("--seed", "S", "random seed", seed);
    p.option("--frames", "F", "frames per gesture", frames);
    p.option("--lighting-level", "L", "light level", level).range(0.0, 1.0);
    p.option("--mode", "M", "thresholds", mode).choices({"relative", "fixed_ranges"});
    p.flag("--overwrite", "replace an existing folder", overwrite);
    p.flag("--no-lighting-normalise", "paper preprocessing", normalise, false);
    p.list("--tables", "LIST", "tables to compute", tables).range(1, 4);
    p.repeated("--speed", "MODEL[@WxH]", "time a model", speed);
  }
  void parse(std::vector<const char*> args) {
    args.insert(args.begin(), "ss_test");
    p.parse(static_cast<int>(args.size()), args.data(), printed);
  }
  // The UsageError message of parsing `args`, or "" if it parsed.
  std::string error(std::vector<const char*> args) {
    try {
      parse(std::move(args));
    } catch (const cli::UsageError& e) {
      return e.what();
    }
    return "";
  }
};

std::string read(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}

} // namespace

TEST_CASE("values in both forms, defaults kept, flags, lists and repeated options") {
  Fixture f;
  f.parse({"--out", "data", "--users=7", "--seed", "18446744073709551615", "--lighting-level", "0",
           "--overwrite", "--no-lighting-normalise", "--tables", "3,1", "--tables=4", "--speed",
           "a,b.ssm", "--speed=c.ssm@80x44", "--mode=fixed_ranges"});
  CHECK(f.out == "data");
  CHECK(f.users == 7);
  CHECK(f.seed == 18446744073709551615ull);
  CHECK(f.level == 0.0);
  CHECK(f.overwrite);
  CHECK_FALSE(f.normalise);
  CHECK(f.tables == std::vector<int>{3, 1, 4});
  CHECK(f.speed == std::vector<std::string>{"a,b.ssm", "c.ssm@80x44"});
  CHECK(f.mode == "fixed_ranges");
  CHECK(f.model == fs::path("models/default.ssm")); // untouched default
  CHECK(f.frames == 20u);
  CHECK(f.p.given("--users"));
  CHECK_FALSE(f.p.given("--model"));
  CHECK(f.printed.str().empty());

  Fixture g; // a value may start with '-' and may be empty after '='
  g.parse({"--out=", "--lighting-level", "1"});
  CHECK(g.out.empty());
  CHECK(g.level == 1.0);
}

TEST_CASE("--help and --version print on the given stream and exit 0") {
  Fixture f;
  try {
    f.parse({"--users", "2", "--help"});
    FAIL("no Exit");
  } catch (const cli::Exit& e) {
    CHECK(e.code == 0);
  }
  const std::string h = f.printed.str();
  CHECK(h.starts_with("usage: ss_test [options]\n\nTests the parser.\n"));
  CHECK(h.find(
            "  --users N                 number of users (an integer in [1, 1000]; default 4)\n") !=
        std::string::npos);
  CHECK(h.find("\n  --out DIR                 output folder (required)\n") != std::string::npos);
  CHECK(h.find("\n  --lighting-level L        light level (a number in [0, 1]; default 0.5)\n") !=
        std::string::npos);
  CHECK(h.find("(one of relative, fixed_ranges; default relative)") != std::string::npos);
  CHECK(
      h.find(
          "  --tables LIST             tables to compute (a comma-separated list, each an integer "
          "in [1, 4];\n                            default 1,2,3,4)\n") != std::string::npos);
  CHECK(h.find("  --speed MODEL[@WxH]       time a model (may be repeated)\n") !=
        std::string::npos);
  CHECK(h.find("  --no-lighting-normalise   paper preprocessing\n") != std::string::npos);
  CHECK(h.find("--help") != std::string::npos);

  Fixture v;
  try {
    v.parse({"--version"});
    FAIL("no Exit");
  } catch (const cli::Exit& e) {
    CHECK(e.code == 0);
  }
  CHECK(v.printed.str() ==
        std::string("ss_test shadowsense ") + shadowsense::version_string + "\n");
  Fixture s;
  CHECK_THROWS_AS(s.parse({"-h"}), cli::Exit);
}

TEST_CASE("strict numbers: the whole text, the type's range and the option's range") {
  const auto err = [](std::vector<const char*> args) {
    Fixture f;
    args.insert(args.begin(), {"--out", "x"});
    return f.error(std::move(args));
  };
  CHECK(err({"--users", "2.9"}) == "--users: expected an integer in [1, 1000], got '2.9'");
  CHECK(err({"--users", "abc"}) == "--users: expected an integer in [1, 1000], got 'abc'");
  CHECK(err({"--users", "1e12"}) == "--users: expected an integer in [1, 1000], got '1e12'");
  CHECK(err({"--users", "99999999999"}) ==
        "--users: expected an integer in [1, 1000], got '99999999999'");
  CHECK(err({"--users", "0"}) == "--users: expected an integer in [1, 1000], got '0'");
  CHECK(err({"--users", "1001"}) == "--users: expected an integer in [1, 1000], got '1001'");
  CHECK(err({"--users", " 5"}) == "--users: expected an integer in [1, 1000], got ' 5'");
  CHECK(err({"--users", "5 "}) == "--users: expected an integer in [1, 1000], got '5 '");
  CHECK(err({"--users", "+5"}) == "--users: expected an integer in [1, 1000], got '+5'");
  CHECK(err({"--users="}) == "--users: expected an integer in [1, 1000], got ''");
  CHECK(err({"--seed", "-1"}) == "--seed: expected a non-negative integer, got '-1'");
  CHECK(err({"--seed", "18446744073709551616"}) ==
        "--seed: expected a non-negative integer, got '18446744073709551616'");
  CHECK(err({"--frames", "4294967296"}) ==
        "--frames: expected a non-negative integer, got '4294967296'");
  CHECK(err({"--lighting-level", "nan"}) ==
        "--lighting-level: expected a number in [0, 1], got 'nan'");
  CHECK(err({"--lighting-level", "inf"}) ==
        "--lighting-level: expected a number in [0, 1], got 'inf'");
  CHECK(err({"--lighting-level", "1.0000001"}) ==
        "--lighting-level: expected a number in [0, 1], got '1.0000001'");
  CHECK(err({"--lighting-level", "0.5x"}) ==
        "--lighting-level: expected a number in [0, 1], got '0.5x'");
  CHECK(err({"--mode", "fixed"}) == "--mode: expected one of relative, fixed_ranges, got 'fixed'");
  CHECK(err({"--tables", "1,5"}) == "--tables: expected an integer in [1, 4], got '5'");
  CHECK(err({"--tables", "1,,2"}) ==
        "--tables: empty item in '1,,2' (expected an integer in [1, 4] per item)");
  CHECK(err({"--tables", "2,"}) ==
        "--tables: empty item in '2,' (expected an integer in [1, 4] per item)");
}

TEST_CASE("unknown, repeated, valueless and missing options") {
  Fixture f;
  CHECK(f.error({"--out", "x", "--bogus"}) == "unknown option '--bogus' (see --help)");
  Fixture g;
  CHECK(g.error({"--out", "x", "--bogus=1"}) == "unknown option '--bogus' (see --help)");
  Fixture h;
  CHECK(h.error({"--out", "x", "--users"}) ==
        "--users: missing value (expected N, an integer in [1, 1000])");
  Fixture i;
  CHECK(i.error({"--users", "3"}) == "missing required option --out DIR");
  Fixture n;
  CHECK(n.error({"--out"}) == "--out: missing value (expected DIR)");
  // The next word is an option: the value is missing (not a file named "--users").
  Fixture m1;
  CHECK(m1.error({"--out", "--users", "3"}) == "--out: missing value (expected DIR)");
  Fixture m2;
  CHECK(m2.error({"--out", "--users=3"}) == "--out: missing value (expected DIR)");
  Fixture m3; // a value spelled with '=' may look like an option
  m3.parse({"--out=--users", "--users", "5"});
  CHECK(m3.out == "--users");
  CHECK(m3.users == 5);
  Fixture j;
  CHECK(j.error({"--out", "x", "--out", "y"}) == "--out: given more than once");
  Fixture k;
  CHECK(k.error({"--out", "x", "--overwrite=yes"}) == "--overwrite: takes no value");
  Fixture l;
  CHECK(l.error({"--out", "x", "stray"}) == "unexpected argument 'stray'");
  Fixture m;
  CHECK(m.error({"--out", "x", "-u"}) == "unknown option '-u' (see --help)");
}

TEST_CASE("positional arguments when declared") {
  Fixture f;
  f.p.positional("IMAGE", "images to classify", f.images);
  f.parse({"a.png", "--out", "x", "b.png", "-"});
  CHECK(f.images == std::vector<std::string>{"a.png", "b.png", "-"});
  CHECK(f.p.help().starts_with("usage: ss_test [options] IMAGE...\n"));
}

TEST_CASE("a documented command line of its own: help text, wording, '=' and repeats") {
  // Parses `args` with a parser in `style` declaring --n (1..9, own wording), --f (own check),
  // a flag --q and positional arguments taken one at a time; the error message or "".
  struct Own {
    int n = 5;
    std::string f = "a";
    bool q = false;
    std::vector<std::string> taken;
    std::ostringstream printed;
    std::string run(cli::Style style, std::vector<const char*> args) {
      cli::Parser p("ss_own", "unused");
      p.help_text("usage: ss_own [--n N] [--f a|b] [--q] ARG\nverbatim\n");
      p.style(std::move(style));
      p.option("--n", "N", "n", n).range(1, 9).expected("a digit 1..9");
      p.option("--f", "F", "f", f).check([](const std::string& v) {
        if (v != "a" && v != "b") throw cli::UsageError("--f '" + v + "': expected a or b");
      });
      p.flag("--q", "q", q);
      p.positional("ARG", "arguments", [this](std::string_view a) {
        if (a == "stop") throw cli::UsageError("no 'stop' please");
        taken.emplace_back(a);
      });
      args.insert(args.begin(), "ss_own");
      try {
        p.parse(static_cast<int>(args.size()), args.data(), printed);
      } catch (const cli::UsageError& e) {
        return e.what();
      }
      return "";
    }
  };
  using E = cli::Style::Equals;
  const cli::Style plain;
  cli::Style cut, none;
  cut.equals = E::cut;
  cut.repeat_replaces = true;
  cut.missing_value = [](const std::string& n) { return n + ": needs a value"; };
  none.equals = E::none;
  const cli::Style lenient = cli::Style::lenient();

  // The help text is printed as given, whatever the style.
  for (const cli::Style* s : std::initializer_list<const cli::Style*>{&plain, &cut, &none}) {
    Own o;
    CHECK_THROWS_AS(o.run(*s, {"--help"}), cli::Exit);
    CHECK(o.printed.str() == "usage: ss_own [--n N] [--f a|b] [--q] ARG\nverbatim\n");
  }
  // expected() rewords the value's description; the range still applies.
  CHECK(Own().run(plain, {"--n", "0"}) == "--n: expected a digit 1..9, got '0'");
  CHECK(Own().run(plain, {"--n", "x"}) == "--n: expected a digit 1..9, got 'x'");
  CHECK(Own().run(plain, {"--n"}) == "--n: missing value (expected N, a digit 1..9)");
  // check() runs on values that passed, before they are stored, and its message stands.
  Own c;
  CHECK(c.run(plain, {"--f", "b"}) == "");
  CHECK(c.f == "b");
  Own d;
  CHECK(d.run(plain, {"--f", "z"}) == "--f 'z': expected a or b");
  CHECK(d.f == "a");
  // A positional function sees every argument in order, and its error stops the parse there.
  Own e;
  CHECK(e.run(plain, {"x", "--n", "2", "-", "y"}) == "");
  CHECK(e.taken == std::vector<std::string>{"x", "-", "y"});
  Own g;
  CHECK(g.run(plain, {"x", "stop", "--bogus"}) == "no 'stop' please");
  CHECK(g.taken == std::vector<std::string>{"x"});

  // Equals::cut: values after '=', "--help=..." is --help, "--q=..." an unknown option; repeats
  // replace; the missing-value wording is the style's.
  Own h;
  CHECK(h.run(cut, {"--n=3", "--n", "4", "--f=b", "--q", "--q"}) == "");
  CHECK(h.n == 4);
  CHECK(h.f == "b");
  CHECK(h.q);
  CHECK_THROWS_AS(Own().run(cut, {"--help=1"}), cli::Exit);
  CHECK_THROWS_AS(Own().run(cut, {"--version=x"}), cli::Exit);
  CHECK(Own().run(cut, {"--q=1"}) == "unknown option '--q' (see --help)");
  CHECK(Own().run(cut, {"--n"}) == "--n: needs a value");
  CHECK(Own().run(cut, {"--bogus=1"}) == "unknown option '--bogus' (see --help)");
  // The default style for the same arguments.
  CHECK(Own().run(plain, {"--n", "3", "--n", "4"}) == "--n: given more than once");
  CHECK(Own().run(plain, {"--help=1"}) == "unknown option '--help' (see --help)");
  CHECK(Own().run(plain, {"--q=1"}) == "--q: takes no value");
  // Equals::none: '=' belongs to the name.
  Own k;
  CHECK(k.run(none, {"--n", "2"}) == "");
  CHECK(k.n == 2);
  CHECK(Own().run(none, {"--n=2"}) == "unknown option '--n=2' (see --help)");
  CHECK(Own().run(none, {"--q=1"}) == "unknown option '--q=1' (see --help)");
  CHECK(Own().run(none, {"--help=1"}) == "unknown option '--help=1' (see --help)");
  CHECK(Own().run(none, {"--q", "--q"}) == "--q: given more than once");

  // Style::lenient(): cut at '=', repeats replace, its own wording for a missing value and, with
  // no positional() declared, for a stray argument.
  const auto stray = [](const cli::Style& s, const char* arg) {
    cli::Parser p("ss_own", "unused");
    p.style(s);
    const char* argv[] = {"ss_own", arg};
    try {
      p.parse(2, argv);
    } catch (const cli::UsageError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  CHECK(stray(lenient, "foo") == "unknown option 'foo' (see --help)");
  CHECK(stray(lenient, "-") == "unknown option '-' (see --help)");
  CHECK(stray(plain, "foo") == "unexpected argument 'foo'");
  Own m;
  CHECK(m.run(lenient, {"--n=3", "--n", "4", "--q", "--q"}) == "");
  CHECK(m.n == 4);
  CHECK(Own().run(lenient, {"--n"}) == "--n: needs a value");
  CHECK(Own().run(lenient, {"--q=1"}) == "unknown option '--q' (see --help)");
  CHECK_THROWS_AS(Own().run(lenient, {"--help=1"}), cli::Exit);
}

TEST_CASE("an alias spells the same option: one value, once, listed under the option") {
  std::string input;
  int n = 1;
  cli::Parser p{"ss_test", "Tests aliases."};
  p.option("--input", "DIR", "input folder", input).required();
  p.alias("--data", "--input");
  p.option("--n", "N", "a number", n).range(1, 9);
  p.alias("--count", "--n");
  const auto parse = [&](std::vector<const char*> args) -> std::string {
    input.clear();
    cli::Parser q{"ss_test", "Tests aliases."};
    q.option("--input", "DIR", "input folder", input).required();
    q.alias("--data", "--input");
    q.option("--n", "N", "a number", n).range(1, 9);
    q.alias("--count", "--n");
    args.insert(args.begin(), "ss_test");
    try {
      q.parse(static_cast<int>(args.size()), args.data());
    } catch (const cli::UsageError& e) {
      return e.what();
    }
    return "";
  };
  CHECK(parse({"--data", "d1"}) == "");
  CHECK(input == "d1");
  CHECK(parse({"--data=d2", "--count=3"}) == "");
  CHECK(input == "d2");
  CHECK(n == 3);
  CHECK(parse({"--input", "a", "--data", "b"}) == "--data: given more than once");
  CHECK(parse({"--data=x", "--count=10"}) == "--count: expected an integer in [1, 9], got '10'");
  CHECK(parse({}) == "missing required option --input DIR");
  const std::string help = p.help();
  CHECK(help.find("input folder (also --data; required)") != std::string::npos);
  CHECK(help.find("  --data") == std::string::npos);
  CHECK_THROWS_AS(p.alias("--other", "--nope"), shadowsense::InvalidArgument);
  CHECK_THROWS_AS(p.alias("--n", "--input"), shadowsense::InvalidArgument);
}

TEST_CASE("require_display: --show refused in one line without highgui or a display") {
  const auto keep = [](const char* name) -> std::optional<std::string> {
    const char* v = std::getenv(name);
    return v ? std::optional<std::string>(v) : std::nullopt;
  };
  const auto display = keep("DISPLAY"), wayland = keep("WAYLAND_DISPLAY");
  ::unsetenv("DISPLAY");
  ::unsetenv("WAYLAND_DISPLAY");
  CHECK(cli::display_problem(true) ==
        "no display to open a window on (DISPLAY and WAYLAND_DISPLAY are unset)");
  CHECK(cli::display_problem(false) ==
        "this build has no OpenCV highgui (install libopencv-highgui-dev)");
  ::setenv("DISPLAY", "", 1); // set but empty: no display either
  CHECK(cli::display_problem(true) != "");
  ::setenv("WAYLAND_DISPLAY", "wayland-0", 1);
  CHECK(cli::display_problem(true) == "");
  ::unsetenv("WAYLAND_DISPLAY");
  ::setenv("DISPLAY", ":0", 1);
  CHECK(cli::display_problem(true) == "");
  CHECK(cli::display_problem(false) != ""); // a display is no use without highgui
  // This test is built without SHADOWSENSE_HAVE_HIGHGUI: the message names the option.
  CHECK_THROWS_WITH_AS(cli::require_display("--show"),
                       "--show: this build has no OpenCV highgui (install libopencv-highgui-dev)",
                       cli::UsageError);
  const auto restore = [](const char* name, const std::optional<std::string>& v) {
    if (v)
      ::setenv(name, v->c_str(), 1);
    else
      ::unsetenv(name);
  };
  restore("DISPLAY", display);
  restore("WAYLAND_DISPLAY", wayland);
}

TEST_CASE("parse_tuio_target: HOST[:PORT], IPv6 in brackets") {
  const auto t = [](const char* spec) {
    const cli::TuioTarget x = cli::parse_tuio_target(spec);
    return x.host + " " + std::to_string(x.port);
  };
  CHECK(t("127.0.0.1") == "127.0.0.1 3333");
  CHECK(t("127.0.0.1:3334") == "127.0.0.1 3334");
  CHECK(t("localhost:1") == "localhost 1");
  CHECK(t("[::1]:3334") == "::1 3334");
  CHECK(t("[::1]") == "::1 3333");
  CHECK(t("::1") == "::1 3333");
  CHECK(t("fe80::1:65535") == "fe80::1:65535 3333"); // bare IPv6: all of it is the host
  CHECK(cli::parse_tuio_target("h", "--tuio", 4000).port == 4000);
  const auto error = [](const char* spec) -> std::string {
    try {
      cli::parse_tuio_target(spec);
    } catch (const cli::UsageError& e) {
      return e.what();
    }
    return "";
  };
  const std::string form =
      "'; expected HOST[:PORT], e.g. 127.0.0.1:3333 or [::1]:3333, PORT in 1..65535";
  CHECK(error("") == "--tuio: no host in '" + form);
  CHECK(error(":3333") == "--tuio: no host in ':3333" + form);
  CHECK(error("[]:3333") == "--tuio: no host in '[]:3333" + form);
  CHECK(error("host:") == "--tuio: no port after ':' in 'host:" + form);
  CHECK(error("host:0") == "--tuio: bad port '0' in 'host:0" + form);
  CHECK(error("host:65536") == "--tuio: bad port '65536' in 'host:65536" + form);
  CHECK(error("host:12x") == "--tuio: bad port '12x' in 'host:12x" + form);
  CHECK(error("[::1:3333") == "--tuio: no ']' after the IPv6 address in '[::1:3333" + form);
  CHECK(error("[::1]3333") == "--tuio: text after ']' in '[::1]3333" + form);
  CHECK(error("[::1]:") == "--tuio: no port after ':' in '[::1]:" + form);
}

TEST_CASE("Progress: the closing line, nothing when disabled; wanted for long inputs") {
  std::ostringstream err;
  cli::Progress on("ss_test", 250, true, err);
  on.update(1); // within the first second: no line yet
  on.finish(250);
  CHECK(err.str() == "\rss_test: 250 frames\n");
  std::ostringstream quiet;
  cli::Progress off("ss_test", 250, false, quiet);
  off.update(1);
  off.finish(250);
  CHECK(quiet.str().empty());
  CHECK(cli::Progress::wanted(false, std::nullopt));
  CHECK(cli::Progress::wanted(false, 101));
  CHECK_FALSE(cli::Progress::wanted(false, 100));
  CHECK_FALSE(cli::Progress::wanted(true, 1000));
}

TEST_CASE("declaring a bad option is a programming error") {
  cli::Parser p("ss_test", "x");
  int n = 0;
  bool b = false;
  p.option("--n", "N", "n", n);
  CHECK_THROWS_AS(p.option("--n", "N", "again", n), shadowsense::InvalidArgument);
  CHECK_THROWS_AS(p.option("-n", "N", "single dash", n), shadowsense::InvalidArgument);
  CHECK_THROWS_AS(p.flag("--help", "reserved", b), shadowsense::InvalidArgument);
  CHECK_THROWS_AS(p.option("--m", "M", "m", n).range(2, 1), shadowsense::InvalidArgument);
}

TEST_CASE("run(): exit codes and one error line") {
  CHECK(cli::run("ss_test", [] { return 0; }) == 0);
  CHECK(cli::run("ss_test", [] { return 3; }) == 3);
  CHECK(cli::run("ss_test", []() -> int { throw cli::Exit{0}; }) == 0);
  std::ostringstream err;
  auto* old = std::cerr.rdbuf(err.rdbuf());
  const int a = cli::run("ss_test", []() -> int { throw cli::UsageError("--x: bad"); });
  const int b = cli::run("ss_test", []() -> int { throw shadowsense::IoError("line\nbreak"); });
  std::cerr.rdbuf(old);
  CHECK(a == 2);
  CHECK(b == 2);
  CHECK(err.str() == "ss_test: error: --x: bad\nss_test: error: line break\n");
}

TEST_CASE("JSON: nesting, commas, layouts and exact numbers") {
  cli::JsonWriter j;
  j.begin_object();
  j.field("n", 3).field("u", std::uint64_t{18446744073709551615ull}).field("neg", -2);
  j.field("x", 0.1).field("tiny", 1e-300).field("f", 0.5f).field("yes", true);
  j.key("none").value(nullptr);
  j.key("list").begin_array(cli::JsonWriter::compact).value(1).value(2.5);
  j.begin_array().value("a").end_array().end_array();
  j.key("empty").begin_object().end_object();
  j.key("rows").begin_array().begin_object(cli::JsonWriter::compact).field("k", "v").end_object();
  j.end_array();
  j.end_object();
  CHECK(j.str() == "{\n"
                   "  \"n\": 3,\n"
                   "  \"u\": 18446744073709551615,\n"
                   "  \"neg\": -2,\n"
                   "  \"x\": 0.1,\n"
                   "  \"tiny\": 1e-300,\n"
                   "  \"f\": 0.5,\n"
                   "  \"yes\": true,\n"
                   "  \"none\": null,\n"
                   "  \"list\": [1, 2.5, [\"a\"]],\n"
                   "  \"empty\": {},\n"
                   "  \"rows\": [\n"
                   "    {\"k\": \"v\"}\n"
                   "  ]\n"
                   "}");
}

TEST_CASE("JSON strings: escapes and UTF-8") {
  const auto json = [](std::string_view s) {
    cli::JsonWriter j;
    j.value(s);
    return j.str();
  };
  CHECK(json("plain") == "\"plain\"");
  CHECK(json("a\"b\\c/d") == "\"a\\\"b\\\\c/d\"");
  CHECK(json("\n\t\r\b\f") == "\"\\n\\t\\r\\b\\f\""); // the one escaper's short forms
  CHECK(json(std::string_view("\0\x1f\x7f", 3)) == "\"\\u0000\\u001f\\u007f\"");
  CHECK(json("caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x91\x8b") ==
        "\"caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x91\x8b\"");
  CHECK(json("bad \xff end") == "\"bad \\ufffd end\"");
  CHECK(json("cut \xe2\x82") == "\"cut \\ufffd\\ufffd\"");
  CHECK(json("overlong \xc0\xaf") == "\"overlong \\ufffd\\ufffd\"");
  CHECK(json("surrogate \xed\xa0\x80") == "\"surrogate \\ufffd\\ufffd\\ufffd\"");
  CHECK(json("too big \xf4\x90\x80\x80") == "\"too big \\ufffd\\ufffd\\ufffd\\ufffd\"");
}

TEST_CASE("JSON: non-finite numbers and misuse are errors") {
  cli::JsonWriter j;
  j.begin_object();
  CHECK_THROWS_WITH_AS(j.field("accuracy", std::nan("")),
                       "JSON output: the value of \"accuracy\" is nan; expected a finite number",
                       shadowsense::InvalidArgument);
  cli::JsonWriter k;
  k.begin_array();
  CHECK_THROWS_AS(k.value(std::numeric_limits<double>::infinity()), shadowsense::InvalidArgument);
  CHECK_THROWS_AS(k.key("x"), std::logic_error);
  CHECK_THROWS_AS(k.end_object(), std::logic_error);
  CHECK_THROWS_AS(k.str(), std::logic_error); // incomplete
  k.end_array();
  CHECK(k.str() == "[]");
  CHECK_THROWS_AS(k.value(1), std::logic_error); // a second document
  cli::JsonWriter m;
  m.begin_object();
  CHECK_THROWS_AS(m.value(1), std::logic_error); // no key
  m.key("a");
  CHECK_THROWS_AS(m.end_object(), std::logic_error); // key without value
}

TEST_CASE("JsonWriter::save replaces the file through core/atomic_file.hpp, never half-written") {
  const fs::path d = tests::fresh_dir("cli_json_save");
  const fs::path target = d / "score.json";
  cli::JsonWriter j;
  j.begin_array(cli::JsonWriter::compact).value("a\"b").end_array();
  j.save(target);
  CHECK(read(target) == "[\"a\\\"b\"]\n");
  CHECK_THROWS_AS(j.save(d / "missing" / "f.json"), shadowsense::IoError);
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(d)) names.push_back(e.path().filename().string());
  CHECK(names == std::vector<std::string>{"score.json"}); // no temporary file left
}

TEST_CASE("calibrate_budget: frames held at 4K stay within the default budget, under 1 GB") {
  namespace cb = calib_budget;
  const cv::Size k4(3840, 2160);
  const double budget = static_cast<double>(cb::kDefaultMiB) * cb::kMiB;
  CHECK(budget < 1e9);
  // (943,718,400 - 104,857,600 - 66 x 8,294,400) / 24,883,200 = 11.7; with the box search's
  // 80 bytes a pixel, 7.05.
  CHECK(cb::frames_within(k4, budget, false) == 11);
  CHECK(cb::frames_within(k4, budget, true) == 7);
  for (const bool labelled : {false, true}) {
    const std::size_t n = cb::frames_within(k4, budget, labelled);
    CHECK(cb::estimate(k4, n, labelled) <= budget);
    CHECK(cb::estimate(k4, n + 1, labelled) > budget);
  }
  // The generator's 635x350 frames: the defaults (60 empty, 60 touch) fit untouched.
  CHECK(cb::frames_within({635, 350}, budget, true) >= 120);
  // Too small for the fit alone: no frame.
  CHECK(cb::frames_within(k4, 500 * cb::kMiB, true) == 0);
}

TEST_CASE("calibrate_budget: the split holds at most the room, whatever is wanted") {
  namespace cb = calib_budget;
  auto same = [](cb::Split s, std::size_t e, std::size_t t, bool ok) {
    return s.empty == e && s.touch == t && s.ok == ok;
  };
  CHECK(same(cb::split(60, 20, 1000), 60, 20, true)); // fits: all of both
  CHECK(same(cb::split(60, 20, 7), 4, 3, true));      // touch at most half the room
  CHECK(same(cb::split(60, 0, 11), 11, 0, true));
  CHECK(same(cb::split(2, 30, 10), 2, 8, true));  // what the empty frames leave goes to touch
  CHECK(same(cb::split(60, 20, 1), 1, 1, false)); // no room for one frame of each
  CHECK(same(cb::split(60, 0, 0), 1, 0, false));
  // Ten thousand frames wanted or more: the frames held never exceed the room.
  for (std::size_t room = 2; room < 40; ++room)
    for (std::size_t e : {1, 5, 60, 10000, 1000000})
      for (std::size_t t : {0, 1, 7, 60, 10000}) {
        const cb::Split s = cb::split(e, t, room);
        CHECK(s.ok);
        CHECK(s.empty + s.touch <= room);
        CHECK(s.empty >= 1);
        CHECK(s.touch == (t ? std::max<std::size_t>(1, s.touch) : 0));
      }
}
