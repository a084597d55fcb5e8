// calibrate_from_frames: a calibration fitted on a robot's own frames - empty-skin frames
// (required) and touch frames labelled by coarse boxes (what labelling tools give) or not
// labelled at all; returns the calibration with the empty-skin model, structured warnings and a
// report per light level. The rules, requires, ensures and throws are stated above the function;
// docs/calibration.md explains them. Frames labelled pixel by pixel: fit_calibration
// (sense/fit_calibration.hpp). sense/calibration.hpp includes both.
// Plain functions; no shared state (any thread).
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/core/image_check.hpp>
#include <shadowsense/sense/segmenter.hpp>
#include <shadowsense/sense/threshold_fit.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

// A touch frame for calibrate_from_frames. labelled = true: shadow_box is the box around the
// whole shadow (hand and arm on the skin) and contact_box the box around the part in contact
// (none: a hovering hand); both coarse. labelled = false: no labels; the frame is clustered.
// name: how warnings and errors call the frame (a file name, "clip.mp4#12"); empty: "touch
// frame <index>". load: when image is empty, gives the frame each time the fit needs it (about
// four times a labelled frame: sampling, the box search's coarse and fine passes, the contact
// samples; twice an unlabelled one): only one such frame is held at a time, e.g. read from its
// file. It must give the same frame every time; what it throws propagates.
struct BoxLabelledFrame {
  cv::Mat image;
  bool labelled = true;
  std::optional<cv::Rect> shadow_box{};
  std::optional<cv::Rect> contact_box{};
  std::string name{};
  std::function<cv::Mat()> load{};
};

namespace detail {
// "touch frame 3" or "touch frame 'u1/palm/0003.png'", for warnings and errors.
inline std::string touch_frame_name(const std::vector<BoxLabelledFrame>& frames, std::size_t i) {
  const std::string& n = frames[i].name;
  return "touch frame " + (n.empty() ? std::to_string(i) : "'" + n + "'");
}

// A touch frame's image: image, else load()'s (checked: 8-bit BGR of the empty frames' size).
inline cv::Mat touch_image(const std::vector<BoxLabelledFrame>& frames, std::size_t i,
                           const cv::Size& size, const std::string& fn) {
  const BoxLabelledFrame& f = frames[i];
  if (!f.image.empty() || !f.load) return f.image;
  cv::Mat m = f.load();
  const std::string n = fn + ": " + touch_frame_name(frames, i);
  require_colour_image(m, n.c_str());
  require(m.size() == size, n + " is " + std::to_string(m.cols) + "x" + std::to_string(m.rows) +
                                "; expected the empty frames' size");
  return m;
}
} // namespace detail

enum class CalibrationIssue {
  no_touch_frames,           // only empty frames: contact thresholds are the defaults
  too_few_pixels,            // a class had fewer than min_class_pixels pixels
  threshold_at_edge,         // a fitted threshold sits at the edge of the searched range
  shadow_near_noise,         // the shadow threshold is within 0.02 of the empty skin's noise
  light_group_without_touch, // a light level with empty frames but no touch frame
  touch_without_empty_light, // a touch frame far from every light level of the empty frames
  contact_not_separated,     // an unlabelled frame gave no warm, dark cluster
};

inline const char* to_string(CalibrationIssue i) {
  switch (i) {
  case CalibrationIssue::no_touch_frames:
    return "no_touch_frames";
  case CalibrationIssue::too_few_pixels:
    return "too_few_pixels";
  case CalibrationIssue::threshold_at_edge:
    return "threshold_at_edge";
  case CalibrationIssue::shadow_near_noise:
    return "shadow_near_noise";
  case CalibrationIssue::light_group_without_touch:
    return "light_group_without_touch";
  case CalibrationIssue::touch_without_empty_light:
    return "touch_without_empty_light";
  case CalibrationIssue::contact_not_separated:
    return "contact_not_separated";
  }
  return "?";
}

struct CalibrationWarning {
  CalibrationIssue issue;
  std::string message; // names the frame or light group and the numbers involved
};

// One light level found among the empty frames.
struct LightGroupReport {
  float luminance = 0;          // median reference luminance of its empty frames (8-bit units)
  int empty_frames = 0;         // empty frames in the group
  int touch_frames = 0;         // touch frames assigned to it (nearest luminance)
  float noise_darkness = 0;     // noise_quantile of the empty skin's smoothed darkness
  float core_darkness = 0;      // median over its touch frames of the shadow core's darkness
  double contact_pixels = 0;    // contact pixels the contact fit used
  LightThresholds thresholds{}; // what was fitted (or inherited, see warnings)
  bool fitted = false;          // thresholds fitted on this group's own touch frames
};

struct CalibrationResult {
  SegmenterCalibration calibration; // thresholds + empty-skin model: ready for save_calibration
  std::vector<CalibrationWarning> warnings;
  std::vector<LightGroupReport> groups;
};

struct CalibrationOptions {
  Segmenter::Config base{}; // pre_blur, reference_percentile, profile_smoothing are used
  // Empty frames whose reference luminance is more than this factor above the previous one
  // (sorted) start a new light group. Frames of one light level form one group.
  float light_group_ratio = 1.25f;
  int ring_margin_px = 4;        // the "surely outside" ring starts this far outside the shadow box
  int ring_width_px = 8;         // and is this wide
  float contact_inset = 0.2f;    // "surely contact": the contact box minus this fraction per side
  double min_class_pixels = 200; // fewer pixels in a class: too_few_pixels
  float noise_quantile = 0.999f; // of the empty skin's darkness
};

namespace detail {

inline float quantile(std::vector<float> v, float q) {
  if (v.empty()) return 0.f;
  const auto k = static_cast<std::size_t>(
      std::clamp(static_cast<double>(q) * static_cast<double>(v.size() - 1), 0.0,
                 static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

inline cv::Rect grow(const cv::Rect& r, int by, const cv::Size& size) {
  return cv::Rect(r.x - by, r.y - by, r.width + 2 * by, r.height + 2 * by) & cv::Rect({}, size);
}

// The shadow darkness threshold in [floor, 0.95] whose shadow boxes best match the labelled
// boxes of `frames` (indices into touch): mean IoU, -1 for a box where the label has none.
// Coarse steps of 0.02, then 0.005 around the best; ties go to the higher threshold.
inline float best_box_threshold(const cv::Mat& model, const SegmenterConfig& base,
                                const std::vector<BoxLabelledFrame>& touch,
                                const std::vector<std::size_t>& frames, float floor) {
  struct Probe {
    const RelativeRule* rule;
    void classify(const PixelRuleInput& in, PixelRuleOutput& out) const { rule->classify(in, out); }
  };
  RelativeRule rule;
  rule.contact_darkness = 1.f; // shadow only
  rule.contact_warmth = 1.f;
  SegmenterConfig cfg = base;
  cfg.calibration.mode = SegmentMode::relative;
  cfg.calibration.by_light.clear();
  cfg.calibration.empty_skin.release();
  cfg.adaptive = false;
  BasicSegmenter<Probe> seg(cfg, Probe{&rule});
  seg.set_empty_skin_profile(model);
  Segmentation s;
  // Each frame is taken once per pass (BoxLabelledFrame::load) and scored at every threshold;
  // each threshold's sum still adds the frames in their order.
  auto scores = [&](const std::vector<float>& ts) {
    std::vector<double> sum(ts.size(), 0.0);
    for (std::size_t i : frames) {
      const cv::Mat image = touch_image(touch, i, model.size(), "calibrate_from_frames");
      const auto& label = touch[i].shadow_box;
      for (std::size_t k = 0; k < ts.size(); ++k) {
        rule.shadow_darkness = ts[k];
        seg.segment(image, s);
        if (!label)
          sum[k] -= s.shadow_box ? 1 : 0;
        else if (s.shadow_box) {
          const double inter = (*s.shadow_box & *label).area();
          sum[k] += inter / (s.shadow_box->area() + label->area() - inter);
        }
      }
    }
    return sum;
  };
  auto search = [&](float lo, float hi, float step, float& best_t) {
    std::vector<float> ts;
    for (float t = lo; t <= hi + 1e-6f; t += step) ts.push_back(t);
    const std::vector<double> v = scores(ts);
    double best = -1e18;
    for (std::size_t k = 0; k < ts.size(); ++k)
      if (v[k] >= best) best = v[k], best_t = ts[k];
  };
  float coarse = floor;
  search(floor, 0.95f, 0.02f, coarse);
  float fine = coarse;
  search(std::max(floor, coarse - 0.02f), std::min(0.95f, coarse + 0.02f), 0.005f, fine);
  return fine;
}

// The requirements on calibrate_from_frames's arguments and options (InvalidArgument naming the
// frame or option); the empty frames' own checks are Segmenter::set_empty_skin's.
inline void check_calibration_input(const std::vector<cv::Mat>& empty_frames,
                                    const std::vector<BoxLabelledFrame>& touch_frames,
                                    const CalibrationOptions& options, const std::string& fn) {
  require(!empty_frames.empty(),
          fn + ": no empty-skin frames; expected at least one frame of the empty skin");
  require(options.light_group_ratio > 1.f && std::isfinite(options.light_group_ratio),
          fn + ": light_group_ratio must be > 1");
  require(options.ring_margin_px >= 0 && options.ring_width_px >= 1,
          fn + ": ring_margin_px must be >= 0 and ring_width_px >= 1");
  require(options.contact_inset >= 0.f && options.contact_inset < 0.5f,
          fn + ": contact_inset must be in [0, 0.5)");
  require(options.noise_quantile > 0.5f && options.noise_quantile < 1.f,
          fn + ": noise_quantile must be in (0.5, 1)");
  const cv::Size size = empty_frames[0].size();
  for (std::size_t i = 0; i < touch_frames.size(); ++i) {
    const BoxLabelledFrame& f = touch_frames[i];
    const std::string n = fn + ": " + touch_frame_name(touch_frames, i);
    if (f.image.empty() && f.load) {
      // checked when loaded (touch_image)
    } else {
      require_colour_image(f.image, n.c_str());
      require(f.image.size() == size, n + " is " + std::to_string(f.image.cols) + "x" +
                                          std::to_string(f.image.rows) +
                                          "; expected the empty frames' size");
    }
    const cv::Rect img({}, size);
    for (const auto* b : {&f.shadow_box, &f.contact_box})
      if (*b)
        require(!(*b)->empty() && ((**b) & img) == **b,
                n + ": a label box is empty or reaches outside the image");
    require(!f.contact_box || f.shadow_box,
            n + ": a contact box needs a shadow box (a contact is part of the shadow)");
  }
}

// One run of calibrate_from_frames (the rules are listed above it). run() takes the steps in
// order: light groups from the empty frames, the empty skin's noise per group, the samples of
// each touch frame, the shadow threshold per group, the "surely contact" samples (which need
// it), the thresholds over all groups (the fallback), each group's report and thresholds, and
// the calibration. Warnings are added in that order. Used once, by one thread.
class FrameCalibration {
public:
  FrameCalibration(const std::vector<cv::Mat>& empty_frames,
                   const std::vector<BoxLabelledFrame>& touch_frames,
                   const CalibrationOptions& options)
      : empty_(empty_frames), touch_(touch_frames), options_(options),
        size_(empty_frames[0].size()), seg_(relative_config(options.base)) {
    seg_.set_empty_skin(empty_frames); // validates the frames; refuses black ones
    skin_ = seg_.skin_area();          // shared, not copied: seg_'s model is set only here
  }

  CalibrationResult run() {
    find_light_groups();
    measure_empty_skin_noise();
    for (std::size_t i = 0; i < touch_.size(); ++i) sample_touch_frame(i);
    fit_shadow_thresholds();
    add_surely_contact_samples();
    const LightThresholds overall = fit_over_all_groups();
    report_light_groups(overall);
    result_.calibration = assemble_calibration(overall);
    return std::move(result_);
  }

private:
  static constexpr const char* fn = "calibrate_from_frames";

  // Per light group: empty-skin darkness (negatives), core darkness per frame, contact samples.
  struct Group {
    ThresholdFit fit;               // shadow negatives (noise) and contact positives / negatives
    std::vector<float> cores;       // frames with a contact: full opacity is on the skin
    std::vector<float> hover_cores; // frames without: used only when there is no other
    std::vector<std::size_t> box_frames; // labelled touch frames (indices), for the box search
  };
  // A labelled frame's regions: the ring (outer minus inner) is "surely outside", the inset
  // contact box (core_box) "surely contact", the shadow box away from the contact box the core.
  struct Regions {
    cv::Rect sb, outer, inner, away, core_box;
  };

  // Features with the relative mode on the calibration's own empty-skin model, no mask blur.
  static SegmenterConfig relative_config(SegmenterConfig cfg) {
    cfg.calibration.mode = SegmentMode::relative;
    cfg.calibration.by_light.clear();
    cfg.calibration.empty_skin.release();
    cfg.adaptive = false;
    cfg.mask_blur = 0;
    return cfg;
  }

  void warn(CalibrationIssue i, const std::string& m) { result_.warnings.push_back({i, m}); }

  // Light groups: the empty frames' reference luminances, sorted, split where one is more than
  // light_group_ratio above the previous.
  void find_light_groups() {
    for (const cv::Mat& e : empty_) {
      seg_.segment(e, scratch_);
      empty_lum_.push_back(luminance(seg_.last_reference()));
    }
    std::vector<float> sorted = empty_lum_;
    std::sort(sorted.begin(), sorted.end());
    std::vector<std::vector<float>> members(1);
    for (std::size_t i = 0; i < sorted.size(); ++i) {
      if (i > 0 && sorted[i] > sorted[i - 1] * options_.light_group_ratio) members.emplace_back();
      members.back().push_back(sorted[i]);
    }
    ng_ = members.size();
    result_.groups.resize(ng_);
    for (std::size_t g = 0; g < ng_; ++g) {
      result_.groups[g].luminance = members[g][members[g].size() / 2];
      result_.groups[g].empty_frames = static_cast<int>(members[g].size());
    }
  }

  // The group of nearest luminance (log scale).
  std::size_t group_of(float l) const {
    std::size_t best = 0;
    for (std::size_t g = 1; g < ng_; ++g)
      if (std::abs(std::log(l / result_.groups[g].luminance)) <
          std::abs(std::log(l / result_.groups[best].luminance)))
        best = g;
    return best;
  }

  void add_contact(Group& g, float d, float w, bool positive) {
    g.fit.add_contact(d, w, positive);
    all_.add_contact(d, w, positive);
  }

  // The last segmented frame's darkness smoothed like the masks are (Config::mask_blur): noise
  // is measured on it, since the mask clean-up removes isolated noisy pixels.
  const cv::Mat& smoothed_darkness() {
    const int blur = options_.base.mask_blur;
    if (blur > 1)
      cv::GaussianBlur(seg_.darkness(), smoothed_, cv::Size(blur, blur), 0, 0,
                       cv::BORDER_REPLICATE);
    else
      smoothed_ = seg_.darkness();
    return smoothed_;
  }

  // The last segmented frame as empty skin: every skin pixel a shadow and contact negative.
  void add_empty(Group& g) {
    const cv::Mat& d = seg_.darkness();
    const cv::Mat& smoothed = smoothed_darkness();
    for (int y = 0; y < d.rows; ++y) {
      const float* dp = d.ptr<float>(y);
      const float* sp = smoothed.ptr<float>(y);
      const float* wp = seg_.warmth().ptr<float>(y);
      const uchar* sk = skin_.ptr<uchar>(y);
      for (int x = 0; x < d.cols; ++x)
        if (sk[x]) {
          g.fit.add_shadow(sp[x], false);
          add_contact(g, dp[x], wp[x], false);
        }
    }
  }

  // Noise per group: noise_quantile of its empty frames' smoothed darkness.
  void measure_empty_skin_noise() {
    groups_.resize(ng_);
    for (std::size_t i = 0; i < empty_.size(); ++i) {
      seg_.segment(empty_[i], scratch_);
      add_empty(groups_[group_of(empty_lum_[i])]);
    }
    noise_.resize(ng_);
    for (std::size_t g = 0; g < ng_; ++g)
      noise_[g] = groups_[g].fit.negative_quantile(options_.noise_quantile);
  }

  // A touch frame joins the group of nearest luminance and gives it samples: clustered when
  // unlabelled, from its boxes when labelled.
  void sample_touch_frame(std::size_t i) {
    const BoxLabelledFrame& f = touch_[i];
    seg_.segment(touch_image(touch_, i, size_, fn), scratch_);
    const float lum = luminance(seg_.last_reference());
    const std::size_t g = group_of(lum);
    ++result_.groups[g].touch_frames;
    if (std::abs(std::log(lum / result_.groups[g].luminance)) >
        std::log(options_.light_group_ratio))
      warn(CalibrationIssue::touch_without_empty_light,
           touch_frame_name(touch_, i) + " has reference luminance " + std::to_string(lum) +
               " but the nearest light level of the empty frames is " +
               std::to_string(result_.groups[g].luminance) +
               "; record empty frames at this light too");
    smoothed_darkness();
    if (!f.labelled)
      sample_unlabelled_frame(i, g);
    else
      sample_labelled_frame(i, g);
  }

  // Pixels whose smoothed darkness exceeds noise + 0.05 are shadow; 2-means on their (darkness,
  // warmth), split first at the median darkness; the warmer cluster is contact when it is also
  // darker and warmer by at least 0.05, else the frame is a hover.
  void sample_unlabelled_frame(std::size_t i, std::size_t g) {
    const cv::Mat& d = seg_.darkness();
    const cv::Mat& w = seg_.warmth();
    Group& grp = groups_[g];
    std::vector<cv::Vec2f> cand;
    std::vector<float> sm; // smoothed darkness, on the noise's footing
    for (int y = 0; y < d.rows; ++y)
      for (int x = 0; x < d.cols; ++x)
        if (skin_.at<uchar>(y, x) && smoothed_.at<float>(y, x) >= noise_[g] + 0.05f) {
          cand.push_back({d.at<float>(y, x), w.at<float>(y, x)});
          sm.push_back(smoothed_.at<float>(y, x));
        }
    if (static_cast<double>(cand.size()) < options_.min_class_pixels) {
      warn(CalibrationIssue::too_few_pixels,
           "unlabelled " + touch_frame_name(touch_, i) + ": " + std::to_string(cand.size()) +
               " shadow pixels; expected at least " +
               std::to_string(static_cast<long long>(options_.min_class_pixels)) +
               " (frame skipped)");
      return;
    }
    const float median = quantile(sm, 0.5f);
    cv::Mat pts(static_cast<int>(cand.size()), 2, CV_32F, cand.data());
    cv::Mat labels(static_cast<int>(cand.size()), 1, CV_32S);
    for (int k = 0; k < labels.rows; ++k)
      labels.at<int>(k) = sm[static_cast<std::size_t>(k)] > median;
    cv::Mat centres;
    cv::kmeans(pts, 2, labels,
               cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 50, 1e-5), 1,
               cv::KMEANS_USE_INITIAL_LABELS, centres);
    const int warm = centres.at<float>(1, 1) > centres.at<float>(0, 1) ? 1 : 0;
    const bool separated = centres.at<float>(warm, 1) - centres.at<float>(1 - warm, 1) >= 0.05f &&
                           centres.at<float>(warm, 0) - centres.at<float>(1 - warm, 0) >= 0.05f;
    if (!separated)
      warn(CalibrationIssue::contact_not_separated,
           "unlabelled " + touch_frame_name(touch_, i) +
               ": no darker, warmer cluster among its shadow pixels; taken as a hover");
    for (int k = 0; k < labels.rows; ++k) {
      const cv::Vec2f& v = cand[static_cast<std::size_t>(k)];
      add_contact(grp, v[0], v[1], separated && labels.at<int>(k) == warm);
    }
    // Core darkness: over all its shadow pixels (contact included), a conservative choice that
    // keeps the empty skin clear; see docs/calibration.md for the measured cost on hovers.
    grp.hover_cores.push_back(quantile(sm, 0.95f));
  }

  // The ring outside the shadow box is "surely outside" (not contact); the shadow box away from
  // the contact box is the shadow core (its 99th-percentile smoothed darkness is the frame's
  // core darkness); the inset contact box is kept until the shadow threshold is known. A frame
  // labelled with no shadow is an empty frame at its light.
  void sample_labelled_frame(std::size_t i, std::size_t g) {
    const BoxLabelledFrame& f = touch_[i];
    Group& grp = groups_[g];
    grp.box_frames.push_back(i);
    if (!f.shadow_box) {
      add_empty(grp);
      return;
    }
    const cv::Mat& d = seg_.darkness();
    const cv::Mat& w = seg_.warmth();
    const Regions r = regions_of(f);
    std::vector<float> core;
    for (int y = r.outer.y; y < r.outer.y + r.outer.height; ++y)
      for (int x = r.outer.x; x < r.outer.x + r.outer.width; ++x) {
        if (!skin_.at<uchar>(y, x)) continue;
        const cv::Point pt(x, y);
        if (!r.inner.contains(pt)) // the ring: not contact (may hold penumbra)
          add_contact(grp, d.at<float>(y, x), w.at<float>(y, x), false);
        else if (r.sb.contains(pt) && !r.core_box.contains(pt) && !r.away.contains(pt))
          core.push_back(smoothed_.at<float>(y, x)); // on the noise's footing
      }
    if (!core.empty())
      (f.contact_box ? grp.cores : grp.hover_cores).push_back(quantile(core, 0.99f));
    shadow_frames_.push_back({i, g});
  }

  Regions regions_of(const BoxLabelledFrame& f) const {
    Regions r;
    r.sb = *f.shadow_box;
    r.outer = grow(r.sb, options_.ring_margin_px + options_.ring_width_px, size_);
    r.inner = grow(r.sb, options_.ring_margin_px, size_);
    if (f.contact_box) {
      const cv::Rect& cb = *f.contact_box;
      r.away = grow(cb, options_.ring_margin_px, size_);
      const int dx = static_cast<int>(std::floor(cb.width * options_.contact_inset));
      const int dy = static_cast<int>(std::floor(cb.height * options_.contact_inset));
      r.core_box = cv::Rect(cb.x + dx, cb.y + dy, cb.width - 2 * dx, cb.height - 2 * dy);
    }
    return r;
  }

  // Shadow threshold per group: from the labelled boxes (best_box_threshold, searched from
  // noise + 0.02 up), else half the median core darkness; a core within 0.04 of the noise
  // leaves the group without one. Throws when no group has one (hopeless input).
  void fit_shadow_thresholds() {
    shadow_t_.resize(ng_);
    bool any_shadow = false;
    // The box search segments with a segmenter of its own: seg_'s planes (model, profile and
    // per-frame features, about 60 bytes a pixel) are let go meanwhile and derived again from
    // the same model after (deterministic: the same planes).
    bool box_search = false;
    for (const Group& grp : groups_) box_search = box_search || !grp.box_frames.empty();
    const cv::Mat model = seg_.empty_skin_model();
    if (box_search) seg_ = Segmenter(relative_config(options_.base));
    for (std::size_t g = 0; g < ng_; ++g) {
      LightGroupReport& r = result_.groups[g];
      r.noise_darkness = noise_[g];
      const std::vector<float>& cores =
          groups_[g].cores.empty() ? groups_[g].hover_cores : groups_[g].cores;
      if (cores.empty()) continue;
      r.core_darkness = quantile(cores, 0.5f);
      if (r.core_darkness <= noise_[g] + 0.04f) {
        warn(CalibrationIssue::shadow_near_noise,
             "light group at luminance " + std::to_string(r.luminance) + ": shadow core darkness " +
                 std::to_string(r.core_darkness) + " is not above the empty skin's noise " +
                 std::to_string(noise_[g]) + "; its touch frames are ignored");
        continue;
      }
      // Labelled frames: the threshold whose shadow boxes best match the labels (mean IoU; a
      // box where the label has none counts -1), searched from noise + 0.02 up. Otherwise half
      // the core darkness (a shadow's edge is where its opacity is half the core's).
      const float floor = std::min(noise_[g] + 0.02f, 0.95f);
      float t = 0.5f * r.core_darkness;
      if (!groups_[g].box_frames.empty()) {
        t = best_box_threshold(model, options_.base, touch_, groups_[g].box_frames, floor);
      } else if (t < floor) {
        warn(CalibrationIssue::shadow_near_noise,
             "light group at luminance " + std::to_string(r.luminance) +
                 ": half the shadow core darkness (" + std::to_string(t) +
                 ") is within 0.02 of the empty skin's noise (" + std::to_string(noise_[g]) +
                 "); raised to noise + 0.02 - faint shadow edges will be missed");
        t = floor;
      }
      if (t <= floor + 1e-6f && !groups_[g].box_frames.empty())
        warn(CalibrationIssue::threshold_at_edge,
             "light group at luminance " + std::to_string(r.luminance) +
                 ": the best shadow threshold is the lowest allowed (" + std::to_string(floor) +
                 ", just above the empty skin's noise): shadows and empty skin overlap");
      shadow_t_[g] = std::min(t, 1.f);
      any_shadow = true;
    }
    if (box_search) seg_.set_empty_skin_profile(model);
    if (!touch_.empty())
      require(any_shadow, std::string(fn) +
                              ": no touch frame shows a shadow darker than the empty "
                              "skin's noise; check the labels, the light and that the "
                              "touch frames show a hand on the skin");
  }

  // "Surely contact": the inset contact box's pixels at least as dark as the group's shadow
  // threshold; the shadow core's pixels are contact negatives.
  // The frames are segmented again rather than their pixels kept from sample_labelled_frame:
  // memory stays one frame's planes whatever the number of labelled frames (the counts, and so
  // the fit, are the same: the segmentation is deterministic and the histograms sum counts).
  void add_surely_contact_samples() {
    for (const auto& [i, g] : shadow_frames_) {
      if (!shadow_t_[g]) continue;
      Group& grp = groups_[g];
      const float t = *shadow_t_[g];
      seg_.segment(touch_image(touch_, i, size_, fn), scratch_);
      const cv::Mat& d = seg_.darkness();
      const cv::Mat& w = seg_.warmth();
      const Regions r = regions_of(touch_[i]);
      for (int y = r.sb.y; y < r.sb.y + r.sb.height; ++y)
        for (int x = r.sb.x; x < r.sb.x + r.sb.width; ++x) {
          if (!skin_.at<uchar>(y, x)) continue;
          const cv::Point pt(x, y);
          const float dv = d.at<float>(y, x), wv = w.at<float>(y, x);
          if (r.core_box.contains(pt)) {
            if (dv >= t) add_contact(grp, dv, wv, true);
          } else if (!r.away.contains(pt)) {
            add_contact(grp, dv, wv, false);
          }
        }
    }
  }

  // The thresholds a group without its own falls back to: contact from the fit over all groups
  // (else the defaults; with no touch frame the shadow threshold comes from the noise), shadow
  // the median of the groups' shadow thresholds.
  LightThresholds fit_over_all_groups() {
    LightThresholds overall{0, options_.base.calibration.shadow_darkness,
                            options_.base.calibration.contact_darkness,
                            options_.base.calibration.contact_warmth};
    if (touch_.empty()) {
      warn(CalibrationIssue::no_touch_frames,
           "no touch frames: the shadow threshold is set from the noise and the contact "
           "thresholds are the defaults; add a few labelled touch frames");
      float worst = 0;
      for (float n : noise_) worst = std::max(worst, n);
      overall.shadow_darkness =
          std::clamp(std::max(overall.shadow_darkness, worst + 0.05f), 0.f, 1.f);
    } else if (all_.contact_positives() >= options_.min_class_pixels) {
      float lowest = 1.f;
      for (const auto& t : shadow_t_)
        if (t) lowest = std::min(lowest, *t);
      const LightThresholds t = all_.fit(0, lowest);
      overall_bins_ = {all_.last_darkness_bin(), all_.last_warmth_bin()};
      overall.contact_darkness = t.contact_darkness;
      overall.contact_warmth = t.contact_warmth;
    } else {
      warn(CalibrationIssue::too_few_pixels,
           "only " + std::to_string(static_cast<long long>(all_.contact_positives())) +
               " surely-contact pixels in all touch frames; expected at least " +
               std::to_string(static_cast<long long>(options_.min_class_pixels)) +
               ": the contact thresholds are the defaults");
    }
    std::vector<float> ts;
    for (const auto& t : shadow_t_)
      if (t) ts.push_back(*t);
    if (!ts.empty()) overall.shadow_darkness = quantile(ts, 0.5f);
    return overall;
  }

  // A fitted contact threshold at the edge of the searched range: the contact pixels are not
  // separated from the rest.
  void warn_if_contact_threshold_at_edge(const ThresholdFit& f, const std::string& where) {
    const int lo_d = ThresholdFit::bin_of(0.f), nb = ThresholdFit::nb;
    if (f.last_darkness_bin() <= lo_d || f.last_darkness_bin() >= nb || f.last_warmth_bin() <= 0 ||
        f.last_warmth_bin() >= nb)
      warn(CalibrationIssue::threshold_at_edge,
           where + ": a contact threshold sits at the edge of the searched range (darkness bin " +
               std::to_string(f.last_darkness_bin()) + ", warmth bin " +
               std::to_string(f.last_warmth_bin()) + " of " + std::to_string(nb) +
               "): the contact pixels are not separated from the rest");
  }
  // The same for the fit over all groups, reported only when some group uses it.
  void warn_if_overall_contact_threshold_at_edge() {
    if (!overall_bins_) return;
    const auto [bi, bj] = *overall_bins_;
    const int nb = ThresholdFit::nb;
    if (bi >= nb || bj <= 0 || bj >= nb)
      warn(CalibrationIssue::threshold_at_edge,
           "all light groups: a contact threshold sits at the edge of the searched range "
           "(darkness bin " +
               std::to_string(bi) + ", warmth bin " + std::to_string(bj) + " of " +
               std::to_string(nb) + "): the contact pixels are not separated");
  }

  // Each group's report: its own thresholds where it had a shadow threshold (contact fitted on
  // its samples when it has enough, else those of all groups), the fallback otherwise.
  void report_light_groups(const LightThresholds& overall) {
    bool overall_used = false;
    for (std::size_t g = 0; g < ng_; ++g) {
      LightGroupReport& r = result_.groups[g];
      const std::string where = "light group at luminance " + std::to_string(r.luminance);
      r.thresholds = overall;
      r.thresholds.luminance = r.luminance;
      r.contact_pixels = groups_[g].fit.contact_positives();
      if (!shadow_t_[g]) {
        if (!touch_.empty() && r.touch_frames == 0)
          warn(CalibrationIssue::light_group_without_touch,
               where + ": " + std::to_string(r.empty_frames) +
                   " empty frames but no touch frame; its thresholds are the other groups'");
        continue;
      }
      r.thresholds.shadow_darkness = *shadow_t_[g];
      if (groups_[g].fit.contact_positives() >= options_.min_class_pixels) {
        const LightThresholds t = groups_[g].fit.fit(r.luminance, *shadow_t_[g]);
        warn_if_contact_threshold_at_edge(groups_[g].fit, where);
        r.thresholds.contact_darkness = t.contact_darkness;
        r.thresholds.contact_warmth = t.contact_warmth;
      } else {
        overall_used = true;
      }
      if (groups_[g].fit.contact_positives() < options_.min_class_pixels && ng_ > 1) {
        warn(CalibrationIssue::too_few_pixels,
             where + ": " +
                 std::to_string(static_cast<long long>(groups_[g].fit.contact_positives())) +
                 " surely-contact pixels; its contact thresholds are those of all groups");
      }
      r.fitted = true;
    }
    if (overall_used) warn_if_overall_contact_threshold_at_edge();
  }

  // One light level: its thresholds are the scalars. Several: the scalars are the fallback and
  // the fitted groups the per-light rows (one fitted row only: the scalars say it).
  SegmenterCalibration assemble_calibration(const LightThresholds& overall) const {
    SegmenterCalibration cal = options_.base.calibration;
    cal.mode = SegmentMode::relative;
    cal.by_light.clear();
    cal.empty_skin = seg_.empty_skin_model(); // shared: seg_ ends with this run, unchanged
    if (ng_ == 1) {
      cal.shadow_darkness = result_.groups[0].thresholds.shadow_darkness;
      cal.contact_darkness = result_.groups[0].thresholds.contact_darkness;
      cal.contact_warmth = result_.groups[0].thresholds.contact_warmth;
    } else {
      cal.shadow_darkness = overall.shadow_darkness;
      cal.contact_darkness = overall.contact_darkness;
      cal.contact_warmth = overall.contact_warmth;
      for (const LightGroupReport& r : result_.groups)
        if (r.fitted) cal.by_light.push_back(r.thresholds);
      if (cal.by_light.size() < 2) cal.by_light.clear(); // one row: the scalars say the same
      if (cal.by_light.empty() && !result_.groups.empty())
        for (const LightGroupReport& r : result_.groups)
          if (r.fitted) {
            cal.shadow_darkness = r.thresholds.shadow_darkness;
            cal.contact_darkness = r.thresholds.contact_darkness;
            cal.contact_warmth = r.thresholds.contact_warmth;
          }
    }
    validate_calibration(cal, fn);
    return cal;
  }

  const std::vector<cv::Mat>& empty_;
  const std::vector<BoxLabelledFrame>& touch_;
  const CalibrationOptions& options_;
  const cv::Size size_; // every frame's
  Segmenter seg_;
  cv::Mat skin_; // the empty-skin model's skin area
  Segmentation scratch_;
  cv::Mat smoothed_; // smoothed_darkness()
  CalibrationResult result_;
  std::vector<float> empty_lum_; // each empty frame's reference luminance
  std::size_t ng_ = 0;           // light groups
  std::vector<Group> groups_;
  ThresholdFit all_; // contact samples of every group
  std::vector<float> noise_;
  std::vector<std::pair<std::size_t, std::size_t>> shadow_frames_; // labelled with a shadow box:
                                                                   // (touch index, group)
  std::vector<std::optional<float>> shadow_t_;
  std::optional<std::pair<int, int>> overall_bins_; // the fit over all groups' contact bins
};

} // namespace detail

// Fits a calibration (relative mode, thresholds per light level when the empty frames show
// several, and the empty-skin model) from a robot's own frames.
//
// Rules (docs/calibration.md):
//  * Empty-skin model: Segmenter::set_empty_skin over all empty frames (each over its own
//    reference, so light levels mix). Light groups: the empty frames' reference luminances,
//    sorted, split where one is more than light_group_ratio above the previous. Each touch frame
//    joins the group of nearest luminance (log scale).
//  * Noise per group: noise_quantile of the empty frames' darkness, smoothed like the masks
//    (Config::mask_blur).
//  * Labelled frame, "surely outside": a ring ring_margin_px..ring_margin_px + ring_width_px
//    outside the shadow box; "shadow core": the pixels in the shadow box away from the contact
//    box, whose 99th-percentile smoothed darkness is the frame's core darkness; "surely contact":
//    the contact box minus contact_inset per side, pixels at least as dark as the shadow
//    threshold.
//  * Shadow threshold per group: the one in [noise + 0.02, 0.95] whose shadow boxes best match
//    the group's labelled shadow boxes (best_box_threshold); a group with unlabelled frames only:
//    half the median core darkness (a shadow's edge is where its opacity is half the core's), at
//    least noise + 0.02. Core darkness within 0.04 of the noise: the group is ignored.
//  * Contact thresholds per group: (darkness from the shadow threshold up, warmth) minimising
//    misclassified pixels between "surely contact" and the shadow core, rings and empty frames.
//  * Unlabelled frame: pixels whose smoothed darkness exceeds noise + 0.05 are shadow; its core
//  darkness as above;
//    2-means on (darkness, warmth) of those pixels (initial split at the median darkness); the
//    cluster with the higher mean warmth is contact when it is also darker and warmer by at least
//    0.05 than the other, else the frame is a hover (contact_not_separated).
// requires: at least one empty frame; all frames CV_8UC3 of one size (a touch frame given by
//           BoxLabelledFrame::load: checked when loaded); boxes inside the image.
// ensures:  result.calibration passes validate_calibration; warnings list every degenerate part
//           (see CalibrationIssue); result.groups reports each light level. Memory beyond the
//           frames: planes of about 63 bytes a pixel, 74 with labelled touch frames (measured at
//           4K), whatever the number of frames; touch frames given by load are held one at a
//           time (docs/calibration.md "Memory").
// throws:   InvalidArgument for bad input (naming the frame), black empty frames, or when no
//           touch frame shows a shadow darker than the empty skin's noise (hopeless).
inline CalibrationResult calibrate_from_frames(const std::vector<cv::Mat>& empty_frames,
                                               const std::vector<BoxLabelledFrame>& touch_frames,
                                               const CalibrationOptions& options = {}) {
  detail::check_calibration_input(empty_frames, touch_frames, options, "calibrate_from_frames");
  return detail::FrameCalibration(empty_frames, touch_frames, options).run();
}

SHADOWSENSE_NAMESPACE_END
