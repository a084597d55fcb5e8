// The programs' default model file: where the shipped models/default.ssm is found, for a
// program run from an installed prefix, from the build folder, or told by the environment.
//
//   const std::filesystem::path model = cli::find_default_model(argv[0]);   // or throws IoError
//   std::cerr << "prog: model " << model.string() << " (" << what << ")\n";  // with &what
//   help: "(default: " + cli::default_model_help(argv[0]) + ")"
//
// The places, in this order:
//   1. $SHADOWSENSE_MODEL, when the variable is set and not empty. It overrides the rest: a
//      variable naming a missing file is an error, never silently skipped.
//   2. <the program's folder>/SHADOWSENSE_INSTALLED_MODEL: after `cmake --install`,
//      <prefix>/bin/../share/shadowsense/models/default.ssm (the relative path is configured
//      from the install directories by examples/CMakeLists.txt).
//   3. The source tree's models/default.ssm (SHADOWSENSE_SOURCE_MODEL), only while the program
//      runs from the build folder it was built in (SHADOWSENSE_BUILD_PROGRAM_DIR): an installed
//      copy never reads the source tree.
// The program's folder is that of /proc/self/exe (symbolic links resolved), else of argv[0]
// (searched on PATH when it has no '/').
//
// search_model() requires: nothing (a missing or unreadable place is just "not there").
// find_default_model() ensures: the returned path names an existing regular file.
//   throws: shadowsense::IoError "no model file given and the default model was not found:
//           looked at <every place looked at, with what it was>; pass --model FILE or set
//           SHADOWSENSE_MODEL".
// Threading: free functions without shared state; they read the environment (getenv).
#pragma once

#include <shadowsense/core/error.hpp>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#ifndef SHADOWSENSE_INSTALLED_MODEL
#define SHADOWSENSE_INSTALLED_MODEL "../share/shadowsense/models/default.ssm"
#endif

namespace cli {

// Everything the search depends on, so a test can set it up without moving files around.
struct ModelPlaces {
  // $SHADOWSENSE_MODEL (nullopt or empty: unset).
  std::optional<std::string> env;
  // The running program's folder (empty: unknown).
  std::filesystem::path program_dir;
  std::filesystem::path installed_relative = SHADOWSENSE_INSTALLED_MODEL;
  // The build folder the program was built in (empty: none) and the source tree's model.
  std::filesystem::path build_program_dir, source_model;
};

// The outcome: `found` is empty when no place holds a file; `looked` lists every place looked
// at with what it was ("$SHADOWSENSE_MODEL", "the installed model", "the source tree's model").
struct ModelSearch {
  std::filesystem::path found;
  std::string what; // what `found` is, e.g. "the installed model"
  std::vector<std::string> looked;
};

inline bool model_is_file(const std::filesystem::path& p) {
  std::error_code ec;
  return std::filesystem::is_regular_file(p, ec);
}

inline ModelSearch search_model(const ModelPlaces& places) {
  ModelSearch s;
  const auto at = [&](const std::filesystem::path& p, const char* what) {
    s.looked.push_back(p.string() + " (" + what + ")");
    if (!model_is_file(p)) return false;
    s.found = p;
    s.what = what;
    return true;
  };
  if (places.env && !places.env->empty()) {
    at(*places.env, "$SHADOWSENSE_MODEL");
    return s; // an explicit choice: no fallback
  }
  if (!places.program_dir.empty() &&
      at((places.program_dir / places.installed_relative).lexically_normal(),
         "the installed model"))
    return s;
  std::error_code ec;
  if (!places.program_dir.empty() && !places.build_program_dir.empty() &&
      std::filesystem::equivalent(places.program_dir, places.build_program_dir, ec) &&
      at(places.source_model, "the source tree's model"))
    return s;
  return s;
}

// The folder of the running program (empty when it cannot be told).
inline std::filesystem::path program_folder(const char* argv0) {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec && self.is_absolute()) return self.parent_path();
  const std::string name = argv0 ? argv0 : "";
  if (name.empty()) return {};
  if (name.find('/') != std::string::npos) return std::filesystem::absolute(name, ec).parent_path();
  const char* path = std::getenv("PATH");
  std::string_view rest = path ? path : "";
  while (!rest.empty()) {
    const auto colon = rest.find(':');
    const std::filesystem::path dir(std::string(rest.substr(0, colon)));
    if (model_is_file(dir / name)) return std::filesystem::absolute(dir, ec);
    if (colon == std::string_view::npos) break;
    rest.remove_prefix(colon + 1);
  }
  return {};
}

// The places of this program (the configured paths come from examples/CMakeLists.txt).
inline ModelPlaces this_program_places(const char* argv0) {
  ModelPlaces p;
  if (const char* env = std::getenv("SHADOWSENSE_MODEL")) p.env = env;
  p.program_dir = program_folder(argv0);
#ifdef SHADOWSENSE_BUILD_PROGRAM_DIR
  p.build_program_dir = SHADOWSENSE_BUILD_PROGRAM_DIR;
#endif
#ifdef SHADOWSENSE_SOURCE_MODEL
  p.source_model = SHADOWSENSE_SOURCE_MODEL;
#endif
  return p;
}

inline std::string looked_at_list(const ModelSearch& s) {
  std::string out;
  for (const auto& place : s.looked) out += (out.empty() ? "" : ", ") + place;
  return out.empty() ? "nowhere (the program's folder is unknown)" : out;
}

// `what` (when given) receives what the file is, e.g. "the installed model", for a note.
inline std::filesystem::path find_default_model(const ModelPlaces& places,
                                                std::string* what = nullptr) {
  const ModelSearch s = search_model(places);
  if (what) *what = s.what;
  if (s.found.empty())
    SHADOWSENSE_THROW(
        shadowsense::IoError("no model file given and the default model was not found: looked at " +
                             looked_at_list(s) + "; pass --model FILE or set SHADOWSENSE_MODEL"));
  return s.found;
}

inline std::filesystem::path find_default_model(const char* argv0, std::string* what = nullptr) {
  return find_default_model(this_program_places(argv0), what);
}

// For --help: "the installed model (<path>)", "$SHADOWSENSE_MODEL (<path>)", ... or, when no
// place holds it, "the installed model, not found (looked at ...)".
inline std::string default_model_help(const ModelPlaces& places) {
  const ModelSearch s = search_model(places);
  if (s.found.empty())
    return "the installed model, not found (looked at " + looked_at_list(s) + ")";
  return s.what + " (" + s.found.string() + ")";
}

inline std::string default_model_help(const char* argv0) {
  return default_model_help(this_program_places(argv0));
}

} // namespace cli
