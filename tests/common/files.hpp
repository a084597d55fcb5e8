// Files and folders for the tests: a fresh folder under the build's test temp folder, and a
// file's bytes.
//
// std::filesystem::path fresh_dir(const std::filesystem::path& relative)
//   requires: SHADOWSENSE_TEST_TMP_DIR is defined (tests/CMakeLists.txt does); `relative` names a
//     folder below it that only the calling test uses.
//   ensures: SHADOWSENSE_TEST_TMP_DIR/relative exists and is empty (whatever was there is
//     removed); returns its path.
//
// std::string read_file(const std::filesystem::path& p)
//   ensures: every byte of p; "" when p cannot be opened.
//
// Threading: no state; tests running at the same time must use different folders.
#pragma once

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace tests {

inline std::filesystem::path fresh_dir(const std::filesystem::path& relative) {
  const std::filesystem::path dir = std::filesystem::path(SHADOWSENSE_TEST_TMP_DIR) / relative;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

inline std::string read_file(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}

} // namespace tests
