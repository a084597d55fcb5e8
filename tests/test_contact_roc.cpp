// Contact vs hover ROC (eval/track_eval.hpp): the ROC/AUC arithmetic on score lists with known
// answers, the sweep rule against the shipped rule, the contact blobs' edge width on a
// constructed frame, and the frame-level ROC on four generator frames with a known outcome.
#include <shadowsense/eval/track_eval.hpp>

#include "common/sim_box.hpp"

#include <doctest/doctest.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <limits>
#include <vector>

using namespace shadowsense;

namespace {

// P(pos > neg) + P(pos == neg) / 2 over all pairs.
double mann_whitney(const std::vector<double>& pos, const std::vector<double>& neg) {
  double s = 0;
  for (double p : pos)
    for (double n : neg) s += p > n ? 1.0 : p == n ? 0.5 : 0.0;
  return s / static_cast<double>(pos.size() * neg.size());
}

sim::Frame frame(sim::TrackCategory c, std::uint64_t seed) {
  return sim::render_random_tracking_frame(test::box_renderer(), c, seed);
}

} // namespace

TEST_CASE("roc_from_scores / roc_auc: perfect, inverted, chance, ties") {
  CHECK(roc_auc(roc_from_scores({2, 3}, {0, 1})) == 1.0);
  CHECK(roc_auc(roc_from_scores({0}, {1})) == 0.0);
  CHECK(roc_auc(roc_from_scores({1, 2}, {1, 2})) == 0.5);
  CHECK(roc_auc(roc_from_scores({7}, {7})) == 0.5); // one tie: half

  // Ties count a half: pairs (1,2) 0, (1,0) 1, (2,2) 1/2, (2,0) 1 -> 2.5 / 4.
  const std::vector<RocPoint> p = roc_from_scores({1, 2}, {2, 0});
  REQUIRE(p.size() == 3); // one point per distinct score, largest first
  CHECK(p[0].offset == 2);
  CHECK(p[0].true_positives == 1);
  CHECK(p[0].false_positives == 1);
  CHECK(p[0].tpr == 0.5);
  CHECK(p[0].fpr == 0.5);
  CHECK(p[1].offset == 1);
  CHECK(p[1].tpr == 1.0);
  CHECK(p[1].fpr == 0.5);
  CHECK(p[2].offset == 0);
  CHECK(p[2].tpr == 1.0);
  CHECK(p[2].fpr == 1.0);
  CHECK(roc_auc(p) == 0.625);

  const std::vector<double> pos{3, 1, 4, 1, 5, 9, 2, 6}, neg{5, 3, 5, 8, 9, 7, 9, 3};
  CHECK(roc_auc(roc_from_scores(pos, neg)) ==
        doctest::Approx(mann_whitney(pos, neg)).epsilon(1e-12));
  CHECK(mann_whitney(pos, neg) == 0.265625); // 17 / 64

  // Points in any order; the polyline runs from (0, 0) to (1, 1).
  CHECK(roc_auc({{.tpr = 1, .fpr = 0.5}, {.tpr = 0.5, .fpr = 0}}) == 0.875);
  CHECK(roc_auc({}) == 0.5);
}

TEST_CASE("tpr_at_fpr and the refusals") {
  RocCurve c;
  c.points = {{.tpr = 0.2, .fpr = 0.0}, {.tpr = 0.7, .fpr = 0.05}, {.tpr = 0.9, .fpr = 0.06}};
  CHECK(tpr_at_fpr(c, 0.05) == 0.7);
  CHECK(tpr_at_fpr(c, 0.0) == 0.2);
  CHECK(tpr_at_fpr(c, 1.0) == 0.9);
  c.points = {{.tpr = 1, .fpr = 0.5}};
  CHECK(tpr_at_fpr(c, 0.05) == 0.0);

  CHECK_THROWS_AS(roc_auc({{.tpr = 0.5, .fpr = 1.5}}), InvalidArgument);
  CHECK_THROWS_AS(roc_auc({{.tpr = std::nan(""), .fpr = 0}}), InvalidArgument);
  CHECK_THROWS_AS(roc_from_scores({}, {1}), InvalidArgument);
  CHECK_THROWS_AS(roc_from_scores({1}, {}), InvalidArgument);
  CHECK_THROWS_AS(roc_from_scores({1, std::numeric_limits<double>::infinity()}, {0}),
                  InvalidArgument);

  const Segmenter seg = segmenter_from(test::box_calibration());
  CHECK_THROWS_AS(ContactRoc(seg, {-0.1f, 0.1f}), InvalidArgument); // no 0
  CHECK_THROWS_AS(ContactRoc(seg, {0.f, -0.1f}), InvalidArgument);  // not increasing
  CHECK_THROWS_AS(ContactRoc(seg, {0.f, 1.5f}), InvalidArgument);   // outside [-1, 1]
  CHECK_THROWS_AS(ContactRoc(seg, {}), InvalidArgument);
  CHECK_THROWS_AS(ContactRoc(Segmenter{}, {0.f}), InvalidArgument); // no empty-skin model
  SegmenterConfig fixed = test::box_calibration().config;
  fixed.calibration.mode = SegmentMode::fixed_ranges;
  CHECK_THROWS_AS(ContactRoc(Segmenter(fixed), {0.f}), InvalidArgument);

  ContactRoc roc(seg, {0.f});
  CHECK_THROWS_AS(roc.curve(ContactCue::joint), InvalidArgument); // no frames
  roc.add(frame(sim::TrackCategory::palm, 11).image, std::nullopt, true);
  CHECK_THROWS_AS(roc.curve(ContactCue::joint), InvalidArgument); // no negative
  roc.add(frame(sim::TrackCategory::hover, 12).image, std::nullopt, false);
  CHECK_NOTHROW(roc.curve(ContactCue::joint));
  CHECK_THROWS_AS(roc.curve(ContactCue::joint_sharp), InvalidArgument);   // needs a gate
  CHECK_THROWS_AS(roc.curve(ContactCue::darkness, 5.0), InvalidArgument); // takes none
  CHECK_THROWS_AS(pick_contact_edge_gate(roc, {}), InvalidArgument);
  CHECK_THROWS_AS(pick_contact_edge_gate(roc, {1.0, 0.0}), InvalidArgument);
}

TEST_CASE("contact blobs carry their edge width: a sharp contact is narrower than a blurred one") {
  const cv::Mat empty(200, 200, CV_8UC3, cv::Scalar(200, 200, 200));
  cv::Mat img = empty.clone();
  // Warm and dark (q = 0.3, 0.4, 0.6: darkness 0.567, warmth 0.3): contact under the defaults.
  cv::rectangle(img, cv::Rect(20, 60, 40, 40), cv::Scalar(60, 80, 120), cv::FILLED);
  cv::Mat soft = empty.clone();
  cv::rectangle(soft, cv::Rect(110, 50, 60, 60), cv::Scalar(60, 80, 120), cv::FILLED);
  cv::GaussianBlur(soft, soft, cv::Size(0, 0), 5.0);
  soft(cv::Rect(100, 0, 100, 200)).copyTo(img(cv::Rect(100, 0, 100, 200)));
  Segmenter seg;
  seg.set_empty_skin({empty});
  const Segmentation s = seg.segment(img);
  REQUIRE(s.contacts.size() == 2);
  const Blob& sharp = s.contacts[0].box.x < 100 ? s.contacts[0] : s.contacts[1];
  const Blob& blurred = s.contacts[0].box.x < 100 ? s.contacts[1] : s.contacts[0];
  // A step of darkness 0.567 differenced over 4 px gives 4 px along the sides, less at the
  // corners (where both gradients add).
  CHECK(sharp.edge_width >= 3.f);
  CHECK(sharp.edge_width <= 4.f);
  CHECK(blurred.edge_width > 2.f * sharp.edge_width);
}

TEST_CASE("ContactSweepRule: the joint cue at offset 0 is the shipped rule, pixel for pixel") {
  const Segmenter::Config& config = test::box_calibration().config;
  Segmenter shipped = segmenter_from(test::box_calibration());
  const SegmenterCalibration& cal = config.calibration;
  const RelativeRule relative{cal.shadow_darkness, cal.contact_darkness, cal.contact_warmth,
                              cal.by_light};
  BasicSegmenter<ContactSweepRule> joint(config, {relative, ContactCue::joint, 0.f});
  BasicSegmenter<ContactSweepRule> dark(config, {relative, ContactCue::darkness, 0.f});
  BasicSegmenter<ContactSweepRule> none(config, {relative, ContactCue::joint, 1.f});
  for (const auto c : {sim::TrackCategory::palm, sim::TrackCategory::hover}) {
    const sim::Frame f = frame(c, 21);
    const Segmentation a = shipped.segment(f.image), b = joint.segment(f.image),
                       d = dark.segment(f.image), n = none.segment(f.image);
    CHECK(cv::countNonZero(a.contact_mask != b.contact_mask) == 0);
    CHECK(cv::countNonZero(a.shadow_mask != b.shadow_mask) == 0);
    CHECK(a.contact_box == b.contact_box);
    // Darkness alone accepts every joint contact pixel; +1 leaves no contact at all.
    CHECK(cv::countNonZero(b.contact_mask & ~d.contact_mask) == 0);
    CHECK(cv::countNonZero(n.contact_mask) == 0);
    CHECK_FALSE(n.contact_box.has_value());
  }
}

TEST_CASE("frame-level ROC on two hovering hands and two contacts of the generator") {
  Segmenter shipped = segmenter_from(test::box_calibration());
  ContactRoc roc(shipped, {-1.f, 0.f, 1.f});
  double shipped_iou = 0;
  int shipped_hover_contacts = 0;
  for (const auto& [c, seed] : {std::pair{sim::TrackCategory::hover, 31u},
                                {sim::TrackCategory::hover, 32u},
                                {sim::TrackCategory::palm, 33u},
                                {sim::TrackCategory::finger, 34u}}) {
    const sim::Frame f = frame(c, seed);
    const bool positive = c != sim::TrackCategory::hover;
    REQUIRE(f.gt.contact_box.has_value() == positive);
    roc.add(f.image, f.gt.contact_box, positive);
    const Segmentation s = shipped.segment(f.image);
    if (positive) {
      REQUIRE(s.contact_box.has_value()); // the shipped rule finds both contacts ...
      shipped_iou += box_iou(*s.contact_box, *f.gt.contact_box) / 2;
    } else if (s.contact_box) {
      ++shipped_hover_contacts; // ... and no contact on these hovers
    }
  }
  REQUIRE(shipped_hover_contacts == 0);
  CHECK(roc.positives() == 2);
  CHECK(roc.negatives() == 2);

  const RocCurve joint = roc.curve(ContactCue::joint);
  REQUIRE(joint.points.size() == 3);
  CHECK(joint.shipped == 1);
  CHECK(joint.points[0].tpr == 1.0); // -1: every skin pixel passes both thresholds
  CHECK(joint.points[0].fpr == 1.0);
  CHECK(joint.points[1].tpr == 1.0); // the shipped point, as the Segmenter decides
  CHECK(joint.points[1].fpr == 0.0);
  CHECK(joint.points[1].contact_iou == doctest::Approx(shipped_iou).epsilon(1e-12));
  CHECK(joint.points[2].tpr == 0.0); // +1: darkness above 1, nothing
  CHECK(joint.points[2].fpr == 0.0);
  CHECK(joint.auc == 1.0);

  for (ContactCue cue : {ContactCue::darkness, ContactCue::warmth}) {
    const RocCurve r = roc.curve(cue);
    CHECK(r.points[0].tpr == 1.0); // every hover casts a shadow: all frames report a contact
    CHECK(r.points[0].fpr == 1.0);
    CHECK(r.points[1].tpr == 1.0); // a single cue keeps the true contacts
  }
  const RocCurve dark = roc.curve(ContactCue::darkness);
  CHECK(dark.points[2].true_positives == 0); // +1: darkness above 1, nothing
  CHECK(dark.points[2].false_positives == 0);

  // A gate no blob reaches changes nothing; the picked gate is the smallest of the best.
  const RocCurve wide = roc.curve(ContactCue::joint_sharp, 1e6);
  for (std::size_t k = 0; k < 3; ++k) {
    CHECK(wide.points[k].true_positives == joint.points[k].true_positives);
    CHECK(wide.points[k].false_positives == joint.points[k].false_positives);
    CHECK(wide.points[k].contact_iou == joint.points[k].contact_iou);
  }
  CHECK(wide.auc == 1.0);
  CHECK(pick_contact_edge_gate(roc, {1e6, 2e6}) == 1e6);
  const RocCurve tiny = roc.curve(ContactCue::joint_sharp, 1e-6); // no real blob is that sharp
  CHECK(tiny.points[1].true_positives == 0);
  CHECK(tiny.points[1].false_positives == 0);
}
