// The segmenter's extension point and limits: a user-defined PixelRule plugs in without editing
// the library; many tiny blobs are capped and merged quickly; bad models and sizes are refused;
// one Segmenter entered from two threads at once is refused.
#include <shadowsense/sense/segmenter.hpp>

#include <doctest/doctest.h>

#include <opencv2/imgproc.hpp>

#include <atomic>
#include <chrono>
#include <thread>

using namespace shadowsense;

namespace {

// A user's own rule: a pixel is shadow when its green channel is below `green_below`, contact
// when its red channel is above `red_above` (and it is shadow). Not in the library.
struct GreenRedRule {
  int green_below = 100;
  int red_above = 200;
  void classify(const PixelRuleInput& in, PixelRuleOutput& out) const {
    out.darkness.release();
    out.warmth.release();
    for (int y = 0; y < in.bgr.rows; ++y)
      for (int x = 0; x < in.bgr.cols; ++x) {
        const cv::Vec3b p = in.bgr.at<cv::Vec3b>(y, x);
        const bool skin = in.skin.at<uchar>(y, x) != 0;
        const bool shadow = skin && p[1] < green_below;
        out.shadow_mask.at<uchar>(y, x) = shadow ? 255 : 0;
        out.contact_mask.at<uchar>(y, x) = shadow && p[2] > red_above ? 255 : 0;
      }
  }
};
static_assert(PixelRule<GreenRedRule>);

} // namespace

TEST_CASE("a user-defined pixel rule plugs into BasicSegmenter") {
  cv::Mat img(120, 160, CV_8UC3, cv::Scalar(180, 180, 180));
  cv::rectangle(img, cv::Rect(20, 30, 50, 40), cv::Scalar(60, 60, 60), cv::FILLED);   // shadow
  cv::rectangle(img, cv::Rect(100, 20, 30, 30), cv::Scalar(40, 50, 230), cv::FILLED); // contact
  BasicSegmenter<GreenRedRule>::Config cfg;
  cfg.mask_blur = 0;
  BasicSegmenter<GreenRedRule> seg(cfg, GreenRedRule{});
  const Segmentation s = seg.segment(img);
  REQUIRE(s.shadows.size() == 2);
  REQUIRE(s.contacts.size() == 1);
  CHECK(s.contacts[0].box == cv::Rect(100, 20, 30, 30));
  CHECK(s.contact_point->x == doctest::Approx(114.5));
  CHECK(s.contact_point->y == doctest::Approx(34.5));
  CHECK(s.shadow_box == (cv::Rect(20, 30, 50, 40) | cv::Rect(100, 20, 30, 30)));
  CHECK(seg.darkness().empty());
  // The library's own rules, used directly, are models of the same concept.
  BasicSegmenter<FixedRangeRule> fixed(
      {}, FixedRangeRule{{{0, 0, 0}, {100, 100, 100}}, {{0, 0, 200}, {60, 60, 255}}});
  const Segmentation f = fixed.segment(img);
  // The grey rectangle is shadow; the red square is contact by its range, hence shadow too.
  REQUIRE(f.shadows.size() == 2);
  REQUIRE(f.contacts.size() == 1);
  CHECK(f.contacts[0].box == cv::Rect(100, 20, 30, 30));
  CHECK(f.shadows[0].box == cv::Rect(20, 30, 50, 40));
}

TEST_CASE("thousands of tiny blobs: capped, smallest dropped and counted, quickly") {
  // 2x2 dots every 4 px: 16,384 separate blobs of 4 px in a 512x512 frame, and one big square.
  cv::Mat img(512, 512, CV_8UC3, cv::Scalar(200, 200, 200));
  for (int y = 0; y < 512; y += 4)
    for (int x = 0; x < 512; x += 4) img(cv::Rect(x, y, 2, 2)).setTo(cv::Scalar(50, 50, 50));
  img(cv::Rect(200, 200, 58, 58)).setTo(cv::Scalar(50, 50, 50));
  BasicSegmenter<FixedRangeRule>::Config cfg;
  cfg.mask_blur = 0;
  cfg.min_shadow_area = 0;
  cfg.shadow_merge_gap = 1; // the dots are 2 px apart: none merge
  cfg.max_blobs = 1000;
  BasicSegmenter<FixedRangeRule> seg(
      cfg, FixedRangeRule{{{0, 0, 0}, {100, 100, 100}}, {{255, 255, 255}, {255, 255, 255}}});
  const auto t0 = std::chrono::steady_clock::now();
  const Segmentation s = seg.segment(img);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Contours: 128 x 128 = 16384 dots; the square [200, 258) covers 15 x 15 of them and leaves a
  // 2 px gap to the others, so 16384 - 225 + 1 = 16160 blobs, 1000 kept.
  CHECK(s.shadows.size() == 1000);
  CHECK(s.dropped_shadow_blobs == 15160);
  CHECK(s.shadows[0].area == 58 * 58); // the largest blob is kept
  CHECK(s.shadows[1].area == 4);
  CHECK(seconds < 5.0); // was quadratic: minutes at this count
}

TEST_CASE("empty-skin models: a black frame, an all-dark profile or a 0..255 profile are refused") {
  Segmenter seg;
  CHECK_THROWS_WITH_AS(seg.set_empty_skin({cv::Mat(50, 60, CV_8UC3, cv::Scalar::all(0))}),
                       doctest::Contains("black"), InvalidArgument);
  CHECK_THROWS_WITH_AS(seg.set_empty_skin_profile(cv::Mat(50, 60, CV_32FC3, cv::Scalar::all(0.1))),
                       doctest::Contains("at least 1%"), InvalidArgument);
  CHECK_THROWS_WITH_AS(seg.set_empty_skin_profile(cv::Mat(50, 60, CV_32FC3, cv::Scalar::all(200))),
                       doctest::Contains("0..255"), InvalidArgument);
  CHECK_THROWS_AS(seg.set_empty_skin_profile(cv::Mat(50, 60, CV_32FC1, cv::Scalar::all(1))),
                  InvalidArgument);
  CHECK_FALSE(seg.has_empty_skin());
  seg.set_empty_skin_profile(cv::Mat(50, 60, CV_32FC3, cv::Scalar::all(1)));
  CHECK(seg.has_empty_skin());
  CHECK(seg.empty_skin_model().size() == cv::Size(60, 50));
}

TEST_CASE("frames larger than max_image_side are refused with the limit in the message") {
  Segmenter::Config cfg;
  cfg.max_image_side = 64;
  Segmenter seg(cfg);
  CHECK_THROWS_WITH_AS(seg.segment(cv::Mat(65, 10, CV_8UC3, cv::Scalar::all(100))),
                       doctest::Contains("at most 64"), InvalidArgument);
  CHECK_NOTHROW(seg.segment(cv::Mat(64, 64, CV_8UC3, cv::Scalar::all(100))));
  cfg.max_image_side = 8;
  CHECK_THROWS_AS(Segmenter{cfg}, InvalidArgument);
}

#ifndef SHADOWSENSE_NO_THREAD_CHECK
TEST_CASE("one Segmenter entered from two threads at once: the second gets a clear error") {
  // A rule that waits inside classify until told to go on, so the overlap is certain.
  struct SlowRule {
    std::atomic<bool>* inside;
    std::atomic<bool>* go;
    void classify(const PixelRuleInput&, PixelRuleOutput& out) const {
      out.darkness.release();
      out.shadow_mask.setTo(0);
      out.contact_mask.setTo(0);
      inside->store(true);
      while (!go->load()) std::this_thread::yield();
    }
  };
  std::atomic<bool> inside{false}, go{false};
  BasicSegmenter<SlowRule> seg({}, SlowRule{&inside, &go});
  const cv::Mat img(32, 32, CV_8UC3, cv::Scalar::all(100));
  std::thread first([&] { seg.segment(img); });
  while (!inside.load()) std::this_thread::yield();
  CHECK_THROWS_WITH_AS(seg.segment(img), doctest::Contains("two threads at once"),
                       ConcurrentUseError);
  go.store(true);
  first.join();
  CHECK_NOTHROW(seg.segment(img)); // sequential use from another thread is fine
}
#endif
