// FrameAugmenter: random, label-preserving variants of a camera frame for few-shot head
// training (ss_train_head --augment K). A variant goes through the real FrameEncoder and the
// frozen backbone like any frame, so the head sees the features of plausible neighbours of each
// of the few adaptation frames instead of the frames alone.
//
// A variant is, in this order:
//   1. a mirror image (left-right) with probability flip_probability (every gesture of the
//      six-class task is its own mirror image: left and right hands, either side of the robot);
//   2. an affine warp about the image centre: scale 1 + U(-scale, scale), rotation
//      U(-rotate_degrees, rotate_degrees), shift U(-shift, shift) x (width, height); borders
//      replicate the edge pixels;
//   3. a photometric change: per-channel gain (1 + U(-gain, gain)) x (1 + U(-white_balance,
//      white_balance)) and gamma exp(U(-gamma, gamma)) on the 0..1 values;
//   4. Gaussian sensor noise of standard deviation U(0, noise) (0..1 units), rounded to 8 bits.
// U(a, b): uniform. The default config is the one measured in docs/classification_eval.md.
//
// FrameAugmenter(config, seed)
//   requires: every range >= 0 and finite, flip_probability in [0, 1], scale < 0.5, shift <
//   0.5 (else InvalidArgument naming the field).
// run(in, out)
//   requires: in CV_8UC3, non-empty (else InvalidArgument).
//   ensures: out CV_8UC3 of in's size; deterministic: the same seed and the same sequence of
//   calls give the same images; a config of all zeros gives out == in.
// Threading: run() advances the internal generator: one instance per thread.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/core/version.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdint>
#include <random>
#include <string>

SHADOWSENSE_NAMESPACE_BEGIN

class FrameAugmenter {
public:
  struct Config {
    double flip_probability = 0.5;
    double shift = 0.05;         // fraction of width / height
    double scale = 0.08;         // relative
    double rotate_degrees = 5.0; // about the centre
    double gain = 0.25;          // exposure, all channels
    double white_balance = 0.1;  // per channel
    double gamma = 0.2;          // log gamma
    double noise = 0.02;         // max sd, 0..1 units
  };

  FrameAugmenter() : FrameAugmenter(Config{}, 0) {}
  explicit FrameAugmenter(Config config, std::uint64_t seed = 0)
      : config_(config), rng_(seed ^ 0xA5A5F00DCAFEull) {
    auto check = [](double v, double hi, const char* name) {
      detail::require(std::isfinite(v) && v >= 0 && v < hi,
                      std::string("FrameAugmenter: ") + name + " must be in [0, " +
                          std::to_string(hi) + "), got " + std::to_string(v));
    };
    detail::require(config.flip_probability >= 0 && config.flip_probability <= 1,
                    "FrameAugmenter: flip_probability must be in [0, 1], got " +
                        std::to_string(config.flip_probability));
    check(config.shift, 0.5, "shift");
    check(config.scale, 0.5, "scale");
    check(config.rotate_degrees, 180, "rotate_degrees");
    check(config.gain, 1, "gain");
    check(config.white_balance, 1, "white_balance");
    check(config.gamma, 2, "gamma");
    check(config.noise, 1, "noise");
  }
  const Config& config() const { return config_; }

  void run(const cv::Mat& in, cv::Mat& out) {
    detail::require(!in.empty() && in.type() == CV_8UC3,
                    "FrameAugmenter::run: expected a non-empty CV_8UC3 image");
    const bool flip = uniform(0, 1) < config_.flip_probability;
    const double s = 1 + uniform(-config_.scale, config_.scale);
    const double angle = uniform(-config_.rotate_degrees, config_.rotate_degrees);
    const double dx = uniform(-config_.shift, config_.shift) * in.cols;
    const double dy = uniform(-config_.shift, config_.shift) * in.rows;
    const double g = 1 + uniform(-config_.gain, config_.gain);
    double ch[3];
    for (double& c : ch) c = g * (1 + uniform(-config_.white_balance, config_.white_balance));
    const double gamma = std::exp(uniform(-config_.gamma, config_.gamma));
    const double sd = uniform(0, config_.noise);

    cv::Mat src = in;
    if (flip) cv::flip(in, src, 1);
    if (s != 1 || angle != 0 || dx != 0 || dy != 0) {
      cv::Mat a = cv::getRotationMatrix2D(
          cv::Point2f(float(in.cols - 1) * 0.5f, float(in.rows - 1) * 0.5f), angle, s);
      a.at<double>(0, 2) += dx;
      a.at<double>(1, 2) += dy;
      cv::warpAffine(src, warped_, a, in.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    } else {
      warped_ = src.clone();
    }
    // Photometric change as one 256-entry table per channel.
    cv::Mat lut(1, 256, CV_8UC3);
    for (int v = 0; v < 256; ++v)
      for (int c = 0; c < 3; ++c) {
        const double x = std::pow(double(v) / 255.0, gamma) * ch[c];
        lut.at<cv::Vec3b>(0, v)[c] = cv::saturate_cast<uchar>(x * 255.0);
      }
    cv::LUT(warped_, lut, out);
    if (sd > 0) {
      noise_.create(out.size(), CV_32FC3);
      cv::RNG cv_rng(rng_());
      cv_rng.fill(noise_, cv::RNG::NORMAL, 0.0, sd * 255.0);
      cv::Mat f;
      out.convertTo(f, CV_32FC3);
      f += noise_;
      f.convertTo(out, CV_8UC3); // rounds and saturates
    }
  }

private:
  double uniform(double a, double b) {
    const double u = double(rng_() >> 11) * 0x1.0p-53;
    return a + (b - a) * u;
  }

  Config config_;
  std::mt19937_64 rng_;
  cv::Mat warped_, noise_;
};

SHADOWSENSE_NAMESPACE_END
