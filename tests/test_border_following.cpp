// ExternalContours against OpenCV: the same contours as cv::findContours(RETR_EXTERNAL,
// CHAIN_APPROX_SIMPLE), in the same order and point for point, on random masks (noise and
// smooth blobs), shapes with holes and components inside holes, masks touching the borders,
// single pixels, diagonal-only connections, thin rings and checkerboards.
#include <shadowsense/sense/border_following.hpp>

#include <doctest/doctest.h>

#include <opencv2/imgproc.hpp>

#include <string>
#include <vector>

using namespace shadowsense;

namespace {

// Empty when equal, else what differs first.
std::string compare(ExternalContours& ours, const cv::Mat& mask) {
  std::vector<std::vector<cv::Point>> cv_contours;
  cv::findContours(mask, cv_contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  ours.find(mask);
  if (ours.size() != cv_contours.size())
    return "count " + std::to_string(ours.size()) + " vs " + std::to_string(cv_contours.size());
  for (std::size_t i = 0; i < cv_contours.size(); ++i) {
    const auto c = ours.contour(i);
    if (c.size() != cv_contours[i].size())
      return "contour " + std::to_string(i) + " has " + std::to_string(c.size()) + " points vs " +
             std::to_string(cv_contours[i].size());
    for (std::size_t j = 0; j < c.size(); ++j)
      if (c[j] != cv_contours[i][j])
        return "contour " + std::to_string(i) + " point " + std::to_string(j);
    if (ours.box(i) != cv::boundingRect(cv_contours[i]))
      return "box of contour " + std::to_string(i);
  }
  return {};
}

cv::Mat noise_mask(cv::RNG& rng, cv::Size size, double density) {
  cv::Mat m(size, CV_8UC1);
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x) m.at<uchar>(y, x) = rng.uniform(0.0, 1.0) < density ? 255 : 0;
  return m;
}

cv::Mat blob_mask(cv::RNG& rng, cv::Size size) {
  cv::Mat m(size, CV_8UC1, cv::Scalar(0));
  const int n = rng.uniform(1, 12);
  for (int i = 0; i < n; ++i) {
    const cv::Point c(rng.uniform(-5, size.width + 5), rng.uniform(-5, size.height + 5));
    const cv::Size axes(rng.uniform(1, size.width / 2 + 2), rng.uniform(1, size.height / 2 + 2));
    cv::ellipse(m, c, axes, rng.uniform(0.0, 180.0), 0, 360, cv::Scalar(255), cv::FILLED);
    if (rng.uniform(0, 3) == 0) // a hole, sometimes with an island inside
      cv::ellipse(m, c, axes / 2, 0, 0, 360, cv::Scalar(0), cv::FILLED);
    if (rng.uniform(0, 4) == 0) cv::circle(m, c, 1, cv::Scalar(255), cv::FILLED);
  }
  return m;
}

} // namespace

TEST_CASE("ExternalContours equals cv::findContours on random noise masks") {
  cv::RNG rng(0xB0DE);
  ExternalContours ours;
  for (int i = 0; i < 600; ++i) {
    const cv::Size size(rng.uniform(1, 60), rng.uniform(1, 45));
    const std::string diff = compare(ours, noise_mask(rng, size, rng.uniform(0.02, 0.98)));
    INFO("mask " << i << " " << size.width << "x" << size.height << ": " << diff);
    REQUIRE(diff.empty());
  }
}

TEST_CASE("ExternalContours equals cv::findContours on blobs with holes and islands") {
  cv::RNG rng(0xFACE);
  ExternalContours ours;
  for (int i = 0; i < 300; ++i) {
    const cv::Size size(rng.uniform(8, 200), rng.uniform(8, 150));
    const std::string diff = compare(ours, blob_mask(rng, size));
    INFO("mask " << i << " " << size.width << "x" << size.height << ": " << diff);
    REQUIRE(diff.empty());
  }
  // Frame-sized masks: blobs plus speckle.
  for (int i = 0; i < 4; ++i) {
    cv::Mat m = blob_mask(rng, {635, 350}) | noise_mask(rng, {635, 350}, 0.01);
    const std::string diff = compare(ours, m);
    INFO("frame mask " << i << ": " << diff);
    CHECK(diff.empty());
  }
}

TEST_CASE("ExternalContours edge cases") {
  ExternalContours ours;
  auto check = [&](const cv::Mat& m, const char* what) {
    const std::string diff = compare(ours, m);
    INFO(what << ": " << diff);
    CHECK(diff.empty());
  };
  check(cv::Mat(1, 1, CV_8UC1, cv::Scalar(0)), "1 pixel, off");
  check(cv::Mat(1, 1, CV_8UC1, cv::Scalar(255)), "1 pixel, on");
  CHECK(ours.size() == 1);
  check(cv::Mat(1, 17, CV_8UC1, cv::Scalar(255)), "one full row");
  check(cv::Mat(13, 1, CV_8UC1, cv::Scalar(255)), "one full column");
  check(cv::Mat(20, 30, CV_8UC1, cv::Scalar(0)), "all 0");
  CHECK(ours.size() == 0);
  check(cv::Mat(20, 30, CV_8UC1, cv::Scalar(255)), "all 255 (touches every border)");
  check(cv::Mat(20, 30, CV_8UC1, cv::Scalar(7)), "all 7 (any non-zero is object)");
  // Lone pixels everywhere, including corners and edges.
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 6; ++x) {
      cv::Mat m(5, 6, CV_8UC1, cv::Scalar(0));
      m.at<uchar>(y, x) = 255;
      check(m, "lone pixel");
      cv::Mat inv = 255 - m;
      check(inv, "lone hole");
    }
  // Diagonal-only connections (8-connected: one component) and a checkerboard.
  cv::Mat diag(10, 10, CV_8UC1, cv::Scalar(0));
  for (int i = 0; i < 10; ++i) diag.at<uchar>(i, i) = diag.at<uchar>(i, 9 - i) = 255;
  check(diag, "diagonal cross");
  CHECK(ours.size() == 1);
  cv::Mat checker(9, 11, CV_8UC1);
  for (int y = 0; y < 9; ++y)
    for (int x = 0; x < 11; ++x) checker.at<uchar>(y, x) = (x + y) % 2 ? 255 : 0;
  check(checker, "checkerboard");
  // A ring with an island inside (the island is not external) and thin rings.
  cv::Mat ring(40, 40, CV_8UC1, cv::Scalar(0));
  cv::rectangle(ring, {5, 5, 30, 30}, cv::Scalar(255), 1);
  cv::rectangle(ring, {15, 15, 6, 6}, cv::Scalar(255), cv::FILLED);
  check(ring, "1-pixel ring with an island");
  CHECK(ours.size() == 1);
  cv::Mat rings(60, 60, CV_8UC1, cv::Scalar(0));
  for (int r = 3; r < 30; r += 3) cv::circle(rings, {30, 30}, r, cv::Scalar(255), 1);
  check(rings, "concentric 1-pixel rings");
  cv::Mat touching(20, 20, CV_8UC1, cv::Scalar(0));
  touching.row(0).setTo(255);
  touching.col(19).setTo(255);
  touching(cv::Rect(0, 10, 5, 10)).setTo(255);
  check(touching, "shapes along the borders");
  CHECK_THROWS_AS(ours.find(cv::Mat()), InvalidArgument);
  CHECK_THROWS_AS(ours.find(cv::Mat(3, 3, CV_8UC3)), InvalidArgument);
}
