// Files and folders for the tests: a fresh folder under the build's test temp folder, a file's
// bytes, and a snippet of a text file (to compare the README's code with the compiled copy).
//
// std::filesystem::path fresh_dir(const std::filesystem::path& relative)
//   requires: SHADOWSENSE_TEST_TMP_DIR (and, for readme_snippet, SHADOWSENSE_SOURCE_DIR) is
//     defined (tests/CMakeLists.txt does); `relative` names a
//     folder below it that only the calling test uses.
//   ensures: SHADOWSENSE_TEST_TMP_DIR/relative exists and is empty (whatever was there is
//     removed); returns its path.
//
// std::string read_file(const std::filesystem::path& p)
//   ensures: every byte of p; "" when p cannot be opened.
//
// bool write_file(const std::filesystem::path& p, const std::string& bytes)
//   ensures: p holds exactly `bytes` (created or replaced); false when it cannot be written.
//   Test fixtures only: not atomic (the library's writes are, core/atomic_file.hpp).
//
// std::vector<std::string> snippet_lines(const std::filesystem::path& p, const std::string& from,
//                                        const std::string& to)
//   ensures: the lines of p from the first that starts with `from` (after its leading spaces) to
//     the next that contains `to`, both included, each without its leading spaces (so the
//     README's code and the same code indented in a test compare equal); empty when no line
//     starts with `from`, and to the end of the file when none after it contains `to`.
//
// ReadmeSnippet readme_snippet(test_file, from, to)
//   ensures: .readme = snippet_lines of the README, .here = snippet_lines of test_file (a path
//     below the source tree, e.g. "tests/test_runtime.cpp": the compiled copy of the snippet).
//
// WorkingFolder(relative): the current folder is fresh_dir(relative) until the object is
//   destroyed, then the one before again (also when the test throws). Not for tests that run at
//   the same time (the current folder is the process's).
//
// Threading: no state; tests running at the same time must use different folders.
#pragma once

#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

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

inline bool write_file(const std::filesystem::path& p, const std::string& bytes) {
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  f.close();
  return static_cast<bool>(f);
}

inline std::vector<std::string> snippet_lines(const std::filesystem::path& p,
                                              const std::string& from, const std::string& to) {
  std::vector<std::string> out;
  std::istringstream in(read_file(p));
  std::string line;
  bool inside = false;
  while (std::getline(in, line)) {
    const auto first = line.find_first_not_of(' ');
    const std::string t = first == std::string::npos ? "" : line.substr(first);
    if (t.rfind(from, 0) == 0) inside = true;
    if (inside) out.push_back(t);
    if (inside && t.find(to) != std::string::npos) break;
  }
  return out;
}

struct ReadmeSnippet {
  std::vector<std::string> readme, here;
};
inline ReadmeSnippet readme_snippet(const std::string& test_file, const std::string& from,
                                    const std::string& to) {
  const std::filesystem::path source(SHADOWSENSE_SOURCE_DIR);
  return {snippet_lines(source / "README.md", from, to),
          snippet_lines(source / test_file, from, to)};
}

class WorkingFolder {
public:
  explicit WorkingFolder(const std::filesystem::path& relative)
      : before_(std::filesystem::current_path()) {
    std::filesystem::current_path(fresh_dir(relative));
  }
  ~WorkingFolder() { std::filesystem::current_path(before_); }
  WorkingFolder(const WorkingFolder&) = delete;
  WorkingFolder& operator=(const WorkingFolder&) = delete;

private:
  std::filesystem::path before_;
};

} // namespace tests
