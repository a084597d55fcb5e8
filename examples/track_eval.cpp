// ss_track_eval: the paper's Table 5 (shadow and contact tracking accuracy per category) and
// Figure 14 (slide direction accuracy against the observed ratio) on datasets written by
// ss_synth. Keys of the --json output are documented in docs/tracking_eval.md.
//
//   ss_track_eval --input DIR [--tracking DIR] [--slides DIR] [--json PATH] [--annotate DIR]
//                 [--annotate-limit N] [--calib-seed N] [--calib-frames N]
//                 [--calibration FILE] [--save-calibration FILE] [--mode relative|fixed_ranges]
//                 [--differential-window MS] [--roc CSV] [--roc-gate PX] [--roc-pick-frames N]
//
// --roc: the frame-level contact vs hover ROC of four detectors (eval/track_eval.hpp ContactRoc)
// on the tracking dataset, written as CSV (atomically) and summarised on stdout; the sharp-edge
// detector's gate is picked on generator frames (--roc-pick-frames, another seed), never on the
// evaluated frames, unless --roc-gate gives it.
//
// --temporal DIR: the temporal touch gestures (docs/temporal_gestures.md) on a temporal gesture
// dataset (docs/dataset_format.md; ss_synth --dataset temporal writes one): every frame goes
// through the segmenter, the touch pipeline and the temporal gesture recogniser, with the
// frame's hand-shape reading from frames.csv standing in for the classifier (--temporal-shapes
// none: no reading; --temporal-shapes model: the classifier itself, the library's Runtime with
// the model of --model or the installed one, as ss_track runs it); the events are scored
// against gestures.csv by eval/temporal_eval.hpp
// (score_temporal, tracks matched with TemporalTrackMatch::any_track: the tracker numbers the
// hands itself). Per frame rate: per-gesture precision, recall, F1, the confusion matrix (text;
// a PNG per rate with --temporal-confusion DIR), latency p50/p90/max, repetition errors and
// the milliseconds per frame; --json PATH writes them (schema shadowsense.temporal_eval/1,
// docs/temporal_gestures.md). Nothing else is evaluated in this mode.
//
// The segmenter is calibrated on frames rendered by the scene generator with --calib-seed, never
// on the evaluated frames.
#include <shadowsense/core/atomic_file.hpp>
#include <shadowsense/eval.hpp>
#include <shadowsense/eval/temporal_eval.hpp>
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/io/dataset.hpp>
#include <shadowsense/io/temporal_dataset.hpp>
#include <shadowsense/runtime/densenet_runtime.hpp>
#include <shadowsense/sense/segmenter.hpp>
#include <shadowsense/sense/touch_state_machine.hpp>

#include "common/cli.hpp"
#include "common/frame_source.hpp"
#include "common/json.hpp"
#include "common/model_path.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace shadowsense;

namespace {

struct Options {
  fs::path tracking, slides, json, annotate, calibration_in, calibration_out;
  // Named on the command line (not derived from --input): then it must exist.
  bool tracking_named = false, slides_named = false;
  int annotate_limit = 10;
  std::uint64_t calib_seed = 0xCA11B8A7Eull;
  int calib_frames = 150;
  SegmentMode mode = SegmentMode::relative;
  double differential_window_ms = 300;
  fs::path roc;
  double roc_gate = 0; // 0: picked on generator frames
  int roc_pick_frames = 120;
  fs::path temporal, temporal_confusion;
  std::string temporal_shapes = "file"; // file | none | model
  fs::path model;                       // --temporal-shapes model: empty = the installed one
  double px_per_cm = 0;                 // 0: each sequence's own
};

Options parse(int argc, char** argv) {
  Options o;
  fs::path data;
  std::string mode = "relative";
  cli::Parser p("ss_track_eval",
                "The paper's Table 5 (shadow and contact tracking accuracy per category) and "
                "Figure 14 (slide direction accuracy against the observed ratio) on datasets "
                "written by ss_synth; the segmenter is calibrated on generator frames, never on "
                "the evaluated ones.");
  p.usage("ss_track_eval --input DIR [options]");
  p.usage("ss_track_eval --tracking DIR --slides DIR [options]");
  p.usage(
      "ss_track_eval --temporal DIR [--temporal-confusion DIR] [--temporal-shapes file|none|model] "
      "[--model FILE] [--px-per-cm X] [--json PATH] [calibration options]");
  p.option("--input", "DIR", "folder holding tracking/ and slides/", data);
  p.alias("--data", "--input");
  p.option("--tracking", "DIR", "tracking dataset (instead of DIR/tracking)", o.tracking);
  p.option("--slides", "DIR", "slides dataset (instead of DIR/slides)", o.slides);
  p.option("--json", "PATH", "write the results as JSON (docs/tracking_eval.md)", o.json);
  p.option("--annotate", "DIR", "write annotated frames to DIR", o.annotate);
  p.option("--annotate-limit", "N", "annotated frames per category / slide sequences",
           o.annotate_limit)
      .range(0, 1000000);
  p.option("--calib-seed", "N", "seed of the calibration frames", o.calib_seed);
  p.option("--calib-frames", "N", "number of calibration frames", o.calib_frames).range(1, 100000);
  p.option("--calibration", "FILE", "take the thresholds from a calibration file",
           o.calibration_in);
  p.option("--save-calibration", "FILE", "write the calibration used", o.calibration_out);
  p.option("--mode", "MODE", "segmentation thresholds", mode).choices({"relative", "fixed_ranges"});
  p.option("--differential-window", "MS", "touch state machine's differential window",
           o.differential_window_ms)
      .range(0.0, 1e9);
  p.option("--roc", "CSV",
           "write the contact vs hover ROC of the tracking dataset (docs/tracking_eval.md)", o.roc);
  p.option("--roc-gate", "PX",
           "sharp-edge detector: largest contact edge width kept (default: picked on generator "
           "frames)",
           o.roc_gate)
      .range(0.01, 1000.0);
  p.option("--roc-pick-frames", "N", "generator frames (half hover) the edge gate is picked on",
           o.roc_pick_frames)
      .range(2, 100000);
  p.option("--temporal", "DIR",
           "evaluate the temporal touch gestures on a temporal gesture dataset (docs/"
           "dataset_format.md; ss_synth --dataset temporal): per frame rate P/R/F1, confusion, "
           "latency, repetition errors, ms per frame; nothing else is evaluated",
           o.temporal);
  p.option("--temporal-confusion", "DIR",
           "--temporal: write the confusion matrix per frame rate as "
           "DIR/temporal_confusion_<F>fps.png",
           o.temporal_confusion);
  p.option("--temporal-shapes", "SOURCE",
           "--temporal: the hand-shape reading per frame: the dataset's shape column (file), "
           "none (palm vs finger from the contact area; no hug, punch or two_hands) or the "
           "classifier on the frame (model: the Runtime as ss_track runs it)",
           o.temporal_shapes)
      .choices({"file", "none", "model"});
  p.option("--model", "FILE",
           "--temporal-shapes model: the gesture model (default: " +
               cli::default_model_help(argv[0]) + ")",
           o.model);
  p.option("--px-per-cm", "X", "--temporal: image scale at the skin for the recogniser",
           o.px_per_cm)
      .range(0.01, 1000.0)
      .default_text("each sequence's px_per_cm in sequences.csv");
  p.parse(argc, argv);
  if (!o.temporal.empty()) {
    if (!data.empty() || p.given("--tracking") || p.given("--slides"))
      throw cli::UsageError("--temporal evaluates only the temporal dataset; leave out --input, "
                            "--tracking and --slides");
    if (p.given("--model") && o.temporal_shapes != "model")
      throw cli::UsageError("--model needs --temporal-shapes model");
    return o;
  }
  if (p.given("--temporal-confusion") || p.given("--temporal-shapes") || p.given("--px-per-cm") ||
      p.given("--model"))
    throw cli::UsageError(
        "--temporal-confusion, --temporal-shapes, --model and --px-per-cm need --temporal");
  if (!data.empty()) { // --tracking / --slides override one of the two
    if (!p.given("--tracking")) o.tracking = data / "tracking";
    if (!p.given("--slides")) o.slides = data / "slides";
  }
  if (o.tracking.empty() && o.slides.empty())
    throw cli::UsageError("give --input DIR, --tracking DIR or --slides DIR");
  o.tracking_named = p.given("--tracking");
  o.slides_named = p.given("--slides");
  o.mode = mode == "relative" ? SegmentMode::relative : SegmentMode::fixed_ranges;
  return o;
}

// ----------------------------------------------------------------------------------------------
// Table 5

struct ClassStats {
  int frames = 0;
  int truth = 0, missed = 0, false_positives = 0;
  RunningStats err_x, err_y, iou;
};

struct CategoryResult {
  int frames = 0;
  ClassStats shadow, contact;
};

void score(ClassStats& s, const std::optional<cv::Rect>& truth,
           const std::optional<cv::Rect>& found, double px_per_cm) {
  ++s.frames;
  if (!truth) {
    if (found) ++s.false_positives;
    return;
  }
  ++s.truth;
  if (!found) {
    ++s.missed;
    return;
  }
  const cv::Point2d a = box_centre(*found), b = box_centre(*truth);
  s.err_x.add((a.x - b.x) / px_per_cm);
  s.err_y.add((a.y - b.y) / px_per_cm);
  s.iou.add(box_iou(*found, *truth));
}

const char* state_label(const Segmentation& s) {
  return s.contact_box ? "touch" : s.shadow_box ? "appear" : "none";
}

void annotate(cv::Mat& img, const Segmentation& s, const std::optional<cv::Rect>& gt_shadow,
              const std::optional<cv::Rect>& gt_contact, const std::string& label) {
  auto draw = [&](const cv::Rect& r, const cv::Scalar& c) {
    cv::rectangle(img, r.tl(), r.br() - cv::Point(1, 1), c, 1, cv::LINE_8);
  };
  if (gt_shadow) draw(*gt_shadow, {0, 0, 255});
  if (gt_contact) draw(*gt_contact, {0, 0, 255});
  if (s.shadow_box) draw(*s.shadow_box, {255, 0, 0});       // shadow: blue
  if (s.contact_box) draw(*s.contact_box, {255, 255, 255}); // contact: white
  if (s.contact_point)
    cv::circle(img, cv::Point(cvRound(s.contact_point->x), cvRound(s.contact_point->y)), 3,
               {255, 255, 255}, 1, cv::LINE_AA);
  cv::putText(img, label, {4, 14}, cv::FONT_HERSHEY_SIMPLEX, 0.45, {0, 0, 0}, 3, cv::LINE_AA);
  cv::putText(img, label, {4, 14}, cv::FONT_HERSHEY_SIMPLEX, 0.45, {0, 255, 255}, 1, cv::LINE_AA);
}

std::map<std::string, CategoryResult> evaluate_tracking(const Options& o, Segmenter& seg) {
  const Metadata md = read_metadata(o.tracking / "metadata.csv");
  std::map<std::string, CategoryResult> out;
  std::map<std::string, int> annotated;
  Segmentation s;
  for (const MetadataRow& row : md.rows) {
    const cv::Mat img = read_image(md, row);
    seg.segment(img, s);
    CategoryResult& c = out[row.label];
    ++c.frames;
    detail::require<DatasetError>(row.px_per_cm > 0, md.csv_path.string() + ":" +
                                                         std::to_string(row.line) +
                                                         ": px_per_cm must be > 0");
    score(c.shadow, row.shadow_box, s.shadow_box, row.px_per_cm);
    score(c.contact, row.contact_box, s.contact_box, row.px_per_cm);
    if (!o.annotate.empty() && annotated[row.label]++ < o.annotate_limit) {
      cv::Mat a = img.clone();
      annotate(a, s, row.shadow_box, row.contact_box, state_label(s));
      const fs::path p = o.annotate / "tracking" / row.file_name;
      fs::create_directories(p.parent_path());
      frames::write_png_atomically(p, a); // temp + rename, checked
    }
  }
  return out;
}

// ----------------------------------------------------------------------------------------------
// Figure 14

constexpr int kRatios = 10;

struct Curve {
  std::array<int, kRatios> correct{};
  int sequences = 0;
};

struct SlideResults {
  std::map<std::string, Curve> by_gesture, by_direction;
  Curve overall;
  int no_touch = 0; // sequences in which no contact was ever found
};

SlideResults evaluate_slides(const Options& o, Segmenter& seg) {
  SlideResults r;
  const std::vector<SequenceRow> seqs = read_sequences(o.slides / "sequences.csv");
  Segmentation s;
  int annotated = 0;
  for (const SequenceRow& q : seqs) {
    // Checked against its sequences.csv row (folder inside the dataset, frames, labels).
    const Metadata md = read_sequence_metadata(o.slides / "sequences.csv", q);
    std::vector<double> ts;
    std::vector<TouchObservation> obs;
    bool any_contact = false;
    TouchStateMachine::Config fc;
    fc.differential_window_ms = o.differential_window_ms;
    TouchStateMachine fsm(fc);
    const bool draw = !o.annotate.empty() && annotated < o.annotate_limit;
    if (draw) ++annotated;
    for (const MetadataRow& row : md.rows) {
      const cv::Mat img = read_image(md, row);
      seg.segment(img, s);
      ts.push_back(row.timestamp_ms);
      obs.push_back({s.shadow_box.has_value(), s.contact_point});
      any_contact = any_contact || s.contact_point.has_value();
      try {
        fsm.update(row.timestamp_ms, obs.back());
      } catch (const InvalidArgument& e) { // e.g. a timestamp that goes back: name the row
        throw DatasetError(md.csv_path.string() + ":" + std::to_string(row.line) + ": " + e.what());
      }
      if (draw) {
        cv::Mat a = img.clone();
        std::string label = to_string(fsm.state());
        if (fsm.state() == TouchState::move) label += std::string(" ") + to_string(fsm.direction());
        annotate(a, s, row.shadow_box, row.contact_box, label);
        const fs::path p = o.annotate / "slides" / q.sequence / row.file_name;
        fs::create_directories(p.parent_path());
        frames::write_png_atomically(p, a); // temp + rename, checked
      }
    }
    if (!any_contact) ++r.no_touch;
    const std::string truth(sim::to_string(q.direction));
    const std::string gesture(sim::to_string(q.gesture));
    Curve* curves[] = {&r.overall, &r.by_gesture[gesture], &r.by_direction[truth]};
    for (Curve* c : curves) ++c->sequences;
    const std::size_t n = ts.size();
    for (int k = 0; k < kRatios; ++k) {
      // Observed ratio (k+1)/10: the first ceil(ratio * n) frames (at least one).
      const std::size_t m =
          std::max<std::size_t>(1, (static_cast<std::size_t>(k + 1) * n + kRatios - 1) / kRatios);
      const std::vector<double> t(ts.begin(),
                                  ts.begin() + static_cast<std::ptrdiff_t>(std::min(m, n)));
      const std::vector<TouchObservation> ob(
          obs.begin(), obs.begin() + static_cast<std::ptrdiff_t>(std::min(m, n)));
      const bool ok = n > 0 && std::string(to_string(sequence_direction(t, ob, fc))) == truth;
      for (Curve* c : curves) c->correct[static_cast<std::size_t>(k)] += ok ? 1 : 0;
    }
  }
  return r;
}

// ----------------------------------------------------------------------------------------------
// Contact vs hover ROC

// The edge gates tried when picking: 1 .. 30 px in steps of 0.5.
std::vector<double> candidate_gates() {
  std::vector<double> g;
  for (int k = 2; k <= 60; ++k) g.push_back(k / 2.0);
  return g;
}

struct RocResult {
  std::vector<RocCurve> curves;
  double gate = 0;
  bool gate_picked = false;
  int pick_frames = 0;
};

RocResult evaluate_roc(const Options& o, const Segmenter& seg, const Segmenter& sim_seg,
                       sim::Renderer& renderer) {
  RocResult r;
  r.gate = o.roc_gate;
  if (r.gate <= 0) { // pick on generator frames of another seed, with the generator calibration
    ContactRoc pick(sim_seg);
    add_sim_frames(pick, renderer, sim::derive_seed(o.calib_seed, 0x50C), o.roc_pick_frames);
    r.gate = pick_contact_edge_gate(pick, candidate_gates());
    r.gate_picked = true;
    r.pick_frames = o.roc_pick_frames;
  }
  ContactRoc roc(seg);
  const Metadata md = read_metadata(o.tracking / "metadata.csv");
  for (const MetadataRow& row : md.rows) {
    const bool positive = row.contact_box.has_value();
    if (!positive && row.label != "hover") continue; // negatives: hovering hands only
    roc.add(read_image(md, row), row.contact_box, positive);
  }
  detail::require<DatasetError>(roc.positives() > 0 && roc.negatives() > 0,
                                md.csv_path.string() + ": " + std::to_string(roc.positives()) +
                                    " frames with a contact and " +
                                    std::to_string(roc.negatives()) +
                                    " hover frames; the ROC needs at least one of each");
  for (ContactCue c : all_contact_cues)
    r.curves.push_back(roc.curve(c, c == ContactCue::joint_sharp ? r.gate : 0.0));
  return r;
}

void write_roc_csv(const fs::path& path, const RocResult& r) {
  write_file_atomically(path, [&](std::ostream& out) {
    out << "variant,offset,shipped,positives,negatives,true_positives,false_positives,tpr,fpr,"
           "contact_iou,auc,edge_gate_px\n";
    char buf[256];
    for (const RocCurve& c : r.curves)
      for (std::size_t k = 0; k < c.points.size(); ++k) {
        const RocPoint& p = c.points[k];
        std::snprintf(buf, sizeof buf, "%s,%.2f,%d,%d,%d,%d,%d,%.6f,%.6f,%.6f,%.6f,%g\n",
                      to_string(c.cue), p.offset, k == c.shipped ? 1 : 0, c.positives, c.negatives,
                      p.true_positives, p.false_positives, p.tpr, p.fpr, p.contact_iou, c.auc,
                      c.edge_gate_px);
        out << buf;
      }
  });
}

void print_roc(const RocResult& r) {
  const RocCurve& any = r.curves.front();
  std::printf(
      "\nContact vs hover ROC (%d frames with a contact, %d hovering hands; offset %+.2f .. "
      "%+.2f on the contact thresholds)\n",
      any.positives, any.negatives, any.points.front().offset, any.points.back().offset);
  if (r.gate_picked)
    std::printf("sharp-edge gate %.1f px, picked on %d generator frames (largest AUC)\n", r.gate,
                r.pick_frames);
  else
    std::printf("sharp-edge gate %.1f px (--roc-gate)\n", r.gate);
  std::printf("%-32s %6s   %-28s %12s\n", "variant", "AUC", "shipped point: FPR TPR IoU",
              "TPR@FPR<=5%");
  for (const RocCurve& c : r.curves) {
    const RocPoint& p = c.points[c.shipped];
    std::printf("%-32s %6.4f   %6.4f %6.4f %6.4f        %12.4f\n", to_string(c.cue), c.auc, p.fpr,
                p.tpr, p.contact_iou, tpr_at_fpr(c, 0.05));
  }
}

// ----------------------------------------------------------------------------------------------
// Temporal touch gestures

struct TemporalRate {
  TemporalEvalResult result;
  int sequences = 0;
  double pipeline_ms = 0, decode_ms = 0; // summed over the frames
  std::size_t classified = 0;            // frames the classifier ran on (--temporal-shapes model)
};

cv::Mat read_temporal_frame(const TemporalSequence& seq, const TemporalFrameRow& f) {
  const std::string at = seq.frames_csv.string() + ":" + std::to_string(f.line) + ": ";
  const fs::path p = detail::inside_folder(seq.folder, f.file_name, at + "column 2 'file_name': ");
  return detail::image_file(p, cv::IMREAD_COLOR, {}, at + "cannot read image: ", true);
}

std::map<double, TemporalRate>
evaluate_temporal_dataset(const Options& o, const std::vector<TemporalSequenceRow>& rows,
                          const SimCalibration& cal, const std::optional<ModelFile>& model) {
  using clock = std::chrono::steady_clock;
  auto ms = [](clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); };
  std::map<double, TemporalRate> rates;
  for (const TemporalSequenceRow& row : rows) {
    const TemporalSequence seq = read_temporal_sequence(o.temporal, row);
    TemporalRate& rate = rates[row.fps];
    TemporalGestureConfig tc;
    tc.px_per_cm = o.px_per_cm > 0 ? o.px_per_cm : row.px_per_cm;
    TemporalEventLog log;
    const double end_ms = seq.frames.back().timestamp_ms + 1000.0 / row.fps;
    if (model) {
      // The system as ss_track runs it: the classifier gated by the shadow feeds the recogniser.
      Runtime sense(TouchPipeline{segmenter_from(cal)}, make_densenet_classifier(*model),
                    RuntimeConfig{.temporal = tc});
      for (const TemporalFrameRow& f : seq.frames) {
        const auto t0 = clock::now();
        const cv::Mat img = read_temporal_frame(seq, f);
        const auto t1 = clock::now();
        const RuntimeFrame& r = sense.update(img, f.timestamp_ms);
        log.add(r.touch_gestures);
        rate.classified += r.classified ? 1 : 0;
        rate.decode_ms += ms(t1 - t0);
        rate.pipeline_ms += ms(clock::now() - t1);
      }
      log.add(sense.flush(end_ms).touch_gestures);
    } else {
      TouchPipeline pipeline(segmenter_from(cal));
      TemporalGestureRecogniser recogniser(tc);
      OutputGesture shape;
      for (const TemporalFrameRow& f : seq.frames) {
        const auto t0 = clock::now();
        const cv::Mat img = read_temporal_frame(seq, f);
        const auto t1 = clock::now();
        const TouchFrame& touch = pipeline.update(img, f.timestamp_ms);
        shape.available = o.temporal_shapes == "file" && !f.shape.empty();
        shape.label = shape.available ? f.shape : std::string();
        shape.confidence = static_cast<float>(f.shape_confidence);
        log.add(recogniser.update(touch, shape));
        rate.decode_ms += ms(t1 - t0);
        rate.pipeline_ms += ms(clock::now() - t1);
      }
      log.add(recogniser.flush(end_ms));
    }
    std::vector<sim::TouchGestureTruth> truth;
    for (const TemporalGestureRow& g : seq.gestures)
      truth.push_back({g.gesture, g.track_id, g.start_ms, g.end_ms, g.repetitions, g.direction});
    score_temporal(truth, log.last(), 1000.0 / row.fps, TemporalTrackMatch::any_track, rate.result);
    rate.result.frames += seq.frames.size();
    ++rate.result.users;
    ++rate.sequences;
  }
  return rates;
}

// The confusion matrix of one frame rate as an image: rows truth, columns predicted (the last
// row and column: none), cells shaded by the row-normalised rate, counts written in.
void write_temporal_confusion_png(const fs::path& path, const TemporalEvalResult& r,
                                  const std::string& title) {
  const int n = static_cast<int>(TemporalEvalResult::n) + 1, cell = 56, left = 100, top = 70;
  cv::Mat img(top + n * cell + 20, left + n * cell + 20, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::putText(img, title, {10, 22}, cv::FONT_HERSHEY_SIMPLEX, 0.55, {0, 0, 0}, 1, cv::LINE_AA);
  auto name = [](int i) {
    return i < static_cast<int>(TemporalEvalResult::n)
               ? std::string(to_string(all_touch_gestures[static_cast<std::size_t>(i)]))
               : std::string("none");
  };
  for (int i = 0; i < n; ++i) {
    const auto& row = r.confusion[static_cast<std::size_t>(i)];
    int total = 0;
    for (int v : row) total += v;
    cv::putText(img, name(i), {5, top + i * cell + cell / 2 + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.42,
                {0, 0, 0}, 1, cv::LINE_AA);
    cv::putText(img, name(i).substr(0, 7), {left + i * cell + 2, top - 8}, cv::FONT_HERSHEY_SIMPLEX,
                0.36, {0, 0, 0}, 1, cv::LINE_AA);
    for (int j = 0; j < n; ++j) {
      const int v = row[static_cast<std::size_t>(j)];
      const double f = total ? static_cast<double>(v) / total : 0;
      const cv::Rect box(left + j * cell, top + i * cell, cell - 2, cell - 2);
      cv::rectangle(img, box, cv::Scalar(255 - 40 * f, 255 - 120 * f, 255 - 200 * f), cv::FILLED);
      const cv::Scalar ink = f > 0.6 ? cv::Scalar(255, 255, 255) : cv::Scalar(0, 0, 0);
      cv::putText(img, std::to_string(v), {box.x + 6, box.y + 32}, cv::FONT_HERSHEY_SIMPLEX, 0.5,
                  ink, 1, cv::LINE_AA);
    }
  }
  frames::write_png_atomically(path, img); // temp + rename, checked
}

void write_temporal_json(const Options& o, const std::map<double, TemporalRate>& rates) {
  cli::JsonWriter j;
  j.begin_object().field("schema", "shadowsense.temporal_eval/1");
  j.field("dataset", o.temporal.string()).field("shapes", o.temporal_shapes);
  j.key("rates").begin_array();
  for (const auto& [fps, rate] : rates) {
    const TemporalEvalResult& r = rate.result;
    const double frames = static_cast<double>(std::max<std::size_t>(1, r.frames));
    j.begin_object().field("fps", fps).field("sequences", rate.sequences);
    j.field("frames", r.frames).field("macro_f1", r.macro_f1());
    j.field("repetition_errors", r.repetition_errors);
    j.field("ms_per_frame", rate.pipeline_ms / frames);
    j.field("decode_ms_per_frame", rate.decode_ms / frames);
    j.field("classified_frames", rate.classified);
    j.key("latency_ms").begin_object(cli::JsonWriter::compact);
    j.field("p50", r.latency_quantile(TemporalEvalResult::n, 0.5));
    j.field("p90", r.latency_quantile(TemporalEvalResult::n, 0.9));
    j.field("max", r.latency_quantile(TemporalEvalResult::n, 1.0)).end_object();
    j.key("gestures").begin_object();
    for (std::size_t g = 0; g < TemporalEvalResult::n; ++g) {
      j.key(std::string(to_string(all_touch_gestures[g]))).begin_object(cli::JsonWriter::compact);
      j.field("tp", r.tp[g]).field("fp", r.fp[g]).field("fn", r.fn[g]);
      j.field("precision", r.precision(g)).field("recall", r.recall(g)).field("f1", r.f1(g));
      j.field("latency_p50_ms", r.latency_quantile(g, 0.5)).end_object();
    }
    j.end_object();
    // Rows truth, columns predicted, in `labels` order (the last one: none).
    j.key("labels").begin_array(cli::JsonWriter::compact);
    for (TouchGesture g : all_touch_gestures) j.value(std::string(to_string(g)));
    j.value("none").end_array();
    j.key("confusion").begin_array();
    for (const auto& row : r.confusion) {
      j.begin_array(cli::JsonWriter::compact);
      for (int v : row) j.value(v);
      j.end_array();
    }
    j.end_array().end_object();
  }
  j.end_array().end_object();
  j.save(o.json);
}

int run_temporal(const Options& o, const char* argv0) {
  // Refuse a missing or bad dataset before the calibration's rendering.
  const std::vector<TemporalSequenceRow> rows = read_temporal_sequences(o.temporal);
  detail::require<DatasetError>(!rows.empty(),
                                (o.temporal / "sequences.csv").string() + ": lists no sequence");
  const TemporalSequence first = read_temporal_sequence(o.temporal, rows.front());
  const cv::Size size = read_temporal_frame(first, first.frames.front()).size();
  const sim::Rig rig =
      size == sim::Rig::robot().image_size ? sim::Rig::robot() : sim::Rig::tracking_box();
  if (!o.temporal_confusion.empty()) fs::create_directories(o.temporal_confusion);
  sim::Renderer renderer(rig);
  Segmenter::Config base;
  base.calibration.mode = o.mode;
  SimCalibration cal = calibrate_on_sim(renderer, o.calib_seed, o.calib_frames, base);
  if (!o.calibration_in.empty())
    cal.config.calibration = load_calibration(o.calibration_in.string());
  cal.config.calibration.mode = o.mode;
  if (!o.calibration_out.empty())
    save_calibration(cal.config.calibration, o.calibration_out.string());
  std::cout << "calibration: " << o.calib_frames << " generator frames (" << rig.name
            << " rig), seed " << o.calib_seed
            << (o.calibration_in.empty() ? ""
                                         : " (thresholds from " + o.calibration_in.string() + ")")
            << "\nhand-shape reading: ";
  std::optional<ModelFile> model;
  std::string model_what;
  if (o.temporal_shapes == "model") {
    const fs::path path = o.model.empty() ? cli::find_default_model(argv0, &model_what) : o.model;
    model = ModelFile::load(path.string());
    std::cout << "the classifier, " << path.string()
              << (model_what.empty() ? "" : " (" + model_what + ")") << "\n";
  } else {
    std::cout << (o.temporal_shapes == "file" ? "the dataset's shape column"
                                              : "none (contact area)")
              << "\n";
  }
  const std::map<double, TemporalRate> rates = evaluate_temporal_dataset(o, rows, cal, model);
  for (const auto& [fps, rate] : rates) {
    const TemporalEvalResult& r = rate.result;
    std::printf("\n== temporal gestures at %g fps: %d sequences (rendered frames)\n", fps,
                rate.sequences);
    std::cout << format_temporal_eval(r);
    const double frames = static_cast<double>(std::max<std::size_t>(1, r.frames));
    std::printf("summary %g fps: macro-F1 %.4f, latency p50 %.0f ms, p90 %.0f ms, max %.0f ms, "
                "repetition errors %d; %.3f ms per frame (segmenter + touch pipeline + "
                "%srecogniser), %.3f ms per frame decoding the image\n",
                fps, r.macro_f1(), r.latency_quantile(TemporalEvalResult::n, 0.5),
                r.latency_quantile(TemporalEvalResult::n, 0.9),
                r.latency_quantile(TemporalEvalResult::n, 1.0), r.repetition_errors,
                rate.pipeline_ms / frames, model ? "classifier + " : "", rate.decode_ms / frames);
    if (model)
      std::printf("classifier ran on %zu of %zu frames (gated by the shadow)\n", rate.classified,
                  r.frames);
    if (!o.temporal_confusion.empty()) {
      char name[64], title[128];
      std::snprintf(name, sizeof name, "temporal_confusion_%gfps.png", fps);
      std::snprintf(title, sizeof title,
                    "temporal gestures at %g fps, %d sequences: rows truth, columns predicted", fps,
                    rate.sequences);
      write_temporal_confusion_png(o.temporal_confusion / name, r, title);
    }
  }
  if (!o.json.empty()) write_temporal_json(o, rates);
  return 0;
}

// ----------------------------------------------------------------------------------------------
// Output

std::string num(double v, int decimals = 4) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string pct(int k, int n) {
  return n ? num(100.0 * k / n, 1) + "%" : "n/a";
}

void print_table5(const std::map<std::string, CategoryResult>& t) {
  std::cout << "\nTable 5 - tracking accuracy (mean (SD)); centre error in cm\n";
  const char* cats[] = {"hover", "palm", "fist", "finger"};
  auto row = [&](const std::string& name, auto get) {
    std::printf("%-26s", name.c_str());
    for (const char* c : cats) {
      auto it = t.find(c);
      std::printf(" %16s", it == t.end() ? "-" : get(it->second.shadow).c_str());
    }
    for (const char* c : cats) {
      if (std::string(c) == "hover") continue;
      auto it = t.find(c);
      std::printf(" %16s", it == t.end() ? "-" : get(it->second.contact).c_str());
    }
    std::printf("\n");
  };
  std::printf("%-26s %16s %16s %16s %16s %16s %16s %16s\n", "", "shadow hover", "shadow palm",
              "shadow fist", "shadow finger", "contact palm", "contact fist", "contact finger");
  auto ms = [](const RunningStats& r) { return num(r.mean(), 3) + " (" + num(r.sd(), 3) + ")"; };
  row("error in X, cm", [&](const ClassStats& s) { return ms(s.err_x); });
  row("error in Y, cm", [&](const ClassStats& s) { return ms(s.err_y); });
  row("IoU", [&](const ClassStats& s) { return ms(s.iou); });
  row("tracking error", [&](const ClassStats& s) { return pct(s.missed, s.truth); });
  row("frames with truth", [&](const ClassStats& s) { return std::to_string(s.truth); });
  if (auto it = t.find("nothing"); it != t.end())
    std::printf("false positives on nothing: shadow %d / %d, contact %d / %d\n",
                it->second.shadow.false_positives, it->second.frames,
                it->second.contact.false_positives, it->second.frames);
  if (auto it = t.find("hover"); it != t.end())
    std::printf("false contact on hover: %d / %d\n", it->second.contact.false_positives,
                it->second.frames);
  for (const auto& [name, c] : t) {
    if (name == "nothing" || name == "hover" || name == "palm" || name == "fist" ||
        name == "finger")
      continue;
    std::printf(
        "%s (%d frames): shadow IoU %.3f (%.3f), missed %d, false pos. %d; contact IoU %.3f "
        "(%.3f), missed %d, false pos. %d\n",
        name.c_str(), c.frames, c.shadow.iou.mean(), c.shadow.iou.sd(), c.shadow.missed,
        c.shadow.false_positives, c.contact.iou.mean(), c.contact.iou.sd(), c.contact.missed,
        c.contact.false_positives);
  }
}

void print_figure14(const SlideResults& r) {
  std::cout << "\nFigure 14 - direction accuracy vs observed ratio (" << r.overall.sequences
            << " sequences; no contact found in " << r.no_touch << ")\n";
  std::printf("%-10s", "ratio");
  for (int k = 0; k < kRatios; ++k) std::printf(" %5.1f", (k + 1) / 10.0);
  std::printf("\n");
  auto line = [](const std::string& name, const Curve& c) {
    std::printf("%-10s", name.c_str());
    for (int k = 0; k < kRatios; ++k)
      std::printf(" %5.3f",
                  c.sequences
                      ? static_cast<double>(c.correct[static_cast<std::size_t>(k)]) / c.sequences
                      : 0.0);
    std::printf("   (n=%d)\n", c.sequences);
  };
  line("all", r.overall);
  for (const auto& [k, c] : r.by_gesture) line(k, c);
  for (const auto& [k, c] : r.by_direction) line(k, c);
}

void json_stats(cli::JsonWriter& j, const ClassStats& s) {
  j.begin_object(cli::JsonWriter::compact);
  j.field("frames", s.frames).field("truth", s.truth).field("missed", s.missed);
  j.field("tracking_error_rate", s.truth ? static_cast<double>(s.missed) / s.truth : 0.0);
  j.field("false_positives", s.false_positives).field("matched", s.iou.count());
  j.field("error_x_cm_mean", s.err_x.mean()).field("error_x_cm_sd", s.err_x.sd());
  j.field("error_y_cm_mean", s.err_y.mean()).field("error_y_cm_sd", s.err_y.sd());
  j.field("iou_mean", s.iou.mean()).field("iou_sd", s.iou.sd());
  j.end_object();
}

void json_curve(cli::JsonWriter& j, const Curve& c) {
  j.begin_object(cli::JsonWriter::compact).field("sequences", c.sequences);
  j.key("accuracy").begin_array();
  for (int k = 0; k < kRatios; ++k)
    j.value(c.sequences ? static_cast<double>(c.correct[static_cast<std::size_t>(k)]) / c.sequences
                        : 0.0);
  j.end_array().end_object();
}

void write_json(const Options& o, const SegmenterCalibration& cal,
                const std::optional<std::map<std::string, CategoryResult>>& t5,
                const std::optional<SlideResults>& f14, const HoverHeightResult& hh,
                const std::optional<RocResult>& roc) {
  cli::JsonWriter j;
  j.begin_object().field("schema", "shadowsense.track_eval/1");
  j.key("calibration").begin_object(cli::JsonWriter::compact);
  j.field("seed", o.calib_seed).field("frames", o.calib_frames);
  j.field("mode", cal.mode == SegmentMode::relative ? "relative" : "fixed_ranges");
  j.field("from_file", !o.calibration_in.empty()).end_object();
  j.key("table5");
  if (t5) {
    j.begin_object();
    for (const auto& [name, c] : *t5) {
      j.key(name).begin_object(cli::JsonWriter::compact).field("frames", c.frames);
      j.key("shadow");
      json_stats(j, c.shadow);
      j.key("contact");
      json_stats(j, c.contact);
      j.end_object();
    }
    j.end_object();
  } else {
    j.value(nullptr);
  }
  j.key("figure14");
  if (f14) {
    j.begin_object();
    j.key("ratios").begin_array(cli::JsonWriter::compact);
    for (int k = 0; k < kRatios; ++k) j.value((k + 1) / 10.0);
    j.end_array().field("sequences_without_contact", f14->no_touch);
    j.key("overall");
    json_curve(j, f14->overall);
    for (const auto& [group, curves] : {std::pair{"by_gesture", &f14->by_gesture},
                                        std::pair{"by_direction", &f14->by_direction}}) {
      j.key(group).begin_object();
      for (const auto& [k, c] : *curves) {
        j.key(k);
        json_curve(j, c);
      }
      j.end_object();
    }
    j.end_object();
  } else {
    j.value(nullptr);
  }
  j.key("hover_height").begin_object(cli::JsonWriter::compact);
  j.field("fit_frames", hh.fit_frames).field("test_frames", hh.test_frames);
  j.field("mae_cm", hh.mae_cm).field("rmse_cm", hh.rmse_cm);
  j.field("baseline_mae_cm", hh.baseline_mae_cm);
  j.key("model").begin_object();
  j.field("intercept", hh.model.intercept).field("per_edge_px", hh.model.per_edge_px);
  j.field("per_opacity", hh.model.per_opacity).end_object();
  j.end_object();
  if (roc) {
    const RocCurve& any = roc->curves.front();
    j.key("contact_roc").begin_object();
    j.field("positives", any.positives).field("negatives", any.negatives);
    j.field("edge_gate_px", roc->gate).field("edge_gate_picked", roc->gate_picked);
    j.field("csv", o.roc.string());
    j.key("variants").begin_object();
    for (const RocCurve& c : roc->curves) {
      const RocPoint& p = c.points[c.shipped];
      j.key(to_string(c.cue)).begin_object(cli::JsonWriter::compact);
      j.field("auc", c.auc).field("shipped_fpr", p.fpr).field("shipped_tpr", p.tpr);
      j.field("shipped_contact_iou", p.contact_iou).field("tpr_at_fpr_5pct", tpr_at_fpr(c, 0.05));
      j.end_object();
    }
    j.end_object().end_object();
  }
  j.end_object();
  j.save(o.json);
}

} // namespace

int main(int argc, char** argv) {
  return cli::run("ss_track_eval", [&] {
    const Options o = parse(argc, argv);
    if (!o.temporal.empty()) return run_temporal(o, argv[0]);
    // The calibration frames are rendered with the rig whose frame size matches the data
    // (tracking box 200x205 or robot 635x350), taken from the first image.
    sim::Rig rig = sim::Rig::tracking_box();
    {
      fs::path csv = o.tracking / "metadata.csv";
      if (!fs::exists(csv) && fs::exists(o.slides / "sequences.csv")) {
        const auto seqs = read_sequences(o.slides / "sequences.csv");
        if (!seqs.empty()) csv = o.slides / seqs.front().sequence / "metadata.csv";
      }
      if (fs::exists(csv)) {
        const Metadata md = read_metadata(csv);
        if (!md.rows.empty() &&
            read_image(md, md.rows.front()).size() == sim::Rig::robot().image_size)
          rig = sim::Rig::robot();
      }
    }
    // Refuse a missing input before the calibration's minute of rendering.
    const bool has_tracking = !o.tracking.empty() && fs::exists(o.tracking / "metadata.csv");
    const bool has_slides = !o.slides.empty() && fs::exists(o.slides / "sequences.csv");
    // A dataset named by --tracking or --slides is required; under --input either may be absent.
    detail::require<DatasetError>(!o.tracking_named || has_tracking,
                                  "--tracking: no dataset at " + o.tracking.string() +
                                      " (expected " + (o.tracking / "metadata.csv").string() + ")");
    detail::require<DatasetError>(!o.slides_named || has_slides,
                                  "--slides: no dataset at " + o.slides.string() + " (expected " +
                                      (o.slides / "sequences.csv").string() + ")");
    if (!has_tracking && !has_slides)
      throw DatasetError(
          "nothing to evaluate: no " +
          (o.tracking.empty() ? std::string("--tracking")
                              : (o.tracking / "metadata.csv").string()) +
          " and no " +
          (o.slides.empty() ? std::string("--slides") : (o.slides / "sequences.csv").string()));
    sim::Renderer renderer(rig);
    Segmenter::Config base;
    base.calibration.mode = o.mode;
    SimCalibration cal = calibrate_on_sim(renderer, o.calib_seed, o.calib_frames, base);
    const SimCalibration sim_cal = cal; // the ROC's edge gate is picked with this one
    if (!o.calibration_in.empty())
      cal.config.calibration = load_calibration(o.calibration_in.string());
    cal.config.calibration.mode = o.mode;
    if (!o.calibration_out.empty())
      save_calibration(cal.config.calibration, o.calibration_out.string());
    Segmenter seg = segmenter_from(cal);
    std::cout << "calibration: " << o.calib_frames << " generator frames (" << rig.name
              << " rig), seed " << o.calib_seed
              << (o.calibration_in.empty()
                      ? ""
                      : " (thresholds" +
                            std::string(cal.config.calibration.empty_skin.empty()
                                            ? ""
                                            : " and empty-skin model") +
                            " from " + o.calibration_in.string() + ")")
              << "\n";

    std::optional<std::map<std::string, CategoryResult>> t5;
    std::optional<SlideResults> f14;
    if (has_tracking) {
      t5 = evaluate_tracking(o, seg);
      print_table5(*t5);
    } else if (!o.tracking.empty()) {
      std::cout << "no tracking dataset at " << o.tracking << "\n";
    }
    if (has_slides) {
      Segmenter slide_seg = segmenter_from(cal);
      f14 = evaluate_slides(o, slide_seg);
      print_figure14(*f14);
    } else if (!o.slides.empty()) {
      std::cout << "no slides dataset at " << o.slides << "\n";
    }
    std::optional<RocResult> roc;
    if (!o.roc.empty()) {
      detail::require<DatasetError>(t5.has_value(), "--roc needs a tracking dataset");
      roc = evaluate_roc(o, seg, segmenter_from(sim_cal), renderer);
      write_roc_csv(o.roc, *roc);
      print_roc(*roc);
    }
    // Hover height: the datasets carry no heights, so fit and test on generator frames (two
    // seeds, both different from the calibration's).
    Segmenter hover_seg = segmenter_from(cal);
    const HoverHeightResult hh =
        evaluate_hover_height(renderer, hover_seg, sim::derive_seed(o.calib_seed, 0x40FE),
                              sim::derive_seed(o.calib_seed, 0x7E57), 200);
    std::printf("\nHover height from penumbra width and core opacity (generator frames, hand 5-20 "
                "cm above the skin):\n  fit on %zu frames, tested on %zu others: MAE %.2f cm, "
                "RMSE %.2f cm (always-the-mean baseline: MAE %.2f cm)\n",
                hh.fit_frames, hh.test_frames, hh.mae_cm, hh.rmse_cm, hh.baseline_mae_cm);
    if (!o.json.empty()) write_json(o, cal.config.calibration, t5, f14, hh, roc);
    return 0;
  });
}
