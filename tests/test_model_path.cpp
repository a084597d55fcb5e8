// The programs' default-model search (examples/common/model_path.hpp) on a temporary tree laid
// out like an installed prefix and a build folder: the order of the places, the build-folder
// restriction of the source tree's model, $SHADOWSENSE_MODEL as an override, and an error that
// names every place looked at.
#include <doctest/doctest.h>

#include "common/model_path.hpp"

#include "common/files.hpp"
#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;

namespace {

void touch(const fs::path& p) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << "model";
}

std::string error_of(const cli::ModelPlaces& places) {
  try {
    cli::find_default_model(places);
  } catch (const shadowsense::IoError& e) {
    return e.what();
  }
  return "(no error)";
}

} // namespace

TEST_CASE("the installed model beside the program's prefix comes first") {
  const fs::path root = tests::fresh_dir("model_path_installed");
  const fs::path installed = root / "prefix/share/shadowsense/models/default.ssm";
  touch(installed);
  touch(root / "src/models/default.ssm");
  cli::ModelPlaces p;
  p.program_dir = root / "prefix/bin";
  p.build_program_dir = root / "prefix/bin"; // even when run from the build folder
  p.source_model = root / "src/models/default.ssm";
  CHECK(cli::find_default_model(p) == installed);
  std::string what;
  cli::find_default_model(p, &what);
  CHECK(what == "the installed model");
  CHECK(cli::default_model_help(p) == "the installed model (" + installed.string() + ")");
}

TEST_CASE("the source tree's model only from the build folder the program was built in") {
  const fs::path root = tests::fresh_dir("model_path_build");
  const fs::path source_model = root / "src/models/default.ssm";
  touch(source_model);
  fs::create_directories(root / "build/examples");
  fs::create_directories(root / "copy/bin");
  cli::ModelPlaces p;
  p.program_dir = root / "build/examples";
  p.build_program_dir = root / "build/examples";
  p.source_model = source_model;
  CHECK(cli::find_default_model(p) == source_model);
  CHECK(cli::default_model_help(p) == "the source tree's model (" + source_model.string() + ")");
  // A copy elsewhere (an installed program without its share/) never reads the source tree.
  p.program_dir = root / "copy/bin";
  const std::string e = error_of(p);
  CHECK(e == "no model file given and the default model was not found: looked at " +
                 (root / "copy/share/shadowsense/models/default.ssm").string() +
                 " (the installed model); pass --model FILE or set SHADOWSENSE_MODEL");
  CHECK(cli::default_model_help(p).rfind("the installed model, not found (looked at ", 0) == 0);
}

TEST_CASE("$SHADOWSENSE_MODEL overrides, and a missing file there is an error naming it") {
  const fs::path root = tests::fresh_dir("model_path_env");
  touch(root / "prefix/share/shadowsense/models/default.ssm");
  touch(root / "mine.ssm");
  cli::ModelPlaces p;
  p.program_dir = root / "prefix/bin";
  p.env = (root / "mine.ssm").string();
  CHECK(cli::find_default_model(p) == root / "mine.ssm");
  CHECK(cli::default_model_help(p) == "$SHADOWSENSE_MODEL (" + (root / "mine.ssm").string() + ")");
  p.env = (root / "missing.ssm").string(); // no fallback to the installed model
  CHECK(error_of(p) == "no model file given and the default model was not found: looked at " +
                           (root / "missing.ssm").string() +
                           " ($SHADOWSENSE_MODEL); pass --model FILE or set SHADOWSENSE_MODEL");
  p.env = ""; // set but empty: as if unset
  CHECK(cli::find_default_model(p) == root / "prefix/share/shadowsense/models/default.ssm");
}

TEST_CASE("every place looked at is named, in order; a folder is not a model") {
  const fs::path root = tests::fresh_dir("model_path_none");
  fs::create_directories(root / "prefix/share/shadowsense/models/default.ssm"); // a folder
  fs::create_directories(root / "build");
  cli::ModelPlaces p;
  p.program_dir = root / "build";
  p.installed_relative = "../prefix/share/shadowsense/models/default.ssm";
  p.build_program_dir = root / "build";
  p.source_model = root / "src/models/default.ssm";
  CHECK(error_of(p) == "no model file given and the default model was not found: looked at " +
                           (root / "prefix/share/shadowsense/models/default.ssm").string() +
                           " (the installed model), " + p.source_model.string() +
                           " (the source tree's model); pass --model FILE or set "
                           "SHADOWSENSE_MODEL");
  cli::ModelPlaces unknown; // the program's folder could not be told
  CHECK(error_of(unknown) == "no model file given and the default model was not found: looked "
                             "at nowhere (the program's folder is unknown); pass --model FILE or "
                             "set SHADOWSENSE_MODEL");
}

TEST_CASE("this program's folder is found from /proc/self/exe") {
  // This file is compiled into a group executable (tests/CMakeLists.txt): ask for its name.
  const fs::path self = fs::read_symlink("/proc/self/exe");
  const std::string name = self.filename().string();
  const cli::ModelPlaces p = cli::this_program_places(name.c_str());
  CHECK(fs::equivalent(p.program_dir / name, self));
}
