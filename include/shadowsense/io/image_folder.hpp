// The images of a folder, found the same way by every program (ss_classify, ss_track,
// ss_calibrate, ...) and by the training readers: ONE rule, so a folder means the same thing
// everywhere (docs/dataset_format.md, "Folders of images").
//
// THE RULE
//   * Recursive: images in sub-folders are found too (a dataset's class folders, a camera's
//     day folders). Symbolic links to folders are not followed (no cycles).
//   * Extensions .png .jpg .jpeg .bmp .tif .tiff .webp .ppm .pgm, in any case.
//   * Names starting with '.' are skipped, files and folders alike (.git, editor files).
//   * Sorted by path, component by component (byte order within a component): a folder's
//     images stay together, and zero-padded frame numbers sort in capture order.
//   * Bounded: more than limits.max_images images is an error, not hours of listing.
//
// API
//   bool is_image_name(path)
//     ensures: whether path's extension is one of the rule's (any case).
//   std::string image_extensions_text()
//     ensures: ".png .jpg .jpeg .bmp .tif .tiff .webp .ppm .pgm", for messages and --help.
//   struct ImageFolderLimits { std::size_t max_images = 1'000'000; }
//   std::vector<path> find_images(folder, limits = {})
//     requires: nothing (any path).
//     ensures:  every image under folder by the rule above, sorted; may be empty.
//     throws:   IoError naming the folder when it is missing or not a folder, cannot be
//               listed, or holds more than limits.max_images images; InvalidArgument when
//               limits.max_images is 0.
//   std::vector<path> require_images(folder, limits = {})
//     ensures:  find_images(folder, limits), never empty.
//     throws:   as find_images, and IoError naming the folder and the extensions when it holds
//               no image.
//
// THREADING
//   Stateless functions: safe from any number of threads (the folder may change meanwhile;
//   a file that vanishes is then reported by whoever reads it).
#pragma once

#include <shadowsense/core/error.hpp>

#include <algorithm>
#include <cctype>
#include <cstddef>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

namespace detail {
inline constexpr const char* image_extensions[] = {".png",  ".jpg",  ".jpeg", ".bmp", ".tif",
                                                   ".tiff", ".webp", ".ppm",  ".pgm"};
} // namespace detail

inline bool is_image_name(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const char* e : detail::image_extensions)
    if (ext == e) return true;
  return false;
}

inline std::string image_extensions_text() {
  std::string s;
  for (const char* e : detail::image_extensions) {
    if (!s.empty()) s += ' ';
    s += e;
  }
  return s;
}

struct ImageFolderLimits {
  std::size_t max_images = 1'000'000;
};

inline std::vector<std::filesystem::path> find_images(const std::filesystem::path& folder,
                                                      const ImageFolderLimits& limits = {}) {
  namespace fs = std::filesystem;
  detail::require(limits.max_images >= 1, "find_images: max_images must be >= 1");
  std::error_code ec;
  detail::require<IoError>(fs::is_directory(folder, ec),
                           folder.string() +
                               (fs::exists(folder, ec) ? ": not a folder" : ": missing") +
                               ", expected a folder of images");
  std::vector<fs::path> out;
  try {
    for (auto it = fs::recursive_directory_iterator(folder);
         it != fs::recursive_directory_iterator(); ++it) {
      const auto name = it->path().filename().string();
      if (!name.empty() && name[0] == '.') {
        if (it->is_directory()) it.disable_recursion_pending();
        continue;
      }
      if (!it->is_regular_file() || !is_image_name(it->path())) continue;
      detail::require<IoError>(out.size() < limits.max_images,
                               folder.string() + ": more than " +
                                   std::to_string(limits.max_images) +
                                   " images; expected at most that many");
      out.push_back(it->path());
    }
  } catch (const fs::filesystem_error& e) {
    SHADOWSENSE_THROW(IoError(folder.string() + ": cannot list the folder: " + e.what()));
  }
  std::sort(out.begin(), out.end());
  return out;
}

inline std::vector<std::filesystem::path> require_images(const std::filesystem::path& folder,
                                                         const ImageFolderLimits& limits = {}) {
  auto out = find_images(folder, limits);
  detail::require<IoError>(!out.empty(), folder.string() + ": holds no image (looked for " +
                                             image_extensions_text() + ", in sub-folders too)");
  return out;
}

SHADOWSENSE_NAMESPACE_END
