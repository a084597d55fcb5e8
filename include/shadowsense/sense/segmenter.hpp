// Shadow and contact segmentation (paper section 4.3): two colour classes, "shadow" and
// "contact"; the binary mask of each is smoothed with a Gaussian blur, its external contours found
// by Suzuki-Abe border following, thresholded by size and merged when close; the result is a box
// per class (and per blob, for multi-touch) and the contact position is the centroid of the
// contact region. The blur and the contours are the library's own (mask_smoothing.hpp,
// border_following.hpp), equal to OpenCV's bit for bit and point for point, without per-frame
// allocations.
//
// One pass over the frame: when the rule has the row interface (RowPixelRule, pixel_rule.hpp:
// both of the library's rules) and mask_blur is 0, 1, 3 or 5 (default 5), each row is
// classified, smoothed and written to the masks and to the contour images while it is in cache
// (the per-row kernels: segment_kernels.hpp, AVX2 / NEON / portable); otherwise the rule runs
// over the whole frame and the masks are smoothed and scanned in passes of their own. Both give
// the same masks, features and blobs (tests/test_segment_one_pass.cpp, against
// segment_reference.hpp).
//
// BasicSegmenter<Rule> does everything around the per-pixel decision, which a PixelRule makes
// (pixel_rule.hpp): the empty-skin model, the per-frame reference, mask clean-up, blobs
// (blobs.hpp), shadow opacity and hover height (hover_height.hpp). `Segmenter` is
// BasicSegmenter<CalibratedRule>: the rule chosen by Config::calibration (relative to the empty
// skin by default, or the paper's fixed colour ranges). Use your own rule with
// BasicSegmenter<MyRule>(config, MyRule{...}).
//
// Empty-skin model: per pixel and channel, the lit empty skin's brightness relative to the
// frame's reference (set_empty_skin from a few frames of the empty skin, set_empty_skin_profile,
// or Config::calibration.empty_skin, e.g. from a calibration file). It holds vignetting and the
// visible-skin outline; pixels darker than half the reference in the model are not skin (robot
// interior, box walls) and are never classified. The reference of each frame is a high
// percentile of each channel of the frame over the model, so every frame, at any light, is
// judged against its own light. With Config::adaptive the model is also updated slowly on pixels
// outside any shadow, so it follows slow changes in a video. The rule reads the model's inverse,
// 1 / model per channel, rounded to the nearest IEEE binary16 (relative error at most 2^-11): it
// reads it every frame, and half precision halves those bytes (the largest share of what a frame
// moves; docs/densenet.md, "The empty-skin model in half precision"). darkness(), warmth(), the
// masks and the reference all follow from the rounded values.
//
// Constructors
//   requires: a valid Config (validate_calibration; pre_blur in [0, 15]; mask_blur 0, 1 or odd
//             <= 31; finite areas >= 0; merge gaps >= 0; adapt_rate in (0, 1]; profile_smoothing
//             in [0, 50]; max_blobs >= 1; max_image_side in [16, 65536]).
//   ensures:  the empty-skin model of config.calibration.empty_skin is set when it holds one.
//   throws:   InvalidArgument naming the bad field.
// set_empty_skin(frames)
//   requires: at least one CV_8UC3 frame, all the same size, none larger than max_image_side,
//             none black or nearly black (reference luminance < 4 of 255).
//   ensures:  the model is the per-pixel median of the frames, each over its own reference.
//             Memory beyond the frames and the model: float strips of about 16 MB (at least one
//             row of every frame), never a float copy of every frame.
// set_empty_skin_profile(model)
//   requires: CV_32FC3 with finite values in [0, 8] (relative brightness; an image in 0..255 is
//             refused) showing skin (mean >= 0.5) on at least 1% of its pixels.
// segment(bgr[, out])
//   requires: CV_8UC3, no side larger than max_image_side, the model's size when a model is set.
//   ensures:  out holds the masks, the blobs (at most max_blobs contours per class are kept;
//             the smallest beyond are dropped and counted in dropped_*_blobs), the union boxes
//             and the contact point. Shadow and contact blobs carry edge_width (relative mode;
//             the contact blobs' is a sharpness cue, docs/tracking_eval.md "Contact vs hover
//             ROC").
//   throws:   InvalidArgument for a bad image.
// check_frame(bgr): throws what segment() would throw for this frame; changes nothing.
// Threading: a Segmenter holds per-frame scratch and the model; use one instance per thread.
// A cheap owner check (core/thread_owner.hpp) throws ConcurrentUseError when one instance is
// entered from two threads at once - segment() and the read accessors (darkness(), warmth(),
// skin_area()) alike (compiled out with SHADOWSENSE_NO_THREAD_CHECK). Copies are
// independent.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/core/image_check.hpp>
#include <shadowsense/core/thread_owner.hpp>
#include <shadowsense/sense/blobs.hpp>
#include <shadowsense/sense/hover_height.hpp>
#include <shadowsense/sense/mask_smoothing.hpp>
#include <shadowsense/sense/pixel_rule.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

struct Segmentation {
  std::vector<Blob> shadows;
  std::vector<Blob> contacts;
  std::optional<cv::Rect> shadow_box{};       // union of all shadow blobs (the paper's box)
  std::optional<cv::Rect> contact_box{};      // union of all contact blobs
  std::optional<cv::Point2f> contact_point{}; // centroid of all contact pixels
  cv::Mat shadow_mask;                        // CV_8UC1 0/255, after blur and threshold
  cv::Mat contact_mask;                       // CV_8UC1 0/255, after blur and threshold
  std::size_t dropped_shadow_blobs = 0;       // contours beyond Config::max_blobs, smallest first
  std::size_t dropped_contact_blobs = 0;      // likewise for contact
};

// Segmenter settings (every BasicSegmenter<Rule> takes the same).
struct SegmenterConfig {
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
  int max_blobs = 1024;           // contours kept per class and frame (largest first)
  int max_image_side = 8192;      // frames wider or taller are refused before any allocation
};

template <PixelRule Rule>
class BasicSegmenter {
public:
  using Config = SegmenterConfig;

  BasicSegmenter() requires std::is_default_constructible_v<Rule> ||
      std::is_constructible_v<Rule, const SegmenterCalibration&> : BasicSegmenter(Config{}) {}
  explicit BasicSegmenter(const Config& c) requires std::is_default_constructible_v<Rule> ||
      std::is_constructible_v<Rule, const SegmenterCalibration&> : BasicSegmenter(c, make_rule(c)) {
  }
  BasicSegmenter(const Config& c, Rule rule) : config_(c), rule_(std::move(rule)) {
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
    detail::require(c.max_blobs >= 1, "Segmenter: max_blobs must be >= 1");
    detail::require(c.max_image_side >= 16 && c.max_image_side <= 65536,
                    "Segmenter: max_image_side must be in [16, 65536]");
    if (!c.calibration.empty_skin.empty()) set_empty_skin_profile(c.calibration.empty_skin);
  }

  // Sets the empty-skin model from frames of the empty skin (any light level each): per pixel
  // and channel, the median over the frames of the frame over its reference (robust to a
  // passing shadow in one), then smoothed over Config::profile_smoothing px inside the skin.
  void set_empty_skin(const std::vector<cv::Mat>& empty_frames) {
    const auto guard = owner_.enter("Segmenter");
    detail::require(!empty_frames.empty(),
                    "Segmenter::set_empty_skin: no frames; expected at least one empty-skin frame");
    for (std::size_t i = 0; i < empty_frames.size(); ++i) {
      const std::string name = "Segmenter::set_empty_skin: frame " + std::to_string(i);
      require_colour_image(empty_frames[i], name.c_str());
      require_size(empty_frames[i], name.c_str());
      detail::require(empty_frames[i].size() == empty_frames[0].size(),
                      name + " has a different size from frame 0; expected all the same size");
    }
    // Each frame's reference first, then the median in strips of rows: only one strip of each
    // frame is ever held in float (memory: the frames plus a fixed budget, not a float copy of
    // every frame). Values are those of the whole-frame computation, element by element.
    for (cv::Mat& p : inv_planes_) p.release(); // each frame's reference over the whole frame
    for (cv::Mat& p : inv_half_) p.release();
    const std::size_t n = empty_frames.size();
    std::vector<cv::Vec3f> refs(n);
    std::vector<cv::Mat> blurred; // the pre-blurred frames (Config::pre_blur > 1 only)
    for (std::size_t i = 0; i < n; ++i) {
      smooth(empty_frames[i]);
      refs[i] = global_reference();
      detail::require(detail::luminance(refs[i]) >= 4.f,
                      "Segmenter::set_empty_skin: frame " + std::to_string(i) +
                          " is black or nearly black (reference luminance " +
                          std::to_string(detail::luminance(refs[i])) +
                          " of 255); expected a frame of the lit, empty skin");
      if (src_ == &colour_blur_) blurred.push_back(std::exchange(colour_blur_, cv::Mat()));
    }
    const cv::Size size = empty_frames[0].size();
    cv::Mat median(size, CV_32FC3);
    constexpr std::size_t strip_budget = std::size_t{16} << 20; // bytes of float strips
    const std::size_t row_bytes = static_cast<std::size_t>(size.width) * sizeof(cv::Vec3f) * n;
    const int strip_rows =
        static_cast<int>(std::clamp<std::size_t>(strip_budget / row_bytes, 1, size.height));
    std::vector<cv::Mat> strips(n);
    cv::Mat f;
    std::vector<float> v(n);
    for (int y0 = 0; y0 < size.height; y0 += strip_rows) {
      const cv::Range rows(y0, std::min(size.height, y0 + strip_rows));
      for (std::size_t i = 0; i < n; ++i) {
        const cv::Mat& src = blurred.empty() ? empty_frames[i] : blurred[i];
        src.rowRange(rows).convertTo(f, CV_32FC3);
        strips[i] = f.mul(cv::Scalar(1.0 / refs[i][0], 1.0 / refs[i][1], 1.0 / refs[i][2]));
      }
      for (int y = rows.start; y < rows.end; ++y) {
        cv::Vec3f* out = median.ptr<cv::Vec3f>(y);
        for (int x = 0; x < size.width; ++x)
          for (int k = 0; k < 3; ++k) {
            for (std::size_t i = 0; i < n; ++i)
              v[i] = strips[i].ptr<cv::Vec3f>(y - rows.start)[x][k];
            std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(n / 2), v.end());
            out[x][k] = v[n / 2];
          }
      }
    }
    strips.clear();
    blurred.clear();
    detail::validate_empty_skin(median, "Segmenter::set_empty_skin_profile");
    use_model(std::move(median));
  }

  // Sets the empty-skin model directly (CV_32FC3, 1 = lit skin at the reference brightness, as
  // returned by empty_skin_model(); smoothed here like set_empty_skin's).
  void set_empty_skin_profile(const cv::Mat& profile) {
    const auto guard = owner_.enter("Segmenter");
    detail::validate_empty_skin(profile, "Segmenter::set_empty_skin_profile");
    require_size(profile, "Segmenter::set_empty_skin_profile: the model");
    use_model(profile.clone());
  }
  void set_background(const cv::Mat& empty_frame) { set_empty_skin({empty_frame}); }
  bool has_empty_skin() const { return !profile_.empty(); }
  // The smoothed model the frames are divided by (follows Config::adaptive updates).
  const cv::Mat& empty_skin_profile() const { return profile_; }
  // The model as set (unsmoothed, without adaptive updates): what a calibration file stores
  // (SegmenterCalibration::empty_skin). Empty without a model.
  const cv::Mat& empty_skin_model() const { return model_; }
  // 255 where the empty-skin model shows skin (empty without a model).
  const cv::Mat& skin_area() const {
    const auto guard = owner_.enter("Segmenter");
    return valid_;
  }

  // Throws InvalidArgument when segment() would refuse the frame (not 8-bit BGR, too large, or
  // not the empty-skin model's size); changes nothing.
  void check_frame(const cv::Mat& bgr) const {
    require_colour_image(bgr, "Segmenter::segment: image");
    require_size(bgr, "Segmenter::segment: image");
    if (!profile_.empty())
      if (!(bgr.size() == profile_.size()))
        SHADOWSENSE_THROW(
            InvalidArgument("Segmenter::segment: image is " + std::to_string(bgr.cols) + "x" +
                            std::to_string(bgr.rows) + " but the empty-skin model is " +
                            std::to_string(profile_.cols) + "x" + std::to_string(profile_.rows) +
                            "; expected the same size"));
  }

  // Segments one BGR frame into `out` (buffers reused across calls).
  void segment(const cv::Mat& bgr, Segmentation& out) {
    const auto guard = owner_.enter("Segmenter");
    check_frame(bgr);
    if (config_.adaptive && profile_.empty()) set_empty_skin({bgr}); // first frame = empty skin
    smooth(bgr);
    bool prepared = false; // the contour images written by the one pass
    if constexpr (RowPixelRule<Rule>) {
      if (MaskSmoother::streams(config_.mask_blur, bgr.size())) {
        classify_in_one_pass(out);
        prepared = true;
      }
    }
    if (!prepared) { // a rule without rows, or a kernel the row pass does not do
      classify(out);
      shadow_smoother_.apply(out.shadow_mask, config_.mask_blur);
      contact_smoother_.apply(out.contact_mask, config_.mask_blur);
    }
    out.dropped_shadow_blobs =
        extract(out.shadow_mask, config_.min_shadow_area, config_.shadow_merge_gap, out.shadows,
                shadow_finder_, prepared);
    out.dropped_contact_blobs =
        extract(out.contact_mask, config_.min_contact_area, config_.contact_merge_gap, out.contacts,
                contact_finder_, prepared);
    summarise(out);
    if (config_.adaptive) adapt(out);
  }
  Segmentation segment(const cv::Mat& bgr) {
    Segmentation s;
    segment(bgr, s);
    return s;
  }

  // Per-pixel darkness and warmth of the last segmented frame, CV_32F (empty when the rule has
  // no such features, e.g. fixed ranges).
  const cv::Mat& darkness() const {
    const auto guard = owner_.enter("Segmenter");
    return darkness_;
  }
  const cv::Mat& warmth() const {
    const auto guard = owner_.enter("Segmenter");
    return warmth_;
  }
  // Reference colour (BGR) of the last segmented frame (rules that use it).
  cv::Vec3f last_reference() const { return gain_; }

  const Config& config() const { return config_; }
  const Rule& rule() const { return rule_; }
  // The rule may be changed between frames (e.g. a threshold swept by an evaluation); it is
  // part of the instance, under the same one-thread contract.
  Rule& rule() { return rule_; }

private:
  static Rule make_rule(const Config& c) {
    if constexpr (std::is_constructible_v<Rule, const SegmenterCalibration&>)
      return Rule(c.calibration);
    else
      return Rule{};
  }

  // The model (validated, owned) becomes model_; the smoothed profile, its inverse and the skin
  // area are derived from it. Temporaries are released as soon as they are used: at 4K each
  // float plane is 33 MB.
  void use_model(cv::Mat model) {
    model_ = std::move(model);
    {
      cv::Mat lum;
      cv::transform(model_, lum, cv::Matx13f(1.f / 3, 1.f / 3, 1.f / 3));
      valid_ = lum >= 0.5f;
    }
    // Normalised convolution: smooth inside the skin only, so the outline stays sharp.
    const double sg = config_.profile_smoothing;
    cv::Mat num, den;
    {
      cv::Mat w, masked = model_.clone();
      valid_.convertTo(w, CV_32F, 1.0 / 255);
      masked.setTo(cv::Scalar::all(0), ~valid_);
      if (sg > 0) {
        cv::GaussianBlur(masked, num, cv::Size(0, 0), sg, sg, cv::BORDER_REPLICATE);
        cv::GaussianBlur(w, den, cv::Size(0, 0), sg, sg, cv::BORDER_REPLICATE);
      } else {
        num = masked;
        den = w;
      }
    }
    profile_.create(model_.size(), CV_32FC3);
    for (std::size_t k = 0; k < 3; ++k) {
      inv_planes_[k].create(model_.size(), CV_32F);
      inv_half_[k].create(model_.size(), CV_16F);
    }
    for (int y = 0; y < model_.rows; ++y) {
      const cv::Vec3f* n = num.ptr<cv::Vec3f>(y);
      const float* d = den.ptr<float>(y);
      const uchar* v = valid_.ptr<uchar>(y);
      cv::Vec3f* p = profile_.ptr<cv::Vec3f>(y);
      for (int x = 0; x < model_.cols; ++x)
        for (int k = 0; k < 3; ++k) {
          p[x][k] = v[x] && d[x] > 1e-6f ? std::max(n[x][k] / d[x], 0.05f) : 0.f;
          set_inverse(k, y, x, p[x][k] > 0 ? 1.f / p[x][k] : 0.f);
        }
    }
    num.release();
    den.release();
    valid_.convertTo(inv_planes_[3], CV_32F, 1.0 / 255); // skin weight: darkness 0 off the skin
    refresh_ref_samples();
  }

  void require_size(const cv::Mat& m, const char* name) const {
    if (!(m.cols <= config_.max_image_side && m.rows <= config_.max_image_side))
      SHADOWSENSE_THROW(InvalidArgument(std::string(name) + " is " + std::to_string(m.cols) + "x" +
                                        std::to_string(m.rows) + "; expected at most " +
                                        std::to_string(config_.max_image_side) +
                                        " px per side (Config::max_image_side)"));
  }

  // Pixel (y, x) of channel k's inverse model: v rounded to the nearest binary16 (ties to even,
  // cv::float16_t), in both the half plane the rule reads and the float plane.
  void set_inverse(int k, int y, int x, float v) {
    const cv::float16_t h(v);
    inv_half_[static_cast<std::size_t>(k)].ptr<cv::float16_t>(y)[x] = h;
    inv_planes_[static_cast<std::size_t>(k)].ptr<float>(y)[x] = static_cast<float>(h);
  }

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
    const bool prof = !inv_planes_[0].empty() && inv_planes_[0].size() == src_->size();
    int n = 0;
    if (prof) { // the model's precomputed sample grid (on the skin only), contiguous in memory
      n = static_cast<int>(ref_y_.size());
      const auto un = static_cast<std::size_t>(n);
      ref_bins_.resize(3 * un);
      segment_kernels().reference_bins(src_->ptr<uchar>(0), src_->step[0], ref_y_.data(),
                                       ref_x_.data(), ref_inv_[0].data(), ref_inv_[1].data(),
                                       ref_inv_[2].data(), n, ref_bins_.data(),
                                       ref_bins_.data() + un, ref_bins_.data() + 2 * un);
      // Four interleaved histograms per channel, added up after: skin under even light puts
      // runs of samples in one bin, and one histogram's increments of a bin wait on each other.
      if (hist4_.size() != 4 * bins) hist4_.assign(4 * bins, 0); // all 0 between calls
      for (std::size_t k = 0; k < 3; ++k) {
        const std::uint16_t* b = ref_bins_.data() + k * un;
        int* h = hist4_.data();
        std::size_t i = 0;
        for (; i + 4 <= un; i += 4) {
          ++h[b[i]];
          ++h[bins + b[i + 1]];
          ++h[2 * bins + b[i + 2]];
          ++h[3 * bins + b[i + 3]];
        }
        for (; i < un; ++i) ++h[b[i]];
        int* out = hist[k].data();
        for (int v = 0; v < bins; ++v) {
          out[v] = h[v] + h[bins + v] + h[2 * bins + v] + h[3 * bins + v];
          h[v] = h[bins + v] = h[2 * bins + v] = h[3 * bins + v] = 0;
        }
      }
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

  // The masks allocated, the frame's reference, and what the rule reads.
  PixelRuleInput rule_input(Segmentation& out) {
    const cv::Size size = src_->size();
    out.shadow_mask.create(size, CV_8UC1);
    out.contact_mask.create(size, CV_8UC1);
    const bool prof = !inv_planes_[0].empty();
    if (!prof && (uniform_valid_.size() != size)) { // no empty-skin model: all skin, flat
      for (cv::Mat& p : uniform_planes_) {
        p.create(size, CV_32F);
        p.setTo(1.0);
      }
      for (cv::Mat& p : uniform_half_) {
        p.create(size, CV_16F);
        p.setTo(1.0);
      }
      uniform_valid_.create(size, CV_8UC1);
      uniform_valid_.setTo(255);
    }
    if (detail::rule_uses_reference(rule_)) gain_ = global_reference();
    return {*src_, prof ? inv_planes_ : uniform_planes_, prof ? valid_ : uniform_valid_, gain_,
            prof ? &inv_half_ : &uniform_half_};
  }

  // The multi-pass way: the rule over the whole frame (then the masks are smoothed and scanned
  // in passes of their own).
  void classify(Segmentation& out) {
    const PixelRuleInput in = rule_input(out);
    PixelRuleOutput o{out.shadow_mask, out.contact_mask, darkness_, warmth_};
    rule_.classify(in, o);
    frame_shadow_threshold_ = o.shadow_threshold;
  }

  // One pass over the frame: each row is classified, then both class masks are smoothed (a
  // Gaussian blur of the binary mask, back to binary at half height: a majority filter that
  // removes speckle and fills pinholes without moving straight edges; mask_smoothing.hpp) and
  // their final rows written, with the 0/1 contour images (border_following.hpp), while the
  // rows are in cache. The same masks, features and contours as classify() + apply() + find().
  void classify_in_one_pass(Segmentation& out) requires RowPixelRule<Rule> {
    const PixelRuleInput in = rule_input(out);
    PixelRuleOutput o{out.shadow_mask, out.contact_mask, darkness_, warmth_};
    const typename Rule::RowState st = rule_.begin_rows(in, o);
    const int w = src_->cols, h = src_->rows;
    ExternalContours& sc = shadow_finder_.contours_input();
    ExternalContours& cc = contact_finder_.contours_input();
    std::uint8_t* const shadow_marks = sc.prepare(w, h);
    std::uint8_t* const contact_marks = cc.prepare(w, h);
    shadow_smoother_.begin(out.shadow_mask, config_.mask_blur, shadow_marks, sc.marks_stride(),
                           sc.row_flags());
    contact_smoother_.begin(out.contact_mask, config_.mask_blur, contact_marks, cc.marks_stride(),
                            cc.row_flags());
    for (int y = 0; y < h; ++y) {
      rule_.classify_row(in, st, o, y, shadow_smoother_.row(), contact_smoother_.row());
      shadow_smoother_.push();
      contact_smoother_.push();
    }
    shadow_smoother_.end();
    contact_smoother_.end();
    frame_shadow_threshold_ = o.shadow_threshold;
  }

  // Blobs of one class mask; returns how many contours the cap dropped. prepared: the finder's
  // contour image is already written (the one pass).
  std::size_t extract(const cv::Mat& mask, double min_area, int merge_gap, std::vector<Blob>& blobs,
                      BlobFinder& finder, bool prepared) {
    blobs.clear();
    const auto cap = static_cast<std::size_t>(config_.max_blobs);
    if (prepared)
      finder.find_prepared(mask, min_area, merge_gap, cap);
    else
      finder.find(mask, min_area, merge_gap, cap);
    for (const BlobFinder::Group& g : finder.groups()) {
      Blob b;
      b.box = g.box;
      const BoxSums m = box_sums(mask, g.box);
      b.area = m.m00;
      b.centroid = m.m00 > 0
                       ? cv::Point2f(static_cast<float>(g.box.x + m.m10 / m.m00),
                                     static_cast<float>(g.box.y + m.m01 / m.m00))
                       : cv::Point2f(g.box.x + g.box.width * 0.5f, g.box.y + g.box.height * 0.5f);
      if (!darkness_.empty()) {
        b.darkness = static_cast<float>(m.darkness * (m.m00 > 0 ? 1.0 / m.m00 : 0.0));
        b.edge_width = edge_width(g, b.darkness, finder);
      }
      blobs.push_back(b);
    }
    std::sort(blobs.begin(), blobs.end(), [](const Blob& a, const Blob& b) {
      return a.area != b.area ? a.area > b.area
                              : (a.box.x != b.box.x ? a.box.x < b.box.x : a.box.y < b.box.y);
    });
    return finder.dropped();
  }

  // The set pixels of mask within box: their count, the sums of their x and y (relative to the
  // box) and, with a darkness plane, the sum of their darkness in double in row order. These
  // are the values cv::moments(mask(box), true) (m00, m10, m01: integer sums, exact) and
  // cv::mean(darkness(box), mask(box)) (sum * (1 / count)) give, bit for bit, in one pass
  // instead of their per-tile calls (a third of segment() on frames with large shadows; see
  // docs/densenet.md, "Blob sums in one pass").
  struct BoxSums {
    double m00 = 0, m10 = 0, m01 = 0, darkness = 0;
  };
  BoxSums box_sums(const cv::Mat& mask, cv::Rect box) const {
    std::int64_t n = 0, sx = 0, sy = 0;
    double dark = 0;
    const bool with_darkness = !darkness_.empty();
    for (int y = 0; y < box.height; ++y) {
      const uchar* m = mask.ptr<uchar>(box.y + y) + box.x;
      const float* d = with_darkness ? darkness_.ptr<float>(box.y + y) + box.x : nullptr;
      std::int64_t row_n = 0, row_x = 0;
      for (int x = 0; x < box.width; ++x)
        if (m[x]) {
          ++row_n;
          row_x += x;
          if (with_darkness) dark += static_cast<double>(d[x]);
        }
      n += row_n;
      sx += row_x;
      sy += row_n * y;
    }
    return {static_cast<double>(n), static_cast<double>(sx), static_cast<double>(sy), dark};
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
    ref_y_.clear();
    ref_x_.clear();
    for (auto& v : ref_inv_) v.clear();
    for (int y = 1; y < inv_planes_[0].rows; y += 3) {
      const std::array<const float*, 3> ip{
          inv_planes_[0].ptr<float>(y), inv_planes_[1].ptr<float>(y), inv_planes_[2].ptr<float>(y)};
      for (int x = 1; x < inv_planes_[0].cols; x += 3)
        if (ip[0][x] != 0.f) {
          ref_y_.push_back(y);
          ref_x_.push_back(x);
          for (std::size_t k = 0; k < 3; ++k) ref_inv_[k].push_back(ip[k][x]);
        }
    }
  }

  // Slow update of the empty-skin model on skin pixels well outside any shadow.
  void adapt(const Segmentation& out) {
    if (darkness_.empty()) return; // a rule without features has no use for the model
    cv::dilate(out.shadow_mask, dilated_, cv::Mat(), cv::Point(-1, -1), 3);
    const float a = config_.adapt_rate;
    const std::array<float, 3> inv{1.f / gain_[0], 1.f / gain_[1], 1.f / gain_[2]};
    for (int y = 0; y < src_->rows; ++y) {
      const cv::Vec3b* in = src_->ptr<cv::Vec3b>(y);
      const uchar* m = dilated_.ptr<uchar>(y);
      cv::Vec3f* p = profile_.ptr<cv::Vec3f>(y);
      const float* ip0 = inv_planes_[0].ptr<float>(y);
      for (int x = 0; x < src_->cols; ++x) {
        if (m[x] || ip0[x] == 0.f) continue;
        for (int k = 0; k < 3; ++k) {
          p[x][k] = std::max(p[x][k] + a * (in[x][k] * inv[k] - p[x][k]), 0.05f);
          set_inverse(k, y, x, 1.f / p[x][k]);
        }
      }
    }
    refresh_ref_samples();
  }

  // Width of the darkness ramp at a blob's edge: its mean darkness divided by the mean darkness
  // gradient on its contour (a Gaussian penumbra of sigma s gives about 2.5 s). Grows with the
  // height of a hovering part; see HoverHeightModel.
  float edge_width(const BlobFinder::Group& group, float darkness, const BlobFinder& finder) {
    double sum = 0;
    int n = 0;
    const int w = darkness_.cols, h = darkness_.rows;
    for (const int j : group.members) {
      const std::size_t c = finder.kept()[static_cast<std::size_t>(j)].contour;
      for (const cv::Point& p : finder.contours().contour(c)) {
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

  Config config_;
  Rule rule_;
  mutable ThreadOwner owner_; // mutable: the read accessors check too
  cv::Mat colour_blur_, darkness_, warmth_, dilated_;
  const cv::Mat* src_ = nullptr;          // the frame being segmented (valid during segment())
  cv::Mat model_;                         // the model as set (unsmoothed)
  cv::Mat profile_, valid_;               // empty-skin model in use (smoothed) and its skin
  std::array<cv::Mat, 4> inv_planes_;     // inverse model per channel (CV_32F) + skin weight (1/0)
  std::array<cv::Mat, 3> inv_half_;       // the inverse model's planes as read: CV_16F
  std::array<cv::Mat, 4> uniform_planes_; // stand-ins without a model
  std::array<cv::Mat, 3> uniform_half_;
  cv::Mat uniform_valid_;
  // The reference's samples (row, column, inverse model per channel), one array each for the
  // vector kernel, and their histogram bins per channel (scratch).
  std::vector<std::int32_t> ref_y_, ref_x_;
  std::array<std::vector<float>, 3> ref_inv_;
  mutable std::vector<std::uint16_t> ref_bins_;
  cv::Vec3f gain_{1, 1, 1};
  float frame_shadow_threshold_ = 0;
  mutable std::array<std::vector<int>, 3> hist_;
  mutable std::vector<int> hist4_; // global_reference: four interleaved histograms of a channel
  BlobFinder shadow_finder_, contact_finder_;       // one each: the one pass fills both images
  MaskSmoother shadow_smoother_, contact_smoother_; // likewise, row by row
};

// The segmenter users have: the rule a SegmenterCalibration selects.
using Segmenter = BasicSegmenter<CalibratedRule>;

SHADOWSENSE_NAMESPACE_END

// The calibration file (load_calibration, save_calibration) used to live in this header; keep
// including it for existing users. It needs only pixel_rule.hpp. The fit (calibration.hpp) uses
// the Segmenter, so it includes this header and not the other way round: include it directly.
#include <shadowsense/sense/calibration_file.hpp>
