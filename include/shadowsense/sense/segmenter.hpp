// Shadow and contact segmentation (paper section 4.3): two colour classes, "shadow" and
// "contact"; the binary mask of each is smoothed with a Gaussian blur, its contours found with
// cv::findContours (Suzuki-Abe), thresholded by size and merged when close; the result is a box
// per class (and per blob, for multi-touch) and the contact position is the centroid of the
// contact region.
//
// Two ways to colour-classify a pixel (SegmenterCalibration::mode):
//  * fixed_ranges - the paper's method: a pixel is in a class when its B, G and R values each lie
//    in that class's inclusive range. Cheap, but breaks when the light changes.
//  * relative     - the default: each pixel is divided by the lit, empty skin's colour there,
//    giving per-channel ratios q = I / reference. darkness = 1 - mean(q); warmth = q_R - q_B.
//    A hovering shadow darkens the fabric roughly neutrally (cool); a part in contact is
//    darkest and skin-tinted (warm). shadow: darkness >= shadow_darkness; contact: darkness >=
//    contact_darkness and warmth >= contact_warmth (thresholds optionally per light level).
//    reference = gain x empty-skin model: the model (set_empty_skin, from a few frames of the
//    empty skin) holds vignetting and the visible-skin outline; the gain is a high percentile of
//    each channel of the frame over the model, so every frame, at any light, is judged against
//    its own light. With Config::adaptive the model is also updated slowly on pixels outside any
//    shadow, so it follows slow changes in a video.
//
// Calibration (fit_calibration) fits the ranges and thresholds from frames of the empty skin and
// a few labelled touch frames; save_calibration / load_calibration store them in a small text
// file (format in docs/tracking_eval.md).
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/core/image_check.hpp>

#include <opencv2/core.hpp>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <numeric>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// Inclusive per-channel range in BGR order.
struct ColourRange {
  cv::Vec3b lower{0, 0, 0};
  cv::Vec3b upper{0, 0, 0};
  bool contains(const cv::Vec3b& p) const {
    return p[0] >= lower[0] && p[0] <= upper[0] && p[1] >= lower[1] && p[1] <= upper[1] &&
           p[2] >= lower[2] && p[2] <= upper[2];
  }
  bool operator==(const ColourRange&) const = default;
};

enum class SegmentMode { fixed_ranges, relative };

// Relative-mode thresholds for frames whose reference luminance (mean of the B, G, R reference,
// 8-bit units) is `luminance`.
struct LightThresholds {
  float luminance = 0;
  float shadow_darkness = 0.2f;
  float contact_darkness = 0.45f;
  float contact_warmth = 0.08f;
  bool operator==(const LightThresholds&) const = default;
};

struct SegmenterCalibration {
  SegmentMode mode = SegmentMode::relative;
  // fixed_ranges mode.
  ColourRange shadow_range{{0, 0, 0}, {120, 120, 120}};
  ColourRange contact_range{{0, 0, 40}, {90, 110, 160}};
  // relative mode.
  float shadow_darkness = 0.2f;
  float contact_darkness = 0.45f;
  float contact_warmth = 0.08f;
  float reference_percentile = 0.9f; // per-frame reference: this percentile of each channel
  // Optional thresholds per light level, sorted by strictly increasing luminance: when present,
  // each frame uses the thresholds interpolated linearly at its reference luminance (clamped to
  // the first/last row), since the diffuse part of the light, and with it the darkness of the
  // half-penumbra line, changes with the light level. Empty: the three thresholds above.
  std::vector<LightThresholds> by_light{};
  LightThresholds thresholds_at(float luminance) const {
    if (by_light.empty()) return {luminance, shadow_darkness, contact_darkness, contact_warmth};
    if (luminance <= by_light.front().luminance) return by_light.front();
    if (luminance >= by_light.back().luminance) return by_light.back();
    std::size_t i = 1;
    while (by_light[i].luminance < luminance) ++i;
    const LightThresholds &a = by_light[i - 1], &b = by_light[i];
    const float t = (luminance - a.luminance) / (b.luminance - a.luminance);
    auto mix = [t](float u, float v) { return u + (v - u) * t; };
    return {luminance, mix(a.shadow_darkness, b.shadow_darkness),
            mix(a.contact_darkness, b.contact_darkness), mix(a.contact_warmth, b.contact_warmth)};
  }
  bool operator==(const SegmenterCalibration&) const = default;
};

// A group of nearby contours of one class.
struct Blob {
  cv::Rect box{};         // inclusive pixel coverage of the group
  cv::Point2f centroid{}; // centroid of the group's mask pixels
  double area = 0;        // mask pixels in the group
  float darkness = 0;     // mean darkness of its pixels (relative mode; 0 in fixed_ranges)
  float edge_width = 0;   // mean width of the darkness ramp at its edge, px (shadow blobs)
  // Shadow blobs that touch nothing (relative mode): estimated opacity of the shadow's core, the
  // 95th percentile of its darkness over the darkness of the half-opacity line (2 x the frame's
  // shadow threshold); falls as the part rises.
  float opacity = 0;
  bool touching = false; // shadow blobs: a contact blob lies inside
  std::optional<float>
      hover_height_cm{}; // shadow blobs not touching, when a HoverHeightModel is set
};

// Hover height of a shadow that touches nothing, from its penumbra width and core opacity
// (paper 3.1: the shadow blurs and fades as the part rises): height = intercept + per_edge_px *
// edge_width + per_opacity * opacity, clamped at 0. Fit it with fit_hover_height.
struct HoverHeightModel {
  double intercept = 0;
  double per_edge_px = 0;
  double per_opacity = 0;
  double estimate(float edge_width, float opacity) const {
    return std::max(0.0, intercept + per_edge_px * edge_width + per_opacity * opacity);
  }
};

struct HoverSample {
  float edge_width = 0; // Blob::edge_width
  float opacity = 0;    // Blob::opacity
  double height_cm = 0; // true height of the hovering part
};

// Least-squares fit of a HoverHeightModel. Throws InvalidArgument with fewer than 3 samples,
// non-finite values, or samples that do not determine the three coefficients.
inline HoverHeightModel fit_hover_height(const std::vector<HoverSample>& samples) {
  detail::require(samples.size() >= 3, "fit_hover_height: " + std::to_string(samples.size()) +
                                           " samples; expected at least 3");
  cv::Mat a(static_cast<int>(samples.size()), 3, CV_64F),
      b(static_cast<int>(samples.size()), 1, CV_64F);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const HoverSample& s = samples[i];
    detail::require(std::isfinite(s.edge_width) && std::isfinite(s.opacity) &&
                        std::isfinite(s.height_cm),
                    "fit_hover_height: sample " + std::to_string(i) + " is not finite");
    const int r = static_cast<int>(i);
    a.at<double>(r, 0) = 1;
    a.at<double>(r, 1) = s.edge_width;
    a.at<double>(r, 2) = s.opacity;
    b.at<double>(r, 0) = s.height_cm;
  }
  cv::Mat x;
  const cv::Mat ata = a.t() * a;
  detail::require(
      std::abs(cv::determinant(ata)) > 1e-9,
      "fit_hover_height: the samples do not vary enough in edge width and darkness to fit "
      "the model");
  cv::solve(ata, a.t() * b, x, cv::DECOMP_CHOLESKY);
  return {x.at<double>(0), x.at<double>(1), x.at<double>(2)};
}

struct Segmentation {
  std::vector<Blob> shadows;
  std::vector<Blob> contacts;
  std::optional<cv::Rect> shadow_box{};       // union of all shadow blobs (the paper's box)
  std::optional<cv::Rect> contact_box{};      // union of all contact blobs
  std::optional<cv::Point2f> contact_point{}; // centroid of all contact pixels
  cv::Mat shadow_mask;                        // CV_8UC1 0/255, after blur and threshold
  cv::Mat contact_mask;                       // CV_8UC1 0/255, after blur and threshold
};

namespace detail {

inline float luminance(const cv::Vec3f& bgr) {
  return (bgr[0] + bgr[1] + bgr[2]) / 3.f;
}

inline void validate_calibration(const SegmenterCalibration& c, const std::string& where) {
  auto in01 = [](float v) { return std::isfinite(v) && v >= 0.f && v <= 1.f; };
  require(in01(c.shadow_darkness), where + ": shadow_darkness must be in [0, 1]");
  require(in01(c.contact_darkness), where + ": contact_darkness must be in [0, 1]");
  require(std::isfinite(c.contact_warmth) && c.contact_warmth >= -1.f && c.contact_warmth <= 1.f,
          where + ": contact_warmth must be in [-1, 1]");
  require(std::isfinite(c.reference_percentile) && c.reference_percentile > 0.f &&
              c.reference_percentile <= 1.f,
          where + ": reference_percentile must be in (0, 1]");
  for (std::size_t i = 0; i < c.by_light.size(); ++i) {
    const LightThresholds& t = c.by_light[i];
    const std::string row = where + ": by_light[" + std::to_string(i) + "]";
    require(std::isfinite(t.luminance) && t.luminance >= 0 && t.luminance <= 255,
            row + ".luminance must be in [0, 255]");
    require(i == 0 || t.luminance > c.by_light[i - 1].luminance,
            row + ".luminance must be greater than the previous row's (sorted, no repeats)");
    require(in01(t.shadow_darkness) && in01(t.contact_darkness),
            row + ": darkness thresholds must be in [0, 1]");
    require(std::isfinite(t.contact_warmth) && t.contact_warmth >= -1.f && t.contact_warmth <= 1.f,
            row + ".contact_warmth must be in [-1, 1]");
  }
  for (int k = 0; k < 3; ++k) {
    require(c.shadow_range.lower[k] <= c.shadow_range.upper[k],
            where + ": shadow_range lower exceeds upper in channel " + std::to_string(k));
    require(c.contact_range.lower[k] <= c.contact_range.upper[k],
            where + ": contact_range lower exceeds upper in channel " + std::to_string(k));
  }
}

// Union-find over small index sets (contour grouping).
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

class Segmenter {
public:
  struct Config {
    SegmenterCalibration calibration{};
    int pre_blur = 0;            // box blur of the colour image before classification (0/1 = off)
    int mask_blur = 5;           // Gaussian kernel for the binary masks (odd; 0/1 = off)
    double min_shadow_area = 30; // contours smaller than this (mask px) are dropped
    double min_contact_area = 6;
    int shadow_merge_gap = 12; // contours whose boxes are this close (px) form one blob
    int contact_merge_gap = 4;
    std::optional<HoverHeightModel> hover_model{}; // sets Blob::hover_height_cm when present
    bool adaptive = false;          // per-pixel empty-skin model updated over time (video)
    float adapt_rate = 0.05f;       // weight of a new frame in the empty-skin model
    double profile_smoothing = 3.0; // Gaussian sigma (px) of the empty-skin model
  };

  Segmenter() : Segmenter(Config{}) {}
  explicit Segmenter(const Config& c) : config_(c) {
    detail::validate_calibration(c.calibration, "Segmenter");
    detail::require(c.pre_blur >= 0 && c.pre_blur <= 15, "Segmenter: pre_blur must be in [0, 15]");
    detail::require(c.mask_blur >= 0 && c.mask_blur <= 31 &&
                        (c.mask_blur <= 1 || c.mask_blur % 2 == 1),
                    "Segmenter: mask_blur must be 0, 1 or an odd number up to 31");
    detail::require(std::isfinite(c.min_shadow_area) && c.min_shadow_area >= 0 &&
                        std::isfinite(c.min_contact_area) && c.min_contact_area >= 0,
                    "Segmenter: minimum areas must be finite and >= 0");
    detail::require(c.shadow_merge_gap >= 0 && c.contact_merge_gap >= 0,
                    "Segmenter: merge gaps must be >= 0");
    detail::require(std::isfinite(c.adapt_rate) && c.adapt_rate > 0 && c.adapt_rate <= 1,
                    "Segmenter: adapt_rate must be in (0, 1]");
    detail::require(std::isfinite(c.profile_smoothing) && c.profile_smoothing >= 0 &&
                        c.profile_smoothing <= 50,
                    "Segmenter: profile_smoothing must be in [0, 50]");
  }

  // Sets the empty-skin model from frames of the empty skin (any light level each): per pixel
  // and channel, the skin's brightness relative to the frame's reference, smoothed over
  // Config::profile_smoothing px (so it keeps vignetting and the visible-skin outline, not the
  // weave). Pixels darker than half the reference in the model are not skin (robot interior,
  // box walls) and are never classified. Throws InvalidArgument for no frames, a frame that is
  // not an 8-bit colour image, or frames of different sizes.
  void set_empty_skin(const std::vector<cv::Mat>& empty_frames) {
    detail::require(!empty_frames.empty(),
                    "Segmenter::set_empty_skin: no frames; expected at least one empty-skin frame");
    // Per pixel and channel, the median over the frames (robust to a passing shadow in one).
    for (std::size_t i = 0; i < empty_frames.size(); ++i) {
      const std::string name = "Segmenter::set_empty_skin: frame " + std::to_string(i);
      require_colour_image(empty_frames[i], name.c_str());
      detail::require(empty_frames[i].size() == empty_frames[0].size(),
                      name + " has a different size from frame 0; expected all the same size");
    }
    std::vector<cv::Mat> normalised;
    inv_profile_.release(); // each frame's reference over the whole frame
    for (std::size_t i = 0; i < empty_frames.size(); ++i) {
      smooth(empty_frames[i]);
      const cv::Vec3f ref = global_reference();
      cv::Mat f;
      src_->convertTo(f, CV_32FC3);
      normalised.push_back(f.mul(cv::Scalar(1.0 / ref[0], 1.0 / ref[1], 1.0 / ref[2])));
    }
    cv::Mat sum(empty_frames[0].size(), CV_32FC3);
    std::vector<float> v(normalised.size());
    for (int y = 0; y < sum.rows; ++y)
      for (int x = 0; x < sum.cols; ++x)
        for (int k = 0; k < 3; ++k) {
          for (std::size_t i = 0; i < normalised.size(); ++i)
            v[i] = normalised[i].at<cv::Vec3f>(y, x)[k];
          std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2),
                           v.end());
          sum.at<cv::Vec3f>(y, x)[k] = v[v.size() / 2];
        }
    set_empty_skin_profile(sum);
  }

  // Sets the empty-skin model directly (CV_32FC3, 1 = lit skin at the reference brightness, as
  // returned by empty_skin_profile()).
  void set_empty_skin_profile(const cv::Mat& profile) {
    detail::require(!profile.empty() && profile.type() == CV_32FC3,
                    "Segmenter::set_empty_skin_profile: expected a non-empty CV_32FC3 profile");
    cv::Mat lum;
    cv::transform(profile, lum, cv::Matx13f(1.f / 3, 1.f / 3, 1.f / 3));
    valid_ = lum >= 0.5f;
    // Normalised convolution: smooth inside the skin only, so the outline stays sharp.
    const double sg = config_.profile_smoothing;
    cv::Mat w, num, den;
    valid_.convertTo(w, CV_32F, 1.0 / 255);
    cv::Mat masked = profile.clone();
    masked.setTo(cv::Scalar::all(0), ~valid_);
    if (sg > 0) {
      cv::GaussianBlur(masked, num, cv::Size(0, 0), sg, sg, cv::BORDER_REPLICATE);
      cv::GaussianBlur(w, den, cv::Size(0, 0), sg, sg, cv::BORDER_REPLICATE);
    } else {
      num = masked;
      den = w;
    }
    profile_.create(profile.size(), CV_32FC3);
    inv_profile_.create(profile.size(), CV_32FC3);
    for (int y = 0; y < profile.rows; ++y) {
      const cv::Vec3f* n = num.ptr<cv::Vec3f>(y);
      const float* d = den.ptr<float>(y);
      const uchar* v = valid_.ptr<uchar>(y);
      cv::Vec3f* p = profile_.ptr<cv::Vec3f>(y);
      cv::Vec3f* ip = inv_profile_.ptr<cv::Vec3f>(y);
      for (int x = 0; x < profile.cols; ++x)
        for (int k = 0; k < 3; ++k) {
          p[x][k] = v[x] && d[x] > 1e-6f ? std::max(n[x][k] / d[x], 0.05f) : 0.f;
          ip[x][k] = p[x][k] > 0 ? 1.f / p[x][k] : 0.f;
        }
    }
    cv::split(inv_profile_, inv_planes_.data());
    valid_.convertTo(inv_planes_[3], CV_32F, 1.0 / 255); // skin weight: darkness 0 off the skin
    refresh_ref_samples();
  }
  void set_background(const cv::Mat& empty_frame) { set_empty_skin({empty_frame}); }
  bool has_empty_skin() const { return !profile_.empty(); }
  const cv::Mat& empty_skin_profile() const { return profile_; }
  // 255 where the empty-skin model shows skin (empty without a model).
  const cv::Mat& skin_area() const { return valid_; }

  // Segments one BGR frame into `out` (buffers reused across calls).
  void segment(const cv::Mat& bgr, Segmentation& out) {
    require_colour_image(bgr, "Segmenter::segment: image");
    if (!profile_.empty())
      detail::require(bgr.size() == profile_.size(),
                      "Segmenter::segment: image is " + std::to_string(bgr.cols) + "x" +
                          std::to_string(bgr.rows) + " but the empty-skin model is " +
                          std::to_string(profile_.cols) + "x" + std::to_string(profile_.rows) +
                          "; expected the same size");
    if (config_.adaptive && profile_.empty()) set_empty_skin({bgr}); // first frame = empty skin
    smooth(bgr);
    classify(out);
    finish_mask(out.shadow_mask);
    finish_mask(out.contact_mask);
    extract(out.shadow_mask, config_.min_shadow_area, config_.shadow_merge_gap, out.shadows, true);
    extract(out.contact_mask, config_.min_contact_area, config_.contact_merge_gap, out.contacts);
    summarise(out);
    if (config_.adaptive) adapt(out);
  }
  Segmentation segment(const cv::Mat& bgr) {
    Segmentation s;
    segment(bgr, s);
    return s;
  }

  // Per-pixel darkness and warmth (relative mode features) of the last segmented frame, CV_32F.
  const cv::Mat& darkness() const { return darkness_; }
  const cv::Mat& warmth() const { return warmth_; }
  // Reference colour (BGR) of the last segmented frame (relative mode).
  cv::Vec3f last_reference() const { return gain_; }

  const Config& config() const { return config_; }

private:
  // Points src_ at the frame, or at its box-blurred copy (never writes into the caller's image).
  void smooth(const cv::Mat& bgr) {
    if (config_.pre_blur > 1) {
      cv::blur(bgr, colour_blur_, cv::Size(config_.pre_blur, config_.pre_blur), cv::Point(-1, -1),
               cv::BORDER_REPLICATE);
      src_ = &colour_blur_;
    } else {
      src_ = &bgr;
    }
  }

  // The configured percentile of each channel of the frame / profile over the skin (every third
  // pixel of every third row), in 8-bit units.
  cv::Vec3f global_reference() const {
    constexpr int bins = 1024; // quarter-unit bins up to 256
    std::array<std::vector<int>, 3>& hist = hist_;
    for (auto& h : hist) h.assign(bins, 0);
    const bool prof = !inv_profile_.empty() && inv_profile_.size() == src_->size();
    int n = 0;
    if (prof) { // the model's precomputed sample grid (on the skin only), contiguous in memory
      for (const RefSample& r : ref_samples_) {
        const uchar* px = src_->ptr<uchar>(r.y) + 3 * r.x;
        for (int k = 0; k < 3; ++k)
          ++hist[k][static_cast<std::size_t>(
              std::clamp(static_cast<int>(px[k] * r.inv[k] * 4.f), 0, bins - 1))];
      }
      n = static_cast<int>(ref_samples_.size());
    } else {
      for (int y = 1; y < src_->rows; y += 3) {
        const uchar* row = src_->ptr<uchar>(y);
        for (int x = 1; x < src_->cols; x += 3, ++n)
          for (int k = 0; k < 3; ++k) ++hist[k][static_cast<std::size_t>(row[3 * x + k]) * 4];
      }
    }
    const int target =
        std::max(1, static_cast<int>(std::ceil(config_.calibration.reference_percentile * n)));
    cv::Vec3f ref;
    for (int k = 0; k < 3; ++k) {
      // From the top: the bin where the count from below first reaches `target`.
      int above = n, v = bins - 1;
      for (; v > 0; --v) {
        above -= hist[k][static_cast<std::size_t>(v)];
        if (above < target) break;
      }
      ref[k] = std::max(1.0f, (static_cast<float>(v) + 0.5f) * 0.25f);
    }
    return ref;
  }

  void classify(Segmentation& out) {
    const cv::Size size = src_->size();
    out.shadow_mask.create(size, CV_8UC1);
    out.contact_mask.create(size, CV_8UC1);
    const SegmenterCalibration& cal = config_.calibration;
    const bool prof = !inv_profile_.empty();
    if (cal.mode == SegmentMode::fixed_ranges) {
      darkness_.release();
      warmth_.release();
      for (int y = 0; y < size.height; ++y) {
        const cv::Vec3b* in = src_->ptr<cv::Vec3b>(y);
        const uchar* v = prof ? valid_.ptr<uchar>(y) : nullptr;
        uchar* s = out.shadow_mask.ptr<uchar>(y);
        uchar* c = out.contact_mask.ptr<uchar>(y);
        for (int x = 0; x < size.width; ++x) {
          const bool skin = !v || v[x];
          const bool contact = skin && cal.contact_range.contains(in[x]);
          c[x] = contact ? 255 : 0;
          s[x] = (contact || (skin && cal.shadow_range.contains(in[x]))) ? 255 : 0;
        }
      }
      return;
    }
    darkness_.create(size, CV_32F);
    warmth_.create(size, CV_32F);
    gain_ = global_reference();
    const std::array<float, 3> inv{1.f / gain_[0], 1.f / gain_[1], 1.f / gain_[2]};
    const LightThresholds th = cal.thresholds_at(detail::luminance(gain_));
    const float ts = th.shadow_darkness, tc = th.contact_darkness, tw = th.contact_warmth;
    frame_shadow_threshold_ = ts;
    if (!prof && (uniform_valid_.size() != size)) { // no empty-skin model: all skin, flat
      for (cv::Mat& p : uniform_planes_) {
        p.create(size, CV_32F);
        p.setTo(1.0);
      }
      uniform_valid_.create(size, CV_8UC1);
      uniform_valid_.setTo(255);
    }
    const std::array<cv::Mat, 4>& planes = prof ? inv_planes_ : uniform_planes_;
    const cv::Mat& valid_map = prof ? valid_ : uniform_valid_;
    const float gb = inv[0], gg = inv[1], gr = inv[2];
    for (int y = 0; y < size.height; ++y) {
      const uchar* in = src_->ptr<uchar>(y);
      const float* ipb = planes[0].ptr<float>(y);
      const float* ipg = planes[1].ptr<float>(y);
      const float* ipr = planes[2].ptr<float>(y);
      const float* sk = planes[3].ptr<float>(y);
      const uchar* v = valid_map.ptr<uchar>(y);
      float* dk = darkness_.ptr<float>(y);
      float* wm = warmth_.ptr<float>(y);
      uchar* sm = out.shadow_mask.ptr<uchar>(y);
      uchar* cm = out.contact_mask.ptr<uchar>(y);
      int x = 0;
#if CV_SIMD128
      // 16 pixels at a time with OpenCV's universal intrinsics (same arithmetic as below).
      const cv::v_float32x4 vgb = cv::v_setall_f32(gb), vgg = cv::v_setall_f32(gg),
                            vgr = cv::v_setall_f32(gr), third = cv::v_setall_f32(1.f / 3.f),
                            vts = cv::v_setall_f32(ts), vtc = cv::v_setall_f32(tc),
                            vtw = cv::v_setall_f32(tw);
      auto to_f32 = [](const cv::v_uint8x16& a, cv::v_float32x4* o) {
        cv::v_uint16x8 lo, hi;
        cv::v_expand(a, lo, hi);
        cv::v_uint32x4 a0, a1, a2, a3;
        cv::v_expand(lo, a0, a1);
        cv::v_expand(hi, a2, a3);
        o[0] = cv::v_cvt_f32(cv::v_reinterpret_as_s32(a0));
        o[1] = cv::v_cvt_f32(cv::v_reinterpret_as_s32(a1));
        o[2] = cv::v_cvt_f32(cv::v_reinterpret_as_s32(a2));
        o[3] = cv::v_cvt_f32(cv::v_reinterpret_as_s32(a3));
      };
      for (; x + 16 <= size.width; x += 16) {
        cv::v_uint8x16 b8, g8, r8;
        cv::v_load_deinterleave(in + 3 * x, b8, g8, r8);
        cv::v_float32x4 fb[4], fg[4], fr[4];
        to_f32(b8, fb);
        to_f32(g8, fg);
        to_f32(r8, fr);
        cv::v_int32x4 cmask[4], smask[4];
        for (int j = 0; j < 4; ++j) {
          const int o = x + 4 * j;
          const cv::v_float32x4 qb = fb[j] * cv::v_load(ipb + o) * vgb;
          const cv::v_float32x4 qg = fg[j] * cv::v_load(ipg + o) * vgg;
          const cv::v_float32x4 qr = fr[j] * cv::v_load(ipr + o) * vgr;
          const cv::v_float32x4 d = cv::v_load(sk + o) - (qb + qg + qr) * third;
          const cv::v_float32x4 w = qr - qb;
          cv::v_store(dk + o, d);
          cv::v_store(wm + o, w);
          cmask[j] = cv::v_reinterpret_as_s32((d >= vtc) & (w >= vtw));
          smask[j] = cv::v_reinterpret_as_s32(d >= vts);
        }
        const cv::v_uint8x16 skin = cv::v_load(v + x);
        const cv::v_uint8x16 c =
            cv::v_reinterpret_as_u8(
                cv::v_pack(cv::v_pack(cmask[0], cmask[1]), cv::v_pack(cmask[2], cmask[3]))) &
            skin;
        const cv::v_uint8x16 sh =
            (cv::v_reinterpret_as_u8(
                 cv::v_pack(cv::v_pack(smask[0], smask[1]), cv::v_pack(smask[2], smask[3]))) &
             skin) |
            c;
        cv::v_store(cm + x, c);
        cv::v_store(sm + x, sh);
      }
#endif
      for (; x < size.width; ++x) {
        const float qb = static_cast<float>(in[3 * x]) * ipb[x] * gb;
        const float qg = static_cast<float>(in[3 * x + 1]) * ipg[x] * gg;
        const float qr = static_cast<float>(in[3 * x + 2]) * ipr[x] * gr;
        const float d = sk[x] - (qb + qg + qr) * (1.f / 3.f);
        const float w = qr - qb;
        dk[x] = d;
        wm[x] = w;
        const uchar contact = (d >= tc && w >= tw) ? v[x] : uchar(0);
        cm[x] = contact;
        sm[x] = static_cast<uchar>((d >= ts ? v[x] : uchar(0)) | contact);
      }
    }
  }

  // Gaussian blur of the binary mask, then back to binary at half height: a majority filter that
  // removes speckle and fills pinholes without moving straight edges.
  void finish_mask(cv::Mat& mask) {
    if (config_.mask_blur <= 1) return;
    cv::GaussianBlur(mask, blurred_, cv::Size(config_.mask_blur, config_.mask_blur), 0, 0,
                     cv::BORDER_REPLICATE);
    cv::threshold(blurred_, mask, 127, 255, cv::THRESH_BINARY);
  }

  void extract(const cv::Mat& mask, double min_area, int merge_gap, std::vector<Blob>& blobs,
               bool measure_edges = false) {
    blobs.clear();
    contours_.clear();
    cv::findContours(mask, contours_, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
    kept_.clear();
    for (std::size_t i = 0; i < contours_.size(); ++i) {
      const cv::Rect r = cv::boundingRect(contours_[i]);
      const double area = cv::countNonZero(mask(r)); // pixels, not the polygon's area
      if (area >= min_area && area > 0) kept_.push_back({r, area, i});
    }
    const int n = static_cast<int>(kept_.size());
    sets_.reset(n);
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j)
        if (detail::box_gap(kept_[static_cast<std::size_t>(i)].box,
                            kept_[static_cast<std::size_t>(j)].box) <= merge_gap)
          sets_.unite(i, j);
    for (int i = 0; i < n; ++i) {
      if (sets_.find(i) != i) continue;
      cv::Rect box;
      for (int j = 0; j < n; ++j)
        if (sets_.find(j) == i)
          box = box.empty() ? kept_[static_cast<std::size_t>(j)].box
                            : (box | kept_[static_cast<std::size_t>(j)].box);
      Blob b;
      b.box = box;
      const cv::Moments m = cv::moments(mask(box), true);
      b.area = m.m00;
      b.centroid = m.m00 > 0 ? cv::Point2f(static_cast<float>(box.x + m.m10 / m.m00),
                                           static_cast<float>(box.y + m.m01 / m.m00))
                             : cv::Point2f(box.x + box.width * 0.5f, box.y + box.height * 0.5f);
      if (!darkness_.empty()) {
        b.darkness = static_cast<float>(cv::mean(darkness_(box), mask(box))[0]);
        if (measure_edges) b.edge_width = edge_width(i, b.darkness);
      }
      blobs.push_back(b);
    }
    std::sort(blobs.begin(), blobs.end(), [](const Blob& a, const Blob& b) {
      return a.area != b.area ? a.area > b.area
                              : (a.box.x != b.box.x ? a.box.x < b.box.x : a.box.y < b.box.y);
    });
  }

  // 95th percentile of the darkness over a blob's mask, over twice the frame's shadow threshold.
  float core_opacity(const Blob& b, const cv::Mat& mask) {
    std::array<int, 256> hist{};
    int n = 0;
    for (int y = b.box.y; y < b.box.y + b.box.height; ++y) {
      const float* d = darkness_.ptr<float>(y);
      const uchar* m = mask.ptr<uchar>(y);
      for (int x = b.box.x; x < b.box.x + b.box.width; ++x)
        if (m[x]) {
          ++hist[static_cast<std::size_t>(std::clamp(static_cast<int>(d[x] * 255.f), 0, 255))];
          ++n;
        }
    }
    const int target = (n * 95 + 99) / 100;
    int acc = 0, v = 0;
    for (; v < 255; ++v)
      if ((acc += hist[static_cast<std::size_t>(v)]) >= target) break;
    const float peak = (static_cast<float>(v) + 0.5f) / 255.f;
    return frame_shadow_threshold_ > 0 ? peak / (2.f * frame_shadow_threshold_) : 0.f;
  }

  void summarise(Segmentation& out) {
    out.shadow_box.reset();
    out.contact_box.reset();
    out.contact_point.reset();
    // A contact is also shadow: make sure the shadow box covers every contact.
    for (const Blob& c : out.contacts) {
      bool inside = false;
      for (Blob& s : out.shadows)
        if ((s.box & c.box).area() > 0) s.touching = inside = true;
      if (!inside)
        out.shadows.push_back(
            Blob{c.box, c.centroid, c.area, c.darkness, 0.f, 0.f, true, std::nullopt});
    }
    for (Blob& s : out.shadows) {
      if (s.touching || darkness_.empty()) continue;
      s.opacity = core_opacity(s, out.shadow_mask);
      if (config_.hover_model)
        s.hover_height_cm =
            static_cast<float>(config_.hover_model->estimate(s.edge_width, s.opacity));
    }
    for (const Blob& s : out.shadows)
      out.shadow_box = out.shadow_box ? (*out.shadow_box | s.box) : s.box;
    double sx = 0, sy = 0, sa = 0;
    for (const Blob& c : out.contacts) {
      out.contact_box = out.contact_box ? (*out.contact_box | c.box) : c.box;
      sx += c.centroid.x * c.area;
      sy += c.centroid.y * c.area;
      sa += c.area;
    }
    if (sa > 0)
      out.contact_point = cv::Point2f(static_cast<float>(sx / sa), static_cast<float>(sy / sa));
  }

  // The pixels (every third of every third row, on the skin) that set each frame's gain.
  void refresh_ref_samples() {
    ref_samples_.clear();
    for (int y = 1; y < inv_profile_.rows; y += 3) {
      const cv::Vec3f* ip = inv_profile_.ptr<cv::Vec3f>(y);
      for (int x = 1; x < inv_profile_.cols; x += 3)
        if (ip[x][0] != 0.f) ref_samples_.push_back({y, x, ip[x]});
    }
  }

  // Slow update of the empty-skin model on skin pixels well outside any shadow.
  void adapt(const Segmentation& out) {
    if (config_.calibration.mode != SegmentMode::relative) return;
    cv::dilate(out.shadow_mask, dilated_, cv::Mat(), cv::Point(-1, -1), 3);
    const float a = config_.adapt_rate;
    const std::array<float, 3> inv{1.f / gain_[0], 1.f / gain_[1], 1.f / gain_[2]};
    for (int y = 0; y < src_->rows; ++y) {
      const cv::Vec3b* in = src_->ptr<cv::Vec3b>(y);
      const uchar* m = dilated_.ptr<uchar>(y);
      cv::Vec3f* p = profile_.ptr<cv::Vec3f>(y);
      cv::Vec3f* ip = inv_profile_.ptr<cv::Vec3f>(y);
      for (int x = 0; x < src_->cols; ++x) {
        if (m[x] || ip[x][0] == 0.f) continue;
        for (int k = 0; k < 3; ++k) {
          p[x][k] = std::max(p[x][k] + a * (in[x][k] * inv[k] - p[x][k]), 0.05f);
          ip[x][k] = 1.f / p[x][k];
          inv_planes_[static_cast<std::size_t>(k)].ptr<float>(y)[x] = ip[x][k];
        }
      }
    }
    refresh_ref_samples();
  }

  // Width of the darkness ramp at a blob's edge: its mean darkness divided by the mean darkness
  // gradient on its contour (a Gaussian penumbra of sigma s gives about 2.5 s). Grows with the
  // height of a hovering part; see HoverHeightModel.
  float edge_width(int group, float darkness) {
    double sum = 0;
    int n = 0;
    const int w = darkness_.cols, h = darkness_.rows;
    for (std::size_t j = 0; j < kept_.size(); ++j) {
      if (sets_.find(static_cast<int>(j)) != group) continue;
      for (const cv::Point& p : contours_[kept_[j].contour]) {
        // Differences over +-2 px, averaged over the 3 rows/columns across: robust to noise.
        const int x0 = std::max(p.x - 2, 0), x1 = std::min(p.x + 2, w - 1);
        const int y0 = std::max(p.y - 2, 0), y1 = std::min(p.y + 2, h - 1);
        if (x0 == x1 || y0 == y1) continue;
        float gx = 0, gy = 0;
        for (int o = -1; o <= 1; ++o) {
          const int yy = std::clamp(p.y + o, 0, h - 1), xx = std::clamp(p.x + o, 0, w - 1);
          gx += (darkness_.at<float>(yy, x1) - darkness_.at<float>(yy, x0)) / float(x1 - x0);
          gy += (darkness_.at<float>(y1, xx) - darkness_.at<float>(y0, xx)) / float(y1 - y0);
        }
        gx /= 3.f;
        gy /= 3.f;
        sum += std::hypot(gx, gy);
        ++n;
      }
    }
    if (n == 0 || sum <= 0) return 0.f;
    return static_cast<float>(darkness / (sum / n));
  }

  struct Kept {
    cv::Rect box;
    double area;
    std::size_t contour;
  };
  Config config_;
  cv::Mat colour_blur_, blurred_, darkness_, warmth_, dilated_;
  const cv::Mat* src_ = nullptr;          // the frame being segmented (valid during segment())
  cv::Mat profile_, inv_profile_, valid_; // empty-skin model
  std::array<cv::Mat, 4> inv_planes_;     // inverse model per channel (CV_32F) + skin weight (1/0)
  std::array<cv::Mat, 4> uniform_planes_; // stand-ins without a model
  cv::Mat uniform_valid_;
  struct RefSample {
    int y, x;
    cv::Vec3f inv;
  };
  std::vector<RefSample> ref_samples_;
  cv::Vec3f gain_{1, 1, 1};
  float frame_shadow_threshold_ = 0;
  mutable std::array<std::vector<int>, 3> hist_;
  std::vector<std::vector<cv::Point>> contours_;
  std::vector<Kept> kept_;
  detail::DisjointSets sets_;
};

// ---------------------------------------------------------------------------------------------
// Calibration: fit the colour classes from frames of the empty skin and labelled touch frames.

// A touch frame with its labels: masks of the same size, CV_8UC1, non-zero = pixel in the class.
// The contact pixels should also be marked in shadow_mask (a contact is part of the shadow); the
// fit treats them so either way.
struct LabelledFrame {
  cv::Mat image;
  cv::Mat shadow_mask;
  cv::Mat contact_mask;
};

namespace detail {

inline void require_label_mask(const cv::Mat& m, const cv::Mat& image, const std::string& name) {
  require(!m.empty() && m.type() == CV_8UC1 && m.size() == image.size(),
          name + " must be a CV_8UC1 mask of the image's size (" + std::to_string(image.cols) +
              "x" + std::to_string(image.rows) + ")");
}

// Threshold t minimising false positives + false negatives for "value >= t" given histograms of
// positives and negatives over bins [lo, lo + n*step).
inline float best_threshold(const std::vector<double>& pos, const std::vector<double>& neg,
                            float lo, float step) {
  const std::size_t n = pos.size();
  double fn = 0; // positives below bin i
  double fp = std::accumulate(neg.begin(), neg.end(), 0.0);
  double best = fn + fp;
  std::size_t best_i = 0;
  for (std::size_t i = 1; i <= n; ++i) {
    fn += pos[i - 1];
    fp -= neg[i - 1];
    if (fn + fp < best) {
      best = fn + fp;
      best_i = i;
    }
  }
  return lo + step * static_cast<float>(best_i);
}

inline cv::Vec3b channel_percentile(const std::array<std::array<double, 256>, 3>& h, double p) {
  cv::Vec3b out;
  for (int k = 0; k < 3; ++k) {
    const double total = std::accumulate(h[k].begin(), h[k].end(), 0.0);
    double acc = 0;
    int v = 0;
    for (; v < 255; ++v) {
      acc += h[k][v];
      if (acc >= p * total && acc > 0) break;
    }
    out[k] = static_cast<uchar>(v);
  }
  return out;
}

} // namespace detail

namespace detail {

// Histograms of darkness (shadow vs not) and of (darkness, warmth) (contact vs not), and the
// thresholds minimising misclassified pixels.
class ThresholdFit {
public:
  static constexpr float lo = -0.5f, step = 0.005f;
  static constexpr int nb = 300; // bins over [-0.5, 1.0)

  ThresholdFit() : s_pos_(nb), s_neg_(nb), c_pos_(nb * nb), c_neg_(nb * nb) {}

  void add(const cv::Mat& darkness, const cv::Mat& warmth, const cv::Mat* shadow_mask,
           const cv::Mat* contact_mask) {
    for (int y = 0; y < darkness.rows; ++y) {
      const float* d = darkness.ptr<float>(y);
      const float* w = warmth.ptr<float>(y);
      const uchar* sm = shadow_mask ? shadow_mask->ptr<uchar>(y) : nullptr;
      const uchar* cm = contact_mask ? contact_mask->ptr<uchar>(y) : nullptr;
      for (int x = 0; x < darkness.cols; ++x) {
        const bool c = cm && cm[x];
        const bool s = c || (sm && sm[x]);
        (s ? s_pos_ : s_neg_)[static_cast<std::size_t>(bin(d[x]))] += 1;
        (c ? c_pos_ : c_neg_)[static_cast<std::size_t>(bin(d[x]) * nb + bin(w[x]))] += 1;
      }
    }
  }

  LightThresholds fit(float luminance) const {
    LightThresholds t;
    t.luminance = luminance;
    t.shadow_darkness = std::clamp(best_threshold(s_pos_, s_neg_, lo, step), 0.f, 1.f);
    // Contact: darkness >= td and warmth >= tw. 2-D suffix sums over the histograms.
    std::vector<double> sp((nb + 1) * (nb + 1)), sn((nb + 1) * (nb + 1));
    auto at = [&](std::vector<double>& v, int i, int j) -> double& {
      return v[static_cast<std::size_t>(i * (nb + 1) + j)];
    };
    for (int i = nb - 1; i >= 0; --i)
      for (int j = nb - 1; j >= 0; --j) {
        const std::size_t k = static_cast<std::size_t>(i * nb + j);
        at(sp, i, j) = c_pos_[k] + at(sp, i + 1, j) + at(sp, i, j + 1) - at(sp, i + 1, j + 1);
        at(sn, i, j) = c_neg_[k] + at(sn, i + 1, j) + at(sn, i, j + 1) - at(sn, i + 1, j + 1);
      }
    const double total_pos = at(sp, 0, 0);
    double best = -1;
    int bi = nb, bj = nb;
    for (int i = bin(0.f); i <= nb; ++i) // contact darkness threshold at least 0
      for (int j = 0; j <= nb; ++j) {
        const double err = (total_pos - at(sp, i, j)) + at(sn, i, j);
        if (best < 0 || err < best) {
          best = err;
          bi = i;
          bj = j;
        }
      }
    t.contact_darkness = std::clamp(lo + step * static_cast<float>(bi), 0.f, 1.f);
    t.contact_warmth = std::clamp(lo + step * static_cast<float>(bj), -1.f, 1.f);
    return t;
  }

private:
  static int bin(float v) {
    return std::clamp(static_cast<int>(std::floor((v - lo) / step)), 0, nb - 1);
  }
  std::vector<double> s_pos_, s_neg_, c_pos_, c_neg_;
};

} // namespace detail

// Fits the relative-mode thresholds (shadow_darkness; contact_darkness and contact_warmth jointly)
// by minimising misclassified pixels over all given frames, and the fixed-mode colour ranges
// (contact: the 0.5..99.5 percentiles of contact pixels per channel; shadow: from the 0.1
// percentile of shadow pixels up to just below the 1st percentile of empty-skin pixels). `base`
// supplies the pre-blur and reference percentile the fitted values will be used with; the
// returned calibration keeps base's mode. Throws InvalidArgument if no touch frame is given, a
// frame is not an 8-bit colour image, or a mask does not match its image.
inline SegmenterCalibration fit_calibration(const std::vector<cv::Mat>& empty_frames,
                                            const std::vector<LabelledFrame>& touch_frames,
                                            const Segmenter::Config& base = {},
                                            int light_groups = 0) {
  detail::require(!touch_frames.empty(),
                  "fit_calibration: no labelled touch frames; expected at least one");
  for (std::size_t i = 0; i < empty_frames.size(); ++i)
    require_colour_image(empty_frames[i],
                         ("fit_calibration: empty_frames[" + std::to_string(i) + "]").c_str());
  for (std::size_t i = 0; i < touch_frames.size(); ++i) {
    const std::string n = "fit_calibration: touch_frames[" + std::to_string(i) + "]";
    require_colour_image(touch_frames[i].image, (n + ".image").c_str());
    detail::require_label_mask(touch_frames[i].shadow_mask, touch_frames[i].image,
                               n + ".shadow_mask");
    detail::require_label_mask(touch_frames[i].contact_mask, touch_frames[i].image,
                               n + ".contact_mask");
  }
  // Features with the relative mode on each frame's own reference.
  Segmenter::Config cfg = base;
  cfg.calibration.mode = SegmentMode::relative;
  cfg.calibration.by_light.clear();
  cfg.adaptive = false;
  cfg.mask_blur = 0;
  Segmenter seg(cfg);
  if (!empty_frames.empty()) seg.set_empty_skin(empty_frames);
  Segmentation scratch;
  // Pass 1: each frame's reference luminance, to group frames by light level.
  std::vector<const cv::Mat*> images;
  for (const cv::Mat& e : empty_frames) images.push_back(&e);
  for (const LabelledFrame& f : touch_frames) images.push_back(&f.image);
  std::vector<float> lum(images.size());
  for (std::size_t i = 0; i < images.size(); ++i) {
    seg.segment(*images[i], scratch);
    lum[i] = detail::luminance(seg.last_reference());
  }
  // Groups: equal-count quantiles of the labelled frames' luminance.
  int groups = light_groups;
  if (groups == 0) groups = std::clamp(static_cast<int>(touch_frames.size()) / 8, 1, 6);
  detail::require(groups >= 1, "fit_calibration: light_groups must be >= 0");
  std::vector<float> sorted(lum.begin() + static_cast<std::ptrdiff_t>(empty_frames.size()),
                            lum.end());
  std::sort(sorted.begin(), sorted.end());
  std::vector<float> upper_edge; // group g holds luminance <= upper_edge[g]
  for (int g = 1; g < groups; ++g)
    upper_edge.push_back(
        sorted[static_cast<std::size_t>(g) * sorted.size() / static_cast<std::size_t>(groups)]);
  auto group_of = [&](float l) {
    return static_cast<int>(std::upper_bound(upper_edge.begin(), upper_edge.end(), l) -
                            upper_edge.begin());
  };
  std::vector<detail::ThresholdFit> fits(static_cast<std::size_t>(groups) + 1); // last = all
  std::vector<std::vector<float>> group_lum(static_cast<std::size_t>(groups));
  std::array<std::array<double, 256>, 3> h_contact{}, h_shadow{}, h_empty{};
  for (std::size_t i = 0; i < images.size(); ++i) {
    const bool labelled = i >= empty_frames.size();
    const LabelledFrame* lf = labelled ? &touch_frames[i - empty_frames.size()] : nullptr;
    seg.segment(*images[i], scratch);
    const int g = group_of(lum[i]);
    if (labelled) group_lum[static_cast<std::size_t>(g)].push_back(lum[i]);
    const cv::Mat* sm = lf ? &lf->shadow_mask : nullptr;
    const cv::Mat* cm = lf ? &lf->contact_mask : nullptr;
    fits[static_cast<std::size_t>(g)].add(seg.darkness(), seg.warmth(), sm, cm);
    fits.back().add(seg.darkness(), seg.warmth(), sm, cm);
    cv::Mat smooth;
    if (cfg.pre_blur > 1)
      cv::blur(*images[i], smooth, cv::Size(cfg.pre_blur, cfg.pre_blur), cv::Point(-1, -1),
               cv::BORDER_REPLICATE);
    else
      smooth = *images[i];
    for (int y = 0; y < smooth.rows; ++y) {
      const cv::Vec3b* px = smooth.ptr<cv::Vec3b>(y);
      for (int x = 0; x < smooth.cols; ++x) {
        const bool c = cm && cm->at<uchar>(y, x);
        const bool s = c || (sm && sm->at<uchar>(y, x));
        auto& h = c ? h_contact : (s ? h_shadow : h_empty);
        for (int k = 0; k < 3; ++k) h[k][px[x][k]] += 1;
      }
    }
  }
  SegmenterCalibration cal = base.calibration;
  const LightThresholds all = fits.back().fit(0);
  cal.shadow_darkness = all.shadow_darkness;
  cal.contact_darkness = all.contact_darkness;
  cal.contact_warmth = all.contact_warmth;
  cal.by_light.clear();
  if (groups > 1)
    for (int g = 0; g < groups; ++g) {
      auto& gl = group_lum[static_cast<std::size_t>(g)];
      if (gl.empty()) continue;
      std::sort(gl.begin(), gl.end());
      const float median = gl[gl.size() / 2];
      if (!cal.by_light.empty() && median <= cal.by_light.back().luminance) continue;
      cal.by_light.push_back(fits[static_cast<std::size_t>(g)].fit(median));
    }

  // Fixed ranges (the paper's mode), for comparison and for rigs with constant light.
  if (std::accumulate(h_contact[0].begin(), h_contact[0].end(), 0.0) > 0)
    cal.contact_range = {detail::channel_percentile(h_contact, 0.005),
                         detail::channel_percentile(h_contact, 0.995)};
  auto merged = h_shadow;
  for (int k = 0; k < 3; ++k)
    for (int v = 0; v < 256; ++v) merged[k][v] += h_contact[k][v];
  if (std::accumulate(merged[0].begin(), merged[0].end(), 0.0) > 0) {
    cv::Vec3b lower = detail::channel_percentile(merged, 0.001);
    cv::Vec3b upper = detail::channel_percentile(merged, 0.99);
    if (std::accumulate(h_empty[0].begin(), h_empty[0].end(), 0.0) > 0) {
      const cv::Vec3b empty_low = detail::channel_percentile(h_empty, 0.01);
      for (int k = 0; k < 3; ++k)
        upper[k] =
            static_cast<uchar>(std::max<int>(lower[k], std::min<int>(upper[k], empty_low[k] - 1)));
    }
    cal.shadow_range = {lower, upper};
  }
  detail::validate_calibration(cal, "fit_calibration");
  return cal;
}

// ---------------------------------------------------------------------------------------------
// Calibration file: UTF-8 text, one "key value..." per line, '#' starts a comment. First
// non-comment line: "shadowsense_segmenter_calibration 1". Keys (all required, each once):
//   mode fixed_ranges|relative
//   shadow_range  B_lo G_lo R_lo B_hi G_hi R_hi      (integers 0..255)
//   contact_range B_lo G_lo R_lo B_hi G_hi R_hi
//   shadow_darkness F  contact_darkness F  contact_warmth F  reference_percentile F
// plus zero or more rows, in increasing luminance (SegmenterCalibration::by_light):
//   light_thresholds LUMINANCE SHADOW_DARKNESS CONTACT_DARKNESS CONTACT_WARMTH

inline std::string calibration_to_string(const SegmenterCalibration& c) {
  detail::validate_calibration(c, "calibration_to_string");
  std::ostringstream o;
  o.precision(9);
  auto range = [&](const ColourRange& r) {
    o << int(r.lower[0]) << ' ' << int(r.lower[1]) << ' ' << int(r.lower[2]) << ' '
      << int(r.upper[0]) << ' ' << int(r.upper[1]) << ' ' << int(r.upper[2]) << '\n';
  };
  o << "# shadowsense segmenter calibration (see docs/tracking_eval.md)\n";
  o << "shadowsense_segmenter_calibration 1\n";
  o << "mode " << (c.mode == SegmentMode::relative ? "relative" : "fixed_ranges") << '\n';
  o << "shadow_range ";
  range(c.shadow_range);
  o << "contact_range ";
  range(c.contact_range);
  o << "shadow_darkness " << c.shadow_darkness << '\n';
  o << "contact_darkness " << c.contact_darkness << '\n';
  o << "contact_warmth " << c.contact_warmth << '\n';
  o << "reference_percentile " << c.reference_percentile << '\n';
  for (const LightThresholds& t : c.by_light)
    o << "light_thresholds " << t.luminance << ' ' << t.shadow_darkness << ' ' << t.contact_darkness
      << ' ' << t.contact_warmth << '\n';
  return o.str();
}

// Parses the text format above; throws ModelFileError naming the line on any problem.
inline SegmenterCalibration calibration_from_string(const std::string& text,
                                                    const std::string& source = "calibration") {
  SegmenterCalibration c;
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  bool header = false;
  std::vector<std::string> seen;
  auto fail = [&](const std::string& what) {
    throw ModelFileError(source + ":" + std::to_string(line_no) + ": " + what);
  };
  while (std::getline(in, line)) {
    ++line_no;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::istringstream ls(line);
    std::string key;
    if (!(ls >> key)) continue;
    if (!header) {
      int version = 0;
      if (key != "shadowsense_segmenter_calibration" || !(ls >> version))
        fail("expected the header 'shadowsense_segmenter_calibration 1'");
      if (version != 1)
        fail("format version " + std::to_string(version) + " is not supported; expected 1");
      header = true;
      continue;
    }
    if (key != "light_thresholds" && std::find(seen.begin(), seen.end(), key) != seen.end())
      fail("key '" + key + "' appears twice");
    seen.push_back(key);
    auto read_float = [&](float& v) {
      std::string tok;
      if (!(ls >> tok)) fail("key '" + key + "' needs a number");
      try {
        std::size_t used = 0;
        v = std::stof(tok, &used);
        if (used != tok.size() || !std::isfinite(v)) throw std::invalid_argument(tok);
      } catch (const std::exception&) {
        fail("key '" + key + "': '" + tok + "' is not a finite number");
      }
    };
    auto read_range = [&](ColourRange& r) {
      int v[6];
      for (int& x : v) {
        if (!(ls >> x)) fail("key '" + key + "' needs six integers (B G R low, B G R high)");
        if (x < 0 || x > 255)
          fail("key '" + key + "': value " + std::to_string(x) + " is outside 0..255");
      }
      r = {cv::Vec3b(uchar(v[0]), uchar(v[1]), uchar(v[2])),
           cv::Vec3b(uchar(v[3]), uchar(v[4]), uchar(v[5]))};
    };
    if (key == "mode") {
      std::string m;
      ls >> m;
      if (m == "relative")
        c.mode = SegmentMode::relative;
      else if (m == "fixed_ranges")
        c.mode = SegmentMode::fixed_ranges;
      else
        fail("mode '" + m + "' is unknown; expected relative or fixed_ranges");
    } else if (key == "shadow_range")
      read_range(c.shadow_range);
    else if (key == "contact_range")
      read_range(c.contact_range);
    else if (key == "shadow_darkness")
      read_float(c.shadow_darkness);
    else if (key == "contact_darkness")
      read_float(c.contact_darkness);
    else if (key == "contact_warmth")
      read_float(c.contact_warmth);
    else if (key == "reference_percentile")
      read_float(c.reference_percentile);
    else if (key == "light_thresholds") {
      LightThresholds t;
      read_float(t.luminance);
      read_float(t.shadow_darkness);
      read_float(t.contact_darkness);
      read_float(t.contact_warmth);
      c.by_light.push_back(t);
    } else
      fail("unknown key '" + key + "'");
    std::string extra;
    if (ls >> extra) fail("unexpected extra value '" + extra + "' after key '" + key + "'");
  }
  if (!header)
    throw ModelFileError(source + ": empty; expected a shadowsense segmenter calibration");
  for (const char* k : {"mode", "shadow_range", "contact_range", "shadow_darkness",
                        "contact_darkness", "contact_warmth", "reference_percentile"})
    if (std::find(seen.begin(), seen.end(), k) == seen.end())
      throw ModelFileError(source + ": key '" + k + "' is missing");
  try {
    detail::validate_calibration(c, source);
  } catch (const InvalidArgument& e) {
    throw ModelFileError(e.what());
  }
  return c;
}

inline void save_calibration(const SegmenterCalibration& c, const std::string& path) {
  const std::string text = calibration_to_string(c);
  std::ofstream f(path, std::ios::binary);
  if (!f) throw IoError("save_calibration: cannot open '" + path + "' for writing");
  f << text;
  if (!f.flush()) throw IoError("save_calibration: writing '" + path + "' failed");
}

inline SegmenterCalibration load_calibration(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw IoError("load_calibration: cannot open '" + path + "' for reading");
  std::ostringstream ss;
  ss << f.rdbuf();
  return calibration_from_string(ss.str(), path);
}

SHADOWSENSE_NAMESPACE_END
