// Replacing a file so that readers see either the old content or the new, never a part:
// write_file_atomically() writes a temporary file in the same folder, checks every write,
// flushes it to disk (fsync), closes it and renames it over the target. On any failure the
// temporary file is removed, the old file is left as it was, and IoError is thrown.
//
// POSIX only (open/write/fsync/rename), like the programs that use it.
// Threading: safe to call from several threads for different targets; two concurrent calls for
// the same target leave one of the two contents.
#pragma once

#include <shadowsense/core/error.hpp>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>

#include <fcntl.h>
#include <unistd.h>

namespace cli {

// requires: path names a file (not a folder) in an existing folder.
// ensures: path holds exactly `content` (the permissions of a new file follow the umask).
// throws: shadowsense::IoError naming the path and the system's reason (full disk, file-size
// limit, missing folder, no permission, target is a folder, ...); the old file is unchanged and
// no temporary file is left.
inline void write_file_atomically(const std::filesystem::path& path, std::string_view content) {
  namespace fs = std::filesystem;
  static std::atomic<unsigned> counter{0};
  const auto fail = [&](const std::string& what, int err) {
    return shadowsense::IoError("cannot write '" + path.string() + "': " + what + ": " +
                                std::strerror(err));
  };
  if (path.filename().empty()) throw fail("no file name", EISDIR);
  const fs::path dir = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  fs::path tmp;
  int fd = -1;
  for (int attempt = 0; fd < 0 && attempt < 100; ++attempt) {
    std::string name(1, '.'); // ".<name>.tmp.<pid>.<n>": hidden, unique to this process
    name += path.filename().string();
    name += ".tmp.";
    name += std::to_string(::getpid());
    name += '.';
    name += std::to_string(counter++);
    tmp = dir / name;
    fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0 && errno != EEXIST) throw fail("cannot create a temporary file", errno);
  }
  if (fd < 0) throw fail("cannot create a temporary file", EEXIST);
  const auto abandon = [&](const std::string& what) {
    const int err = errno;
    if (fd >= 0) ::close(fd);
    ::unlink(tmp.c_str());
    return fail(what, err);
  };
  for (std::size_t done = 0; done < content.size();) {
    const ::ssize_t n = ::write(fd, content.data() + done, content.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n == 0) errno = EIO;
      throw abandon("write failed after " + std::to_string(done) + " of " +
                    std::to_string(content.size()) + " bytes");
    }
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) throw abandon("fsync failed");
  const int closed = ::close(fd);
  fd = -1;
  if (closed != 0) throw abandon("close failed");
  if (::rename(tmp.c_str(), path.c_str()) != 0) throw abandon("rename failed");
  // Make the rename itself durable; a failure here cannot undo it, so it is not reported.
  if (const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

} // namespace cli
