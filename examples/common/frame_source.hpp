// Frames for the programs: a folder of images (io/image_folder.hpp), a video file, or a camera
// index, read one frame at a time with the size limit checked before a frame is used; and an
// atomic PNG writer. Programs only (imgcodecs, and videoio when SHADOWSENSE_HAVE_VIDEOIO).
//
// FrameSource::open(spec, max_side)
//   spec: an existing folder -> its images by the one rule of shadowsense/io/image_folder.hpp
//         (recursive, .png .jpg .jpeg .bmp .tif .tiff .webp .ppm .pgm in any case, dot-names
//         skipped, sorted by path: name frames with zero-padded numbers); an existing file -> a
//         video (needs videoio); a non-negative integer -> that camera (needs videoio).
//   throws: shadowsense::IoError naming the spec when it cannot be opened, when a folder holds
//           no image, or when videoio is needed but was not built in.
// next(frame, name) -> false at the end.
//   ensures: frame is CV_8UC3 (grey images are expanded); name is the path relative to the
//            folder with '/' separators (folders) or "frame_NNNNNN", NNNNNN the frame index from
//            0 (videos, cameras).
//   throws:  IoError naming the file for an unreadable image or one larger than max_side.
// skip() -> false at the end: passes over one frame without decoding it (folders) or without
//   converting it (videos: grab only), so a program that keeps a few frames of many reads only
//   those.
// ended_early() -> the message when a video stopped before the frame count it declares (a
//   damaged or truncated file: OpenCV's read simply fails), else empty. Call after the end.
// Decoding limit: the programs set OPENCV_IO_MAX_IMAGE_PIXELS (limit_decoder) before the first
// imread, so OpenCV refuses oversized images from their header, before allocating them.
// One instance per thread.
#pragma once

#include <shadowsense/core/atomic_file.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/io/image_file.hpp>
#include <shadowsense/io/image_folder.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#ifdef SHADOWSENSE_HAVE_VIDEOIO
#include <opencv2/videoio.hpp>
#endif

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

namespace frames {

namespace fs = std::filesystem;

// Kept for the programs' start-up: OpenCV reads OPENCV_IO_MAX_IMAGE_PIXELS once, when its
// image codecs are loaded (before main), so setting it here bounds nothing by itself; the bound
// that takes effect is read_image's check of the file header before decoding.
inline void limit_decoder(int max_side) {
  const std::string v = std::to_string(static_cast<long long>(max_side) * max_side);
  ::setenv("OPENCV_IO_MAX_IMAGE_PIXELS", v.c_str(), 1);
}

// Reads one image as CV_8UC3, or throws IoError naming the file. PNG, JPEG and BMP (the formats
// io/image_file.hpp parses) are refused from their header, before any pixel is decoded, when
// larger than max_side per side; the other formats the image finder accepts (WebP, TIFF, PPM)
// are decoded by OpenCV and then checked.
inline cv::Mat read_image(const fs::path& p, int max_side) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  if (e == ".png" || e == ".jpg" || e == ".jpeg" || e == ".bmp") {
    shadowsense::ImageLimits limits;
    limits.max_width = limits.max_height = max_side;
    return shadowsense::read_image_file(p, cv::IMREAD_COLOR, limits);
  }
  cv::Mat m;
  try {
    m = cv::imread(p.string(), cv::IMREAD_COLOR);
  } catch (const cv::Exception& ex) {
    throw shadowsense::IoError("cannot read image '" + p.string() + "': " + ex.what());
  }
  if (m.empty())
    throw shadowsense::IoError("cannot read image '" + p.string() +
                               "' (missing, not an image, or larger than " +
                               std::to_string(max_side) + "x" + std::to_string(max_side) + ")");
  if (m.cols > max_side || m.rows > max_side)
    throw shadowsense::IoError("image '" + p.string() + "' is " + std::to_string(m.cols) + "x" +
                               std::to_string(m.rows) + "; expected at most " +
                               std::to_string(max_side) + " px per side");
  return m;
}

class FrameSource {
public:
  static FrameSource open(const std::string& spec, int max_side) {
    FrameSource s;
    s.max_side_ = max_side;
    std::error_code ec;
    if (fs::is_directory(spec, ec)) {
      s.root_ = spec;
      s.files_ = shadowsense::require_images(spec);
      return s;
    }
    const bool camera = !spec.empty() && std::all_of(spec.begin(), spec.end(), [](char c) {
      return c >= '0' && c <= '9';
    }) && spec.size() <= 3;
    if (!camera && !fs::exists(spec, ec))
      throw shadowsense::IoError("'" + spec + "' is neither a folder, a file nor a camera index");
#ifdef SHADOWSENSE_HAVE_VIDEOIO
    s.video_.emplace();
    const bool ok = camera ? s.video_->open(std::stoi(spec)) : s.video_->open(spec);
    if (!ok || !s.video_->isOpened())
      throw shadowsense::IoError("cannot open " + std::string(camera ? "camera " : "video '") +
                                 spec + (camera ? "" : "'") +
                                 " (no decoder for it, or not a video)");
    s.camera_ = camera;
    const double fps = s.video_->get(cv::CAP_PROP_FPS);
    if (std::isfinite(fps) && fps > 0 && fps < 10000) s.fps_ = fps;
    const double n = s.video_->get(cv::CAP_PROP_FRAME_COUNT);
    if (!camera && std::isfinite(n) && n > 0) s.count_ = static_cast<std::size_t>(n);
    return s;
#else
    throw shadowsense::IoError("'" + spec +
                               "' is not a folder; videos and cameras need OpenCV videoio, which "
                               "this build does not have (install libopencv-videoio-dev)");
#endif
  }

  bool next(cv::Mat& frame, std::string& name) {
    if (!files_.empty()) {
      if (index_ >= files_.size()) return false;
      frame = read_image(files_[index_], max_side_);
      name = files_[index_].lexically_relative(root_).generic_string();
      ++index_;
      return true;
    }
#ifdef SHADOWSENSE_HAVE_VIDEOIO
    if (!video_ || !video_->read(frame) || frame.empty()) return false;
    if (frame.cols > max_side_ || frame.rows > max_side_)
      throw shadowsense::IoError("video frames are " + std::to_string(frame.cols) + "x" +
                                 std::to_string(frame.rows) + "; expected at most " +
                                 std::to_string(max_side_) + " px per side");
    if (frame.type() == CV_8UC1) cv::cvtColor(frame, frame, cv::COLOR_GRAY2BGR);
    char buf[32];
    std::snprintf(buf, sizeof buf, "frame_%06zu", index_);
    name = buf;
    ++index_;
    return true;
#else
    return false;
#endif
  }

  bool skip() {
    if (!files_.empty()) {
      if (index_ >= files_.size()) return false;
      ++index_;
      return true;
    }
#ifdef SHADOWSENSE_HAVE_VIDEOIO
    if (!video_ || !video_->grab()) return false;
    ++index_;
    return true;
#else
    return false;
#endif
  }

  // Container frame counts can be estimates (duration x rate): a shortfall of up to 1% (at least
  // 2 frames) is not reported.
  std::string ended_early() const {
    if (!files_.empty() || camera_ || !count_) return {};
    const std::size_t slack = std::max<std::size_t>(2, *count_ / 100);
    if (index_ + slack >= *count_) return {};
    return "the video ended after " + std::to_string(index_) + " of the " +
           std::to_string(*count_) + " frames it declares (damaged or truncated?)";
  }

  bool is_folder() const {
    return !files_.empty();
  }
  bool is_camera() const {
    return camera_;
  }
  // Frames per second the video declares (none for folders and some cameras).
  std::optional<double> fps() const {
    return fps_;
  }
  // Number of frames when known (folders, most video files).
  std::optional<std::size_t> count() const {
    if (!files_.empty()) return files_.size();
    return count_;
  }

private:
  fs::path root_;
  std::vector<fs::path> files_;
  std::size_t index_ = 0;
  int max_side_ = 8192;
  bool camera_ = false;
  std::optional<double> fps_;
  std::optional<std::size_t> count_;
#ifdef SHADOWSENSE_HAVE_VIDEOIO
  std::optional<cv::VideoCapture> video_;
#endif
};

inline void write_png_atomically(const fs::path& path, const cv::Mat& image) {
  std::vector<uchar> bytes;
  if (!cv::imencode(".png", image, bytes))
    throw shadowsense::IoError("cannot encode '" + path.string() + "' as PNG");
  shadowsense::write_file_atomically(
      path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

// Draws a segmentation over a frame: shadow pixels tinted blue, contact red, blob boxes.
template <class Segmentation>
cv::Mat overlay(const cv::Mat& frame, const Segmentation& s) {
  cv::Mat out = frame.clone();
  cv::Mat tint(frame.size(), CV_8UC3, cv::Scalar(255, 120, 0));
  cv::Mat mixed;
  cv::addWeighted(frame, 0.55, tint, 0.45, 0, mixed);
  mixed.copyTo(out, s.shadow_mask);
  tint.setTo(cv::Scalar(0, 0, 255));
  cv::addWeighted(frame, 0.4, tint, 0.6, 0, mixed);
  mixed.copyTo(out, s.contact_mask);
  for (const auto& b : s.shadows) cv::rectangle(out, b.box, cv::Scalar(255, 255, 0), 1);
  for (const auto& b : s.contacts) cv::rectangle(out, b.box, cv::Scalar(0, 255, 255), 1);
  return out;
}

} // namespace frames
