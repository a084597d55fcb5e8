// How a pixel is classified shadow / contact: the PixelRule concept and its two models.
//
// A pixel rule turns one (optionally pre-blurred) BGR frame into two binary masks, shadow and
// contact, and may also report per-pixel darkness/warmth features. Segmenter (segmenter.hpp) owns
// everything around it (empty-skin model, per-frame reference, mask clean-up, blobs), so a new
// segmentation method is one new type, with no edit of the library:
//
//   template <class R> concept PixelRule = requires(const R& r, const PixelRuleInput& in,
//                                                   PixelRuleOutput& out) { r.classify(in, out); };
//
//   classify(in, out)
//     requires: in.bgr is CV_8UC3; in.skin is CV_8UC1 (255 on the skin) of the same size;
//               in.inverse_model holds four CV_32F planes of that size: 1 / (empty-skin model) for
//               B, G, R (all 1 without a model), each value one of IEEE binary16 (the segmenter
//               rounds the inverse model to half precision), and the skin weight (1 on the skin,
//               0 off it); in.inverse_model_half, when set, holds the same three B, G, R planes
//               as CV_16F (half the bytes: what RelativeRule reads every frame);
//               in.reference is the frame's reference colour (BGR, 8-bit units; only computed
//               when the rule's uses_reference() returns true, or when it has no such member).
//               out.shadow_mask and out.contact_mask are allocated CV_8UC1 of the frame's size.
//     ensures:  every pixel of both masks is 0 or 255; pixels off the skin (in.skin == 0) are 0;
//               a contact pixel is also a shadow pixel. A rule with features fills out.darkness
//               and out.warmth (CV_32F, frame size) and out.shadow_threshold (the darkness that
//               means shadow in this frame, used for the blobs' opacity); a rule without them
//               releases out.darkness (then blobs carry darkness 0 and the model does not adapt).
//   Optional member `bool uses_reference() const`: false skips the per-frame reference.
//   Optional row interface (RowPixelRule below): begin_rows + classify_row, so the segmenter can
//   classify, smooth and scan row by row in one pass over the frame. The library's three rules
//   have it; RelativeRule's per-pixel work is segment_kernels.hpp's relative_row (AVX2, NEON or
//   portable, picked at run time, the same floats and bytes from each).
//
// Models here:
//  * RelativeRule (the default): each pixel over the lit, empty skin's colour there, q = I /
//    (reference x model); darkness = 1 - mean(q) (0 off the skin), warmth = q_R - q_B. shadow:
//    darkness >= shadow_darkness; contact: darkness >= contact_darkness and warmth >=
//    contact_warmth, thresholds interpolated at the frame's reference luminance (by_light).
//  * FixedRangeRule (the paper's method): a pixel is in a class when its B, G, R values each lie
//    in that class's inclusive range. Cheap, breaks when the light changes.
//  * CalibratedRule: one of the two chosen by SegmenterCalibration::mode (what calibration files
//    store); the rule of Segmenter.
// Rules are immutable during classify (const), so one rule may be shared by threads; the scratch
// lives in the output.
//
// SegmenterCalibration holds the parameters of both rules, the reference percentile, the
// empty-skin model (empty_skin, may be empty) and the camera's scale (px_per_cm, 0 = not measured;
// read by the classifier's frame encoder, not by the segmenter) so that one calibration file
// carries everything a robot's camera needs. validate_calibration throws InvalidArgument naming
// the bad field.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sense/segment_kernels.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <concepts>
#include <cstdint>
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
  // The empty-skin model (CV_32FC3, per pixel and channel the empty skin's brightness over its
  // frame's reference, unsmoothed; see Segmenter::set_empty_skin and empty_skin_model()), or
  // empty. A Segmenter built with a calibration that holds one starts with it set.
  cv::Mat empty_skin{};
  // The camera's scale: px per cm of skin at the image centre, measured once by the user (a
  // ruler on the skin, ss_calibrate --px-per-cm), or 0 = not measured. The segmenter does not
  // read it; the classifier's frame encoder brings frames to the scale its network was trained
  // at (classify/frame_encoder.hpp, docs/input_encodings.md).
  float px_per_cm = 0;

  LightThresholds thresholds_at(float luminance) const {
    return thresholds_at(by_light, {luminance, shadow_darkness, contact_darkness, contact_warmth});
  }
  // The same interpolation over any table (`fixed`: the result when the table is empty; its
  // luminance is the one looked up). No copy, no allocation.
  static LightThresholds thresholds_at(const std::vector<LightThresholds>& by_light,
                                       LightThresholds fixed) {
    const float luminance = fixed.luminance;
    if (by_light.empty()) return fixed;
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
  // Equal when every field is equal and the empty-skin models hold the same values.
  bool operator==(const SegmenterCalibration& o) const {
    if (!(mode == o.mode && shadow_range == o.shadow_range && contact_range == o.contact_range &&
          shadow_darkness == o.shadow_darkness && contact_darkness == o.contact_darkness &&
          contact_warmth == o.contact_warmth && reference_percentile == o.reference_percentile &&
          by_light == o.by_light && px_per_cm == o.px_per_cm))
      return false;
    if (empty_skin.empty() || o.empty_skin.empty())
      return empty_skin.empty() && o.empty_skin.empty();
    return empty_skin.size() == o.empty_skin.size() && empty_skin.type() == o.empty_skin.type() &&
           cv::norm(empty_skin, o.empty_skin, cv::NORM_INF) == 0;
  }
};

namespace detail {

inline float luminance(const cv::Vec3f& bgr) {
  return (bgr[0] + bgr[1] + bgr[2]) / 3.f;
}

// Largest empty-skin model value accepted: models are relative to the frame's reference
// percentile, so real values stay near 1; a model built from 0..255 values is far above.
constexpr float kMaxEmptySkinValue = 8.f;

// Throws InvalidArgument unless `m` is a usable empty-skin model (see SegmenterCalibration).
inline void validate_empty_skin(const cv::Mat& m, const std::string& where) {
  require(!m.empty() && m.dims == 2 && m.type() == CV_32FC3,
          where + ": the empty-skin model must be a non-empty CV_32FC3 image, got " +
              (m.empty() ? std::string("an empty one") : cv::typeToString(m.type())));
  require(cv::checkRange(m, true, nullptr, 0.0, kMaxEmptySkinValue),
          where + ": the empty-skin model holds values outside [0, 8] or not finite; expected "
                  "brightness relative to the frame's reference (about 1 on the skin) - was an "
                  "image in 0..255 passed?");
  cv::Mat lum;
  cv::transform(m, lum, cv::Matx13f(1.f / 3, 1.f / 3, 1.f / 3));
  const int skin = cv::countNonZero(lum >= 0.5f);
  require(skin * 100 >= static_cast<int>(m.total()),
          where + ": the empty-skin model shows skin on " + std::to_string(skin) + " of " +
              std::to_string(m.total()) +
              " pixels; expected at least 1% (a black or all-dark frame is not an empty skin)");
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
  require(c.px_per_cm == 0.f ||
              (std::isfinite(c.px_per_cm) && c.px_per_cm >= 0.05f && c.px_per_cm <= 10000.f),
          where + ": px_per_cm must be 0 (not measured) or in [0.05, 10000]");
  for (std::size_t i = 0; i < c.by_light.size(); ++i) {
    const LightThresholds& t = c.by_light[i];
    const std::string row = where + ": by_light[" + std::to_string(i) + "]";
    require(std::isfinite(t.luminance) && t.luminance >= 0 && t.luminance <= 256,
            row + ".luminance must be in [0, 256]"); // references reach 256
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
  if (!c.empty_skin.empty()) validate_empty_skin(c.empty_skin, where);
}

} // namespace detail

// What a rule sees (see the concept above).
struct PixelRuleInput {
  const cv::Mat& bgr;                          // CV_8UC3 frame (pre-blurred when configured)
  const std::array<cv::Mat, 4>& inverse_model; // 1/model per channel (CV_32F) + skin weight
  const cv::Mat& skin;                         // CV_8UC1, 255 on the skin
  cv::Vec3f reference{1, 1, 1};                // the frame's reference colour (BGR, 8-bit units)
  // The B, G, R planes of inverse_model as CV_16F (the same values): the segmenter sets it.
  const std::array<cv::Mat, 3>* inverse_model_half = nullptr;
};

// What a rule writes (see the concept above).
struct PixelRuleOutput {
  cv::Mat& shadow_mask;       // CV_8UC1 0/255, allocated by the caller
  cv::Mat& contact_mask;      // CV_8UC1 0/255, allocated by the caller
  cv::Mat& darkness;          // CV_32F per-pixel darkness, or released
  cv::Mat& warmth;            // CV_32F per-pixel warmth, or released with darkness
  float shadow_threshold = 0; // darkness meaning shadow in this frame (0 without features)
};

template <class R>
concept PixelRule = requires(const R& r, const PixelRuleInput& in, PixelRuleOutput& out) {
  { r.classify(in, out) } -> std::same_as<void>;
};

// The optional row interface: a rule that also classifies one row at a time lets the segmenter
// smooth and scan each row while it is in cache (one pass over the frame, segmenter.hpp).
//   begin_rows(in, out) -> RowState: once per frame, before the rows; does what classify does to
//     out but the masks (features allocated or released, shadow_threshold set).
//   classify_row(in, state, out, y, shadow, contact): row y, as classify would write it, into
//     the rows `shadow` and `contact` (in.bgr.cols bytes each; the features into out's row y).
// classify(in, out) must equal begin_rows then classify_row for every row into out's masks.
template <class R>
concept RowPixelRule = PixelRule<R> &&
    requires(const R& r, const PixelRuleInput& in, PixelRuleOutput& out,
             const typename R::RowState& st, int y, uchar* row) {
  { r.begin_rows(in, out) } -> std::same_as<typename R::RowState>;
  { r.classify_row(in, st, out, y, row, row) } -> std::same_as<void>;
};

namespace detail {
template <class R>
bool rule_uses_reference(const R& r) {
  if constexpr (requires {
                  { r.uses_reference() } -> std::convertible_to<bool>;
                })
    return r.uses_reference();
  else
    return true;
}
} // namespace detail

// The paper's fixed per-channel colour ranges.
struct FixedRangeRule {
  ColourRange shadow_range{{0, 0, 0}, {120, 120, 120}};
  ColourRange contact_range{{0, 0, 40}, {90, 110, 160}};

  bool uses_reference() const { return false; }
  struct RowState {};
  RowState begin_rows(const PixelRuleInput&, PixelRuleOutput& out) const {
    out.darkness.release();
    out.warmth.release();
    out.shadow_threshold = 0;
    return {};
  }
  void classify_row(const PixelRuleInput& in, const RowState&, PixelRuleOutput&, int y, uchar* s,
                    uchar* c) const {
    const cv::Vec3b* px = in.bgr.ptr<cv::Vec3b>(y);
    const uchar* v = in.skin.ptr<uchar>(y);
    for (int x = 0; x < in.bgr.cols; ++x) {
      const bool skin = v[x] != 0;
      const bool contact = skin && contact_range.contains(px[x]);
      c[x] = contact ? 255 : 0;
      s[x] = (contact || (skin && shadow_range.contains(px[x]))) ? 255 : 0;
    }
  }
  void classify(const PixelRuleInput& in, PixelRuleOutput& out) const {
    const RowState st = begin_rows(in, out);
    for (int y = 0; y < in.bgr.rows; ++y)
      classify_row(in, st, out, y, out.shadow_mask.ptr<uchar>(y), out.contact_mask.ptr<uchar>(y));
  }
};

// Darkness and warmth relative to the empty skin under the frame's own light.
struct RelativeRule {
  float shadow_darkness = 0.2f;
  float contact_darkness = 0.45f;
  float contact_warmth = 0.08f;
  std::vector<LightThresholds> by_light{};

  LightThresholds thresholds_at(float luminance) const {
    return SegmenterCalibration::thresholds_at(
        by_light, {luminance, shadow_darkness, contact_darkness, contact_warmth});
  }

  // One frame's constants and kernels (the row interface, see RowPixelRule above).
  struct RowState {
    detail::RelativeRowParams params;
    const detail::SegmentKernels* kernels;
  };
  RowState begin_rows(const PixelRuleInput& in, PixelRuleOutput& out) const {
    const cv::Size size = in.bgr.size();
    detail::require(in.inverse_model_half != nullptr &&
                        std::all_of(in.inverse_model_half->begin(), in.inverse_model_half->end(),
                                    [size](const cv::Mat& m) {
                                      return m.type() == CV_16F && m.size() == size;
                                    }),
                    "RelativeRule: the input has no CV_16F inverse model of the frame's size "
                    "(PixelRuleInput::inverse_model_half; Segmenter sets it)");
    out.darkness.create(size, CV_32F);
    out.warmth.create(size, CV_32F);
    const cv::Vec3f gain = in.reference;
    const LightThresholds th =
        by_light.empty() ? LightThresholds{0, shadow_darkness, contact_darkness, contact_warmth}
                         : thresholds_at(detail::luminance(gain));
    out.shadow_threshold = th.shadow_darkness;
    return {{1.f / gain[0], 1.f / gain[1], 1.f / gain[2], th.shadow_darkness, th.contact_darkness,
             th.contact_warmth},
            &segment_kernels()};
  }
  void classify_row(const PixelRuleInput& in, const RowState& st, PixelRuleOutput& out, int y,
                    uchar* shadow, uchar* contact) const {
    const std::array<cv::Mat, 3>& planes = *in.inverse_model_half;
    st.kernels->relative_row(st.params, in.bgr.ptr<uchar>(y), planes[0].ptr<std::uint16_t>(y),
                             planes[1].ptr<std::uint16_t>(y), planes[2].ptr<std::uint16_t>(y),
                             in.skin.ptr<uchar>(y), in.bgr.cols, out.darkness.ptr<float>(y),
                             out.warmth.ptr<float>(y), shadow, contact);
  }
  void classify(const PixelRuleInput& in, PixelRuleOutput& out) const {
    const RowState st = begin_rows(in, out);
    for (int y = 0; y < in.bgr.rows; ++y)
      classify_row(in, st, out, y, out.shadow_mask.ptr<uchar>(y), out.contact_mask.ptr<uchar>(y));
  }
};

// The rule a SegmenterCalibration selects (mode): what calibration files describe.
class CalibratedRule {
public:
  CalibratedRule() : CalibratedRule(SegmenterCalibration{}) {}
  explicit CalibratedRule(const SegmenterCalibration& c)
      : mode_(c.mode), fixed_{c.shadow_range, c.contact_range}, relative_{c.shadow_darkness,
                                                                          c.contact_darkness,
                                                                          c.contact_warmth,
                                                                          c.by_light} {}
  bool uses_reference() const { return mode_ == SegmentMode::relative; }
  struct RowState {
    RelativeRule::RowState relative; // unused in fixed_ranges mode
  };
  RowState begin_rows(const PixelRuleInput& in, PixelRuleOutput& out) const {
    if (mode_ == SegmentMode::fixed_ranges) {
      fixed_.begin_rows(in, out);
      return {};
    }
    return {relative_.begin_rows(in, out)};
  }
  void classify_row(const PixelRuleInput& in, const RowState& st, PixelRuleOutput& out, int y,
                    uchar* shadow, uchar* contact) const {
    if (mode_ == SegmentMode::fixed_ranges)
      fixed_.classify_row(in, {}, out, y, shadow, contact);
    else
      relative_.classify_row(in, st.relative, out, y, shadow, contact);
  }
  void classify(const PixelRuleInput& in, PixelRuleOutput& out) const {
    if (mode_ == SegmentMode::fixed_ranges)
      fixed_.classify(in, out);
    else
      relative_.classify(in, out);
  }

private:
  SegmentMode mode_;
  FixedRangeRule fixed_;
  RelativeRule relative_;
};

static_assert(PixelRule<FixedRangeRule> && PixelRule<RelativeRule> && PixelRule<CalibratedRule>);
static_assert(RowPixelRule<FixedRangeRule> && RowPixelRule<RelativeRule> &&
              RowPixelRule<CalibratedRule>);

SHADOWSENSE_NAMESPACE_END
