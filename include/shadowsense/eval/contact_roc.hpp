// Contact vs hover ROC (docs/tracking_eval.md "Contact vs hover ROC"): a frame-level ROC of
// "contact reported" (positives: frames with a true contact; negatives: hovering hands) over a
// sweep of one offset added to the contact thresholds of a calibrated relative-mode segmenter,
// for four detectors (ContactCue): darkness only, warmth only, darkness AND warmth (the shipped
// rule), and the joint rule keeping only contact blobs with a sharp edge (Blob::edge_width of
// the contact blob, the width of the darkness ramp on its contour, at most a gate in px).
//
// ContactSweepRule: a PixelRule; RelativeRule's darkness and warmth, then contact decided by
//   `cue` with the thresholds moved by `offset` (darkness: d >= tc + offset; warmth: shadow and
//   w >= tw + offset; joint / joint_sharp: d >= tc + offset and w >= tw + offset); shadow =
//   d >= ts or contact. With cue joint and offset 0 its masks equal RelativeRule's exactly.
//   Immutable during classify; ContactRoc moves its segmenters' rules along the sweep through
//   BasicSegmenter::rule().
// ContactRoc(shipped, offsets)
//   requires: shipped is a relative-mode Segmenter with an empty-skin model; offsets non-empty,
//             finite, in [-1, 1], strictly increasing, one of them 0 (the shipped thresholds).
//   ensures:  one segmenter per pixel cue (darkness, warmth, joint), each with shipped's
//             configuration (its empty-skin model included); add() moves it along the offsets.
//   throws:   InvalidArgument otherwise.
// add(bgr, true_contact, positive): segments the frame at every cue and offset and keeps its
//   contact blobs. requires: what Segmenter::segment requires. Frames of neither class (e.g.
//   empty skin) should not be added.
// curve(cue, edge_gate_px = 0)
//   requires: cue joint_sharp needs edge_gate_px > 0; the others need edge_gate_px == 0; at
//             least one positive and one negative frame added.
//   ensures:  one RocPoint per offset in order: contact reported when a kept blob remains
//             (joint_sharp keeps blobs with edge_width <= edge_gate_px); tpr = true positives /
//             positives, fpr = false positives / negatives, contact_iou = mean box IoU of the
//             union of the kept blobs against the true contact box over the true positives (0
//             when none); `shipped` is the index of offset 0; auc = roc_auc(points).
//   throws:   InvalidArgument.
// roc_auc(points): area under the polyline through (0, 0), the points sorted by (fpr, tpr), and
//   (1, 1) (trapezoids). requires fpr, tpr in [0, 1] (InvalidArgument otherwise).
// roc_from_scores(pos, neg): one point per distinct score s (decision: score >= s), largest s
//   first; roc_auc of it equals the Mann-Whitney probability P(pos > neg) + P(pos == neg) / 2.
//   requires: both lists non-empty and finite.
// tpr_at_fpr(curve, max_fpr): the largest tpr of a point with fpr <= max_fpr (0 when none).
// pick_contact_edge_gate(roc, gates): the gate (px) whose joint_sharp curve has the largest AUC;
//   ties go to the smallest gate (the tightest use of the cue at that AUC). requires gates
//   non-empty, all finite and > 0 (InvalidArgument otherwise).
// Threading: ContactRoc holds segmenters (scratch) and the offset they share; one instance per
// thread, not copyable.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/eval/track_metrics.hpp>
#include <shadowsense/sense/segmenter.hpp>
#include <shadowsense/sim/sim.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

enum class ContactCue { darkness, warmth, joint, joint_sharp };
inline constexpr std::array<ContactCue, 4> all_contact_cues{
    ContactCue::darkness, ContactCue::warmth, ContactCue::joint, ContactCue::joint_sharp};

inline const char* to_string(ContactCue c) {
  switch (c) {
  case ContactCue::darkness:
    return "darkness";
  case ContactCue::warmth:
    return "warmth";
  case ContactCue::joint:
    return "darkness_and_warmth";
  case ContactCue::joint_sharp:
    return "darkness_and_warmth_sharp_edge";
  }
  return "?";
}

struct ContactSweepRule {
  RelativeRule relative;
  ContactCue cue = ContactCue::joint;
  float offset = 0;

  void classify(const PixelRuleInput& in, PixelRuleOutput& out) const {
    relative.classify(in, out);
    if ((cue == ContactCue::joint || cue == ContactCue::joint_sharp) && offset == 0) return;
    const LightThresholds th = relative.thresholds_at(detail::luminance(in.reference));
    const float ts = th.shadow_darkness, tc = th.contact_darkness + offset,
                tw = th.contact_warmth + offset;
    for (int y = 0; y < in.bgr.rows; ++y) {
      const float* d = out.darkness.ptr<float>(y);
      const float* w = out.warmth.ptr<float>(y);
      const uchar* v = in.skin.ptr<uchar>(y);
      uchar* sm = out.shadow_mask.ptr<uchar>(y);
      uchar* cm = out.contact_mask.ptr<uchar>(y);
      for (int x = 0; x < in.bgr.cols; ++x) {
        bool contact = false;
        switch (cue) {
        case ContactCue::darkness:
          contact = d[x] >= tc;
          break;
        case ContactCue::warmth:
          contact = d[x] >= ts && w[x] >= tw;
          break;
        case ContactCue::joint:
        case ContactCue::joint_sharp:
          contact = d[x] >= tc && w[x] >= tw;
          break;
        }
        cm[x] = contact ? v[x] : uchar(0);
        sm[x] = static_cast<uchar>((d[x] >= ts ? v[x] : uchar(0)) | cm[x]);
      }
    }
  }
};
static_assert(PixelRule<ContactSweepRule>);

struct RocPoint {
  double offset = 0; // added to the contact threshold(s)
  int true_positives = 0, false_positives = 0;
  double tpr = 0, fpr = 0;
  double contact_iou = 0; // mean box IoU over the true positives
};

struct RocCurve {
  ContactCue cue = ContactCue::joint;
  double edge_gate_px = 0; // joint_sharp: the largest contact edge width kept
  int positives = 0, negatives = 0;
  std::vector<RocPoint> points;
  std::size_t shipped = 0; // index of offset 0
  double auc = 0;
};

inline double roc_auc(std::vector<RocPoint> points) {
  for (const RocPoint& p : points)
    detail::require(std::isfinite(p.fpr) && std::isfinite(p.tpr) && p.fpr >= 0 && p.fpr <= 1 &&
                        p.tpr >= 0 && p.tpr <= 1,
                    "roc_auc: a point has fpr " + std::to_string(p.fpr) + ", tpr " +
                        std::to_string(p.tpr) + "; expected both in [0, 1]");
  std::sort(points.begin(), points.end(), [](const RocPoint& a, const RocPoint& b) {
    return a.fpr != b.fpr ? a.fpr < b.fpr : a.tpr < b.tpr;
  });
  double area = 0, x = 0, y = 0;
  auto to = [&](double nx, double ny) {
    area += (nx - x) * (ny + y) / 2;
    x = nx;
    y = ny;
  };
  for (const RocPoint& p : points) to(p.fpr, p.tpr);
  to(1, 1);
  return area;
}

inline std::vector<RocPoint> roc_from_scores(const std::vector<double>& positives,
                                             const std::vector<double>& negatives) {
  detail::require(!positives.empty() && !negatives.empty(),
                  "roc_from_scores: " + std::to_string(positives.size()) + " positive and " +
                      std::to_string(negatives.size()) +
                      " negative scores; expected at least one of each");
  std::vector<double> all;
  for (const auto* list : {&positives, &negatives})
    for (double v : *list) {
      detail::require(std::isfinite(v), "roc_from_scores: a score is not finite");
      all.push_back(v);
    }
  std::sort(all.begin(), all.end(), std::greater<>());
  all.erase(std::unique(all.begin(), all.end()), all.end());
  std::vector<RocPoint> out;
  for (double s : all) {
    RocPoint p;
    p.offset = s;
    p.true_positives = static_cast<int>(
        std::count_if(positives.begin(), positives.end(), [s](double v) { return v >= s; }));
    p.false_positives = static_cast<int>(
        std::count_if(negatives.begin(), negatives.end(), [s](double v) { return v >= s; }));
    p.tpr = static_cast<double>(p.true_positives) / static_cast<double>(positives.size());
    p.fpr = static_cast<double>(p.false_positives) / static_cast<double>(negatives.size());
    out.push_back(p);
  }
  return out;
}

inline double tpr_at_fpr(const RocCurve& c, double max_fpr) {
  double best = 0;
  for (const RocPoint& p : c.points)
    if (p.fpr <= max_fpr) best = std::max(best, p.tpr);
  return best;
}

// The default sweep: -0.50 .. +1.00 in steps of 0.01 (151 offsets, index 50 is 0). At +1.00 the
// darkness threshold exceeds 1 (nothing is contact: the dark core of a low hovering hand's
// shadow can be darker than a contact, so darkness alone needs the whole range); at -0.50
// nearly every shadow pixel is contact.
inline std::vector<float> default_roc_offsets() {
  std::vector<float> o;
  for (int k = -50; k <= 100; ++k) o.push_back(static_cast<float>(k) / 100.f);
  return o;
}

class ContactRoc {
public:
  ContactRoc(const ContactRoc&) = delete;
  ContactRoc& operator=(const ContactRoc&) = delete;
  ContactRoc(const Segmenter& shipped, std::vector<float> offsets = default_roc_offsets())
      : offsets_(std::move(offsets)) {
    const SegmenterCalibration& cal = shipped.config().calibration;
    detail::require(cal.mode == SegmentMode::relative,
                    "ContactRoc: the segmenter is in fixed_ranges mode; expected relative mode "
                    "(the cues are darkness and warmth)");
    detail::require(shipped.has_empty_skin(),
                    "ContactRoc: the segmenter has no empty-skin model; expected one");
    detail::require(!offsets_.empty(), "ContactRoc: no offsets; expected at least one");
    bool zero = false;
    for (std::size_t i = 0; i < offsets_.size(); ++i) {
      const float o = offsets_[i];
      detail::require(std::isfinite(o) && o >= -1 && o <= 1 && (i == 0 || o > offsets_[i - 1]),
                      "ContactRoc: offset " + std::to_string(i) + " is " + std::to_string(o) +
                          "; expected finite values in [-1, 1], strictly increasing");
      if (o == 0) {
        zero = true;
        shipped_ = i;
      }
    }
    detail::require(zero, "ContactRoc: no offset is 0; expected the shipped thresholds in the "
                          "sweep");
    SegmenterConfig config = shipped.config();
    config.calibration.empty_skin = shipped.empty_skin_model().clone();
    const RelativeRule relative{cal.shadow_darkness, cal.contact_darkness, cal.contact_warmth,
                                cal.by_light};
    for (std::size_t c = 0; c < kPixelCues; ++c)
      segmenters_.emplace_back(config, ContactSweepRule{relative, static_cast<ContactCue>(c), 0.f});
  }

  void add(const cv::Mat& bgr, const std::optional<cv::Rect>& true_contact, bool positive) {
    Frame f;
    f.positive = positive;
    f.truth = true_contact;
    for (std::size_t c = 0; c < kPixelCues; ++c)
      for (std::size_t k = 0; k < offsets_.size(); ++k) {
        segmenters_[c].rule().offset = offsets_[k]; // one segmenter per cue, moved along
        segmenters_[c].segment(bgr, scratch_);
        std::vector<Candidate> blobs;
        for (const Blob& b : scratch_.contacts) blobs.push_back({b.box, b.edge_width});
        f.candidates[c].push_back(std::move(blobs));
      }
    (positive ? positives_ : negatives_)++;
    frames_.push_back(std::move(f));
  }

  int positives() const { return positives_; }
  int negatives() const { return negatives_; }
  const std::vector<float>& offsets() const { return offsets_; }

  RocCurve curve(ContactCue cue, double edge_gate_px = 0) const {
    const bool gated = cue == ContactCue::joint_sharp;
    detail::require(gated ? (std::isfinite(edge_gate_px) && edge_gate_px > 0) : edge_gate_px == 0,
                    std::string("ContactRoc::curve: edge gate ") + std::to_string(edge_gate_px) +
                        " px for cue " + to_string(cue) +
                        "; expected > 0 for the sharp-edge cue and 0 for the others");
    detail::require(positives_ > 0 && negatives_ > 0,
                    "ContactRoc::curve: " + std::to_string(positives_) + " positive and " +
                        std::to_string(negatives_) +
                        " negative frames; expected at least one of each");
    const std::size_t c =
        gated ? static_cast<std::size_t>(ContactCue::joint) : static_cast<std::size_t>(cue);
    RocCurve r;
    r.cue = cue;
    r.edge_gate_px = edge_gate_px;
    r.positives = positives_;
    r.negatives = negatives_;
    r.shipped = shipped_;
    for (std::size_t k = 0; k < offsets_.size(); ++k) {
      RocPoint p;
      p.offset = offsets_[k];
      RunningStats iou;
      for (const Frame& f : frames_) {
        std::optional<cv::Rect> box;
        for (const Candidate& b : f.candidates[c][k])
          if (!gated || b.edge_width <= edge_gate_px) box = box ? (*box | b.box) : b.box;
        if (!box) continue;
        if (!f.positive) {
          ++p.false_positives;
          continue;
        }
        ++p.true_positives;
        iou.add(f.truth ? box_iou(*box, *f.truth) : 0.0);
      }
      p.tpr = static_cast<double>(p.true_positives) / positives_;
      p.fpr = static_cast<double>(p.false_positives) / negatives_;
      p.contact_iou = iou.mean();
      r.points.push_back(p);
    }
    r.auc = roc_auc(r.points);
    return r;
  }

private:
  static constexpr std::size_t kPixelCues = 3; // darkness, warmth, joint (joint_sharp reuses it)
  struct Candidate {
    cv::Rect box;
    float edge_width = 0;
  };
  struct Frame {
    bool positive = false;
    std::optional<cv::Rect> truth;
    std::array<std::vector<std::vector<Candidate>>, kPixelCues> candidates; // [cue][offset]
  };
  std::vector<float> offsets_;
  std::size_t shipped_ = 0;
  std::vector<BasicSegmenter<ContactSweepRule>> segmenters_; // one per pixel cue
  std::vector<Frame> frames_;
  Segmentation scratch_;
  int positives_ = 0, negatives_ = 0;
};

inline double pick_contact_edge_gate(const ContactRoc& roc, const std::vector<double>& gates) {
  detail::require(!gates.empty(), "pick_contact_edge_gate: no gates; expected at least one");
  double best_gate = 0, best_auc = -1;
  for (double g : gates) {
    detail::require(std::isfinite(g) && g > 0,
                    "pick_contact_edge_gate: gate " + std::to_string(g) + "; expected > 0");
    const double auc = roc.curve(ContactCue::joint_sharp, g).auc;
    if (auc > best_auc || (auc == best_auc && g < best_gate)) {
      best_auc = auc;
      best_gate = g;
    }
  }
  return best_gate;
}

// Adds `frames` generator frames rendered with `seed` to `roc`: hover frames (negatives) and
// palm, fist, finger in turn (positives), half and half, over all lighting presets equally.
inline void add_sim_frames(ContactRoc& roc, sim::Renderer& renderer, std::uint64_t seed,
                           int frames) {
  sim::TrackingSampleConfig variety;
  variety.lighting_weights = {1, 1, 1};
  const sim::TrackCategory touch[] = {sim::TrackCategory::palm, sim::TrackCategory::fist,
                                      sim::TrackCategory::finger};
  for (int i = 0; i < frames; ++i) {
    const bool positive = i % 2 == 1;
    const sim::TrackCategory category =
        positive ? touch[static_cast<std::size_t>(i / 2) % 3] : sim::TrackCategory::hover;
    const sim::Frame f = sim::render_random_tracking_frame(
        renderer, category, sim::derive_seed(seed, static_cast<std::uint64_t>(i)), variety);
    roc.add(f.image, f.gt.contact_box, positive);
  }
}

SHADOWSENSE_NAMESPACE_END
