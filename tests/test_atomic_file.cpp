// The atomic-write helper: success, and every failure (missing folder, target is a folder,
// a callback that throws, a full disk simulated by RLIMIT_FSIZE in a forked child) leaves the
// old file intact and no temporary file behind.
#include <shadowsense/core/atomic_file.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/files.hpp"
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

using namespace shadowsense;
namespace fs = std::filesystem;

namespace {

// Names of every entry in a folder.
std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> v;
  for (const auto& e : fs::directory_iterator(dir)) v.push_back(e.path().filename().string());
  std::sort(v.begin(), v.end());
  return v;
}

void write_plain(const fs::path& p, const std::string& s) {
  std::ofstream(p, std::ios::binary) << s;
}

} // namespace

TEST_CASE("write_file_atomically writes new files and replaces old ones exactly") {
  const fs::path dir = tests::fresh_dir("atomic_file/ok");
  write_file_atomically(dir / "a.txt", std::string_view("hello\n"));
  CHECK(tests::read_file(dir / "a.txt") == "hello\n");
  std::string big(300000, 'x'); // larger than the stream buffer
  for (std::size_t i = 0; i < big.size(); i += 7) big[i] = static_cast<char>('a' + i % 26);
  write_file_atomically(dir / "a.txt", big);
  CHECK(tests::read_file(dir / "a.txt") == big);
  write_file_atomically(dir / "b.txt", [&](std::ostream& os) {
    os << "n=" << 42 << '\n';
    os.write(big.data(), static_cast<std::streamsize>(big.size()));
  });
  CHECK(tests::read_file(dir / "b.txt") == "n=42\n" + big);
  write_file_atomically(dir / "empty.txt", std::string_view());
  CHECK(fs::exists(dir / "empty.txt"));
  CHECK(fs::file_size(dir / "empty.txt") == 0);
  CHECK(entries(dir) == std::vector<std::string>{"a.txt", "b.txt", "empty.txt"});
}

TEST_CASE("AtomicFileWriter: nothing is visible before commit, and no commit leaves nothing") {
  const fs::path dir = tests::fresh_dir("atomic_file/writer");
  write_plain(dir / "f.csv", "old\n");
  {
    AtomicFileWriter w(dir / "f.csv");
    CHECK(w.temporary_path().parent_path() == dir);
    w.stream() << "new ";
    w.write("content\n");
    CHECK(tests::read_file(dir / "f.csv") == "old\n");
    w.commit();
    CHECK_THROWS_AS(w.commit(), InvalidArgument);
  }
  CHECK(tests::read_file(dir / "f.csv") == "new content\n");
  {
    AtomicFileWriter w(dir / "f.csv");
    w.stream() << "abandoned";
    CHECK(fs::exists(w.temporary_path()));
  } // destroyed without commit
  CHECK(tests::read_file(dir / "f.csv") == "new content\n");
  CHECK(entries(dir) == std::vector<std::string>{"f.csv"});
}

TEST_CASE("a folder that does not exist: IoError naming the path, nothing created") {
  const fs::path dir = tests::fresh_dir("atomic_file/missing");
  const fs::path target = dir / "no" / "such" / "folder" / "x.json";
  try {
    write_file_atomically(target, std::string_view("{}"));
    FAIL("expected IoError");
  } catch (const IoError& e) {
    CHECK(std::string(e.what()) == target.string() +
                                       ": cannot create a temporary file in its folder: No such "
                                       "file or directory (the previous file, if any, is "
                                       "unchanged)");
  }
  CHECK(entries(dir).empty());
}

TEST_CASE("the target is a folder: IoError at the rename, temporary file removed") {
  const fs::path dir = tests::fresh_dir("atomic_file/isdir");
  fs::create_directories(dir / "target");
  write_plain(dir / "target" / "keep", "k");
  try {
    write_file_atomically(dir / "target", std::string_view("data"));
    FAIL("expected IoError");
  } catch (const IoError& e) {
    const std::string m = e.what();
    CHECK(m.find((dir / "target").string() + ": cannot rename the temporary file into place: ") ==
          0);
  }
  CHECK(entries(dir) == std::vector<std::string>{"target"});
  CHECK(tests::read_file(dir / "target" / "keep") == "k");
}

TEST_CASE("a throwing callback propagates unchanged; old file intact, no temporary file") {
  const fs::path dir = tests::fresh_dir("atomic_file/throws");
  write_plain(dir / "m.csv", "old rows\n");
  CHECK_THROWS_WITH_AS(write_file_atomically(dir / "m.csv",
                                             [](std::ostream& os) {
                                               os << std::string(100000, 'y');
                                               throw std::runtime_error("generator failed");
                                             }),
                       "generator failed", std::runtime_error);
  CHECK(tests::read_file(dir / "m.csv") == "old rows\n");
  CHECK(entries(dir) == std::vector<std::string>{"m.csv"});
}

TEST_CASE("a full disk (RLIMIT_FSIZE in a child) fails with IoError; old file intact") {
  const fs::path dir = tests::fresh_dir("atomic_file/full");
  const std::string old = "the good old model\n";
  write_plain(dir / "model.ssdn", old);
  const fs::path target = dir / "model.ssdn";
  for (int form = 0; form < 3; ++form) {
    CAPTURE(form);
    const pid_t pid = ::fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
      // Child: a file may not grow past 4 KiB; writes beyond fail with EFBIG.
      std::signal(SIGXFSZ, SIG_IGN);
      rlimit lim{4096, 4096};
      if (::setrlimit(RLIMIT_FSIZE, &lim) != 0) ::_exit(3);
      const std::string big(1 << 20, 'z');
      try {
        if (form == 0) write_file_atomically(target, big);
        if (form == 1) write_file_atomically(target, [&](std::ostream& os) { os << big; });
        if (form == 2) {
          AtomicFileWriter w(target);
          for (int i = 0; i < 100; ++i) w.stream() << "row " << i << ',' << big.substr(0, 100);
          w.commit();
        }
      } catch (const IoError& e) {
        const std::string m = e.what();
        const std::string want = target.string() +
                                 ": writing failed: File too large (the previous file, if "
                                 "any, is unchanged)";
        ::_exit(m == want ? 0 : 4);
      } catch (...) {
        ::_exit(5);
      }
      ::_exit(6); // no error at all
    }
    int status = 0;
    REQUIRE(::waitpid(pid, &status, 0) == pid);
    REQUIRE(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 0);
    CHECK(tests::read_file(target) == old);
    CHECK(entries(dir) == std::vector<std::string>{"model.ssdn"});
  }
}

TEST_CASE("a writer killed mid-write leaves a temporary file that the next commit removes") {
  // Before: kill -9 left ".skin.calib.tmp.PID.N" for ever.
  const fs::path dir = tests::fresh_dir("atomic_file/killed");
  write_file_atomically(dir / "a.txt", std::string_view("old\n"));
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) { // child: half a new version, then killed before commit
    AtomicFileWriter w(dir / "a.txt");
    w.write("partial");
    ::raise(SIGKILL);
    ::_exit(0);
  }
  int status = 0;
  REQUIRE(::waitpid(pid, &status, 0) == pid);
  REQUIRE(WIFSIGNALED(status));
  const std::vector<std::string> left = entries(dir);
  REQUIRE(left.size() == 2);
  CHECK(left[0].starts_with(".a.txt.tmp." + std::to_string(pid) + "."));
  CHECK(left[1] == "a.txt");
  CHECK(tests::read_file(dir / "a.txt") == "old\n");
  // Temporary files that must stay: this process's own (a writer still open), a live process's
  // (pid 1), another target's, and names that only look similar.
  AtomicFileWriter mine(dir / "a.txt");
  const std::string own = mine.temporary_path().filename().string();
  for (const std::string& keep :
       {std::string(".a.txt.tmp.1.0"), ".b.txt.tmp." + std::to_string(pid) + ".0",
        std::string(".a.txt.tmp.x1.0"), ".a.txt.tmp." + std::to_string(pid) + ".0.bak"})
    write_plain(dir / keep, "keep");
  write_file_atomically(dir / "a.txt", std::string_view("new\n"));
  CHECK(tests::read_file(dir / "a.txt") == "new\n");
  std::vector<std::string> want{".a.txt.tmp." + std::to_string(pid) + ".0.bak",
                                ".a.txt.tmp.1.0",
                                ".a.txt.tmp.x1.0",
                                ".b.txt.tmp." + std::to_string(pid) + ".0",
                                own,
                                "a.txt"};
  std::sort(want.begin(), want.end());
  CHECK(entries(dir) == want);
}
