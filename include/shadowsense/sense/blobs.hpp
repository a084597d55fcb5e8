// Blobs: the connected regions of a binary class mask, found as external contours (Suzuki-Abe,
// border_following.hpp: the same contours as cv::findContours RETR_EXTERNAL +
// CHAIN_APPROX_SIMPLE), filtered by size and grouped when their boxes are close. No heap
// allocation per call once the buffers have grown (members are spans into one reused vector).
//
// Blob: one group of nearby contours of one class, as the segmenter reports it.
//
// BlobFinder::find(mask, min_area, merge_gap, max_contours)
//   requires: mask is CV_8UC1 (0 / non-zero); min_area >= 0; merge_gap >= 0; max_contours >= 1.
//   ensures:  contours() holds every external contour; kept() those whose pixel count is
//             >= min_area and > 0 (at most max_contours: beyond that the smallest are dropped and
//             dropped() says how many), in contour order; groups() partitions kept() into groups
//             whose members are connected by box gaps (Chebyshev distance between boxes, 0 when
//             touching or overlapping) <= merge_gap, each with the union box of its members.
//             Groups' member spans stay valid until the next find().
// find_prepared(mask, ...): the same, with the contour image already written through
//   contours_input().prepare (the segmenter's one pass); mask is still read for the areas.
//   cost:     the contours plus sorting, then a sweep along x over the kept boxes: O(n log n) for
//             scattered blobs; never more than max_contours^2 / 2 box comparisons.
// A BlobFinder holds scratch buffers: one instance per thread (it lives inside a Segmenter).
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sense/border_following.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <numeric>
#include <optional>
#include <span>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// A group of nearby contours of one class.
struct Blob {
  cv::Rect box{};         // inclusive pixel coverage of the group
  cv::Point2f centroid{}; // centroid of the group's mask pixels
  double area = 0;        // mask pixels in the group
  float darkness = 0;     // mean darkness of its pixels (relative mode; 0 in fixed_ranges)
  float edge_width = 0;   // mean width of the darkness ramp at its edge, px (relative mode)
  // Shadow blobs that touch nothing (relative mode): estimated opacity of the shadow's core, the
  // 95th percentile of its darkness over the darkness of the half-opacity line (2 x the frame's
  // shadow threshold); falls as the part rises.
  float opacity = 0;
  bool touching = false; // shadow blobs: a contact blob lies inside
  std::optional<float>
      hover_height_cm{}; // shadow blobs not touching, when a HoverHeightModel is set
};

namespace detail {

// Union-find with path halving.
struct DisjointSets {
  std::vector<int> parent;
  void reset(int n) {
    parent.resize(static_cast<std::size_t>(n));
    std::iota(parent.begin(), parent.end(), 0);
  }
  int find(int i) {
    while (parent[static_cast<std::size_t>(i)] != i) {
      parent[static_cast<std::size_t>(i)] =
          parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(i)])];
      i = parent[static_cast<std::size_t>(i)];
    }
    return i;
  }
  void unite(int a, int b) { parent[static_cast<std::size_t>(find(a))] = find(b); }
};

// Gap between two boxes in pixels (0 when they touch or overlap): Chebyshev distance.
inline int box_gap(const cv::Rect& a, const cv::Rect& b) {
  const int gx = std::max({0, b.x - (a.x + a.width), a.x - (b.x + b.width)});
  const int gy = std::max({0, b.y - (a.y + a.height), a.y - (b.y + b.height)});
  return std::max(gx, gy);
}

} // namespace detail

class BlobFinder {
public:
  struct Kept {
    cv::Rect box;
    double area;         // mask pixels inside the box
    std::size_t contour; // index into contours()
  };
  struct Group {
    cv::Rect box;                 // union of the members' boxes
    std::span<const int> members; // indices into kept(), increasing
  };

  void find(const cv::Mat& mask, double min_area, int merge_gap, std::size_t max_contours) {
    contours_.find(mask);
    find_prepared(mask, min_area, merge_gap, max_contours, false);
  }
  // For find_prepared: prepare() the contour image here, write its rows.
  ExternalContours& contours_input() { return contours_; }
  void find_prepared(const cv::Mat& mask, double min_area, int merge_gap, std::size_t max_contours,
                     bool scan = true) {
    kept_.clear();
    groups_.clear();
    dropped_ = 0;
    if (scan) contours_.scan();
    for (std::size_t i = 0; i < contours_.size(); ++i) {
      const cv::Rect r = contours_.box(i);
      const double area = cv::countNonZero(mask(r)); // pixels, not the polygon's area
      if (area >= min_area && area > 0) kept_.push_back({r, area, i});
    }
    if (kept_.size() > max_contours) { // keep the largest, in contour order
      dropped_ = kept_.size() - max_contours;
      std::nth_element(kept_.begin(), kept_.begin() + static_cast<std::ptrdiff_t>(max_contours),
                       kept_.end(), [](const Kept& a, const Kept& b) {
                         return a.area != b.area ? a.area > b.area : a.contour < b.contour;
                       });
      kept_.resize(max_contours);
      std::sort(kept_.begin(), kept_.end(),
                [](const Kept& a, const Kept& b) { return a.contour < b.contour; });
    }
    group(merge_gap);
  }

  const ExternalContours& contours() const { return contours_; }
  const std::vector<Kept>& kept() const { return kept_; }
  const std::vector<Group>& groups() const { return groups_; }
  std::size_t dropped() const { return dropped_; }

private:
  // Sweep along x: a box can only be within merge_gap of boxes whose right edge plus the gap
  // reaches its left edge; boxes left behind are retired for good.
  void group(int merge_gap) {
    const int n = static_cast<int>(kept_.size());
    sets_.reset(n);
    order_.resize(static_cast<std::size_t>(n));
    std::iota(order_.begin(), order_.end(), 0);
    std::sort(order_.begin(), order_.end(), [&](int a, int b) {
      return kept_[static_cast<std::size_t>(a)].box.x < kept_[static_cast<std::size_t>(b)].box.x;
    });
    active_.clear();
    for (int i : order_) {
      const cv::Rect& bi = kept_[static_cast<std::size_t>(i)].box;
      std::erase_if(active_, [&](int j) {
        const cv::Rect& bj = kept_[static_cast<std::size_t>(j)].box;
        return bj.x + bj.width + merge_gap < bi.x;
      });
      for (int j : active_)
        if (detail::box_gap(bi, kept_[static_cast<std::size_t>(j)].box) <= merge_gap)
          sets_.unite(i, j);
      active_.push_back(i);
    }
    // Group ids in order of each group's first member; members stored group by group.
    root_group_.assign(static_cast<std::size_t>(n), -1);
    group_of_.resize(static_cast<std::size_t>(n));
    int groups = 0;
    for (int i = 0; i < n; ++i) {
      int& g = root_group_[static_cast<std::size_t>(sets_.find(i))];
      if (g < 0) g = groups++;
      group_of_[static_cast<std::size_t>(i)] = g;
    }
    first_.assign(static_cast<std::size_t>(groups) + 1, 0);
    for (int i = 0; i < n; ++i)
      ++first_[static_cast<std::size_t>(group_of_[static_cast<std::size_t>(i)]) + 1];
    for (int g = 0; g < groups; ++g)
      first_[static_cast<std::size_t>(g) + 1] += first_[static_cast<std::size_t>(g)];
    members_.resize(static_cast<std::size_t>(n));
    fill_.assign(first_.begin(), first_.end() - 1);
    groups_.resize(static_cast<std::size_t>(groups));
    for (int i = 0; i < n; ++i) {
      const auto g = static_cast<std::size_t>(group_of_[static_cast<std::size_t>(i)]);
      const cv::Rect& b = kept_[static_cast<std::size_t>(i)].box;
      groups_[g].box = fill_[g] == first_[g] ? b : (groups_[g].box | b);
      members_[static_cast<std::size_t>(fill_[g]++)] = i;
    }
    for (std::size_t g = 0; g < groups_.size(); ++g)
      groups_[g].members = std::span<const int>(
          members_.data() + first_[g], static_cast<std::size_t>(first_[g + 1] - first_[g]));
  }

  ExternalContours contours_;
  std::vector<Kept> kept_;
  std::vector<Group> groups_;
  std::size_t dropped_ = 0;
  detail::DisjointSets sets_;
  std::vector<int> order_, active_, root_group_, group_of_, first_, fill_, members_;
};

SHADOWSENSE_NAMESPACE_END
