// Bounded image reading: the size of an image file is checked from its header BEFORE any pixel
// is decoded, so a small file claiming 20000x20000 pixels (1.2 GB decoded) is refused cheaply.
//
// WHAT THIS IS
//   read_image_header() parses the header bytes itself (no OpenCV) for PNG (IHDR), JPEG (the
//   first SOFn segment, skipping APPn/EXIF segments) and BMP (BITMAPINFOHEADER or
//   BITMAPCOREHEADER); any other format is rejected. read_image_file() checks the header
//   against the limits, then reads the (size-bounded) file into memory and decodes it with
//   cv::imdecode. Before reading anything both check that the path is a regular file (a FIFO
//   would block, /dev/zero would never end): the file is opened with O_NONBLOCK and fstat'ed.
//
// API
//   struct ImageLimits { max_width = 8192, max_height = 8192, max_file_bytes = 256 MiB }
//   struct ImageHeader { std::string format ("png", "jpeg", "bmp"); int width, height; }
//   ImageHeader read_image_header(path, limits = {})
//     requires: nothing (any path).
//     ensures:  the header's format and dimensions, with 1 <= width <= limits.max_width and
//               1 <= height <= limits.max_height; reads at most the header (JPEG: the segment
//               headers before SOF, bounded by the file size).
//     throws:   IoError naming the path and the problem: missing, not a regular file, larger
//               than max_file_bytes, unknown format, truncated or malformed header, zero or
//               too large dimensions (the message gives both the size and the limit).
//   cv::Mat read_image_file(path, flags = cv::IMREAD_COLOR, limits = {})
//     ensures:  the decoded image (8-bit BGR for IMREAD_COLOR), whose size equals the header's
//               (a JPEG's EXIF orientation may swap width and height; IMREAD_REDUCED_* shrink).
//     throws:   IoError as above, or when decoding fails or disagrees with the header.
//   Limits: ImageLimits::validate() throws InvalidArgument unless all are >= 1.
//
// THREADING
//   Stateless functions: safe from any number of threads.
#pragma once

#include <shadowsense/core/error.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <array>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

SHADOWSENSE_NAMESPACE_BEGIN

struct ImageLimits {
  int max_width = 8192;
  int max_height = 8192;
  std::uint64_t max_file_bytes = 256ull << 20;

  void validate() const {
    detail::require(max_width >= 1 && max_height >= 1 && max_file_bytes >= 1,
                    "ImageLimits: max_width, max_height and max_file_bytes must be >= 1");
  }
};

struct ImageHeader {
  std::string format; // "png", "jpeg" or "bmp"
  int width = 0;
  int height = 0;
};

namespace detail {

// An open, regular, size-checked file; reads are bounded by its size.
class BoundedFile {
public:
  // Failures raise IoError("<prefix><path>: ...") or, when as_dataset_error, DatasetError (so
  // the dataset reader needs no catch-and-rethrow, which a user SHADOWSENSE_THROW would skip).
  BoundedFile(const std::filesystem::path& path, const ImageLimits& limits,
              const char* noun = "image", std::string prefix = {}, bool as_dataset_error = false)
      : path_(path), prefix_(std::move(prefix)), as_dataset_error_(as_dataset_error) {
    limits.validate();
    fd_ = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) fail(std::string("cannot open the ") + noun + ": " + std::strerror(errno));
    struct stat st {};
    if (::fstat(fd_, &st) != 0)
      fail(std::string("cannot stat the ") + noun + ": " + std::strerror(errno));
    if (!S_ISREG(st.st_mode))
      fail(std::string("not a regular file (a folder, device or pipe); expected the ") + noun);
    size_ = static_cast<std::uint64_t>(st.st_size);
    if (size_ > limits.max_file_bytes)
      fail("the file has " + std::to_string(size_) + " bytes; the limit is " +
           std::to_string(limits.max_file_bytes));
  }
  BoundedFile(const BoundedFile&) = delete;
  BoundedFile& operator=(const BoundedFile&) = delete;
  ~BoundedFile() {
    if (fd_ >= 0) ::close(fd_);
  }
  std::uint64_t size() const { return size_; }

  // Reads up to n bytes at offset (fewer at the end of the file).
  std::vector<unsigned char> read_at(std::uint64_t offset, std::size_t n) const {
    std::vector<unsigned char> out;
    if (offset >= size_) return out;
    n = static_cast<std::size_t>(std::min<std::uint64_t>(n, size_ - offset));
    out.resize(n);
    std::size_t got = 0;
    while (got < n) {
      const ssize_t r = ::pread(fd_, out.data() + got, n - got, static_cast<off_t>(offset + got));
      if (r < 0 && errno == EINTR) continue;
      if (r < 0) fail(std::string("reading failed: ") + std::strerror(errno));
      if (r == 0) break;
      got += static_cast<std::size_t>(r);
    }
    out.resize(got);
    return out;
  }

  [[noreturn]] void fail(const std::string& what) const {
    const std::string m = prefix_ + path_.string() + ": " + what;
    if (as_dataset_error_) SHADOWSENSE_THROW(DatasetError(m));
    SHADOWSENSE_THROW(IoError(m));
  }

private:
  std::filesystem::path path_;
  std::string prefix_;
  bool as_dataset_error_ = false;
  int fd_ = -1;
  std::uint64_t size_ = 0;
};

inline std::uint32_t be32(const unsigned char* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) |
         std::uint32_t(p[3]);
}
inline std::uint32_t be16(const unsigned char* p) {
  return (std::uint32_t(p[0]) << 8) | p[1];
}
inline std::uint32_t le16(const unsigned char* p) {
  return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8);
}
inline std::uint32_t le32(const unsigned char* p) {
  return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) |
         (std::uint32_t(p[3]) << 24);
}

inline ImageHeader parse_jpeg_header(const BoundedFile& f) {
  std::uint64_t pos = 2; // after FF D8
  for (int segments = 0; segments < 4096; ++segments) {
    std::vector<unsigned char> m = f.read_at(pos, 2);
    if (m.size() < 2) f.fail("truncated JPEG: no SOF segment before the end of the file");
    if (m[0] != 0xFF)
      f.fail("malformed JPEG: expected a segment marker at byte " + std::to_string(pos));
    if (m[1] == 0xFF) { // fill byte
      pos += 1;
      continue;
    }
    const unsigned marker = m[1];
    pos += 2;
    if (marker == 0xD8 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) continue;
    if (marker == 0xD9 || marker == 0xDA)
      f.fail("malformed JPEG: image data starts before any SOF segment");
    const std::vector<unsigned char> seg = f.read_at(pos, 7);
    if (seg.size() < 2) f.fail("truncated JPEG segment header");
    const std::uint32_t len = be16(seg.data());
    if (len < 2) f.fail("malformed JPEG: segment length below 2");
    const bool sof =
        marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (sof) {
      if (seg.size() < 7 || len < 7) f.fail("truncated JPEG SOF segment");
      return {"jpeg", static_cast<int>(be16(seg.data() + 5)),
              static_cast<int>(be16(seg.data() + 3))};
    }
    pos += len;
  }
  f.fail("malformed JPEG: no SOF segment in the first 4096 segments");
}

inline ImageHeader image_header(const std::filesystem::path& path, const ImageLimits& limits,
                                const std::string& prefix, bool as_dataset_error) {
  const BoundedFile f(path, limits, "image", prefix, as_dataset_error);
  const std::vector<unsigned char> h = f.read_at(0, 32);
  static constexpr std::array<unsigned char, 8> png_magic{0x89, 'P',  'N',  'G',
                                                          '\r', '\n', 0x1A, '\n'};
  ImageHeader out;
  std::int64_t w = 0, hgt = 0;
  if (h.size() >= 8 && std::equal(png_magic.begin(), png_magic.end(), h.begin())) {
    if (h.size() < 24) f.fail("truncated PNG: the IHDR chunk is incomplete");
    if (std::memcmp(h.data() + 12, "IHDR", 4) != 0 || be32(h.data() + 8) != 13)
      f.fail("malformed PNG: the first chunk is not a 13-byte IHDR");
    out.format = "png";
    w = be32(h.data() + 16);
    hgt = be32(h.data() + 20);
  } else if (h.size() >= 3 && h[0] == 0xFF && h[1] == 0xD8 && h[2] == 0xFF) {
    const ImageHeader j = parse_jpeg_header(f);
    out.format = j.format;
    w = j.width;
    hgt = j.height;
  } else if (h.size() >= 2 && h[0] == 'B' && h[1] == 'M') {
    if (h.size() < 26) f.fail("truncated BMP header");
    const std::uint32_t dib = le32(h.data() + 14);
    out.format = "bmp";
    if (dib == 12) {
      w = le16(h.data() + 18);
      hgt = le16(h.data() + 20);
    } else if (dib >= 40 && dib <= 124) {
      w = static_cast<std::int32_t>(le32(h.data() + 18));
      hgt = static_cast<std::int32_t>(le32(h.data() + 22));
      if (hgt < 0) hgt = -hgt; // top-down rows
    } else {
      f.fail("malformed BMP: unknown info header size " + std::to_string(dib));
    }
  } else {
    f.fail("unknown image format; expected PNG, JPEG or BMP");
  }
  if (w < 1 || hgt < 1)
    f.fail("the " + out.format + " header gives a size of " + std::to_string(w) + "x" +
           std::to_string(hgt) + "; expected at least 1x1");
  if (w > limits.max_width || hgt > limits.max_height)
    f.fail("the image is " + std::to_string(w) + "x" + std::to_string(hgt) +
           " pixels; the limit is " + std::to_string(limits.max_width) + "x" +
           std::to_string(limits.max_height) + " (ImageLimits)");
  out.width = static_cast<int>(w);
  out.height = static_cast<int>(hgt);
  return out;
}

inline cv::Mat image_file(const std::filesystem::path& path, int flags, const ImageLimits& limits,
                          const std::string& prefix, bool as_dataset_error) {
  const ImageHeader header = image_header(path, limits, prefix, as_dataset_error);
  const BoundedFile f(path, limits, "image", prefix, as_dataset_error);
  const std::vector<unsigned char> bytes = f.read_at(0, static_cast<std::size_t>(f.size()));
  if (bytes.size() != f.size()) f.fail("the file changed size while being read");
  cv::Mat img;
  try {
    img = cv::imdecode(bytes, flags);
  } catch (const cv::Exception& e) {
    f.fail(std::string("cannot decode the image: ") + e.what());
  }
  if (img.empty()) f.fail("cannot decode the " + header.format + " image (corrupt or truncated)");
  // IMREAD_REDUCED_* scale the image down; a JPEG's EXIF orientation may swap the sides.
  const bool reduced = flags > 0 && (flags & 16) != 0;
  const bool swapped =
      header.format == "jpeg" && img.cols == header.height && img.rows == header.width;
  if (!reduced && !swapped && (img.cols != header.width || img.rows != header.height))
    f.fail("decoded size " + std::to_string(img.cols) + "x" + std::to_string(img.rows) +
           " differs from the header's " + std::to_string(header.width) + "x" +
           std::to_string(header.height));
  return img;
}

} // namespace detail

inline ImageHeader read_image_header(const std::filesystem::path& path,
                                     const ImageLimits& limits = {}) {
  return detail::image_header(path, limits, {}, false);
}

inline cv::Mat read_image_file(const std::filesystem::path& path, int flags = cv::IMREAD_COLOR,
                               const ImageLimits& limits = {}) {
  return detail::image_file(path, flags, limits, {}, false);
}

SHADOWSENSE_NAMESPACE_END
