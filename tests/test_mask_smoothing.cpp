// MaskSmoother against OpenCV: the thresholded 8-bit Gaussian must be bit-identical to
// cv::GaussianBlur(BORDER_REPLICATE) + cv::threshold(127) on random masks of every size class
// (1 pixel, one row, one column, smaller than the kernel, frame sized), for every kernel size the
// segmenter accepts, and on the edge cases (all 0, all 255, lone pixels at the borders).
#include <shadowsense/sense/mask_smoothing.hpp>

#include <doctest/doctest.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <string>
#include <vector>

using namespace shadowsense;

namespace {

cv::Mat reference(const cv::Mat& mask, int k) {
  cv::Mat blurred, out;
  cv::GaussianBlur(mask, blurred, cv::Size(k, k), 0, 0, cv::BORDER_REPLICATE);
  cv::threshold(blurred, out, 127, 255, cv::THRESH_BINARY);
  return out;
}

// Number of pixels where ours differs from OpenCV's.
int mismatches(MaskSmoother& smoother, const cv::Mat& mask, int k) {
  cv::Mat ours = mask.clone();
  smoother.apply(ours, k);
  return cv::countNonZero(ours != reference(mask, k));
}

// Random 0/255 mask with blob-like structure (random density per mask) or raw random bytes.
cv::Mat random_mask(cv::RNG& rng, cv::Size size, bool binary) {
  cv::Mat m(size, CV_8UC1);
  if (!binary) {
    rng.fill(m, cv::RNG::UNIFORM, 0, 256);
    return m;
  }
  const double density = rng.uniform(0.05, 0.95);
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x) m.at<uchar>(y, x) = rng.uniform(0.0, 1.0) < density ? 255 : 0;
  if (rng.uniform(0, 2)) { // smoother shapes: blur the noise and threshold it
    cv::Mat f;
    cv::blur(m, f, cv::Size(3, 3));
    m = f > 127;
  }
  return m;
}

} // namespace

TEST_CASE("gaussian_taps_q8: the small kernels are OpenCV's dyadic tables and all sum to 256") {
  CHECK(detail::gaussian_taps_q8(5)[0] == 16);
  CHECK(detail::gaussian_taps_q8(5)[2] == 96);
  for (int k = 1; k <= 31; k += 2) {
    const auto t = detail::gaussian_taps_q8(k);
    int sum = 0;
    for (int i = 0; i < k; ++i) sum += t[static_cast<std::size_t>(i)];
    CHECK(sum == 256);
  }
  CHECK_THROWS_AS(detail::gaussian_taps_q8(4), InvalidArgument);
  CHECK_THROWS_AS(detail::gaussian_taps_q8(33), InvalidArgument);
}

TEST_CASE("MaskSmoother equals cv::GaussianBlur + threshold bit for bit: default kernel 5") {
  cv::RNG rng(0x5EED);
  MaskSmoother smoother;
  int total = 0;
  for (int i = 0; i < 400; ++i) {
    const cv::Size size(rng.uniform(1, 90), rng.uniform(1, 70));
    const cv::Mat m = random_mask(rng, size, i % 4 != 3);
    const int bad = mismatches(smoother, m, 5);
    if (bad) MESSAGE("mask " << i << " (" << size.width << "x" << size.height << ")");
    total += bad;
  }
  CHECK(total == 0);
  // Frame-sized masks (the robot rig's frames are 635x350).
  for (int i = 0; i < 4; ++i)
    CHECK(mismatches(smoother, random_mask(rng, {635, 350}, true), 5) == 0);
}

TEST_CASE("MaskSmoother: bands of empty rows between shapes, one smoother over many masks") {
  // The streaming path skips the sums of all-0 rows (mask_smoothing.hpp): shapes separated by
  // empty bands of every height 0..7, at the top and bottom too, and masks that alternate with
  // full ones so a ring slot that held sums must be cleared before it counts as 0.
  cv::RNG rng(0xBA4D);
  MaskSmoother smoother;
  int total = 0, masks = 0;
  for (const int k : {3, 5}) {
    for (int i = 0; i < 200; ++i) {
      const cv::Size size(rng.uniform(2, 70), rng.uniform(2, 60));
      cv::Mat m = random_mask(rng, size, true);
      for (int y = rng.uniform(0, 3); y < size.height;) { // blank bands of random height
        const int band = rng.uniform(0, 8);
        m.rowRange(y, std::min(size.height, y + band)).setTo(0);
        y += band + rng.uniform(1, 4);
      }
      total += mismatches(smoother, m, k);
      total += mismatches(smoother, cv::Mat(size, CV_8UC1, cv::Scalar(255)), k);
      masks += 2;
    }
  }
  CHECK(masks == 800);
  CHECK(total == 0);
}

TEST_CASE("MaskSmoother equals OpenCV for every kernel size the segmenter accepts") {
  cv::RNG rng(0xC0FFEE);
  MaskSmoother smoother;
  for (int k = 3; k <= 31; k += 2) {
    int total = 0;
    for (int i = 0; i < 60; ++i) {
      const cv::Size size(rng.uniform(1, 80), rng.uniform(1, 60));
      total += mismatches(smoother, random_mask(rng, size, i % 3 != 2), k);
    }
    INFO("kernel " << k);
    CHECK(total == 0);
  }
}

TEST_CASE("MaskSmoother edge cases: 1 pixel, all 0, all 255, lone pixels, half-height ties") {
  MaskSmoother smoother;
  for (int k : {3, 5, 7, 9, 31}) {
    INFO("kernel " << k);
    for (const cv::Size size : {cv::Size(1, 1), cv::Size(1, 9), cv::Size(9, 1), cv::Size(2, 2),
                                cv::Size(4, 3), cv::Size(40, 30)}) {
      INFO("size " << size.width << "x" << size.height);
      CHECK(mismatches(smoother, cv::Mat(size, CV_8UC1, cv::Scalar(0)), k) == 0);
      CHECK(mismatches(smoother, cv::Mat(size, CV_8UC1, cv::Scalar(255)), k) == 0);
      CHECK(mismatches(smoother, cv::Mat(size, CV_8UC1, cv::Scalar(128)), k) == 0);
      CHECK(mismatches(smoother, cv::Mat(size, CV_8UC1, cv::Scalar(127)), k) == 0);
      // A lone pixel on and a lone pixel off at every position.
      for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x) {
          cv::Mat on(size, CV_8UC1, cv::Scalar(0)), off(size, CV_8UC1, cv::Scalar(255));
          on.at<uchar>(y, x) = 255;
          off.at<uchar>(y, x) = 0;
          REQUIRE(mismatches(smoother, on, k) == 0);
          REQUIRE(mismatches(smoother, off, k) == 0);
        }
    }
  }
  // A straight edge: the pixels next to it see exactly half (or more) of the kernel's weight on
  // their own side, so the majority filter keeps the edge where it is.
  cv::Mat edge(20, 20, CV_8UC1, cv::Scalar(0));
  edge.colRange(10, 20).setTo(255);
  cv::Mat ours = edge.clone();
  smoother.apply(ours, 5);
  CHECK(cv::countNonZero(ours != edge) == 0);
  CHECK(mismatches(smoother, edge, 5) == 0);
}

TEST_CASE("MaskSmoother refuses bad input and leaves the mask alone for k <= 1") {
  MaskSmoother smoother;
  cv::Mat m(5, 5, CV_8UC1, cv::Scalar(0));
  m.at<uchar>(2, 2) = 255;
  const cv::Mat before = m.clone();
  smoother.apply(m, 1);
  CHECK(cv::countNonZero(m != before) == 0);
  smoother.apply(m, 0);
  CHECK(cv::countNonZero(m != before) == 0);
  CHECK_THROWS_AS(smoother.apply(m, 4), InvalidArgument);
  CHECK_THROWS_AS(smoother.apply(m, 33), InvalidArgument);
  cv::Mat colour(5, 5, CV_8UC3);
  CHECK_THROWS_AS(smoother.apply(colour, 5), InvalidArgument);
}
