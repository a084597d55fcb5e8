// Runs a built program in a child process, for the tests of the example programs (ss_track,
// ss_calibrate, ss_classify): its exit status and everything it printed.
//
// struct ProgramRun { int status; std::string out, err; }
//   status: the exit status, or -1 when the program did not exit normally (e.g. a signal);
//   out, err: what it wrote on stdout and stderr.
//
// ProgramRun run_program(const std::string& program, const std::string& args,
//                        const std::filesystem::path& dir)
//   requires: `program` is the path of an executable (it is quoted here); `args` is shell text
//     put after it as it is (quote paths in it with shell_quote); `dir` can be created/written.
//   ensures: runs "program args" through std::system (/bin/sh) with stdout and stderr sent to
//     dir/stdout.txt and dir/stderr.txt (created or replaced; dir is created if missing), waits
//     for it and returns the status and both files' contents.
//   throws: std::runtime_error naming the program when it does not exist (not built yet: the
//     tests do not make the build wait for the programs, tests/CMakeLists.txt).
//
// std::string shell_quote(const std::string& s)
//   ensures: `s` as one /bin/sh word: in single quotes, each ' inside written as '\''.
//
// read_file (tests/common/files.hpp) is included for the callers that read the output files.
//
// Threading: no state; calls running at the same time must use different `dir`s.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>

#include "files.hpp"

namespace tests {

struct ProgramRun {
  int status = -1;
  std::string out, err;
};

inline std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

inline ProgramRun run_program(const std::string& program, const std::string& args,
                              const std::filesystem::path& dir) {
  if (!std::filesystem::exists(program))
    throw std::runtime_error("program not built: " + program +
                             " (build it, e.g. cmake --build build, then run the test again)");
  std::filesystem::create_directories(dir);
  const std::filesystem::path out = dir / "stdout.txt", err = dir / "stderr.txt";
  const std::string cmd = shell_quote(program) + " " + args + " > " + shell_quote(out.string()) +
                          " 2> " + shell_quote(err.string());
  const int raw = std::system(cmd.c_str());
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, read_file(out), read_file(err)};
}

} // namespace tests
