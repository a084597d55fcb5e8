// Reads a folder of real hand silhouettes (sim/silhouette_hand.hpp) for the scene generator:
// DIR/manifest.csv and the masks it names. Needs OpenCV imgcodecs (through <shadowsense/io.hpp>'s
// bounded image reader), so it is apart from the core-only generator headers.
//
//   std::vector<HandSilhouette> load_hand_silhouettes(const std::filesystem::path& dir,
//                                                     std::string_view split = "train")
//     reads dir/manifest.csv (header with at least the columns file and pose; optional split
//     and length_cm) and the masks it names (1-bit or 8-bit PNG/JPEG/BMP, > 127 = hand). pose:
//     palm (open), point, punch or fist. Rows whose split column differs from `split` are
//     skipped (an empty `split` keeps every row). length_cm, when absent: 18.5 (palm), 15
//     (point), 10.5 (fist), the folder convention of the hand sources.
//     throws: DatasetError naming the file and line for a malformed manifest, an unknown pose, a
//     file outside dir, a bad length, or no row kept; IoError for an unreadable mask;
//     InvalidArgument (from validate) naming the file for a mask without a wrist row.
//
// Threading: a pure function apart from reading files.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/io/dataset.hpp>
#include <shadowsense/io/image_file.hpp>
#include <shadowsense/sim/silhouette_hand.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN
namespace sim {

inline std::vector<HandSilhouette> load_hand_silhouettes(const std::filesystem::path& dir,
                                                         std::string_view split = "train") {
  namespace fs = std::filesystem;
  const fs::path csv = dir / "manifest.csv";
  const std::vector<std::string> lines = detail::csv_lines(detail::read_csv_text(csv), csv);
  const auto header = detail::split_csv(lines[0]);
  auto column = [&](std::string_view name) -> int {
    for (std::size_t i = 0; i < header.size(); ++i)
      if (header[i] == name) return static_cast<int>(i);
    return -1;
  };
  const int c_file = column("file"), c_pose = column("pose"), c_split = column("split"),
            c_len = column("length_cm");
  if (c_file < 0 || c_pose < 0)
    SHADOWSENSE_THROW(
        DatasetError(csv.string() + ":1: expected a header with the columns file and pose"));
  std::vector<HandSilhouette> out;
  for (std::size_t li = 1; li < lines.size(); ++li) {
    const std::string where = csv.string() + ":" + std::to_string(li + 1) + ": ";
    const auto f = detail::split_csv(lines[li]);
    if (f.size() != header.size())
      SHADOWSENSE_THROW(DatasetError(where + "expected " + std::to_string(header.size()) +
                                     " fields, got " + std::to_string(f.size())));
    if (c_split >= 0 && !split.empty() && f[static_cast<std::size_t>(c_split)] != split) continue;
    HandSilhouette s;
    const std::string_view pose = f[static_cast<std::size_t>(c_pose)];
    if (pose == "palm")
      s.shape = HandShape::open;
    else if (pose == "point")
      s.shape = HandShape::point;
    else if (pose == "punch" || pose == "fist")
      s.shape = HandShape::fist;
    else
      SHADOWSENSE_THROW(DatasetError(where + "unknown pose '" + std::string(pose) +
                                     "'; expected palm, point, punch or fist"));
    s.length_cm = silhouette_default_length_cm(s.shape);
    if (c_len >= 0) {
      const std::string_view v = f[static_cast<std::size_t>(c_len)];
      double len = 0;
      const auto r = std::from_chars(v.data(), v.data() + v.size(), len);
      if (r.ec != std::errc() || r.ptr != v.data() + v.size() || !(len >= 3 && len <= 40))
        SHADOWSENSE_THROW(DatasetError(where + "length_cm must be a number in [3, 40], got '" +
                                       std::string(v) + "'"));
      s.length_cm = len;
    }
    const fs::path rel{std::string(f[static_cast<std::size_t>(c_file)])};
    const bool escapes =
        rel.empty() || rel.is_absolute() ||
        std::any_of(rel.begin(), rel.end(), [](const fs::path& p) { return p == ".."; });
    if (escapes)
      SHADOWSENSE_THROW(DatasetError(where + "file '" + rel.string() +
                                     "' must be a relative path inside the folder"));
    s.name = rel.generic_string();
    cv::Mat grey = read_image_file(dir / rel, cv::IMREAD_GRAYSCALE);
    cv::compare(grey, 127, s.mask, cv::CMP_GT);
    s.validate();
    out.push_back(std::move(s));
  }
  if (out.empty())
    SHADOWSENSE_THROW(
        DatasetError(csv.string() + ": no silhouette" +
                     (split.empty() ? std::string() : " with split '" + std::string(split) + "'")));
  return out;
}

} // namespace sim
SHADOWSENSE_NAMESPACE_END
