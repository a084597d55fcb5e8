// External contours of a binary mask by Suzuki-Abe border following (outer borders only), the
// library's own implementation with buffers kept from call to call (no heap allocation once they
// have grown to the frame size and the frame's number of contour points).
//
// The output is identical, contour for contour and point for point, to
//   cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE)
// of OpenCV 4 (its raster-to-chain scanner): the mask is padded with one pixel of 0 and reduced
// to 0/1; a raster scan finds each outer border at a 0 -> 1 step whose last met border is not the
// left side of an already traced outer border (so components inside holes are skipped, as
// RETR_EXTERNAL does); the border is followed clockwise in image coordinates from that pixel,
// marking its pixels (2, or -126 where the right neighbour is background and was examined), and
// a point is written wherever the chain direction changes (CHAIN_APPROX_SIMPLE). OpenCV links
// each new contour in front of the previous ones, so contour 0 is the one found last (the one
// whose first pixel comes last in raster order).
//
// ExternalContours::find(mask)
//   requires: mask CV_8UC1, non-empty (0 = background, anything else = object).
//   ensures:  size() contours; contour(i) its points (image coordinates) and box(i) their
//             bounding box (cv::boundingRect of the points), in cv::findContours' order.
//   throws:   InvalidArgument for a bad mask.
// prepare(cols, rows) -> marks, marks_stride(), then scan(): find(mask) in two steps, for a
//   caller that makes the mask row by row (the segmenter's one pass writes each final mask row
//   here as it goes, so the mask is not read again).
//   prepare requires cols, rows >= 1; returns where row y of the 0/1 image goes (marks +
//   y * marks_stride(), cols bytes; the frame of 0 around it is set). scan requires every row
//   written with 0 or 1; ensures what find(mask) ensures for the mask whose non-zero pixels
//   are the 1s. row_flags() (rows bytes, all 1 after prepare): the caller may set row y's to 0
//   when that row holds no 1, and the scan skips it (an empty row starts no border and its
//   pixels are never marked, since tracing marks border pixels only, which are 1s).
// Threading: holds scratch buffers; one instance per thread (a BlobFinder owns one).
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sense/byte_runs.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

class ExternalContours {
public:
  void find(const cv::Mat& mask) {
    detail::require(mask.type() == CV_8UC1 && !mask.empty(),
                    "ExternalContours::find: expected a non-empty CV_8UC1 mask");
    std::uint8_t* marks = prepare(mask.cols, mask.rows);
    const int cols = mask.cols; // a local: byte stores below could alias mask.cols
    for (int y = 0; y < mask.rows; ++y) {
      const uchar* __restrict src = mask.ptr<uchar>(y);
      std::uint8_t* __restrict dst = marks + static_cast<std::size_t>(y) * stride_;
      for (int x = 0; x < cols; ++x) dst[x] = std::min<uchar>(src[x], 1); // 0/1 (vectorises)
    }
    scan();
  }

  std::uint8_t* prepare(int cols, int rows) {
    detail::require(cols >= 1 && rows >= 1, "ExternalContours::prepare: expected a non-empty size");
    cols_ = cols;
    rows_ = rows;
    const int w = cols + 2, h = rows + 2;
    const auto uw = static_cast<std::size_t>(w);
    stride_ = uw;
    image_.resize(uw * static_cast<std::size_t>(h));
    std::int8_t* img = image_.data();
    std::fill(img, img + uw, 0); // the frame of 0 around the mask
    std::fill(img + (static_cast<std::size_t>(h) - 1) * uw, img + static_cast<std::size_t>(h) * uw,
              0);
    for (int y = 1; y < h - 1; ++y) {
      std::int8_t* row = img + static_cast<std::size_t>(y) * uw;
      row[0] = row[w - 1] = 0;
    }
    row_flags_.assign(static_cast<std::size_t>(rows), 1);
    // Character types may alias: the caller writes 0/1 bytes.
    return reinterpret_cast<std::uint8_t*>(img + uw + 1);
  }
  std::size_t marks_stride() const { return stride_; }
  std::uint8_t* row_flags() { return row_flags_.data(); }

  void scan() {
    points_.clear();
    found_.clear();
    const int w = cols_ + 2, h = rows_ + 2;
    std::int8_t* img = image_.data();
    const std::size_t uw = stride_;
    // The raster scan of OpenCV's scanner in RETR_EXTERNAL mode.
    for (int y = 1; y < h - 1; ++y) {
      if (!row_flags_[static_cast<std::size_t>(y - 1)]) continue; // no 1 in this row
      std::int8_t* row = img + static_cast<std::size_t>(y) * uw;
      int prev = 0, lnbd = 0; // lnbd: column of the last met border pixel in this row
      for (int x = 1; x < w - 1; ++x) {
        x = detail::run_end(row, x, w - 1, static_cast<std::int8_t>(prev));
        if (x >= w - 1) break;
        const int p = row[x];
        bool outer = prev == 0 && p == 1;
        if (!outer && p == 0 && prev >= 1 && (prev & -2)) lnbd = x - 1; // a hole's edge
        if (outer && row[lnbd] > 0) outer = false; // inside a traced outer border: not external
        if (outer) {
          lnbd = x;
          trace(row + x, w, cv::Point(x - 1, y - 1));
          prev = row[x]; // as marked by the trace
        } else {
          prev = p;
          if (prev & -2) lnbd = x;
        }
      }
    }
  }

  std::size_t size() const { return found_.size(); }
  std::span<const cv::Point> contour(std::size_t i) const {
    const Found& f = found_[found_.size() - 1 - i];
    return {points_.data() + f.begin, f.end - f.begin};
  }
  cv::Rect box(std::size_t i) const { return found_[found_.size() - 1 - i].box; }

private:
  struct Found {
    std::size_t begin, end; // range in points_
    cv::Rect box;
  };

  // OpenCV's icvFetchContour for an outer border with CHAIN_APPROX_SIMPLE.
  void trace(std::int8_t* start, int step, cv::Point pt) {
    // Chain code directions (x, y): right, up-right, up, up-left, left, down-left, down,
    // down-right.
    static constexpr std::array<int, 8> code_x{1, 1, 0, -1, -1, -1, 0, 1};
    static constexpr std::array<int, 8> code_y{0, -1, -1, -1, 0, 1, 1, 1};
    const std::array<int, 16> deltas{1, -step + 1, -step, -step - 1, -1, step - 1, step, step + 1,
                                     1, -step + 1, -step, -step - 1, -1, step - 1, step, step + 1};
    constexpr std::int8_t border = 2, right_border = -126; // nbd and nbd | -128
    Found f{points_.size(), 0, {}};
    int xmin = pt.x, xmax = pt.x, ymin = pt.y, ymax = pt.y;
    auto write = [&](cv::Point q) {
      points_.push_back(q);
      xmin = std::min(xmin, q.x);
      xmax = std::max(xmax, q.x);
      ymin = std::min(ymin, q.y);
      ymax = std::max(ymax, q.y);
    };
    std::int8_t* const i0 = start;
    std::int8_t* i1 = nullptr;
    int s = 4, s_end = 4;
    do {
      s = (s - 1) & 7;
      i1 = i0 + deltas[static_cast<std::size_t>(s)];
    } while (*i1 == 0 && s != s_end);
    if (s == s_end) { // a single pixel
      *i0 = right_border;
      write(pt);
    } else {
      std::int8_t* i3 = i0;
      std::int8_t* i4 = nullptr;
      int prev_s = s ^ 4;
      for (;;) {
        s_end = s;
        while (s < 15) {
          i4 = i3 + deltas[static_cast<std::size_t>(++s)];
          if (*i4 != 0) break;
        }
        s &= 7;
        if (static_cast<unsigned>(s - 1) < static_cast<unsigned>(s_end))
          *i3 = right_border;
        else if (*i3 == 1)
          *i3 = border;
        if (s != prev_s) {
          write(pt);
          prev_s = s;
        }
        pt.x += code_x[static_cast<std::size_t>(s)];
        pt.y += code_y[static_cast<std::size_t>(s)];
        if (i4 == i0 && i3 == i1) break;
        i3 = i4;
        s = (s + 4) & 7;
      }
    }
    f.end = points_.size();
    f.box = cv::Rect(xmin, ymin, xmax - xmin + 1, ymax - ymin + 1);
    found_.push_back(f);
  }

  std::vector<std::int8_t> image_;      // the padded mask: 0/1, then border marks
  int cols_ = 0, rows_ = 0;             // the mask's size (prepare)
  std::size_t stride_ = 0;              // cols_ + 2
  std::vector<std::uint8_t> row_flags_; // 0: the row holds no 1 (skipped by the scan)
  std::vector<cv::Point> points_;       // every contour's points, in the order found
  std::vector<Found> found_;            // in the order found (the reverse of OpenCV's output)
};

SHADOWSENSE_NAMESPACE_END
