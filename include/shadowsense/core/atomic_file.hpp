// Atomic file writing: the one way the library (and its programs) replace a file.
//
// WHAT THIS IS
//   A file written through these functions is, at every moment and after any crash, kill or
//   full disk, either its complete old content (or absent, if it did not exist) or its complete
//   new content; never a mix, never truncated. How:
//     1. the content goes to a new temporary file in the SAME folder as the target (so the
//        final rename stays inside one filesystem), named ".<target name>.tmp.<pid>.<n>",
//        created with O_EXCL (never clobbers anything) and mode 0666 minus the umask;
//     2. every write is checked (short writes are retried, EINTR is retried);
//     3. the data is flushed, fsync'ed, and the file closed with close() checked;
//     4. the temporary file is renamed over the target, then the folder is fsync'ed so the
//        rename itself survives a power cut;
//     5. on ANY failure before the rename (or an exception from the caller's callback, or the
//        writer destroyed without commit()) the temporary file is removed and the target is
//        untouched;
//     6. a process killed mid-write (kill -9, a power cut) cannot remove its temporary file: a
//        later commit with Sync::file removes the target's temporary files whose <pid> names no
//        running process on this machine (kill(pid, 0) fails with ESRCH). Sync::deferred
//        commits skip this scan (they write thousands of files into one folder). A folder
//        shared with another machine may hold that machine's live temporary files under PIDs
//        unknown here: do not point two machines' writers at one target.
//   Errors are IoError (through SHADOWSENSE_THROW) naming the target path, the step that
//   failed and the errno text, e.g. "out/score.json: writing failed: No space left on device".
//   POSIX only (open/write/fsync/rename).
//
//   Durability. Sync::file (the default) fsyncs each file before its rename: after a power cut
//   the target holds old or new content. Writers of many files that are only meaningful
//   together (dataset frames, completed by their csv) may pass Sync::deferred to skip the
//   per-file fsync (an fsync costs ~30 ms on a VM disk; 6,000 frames would spend minutes in it)
//   and MUST call sync_filesystem(folder) once before writing the file that marks the set
//   complete (which itself uses Sync::file). Against kills and full disks both modes are the
//   same: the rename happens only after every write succeeded.
//
// API
//   write_file_atomically(path, std::string_view content, Sync sync = Sync::file)
//     requires: path names a file in an existing, writable folder; path is not a folder.
//     ensures:  path holds exactly `content`; no temporary file remains.
//     throws:   IoError (target unchanged, no temporary file left).
//   write_file_atomically(path, fill, Sync sync = Sync::file)   fill: fill(std::ostream&)
//     ensures:  path holds exactly what fill wrote. If fill throws, the exception propagates
//               unchanged, the target is unchanged and the temporary file is removed. If the
//               stream reports a failure (badbit/failbit, e.g. a full disk) -> IoError.
//   AtomicFileWriter w(path, sync = Sync::file); w.stream() << ...; w.write(bytes); w.commit();
//     The streaming form for writers that produce output piece by piece.
//     AtomicFileWriter(path)  creates the temporary file; throws IoError if it cannot.
//     stream()                the std::ostream to write to (valid until commit/destruction).
//     write(bytes)            appends bytes; throws IoError at once if a write fails.
//     commit()                steps 3-4; throws IoError (temp removed, target unchanged).
//                             After commit() the writer is finished: stream()/write()/commit()
//                             throw InvalidArgument.
//     ~AtomicFileWriter()     without a successful commit(): removes the temporary file.
//     temporary_path()        the temporary file's path (for tests and messages).
//   sync_filesystem(folder)
//     ensures: everything written so far to the filesystem holding `folder` is on disk
//              (syncfs). throws: IoError naming the folder.
//
// THREADING
//   The free functions are safe to call from any threads for different targets. Two threads
//   writing the same target concurrently each produce a complete file; the last rename wins.
//   One AtomicFileWriter must be used by one thread at a time.
#pragma once

#include <shadowsense/core/error.hpp>

#include <atomic>
#include <cerrno>
#include <concepts>
#include <cstring>
#include <filesystem>
#include <ostream>
#include <streambuf>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

SHADOWSENSE_NAMESPACE_BEGIN

// Whether each atomically written file is fsync'ed before its rename (see above).
enum class Sync { file, deferred };

namespace detail {

inline std::string errno_text(int err) {
  return std::strerror(err);
}

// A streambuf over a file descriptor whose every write is checked; the first failure is kept
// (errno value) and turns the stream bad.
class CheckedFdBuf : public std::streambuf {
public:
  CheckedFdBuf() : buffer_(1 << 16) { setp(buffer_.data(), buffer_.data() + buffer_.size()); }
  void attach(int fd) { fd_ = fd; }
  int error() const { return error_; }

  // Writes all of [data, data + n) to the descriptor; false (error() set) on failure.
  bool write_all(const char* data, std::size_t n) {
    if (error_ != 0) return false;
    while (n > 0) {
      const ssize_t w = ::write(fd_, data, n);
      if (w < 0) {
        if (errno == EINTR) continue;
        error_ = errno;
        return false;
      }
      if (w == 0) {
        error_ = EIO;
        return false;
      }
      data += w;
      n -= static_cast<std::size_t>(w);
    }
    return true;
  }

protected:
  int_type overflow(int_type ch) override {
    if (!flush_buffer()) return traits_type::eof();
    if (!traits_type::eq_int_type(ch, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(ch);
      pbump(1);
    }
    return traits_type::not_eof(ch);
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    if (n >= static_cast<std::streamsize>(buffer_.size())) {
      if (!flush_buffer() || !write_all(s, static_cast<std::size_t>(n))) return 0;
      return n;
    }
    return std::streambuf::xsputn(s, n);
  }
  int sync() override { return flush_buffer() ? 0 : -1; }

private:
  bool flush_buffer() {
    const std::size_t n = static_cast<std::size_t>(pptr() - pbase());
    const bool ok = write_all(pbase(), n);
    setp(buffer_.data(), buffer_.data() + buffer_.size());
    return ok;
  }

  std::vector<char> buffer_;
  int fd_ = -1;
  int error_ = 0;
};

} // namespace detail

class AtomicFileWriter {
public:
  explicit AtomicFileWriter(std::filesystem::path target, Sync sync = Sync::file)
      : target_(std::move(target)), sync_(sync), os_(&buf_) {
    detail::require(!target_.empty(), "AtomicFileWriter: the target path is empty");
    detail::require(target_.has_filename(),
                    "AtomicFileWriter: '" + target_.string() + "' names a folder, not a file");
    static std::atomic<unsigned long> counter{0};
    const std::filesystem::path folder = target_.parent_path();
    for (int attempt = 0; attempt < 100; ++attempt) {
      // append() only: GCC 12 warns falsely (-Wrestrict) on operator+ chains.
      std::string name = ".";
      name.append(target_.filename().string())
          .append(".tmp.")
          .append(std::to_string(static_cast<long>(::getpid())))
          .append(".")
          .append(std::to_string(counter++));
      tmp_ = folder.empty() ? std::filesystem::path(name) : folder / name;
      fd_ = ::open(tmp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
      if (fd_ >= 0) break;
      if (errno != EEXIST) fail_now("cannot create a temporary file in its folder", errno, false);
    }
    if (fd_ < 0) fail_now("cannot find an unused temporary file name", EEXIST, false);
    buf_.attach(fd_);
  }
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;
  ~AtomicFileWriter() { discard(); }

  std::ostream& stream() {
    require_open();
    return os_;
  }
  void write(std::string_view bytes) {
    require_open();
    os_.flush();
    if (!buf_.write_all(bytes.data(), bytes.size())) fail_now("writing failed", buf_.error(), true);
  }
  const std::filesystem::path& temporary_path() const { return tmp_; }
  const std::filesystem::path& target() const { return target_; }

  void commit() {
    require_open();
    os_.flush();
    if (buf_.error() != 0) fail_now("writing failed", buf_.error(), true);
    if (!os_) fail_now("the output stream reported a failure", EIO, true);
    if (sync_ == Sync::file && ::fsync(fd_) != 0) fail_now("fsync failed", errno, true);
    const int fd = std::exchange(fd_, -1);
    if (::close(fd) != 0) fail_now("closing failed", errno, true);
    if (::rename(tmp_.c_str(), target_.c_str()) != 0)
      fail_now("cannot rename the temporary file into place", errno, true);
    committed_ = true;
    if (sync_ == Sync::deferred) return;
    remove_stale_temporaries();
    // Make the rename durable. Some filesystems cannot fsync a folder (EINVAL): the file
    // itself is complete either way, so only real I/O errors are reported.
    const std::filesystem::path folder =
        target_.parent_path().empty() ? std::filesystem::path(".") : target_.parent_path();
    const int dfd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd >= 0) {
      const int rc = ::fsync(dfd);
      const int err = errno;
      ::close(dfd);
      if (rc != 0 && err == EIO) fail_now("fsync of the folder failed", err, false);
    }
  }

private:
  // Step 6: ".<name>.tmp.<pid>.<n>" of this target whose process is gone. Best effort: a file
  // that vanished meanwhile or cannot be removed is left alone.
  void remove_stale_temporaries() const {
    const std::filesystem::path folder =
        target_.parent_path().empty() ? std::filesystem::path(".") : target_.parent_path();
    std::string prefix = ".";
    prefix.append(target_.filename().string()).append(".tmp.");
    std::error_code ec;
    for (std::filesystem::directory_iterator it(folder, ec), end; !ec && it != end;
         it.increment(ec)) {
      const std::string name = it->path().filename().string();
      if (!name.starts_with(prefix)) continue;
      const std::string rest = name.substr(prefix.size()); // "<pid>.<n>"
      const std::size_t dot = rest.find('.');
      if (dot == 0 || dot == std::string::npos || rest.find_first_not_of("0123456789") != dot ||
          rest.find_first_not_of("0123456789", dot + 1) != std::string::npos || dot > 9)
        continue;
      const long pid = std::stol(rest.substr(0, dot));
      if (pid <= 0 || pid == static_cast<long>(::getpid())) continue;
      if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH)
        continue; // alive (or not ours)
      std::error_code ignored;
      std::filesystem::remove(it->path(), ignored);
    }
  }

  void require_open() const {
    detail::require(!committed_ && fd_ >= 0, "AtomicFileWriter: '" + target_.string() +
                                                 "' was already committed or has failed");
  }
  void discard() noexcept {
    if (fd_ >= 0) ::close(std::exchange(fd_, -1));
    if (!committed_ && !tmp_.empty()) {
      ::unlink(tmp_.c_str());
      tmp_.clear();
    }
  }
  [[noreturn]] void fail_now(const char* step, int err, bool remove_tmp) {
    if (remove_tmp) discard();
    committed_ = true; // unusable from here on
    // The target is never touched before the rename, so every failure leaves it as it was.
    SHADOWSENSE_THROW(IoError(target_.string() + ": " + step + ": " + detail::errno_text(err) +
                              " (the previous file, if any, is unchanged)"));
  }

  std::filesystem::path target_;
  std::filesystem::path tmp_;
  int fd_ = -1;
  Sync sync_ = Sync::file;
  bool committed_ = false;
  detail::CheckedFdBuf buf_;
  std::ostream os_;
};

inline void write_file_atomically(const std::filesystem::path& path, std::string_view content,
                                  Sync sync = Sync::file) {
  AtomicFileWriter w(path, sync);
  w.write(content);
  w.commit();
}

template <class Fill>
requires std::invocable<Fill&, std::ostream&>
inline void write_file_atomically(const std::filesystem::path& path, Fill&& fill,
                                  Sync sync = Sync::file) {
  AtomicFileWriter w(path, sync);
  fill(w.stream());
  w.commit();
}

inline void sync_filesystem(const std::filesystem::path& folder) {
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0)
    SHADOWSENSE_THROW(IoError(folder.string() +
                              ": cannot open the folder to sync it: " + detail::errno_text(errno)));
  const int rc = ::syncfs(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0)
    SHADOWSENSE_THROW(
        IoError(folder.string() + ": syncing its filesystem failed: " + detail::errno_text(err)));
}

SHADOWSENSE_NAMESPACE_END
