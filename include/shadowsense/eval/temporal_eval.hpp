// Evaluation of the temporal gesture recogniser (sense/temporal_gestures.hpp) on generated
// sequences (sim/touch_sequences.hpp): per-gesture precision, recall and F1, the confusion
// matrix and the latency from each gesture's end to the event that reported it.
//
// evaluate_temporal(sequence_config, first_user, users, recogniser_config = {})
//   requires: valid configs (InvalidArgument otherwise), users >= 1.
//   ensures:  for each user seed first_user .. first_user + users - 1: the sequence is made, fed
//             frame by frame to a fresh TemporalGestureRecogniser (then flushed one frame after
//             the last), and its events collapsed to the last word per (track_id, start_ms)
//             (a revision replaces the tap, an `ended` the `began`). Each truth is matched to the
//             unmatched prediction on its track whose interval overlaps the truth's (widened by
//             one frame interval on each side), preferring the same gesture: the same gesture is
//             a true positive (latency = that prediction's decided_ms - the truth's end_ms,
//             except for a tap, double tap or pat whose count differs from the truth's: a
//             repetition error, counted apart);
//             another gesture counts in the confusion matrix, as a miss of the truth and a false
//             positive of the prediction; no prediction is a miss (column `none`). Predictions
//             left over are false positives (row `none`).
// TemporalEventLog: the last word per (track_id, start_ms) of a stream of events.
// score_temporal(truth, predictions, widen_ms, scoring, result): the matching above for one
//   sequence, added into result. TemporalScoring says how: which tracks a truth may take its
//   prediction from (ss_track_eval --temporal: TemporalTrackMatch::any_track), and the claim
//   rule - `best_one` above, or `all_overlapping`, the rule pre-registered for the real-timing
//   sources (docs/validation_protocol.md, "Issue 23"; ss_timeline_eval): every unclaimed
//   prediction on the truth's track overlapping it is its own; the first of the truth's gesture
//   is the true positive (latency as above), further ones of that gesture are ignored, each of
//   another gesture is a false positive; without one of its gesture the truth is a miss, counted
//   in the confusion matrix under the first other gesture claimed (or `none`). Options:
//   double_tap_as_tap (a double tap prediction counts as a tap) and repetitions (false: no
//   repetition errors; every true positive's latency counts).
//   score_temporal(truth, predictions, widen_ms, match, result) = best_one with that match.
// format_temporal_eval(result) -> text: the per-gesture table, macro-F1, the confusion matrix
//   and the latency quantiles.
// Plain values; no shared state (any thread).
#pragma once

#include <shadowsense/sense/temporal_gestures.hpp>
#include <shadowsense/sim/touch_sequences.hpp>

#include <algorithm>
#include <array>
#include <cstdio>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

struct TemporalEvalResult {
  static constexpr std::size_t n = all_touch_gestures.size(); // + 1 for none
  std::array<int, n> tp{}, fp{}, fn{};
  std::array<std::array<int, n + 1>, n + 1> confusion{}; // [truth][predicted], n = none
  std::array<std::vector<double>, n> latency_ms;         // per true positive
  std::size_t frames = 0, users = 0;
  // True positives of tap, double_tap or pat with another count of repetitions than the truth
  // (left out of the latencies).
  int repetition_errors = 0;

  double precision(std::size_t g) const {
    return tp[g] + fp[g] ? static_cast<double>(tp[g]) / (tp[g] + fp[g]) : 0.0;
  }
  double recall(std::size_t g) const {
    return tp[g] + fn[g] ? static_cast<double>(tp[g]) / (tp[g] + fn[g]) : 0.0;
  }
  double f1(std::size_t g) const {
    const double p = precision(g), r = recall(g);
    return p + r > 0 ? 2 * p * r / (p + r) : 0.0;
  }
  // Mean F1 over the gestures that occur in the truth or the predictions.
  double macro_f1() const {
    double sum = 0;
    int count = 0;
    for (std::size_t g = 0; g < n; ++g)
      if (tp[g] + fp[g] + fn[g] > 0) sum += f1(g), ++count;
    return count ? sum / count : 0.0;
  }
  // The q-quantile (0..1, nearest rank) of the latencies of gesture g, or of all with g = n.
  double latency_quantile(std::size_t g, double q) const {
    std::vector<double> v;
    for (std::size_t k = 0; k < n; ++k)
      if (g == n || g == k) v.insert(v.end(), latency_ms[k].begin(), latency_ms[k].end());
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    const auto i = static_cast<std::size_t>(std::clamp(q, 0.0, 1.0) * (v.size() - 1) + 0.5);
    return v[i];
  }
};

// Keeps the last word per (track_id, start_ms) of a recogniser's events: a revision replaces
// the tap, an `ended` the `began`.
class TemporalEventLog {
public:
  template <class Events>
  void add(const Events& events) {
    for (const GestureEvent& e : events) {
      auto it = std::find_if(last_.begin(), last_.end(), [&](const GestureEvent& x) {
        return x.track_id == e.track_id && x.start_ms == e.start_ms;
      });
      if (it == last_.end())
        last_.push_back(e);
      else
        *it = e;
    }
  }
  const std::vector<GestureEvent>& last() const { return last_; }

private:
  std::vector<GestureEvent> last_;
};

// How a truth finds its prediction's track: the same id (the generator's tracks are fed to the
// recogniser as they are), or any track gesture for a track truth (track_id > 0) and track 0
// for track 0 (rendered frames: the runtime's tracker numbers the hands itself; the generated
// hands never overlap in time).
enum class TemporalTrackMatch { same_id, any_track };

// Which predictions a truth takes (see the specification above).
enum class TemporalClaim { best_one, all_overlapping };

struct TemporalScoring {
  TemporalTrackMatch match = TemporalTrackMatch::same_id;
  TemporalClaim claim = TemporalClaim::best_one;
  bool double_tap_as_tap = false; // a source that does not separate them (CoST, touch logs)
  bool repetitions = true;        // count repetition errors of tap, double_tap and pat
};

namespace detail {

inline bool same_track(TemporalTrackMatch match, int truth_id, int predicted_id) {
  return match == TemporalTrackMatch::same_id ? truth_id == predicted_id
                                              : (truth_id > 0) == (predicted_id > 0);
}

// The pre-registered rule of the real-timing sources: a truth claims every prediction on its
// track that overlaps it.
inline void score_all_overlapping(const std::vector<sim::TouchGestureTruth>& truth,
                                  const std::vector<GestureEvent>& last, double widen_ms,
                                  const TemporalScoring& scoring, TemporalEvalResult& out) {
  const std::size_t none = TemporalEvalResult::n;
  auto gesture_of = [&](const GestureEvent& e) {
    return scoring.double_tap_as_tap && e.gesture == TouchGesture::double_tap ? TouchGesture::tap
                                                                              : e.gesture;
  };
  std::vector<bool> used(last.size(), false);
  for (const sim::TouchGestureTruth& t : truth) {
    const auto tg = static_cast<std::size_t>(t.gesture);
    bool hit = false;
    std::size_t other = last.size();
    for (std::size_t k = 0; k < last.size(); ++k) {
      const GestureEvent& e = last[k];
      if (used[k] || !same_track(scoring.match, t.track_id, e.track_id)) continue;
      if (e.end_ms < t.start_ms - widen_ms || e.start_ms > t.end_ms + widen_ms) continue;
      used[k] = true;
      const auto pg = static_cast<std::size_t>(gesture_of(e));
      if (pg == tg) {
        if (hit) continue; // repeated contacts of one labelled capture
        hit = true;
        ++out.tp[tg];
        ++out.confusion[tg][tg];
        out.latency_ms[tg].push_back(e.decided_ms - t.end_ms);
      } else {
        ++out.fp[pg];
        if (other == last.size()) other = k;
      }
    }
    if (!hit) {
      ++out.fn[tg];
      ++out.confusion[tg][other == last.size() ? none
                                               : static_cast<std::size_t>(gesture_of(last[other]))];
    }
  }
  for (std::size_t k = 0; k < last.size(); ++k)
    if (!used[k]) {
      const auto pg = static_cast<std::size_t>(gesture_of(last[k]));
      ++out.fp[pg];
      ++out.confusion[none][pg];
    }
}

} // namespace detail

// Scores one sequence's collapsed predictions against its truth into `out` (as
// evaluate_temporal says), widening each truth interval by widen_ms on each side.
inline void score_temporal(const std::vector<sim::TouchGestureTruth>& truth,
                           const std::vector<GestureEvent>& predictions, double widen_ms,
                           const TemporalScoring& scoring, TemporalEvalResult& out) {
  if (scoring.claim == TemporalClaim::all_overlapping)
    return detail::score_all_overlapping(truth, predictions, widen_ms, scoring, out);
  const std::size_t none = TemporalEvalResult::n;
  std::vector<GestureEvent> mapped;
  if (scoring.double_tap_as_tap) {
    mapped = predictions;
    for (GestureEvent& e : mapped)
      if (e.gesture == TouchGesture::double_tap) e.gesture = TouchGesture::tap;
  }
  const std::vector<GestureEvent>& last = scoring.double_tap_as_tap ? mapped : predictions;
  std::vector<bool> used(last.size(), false);
  for (const sim::TouchGestureTruth& t : truth) {
    const auto tg = static_cast<std::size_t>(t.gesture);
    std::size_t best = last.size();
    for (std::size_t k = 0; k < last.size(); ++k) {
      const GestureEvent& p = last[k];
      if (used[k] || !detail::same_track(scoring.match, t.track_id, p.track_id)) continue;
      if (p.end_ms < t.start_ms - widen_ms || p.start_ms > t.end_ms + widen_ms) continue;
      if (best == last.size() || (p.gesture == t.gesture && last[best].gesture != t.gesture))
        best = k;
    }
    if (best == last.size()) {
      ++out.fn[tg];
      ++out.confusion[tg][none];
      continue;
    }
    used[best] = true;
    const GestureEvent& p = last[best];
    const auto pg = static_cast<std::size_t>(p.gesture);
    ++out.confusion[tg][pg];
    if (pg == tg) {
      ++out.tp[tg];
      const bool counted = t.gesture == TouchGesture::tap ||
                           t.gesture == TouchGesture::double_tap || t.gesture == TouchGesture::pat;
      if (scoring.repetitions && counted && p.repetitions != t.repetitions)
        ++out.repetition_errors; // e.g. a pat split in two: its event came before the end
      else
        out.latency_ms[tg].push_back(p.decided_ms - t.end_ms);
    } else {
      ++out.fn[tg];
      ++out.fp[pg];
    }
  }
  for (std::size_t k = 0; k < last.size(); ++k)
    if (!used[k]) {
      const auto pg = static_cast<std::size_t>(last[k].gesture);
      ++out.fp[pg];
      ++out.confusion[none][pg];
    }
}

inline void score_temporal(const std::vector<sim::TouchGestureTruth>& truth,
                           const std::vector<GestureEvent>& predictions, double widen_ms,
                           TemporalTrackMatch match, TemporalEvalResult& out) {
  score_temporal(truth, predictions, widen_ms, TemporalScoring{.match = match}, out);
}

inline TemporalEvalResult evaluate_temporal(const sim::TouchSequenceConfig& config,
                                            std::uint64_t first_user, int users,
                                            const TemporalGestureConfig& recogniser = {}) {
  detail::require(users >= 1, "evaluate_temporal: users must be >= 1");
  config.validate();
  TemporalEvalResult out;
  const double widen = 1000.0 / config.fps;
  for (int u = 0; u < users; ++u) {
    const sim::TouchSequence seq =
        sim::make_touch_sequence(config, first_user + static_cast<std::uint64_t>(u));
    TemporalGestureRecogniser r(recogniser);
    TemporalEventLog log;
    for (std::size_t i = 0; i < seq.frames.size(); ++i)
      log.add(r.update(seq.frames[i], seq.shapes[i]));
    log.add(r.flush(seq.frames.empty() ? 0.0 : seq.frames.back().timestamp_ms + widen));
    out.frames += seq.frames.size();
    ++out.users;
    score_temporal(seq.truth, log.last(), widen, TemporalTrackMatch::same_id, out);
  }
  return out;
}

inline std::string format_temporal_eval(const TemporalEvalResult& r) {
  std::string s;
  char line[256];
  std::snprintf(line, sizeof line, "%zu users, %zu frames; repetition errors %d\n", r.users,
                r.frames, r.repetition_errors);
  s += line;
  s += "gesture      precision recall  F1     n_true latency_ms(p50 p90 max)\n";
  for (std::size_t g = 0; g < TemporalEvalResult::n; ++g) {
    std::snprintf(line, sizeof line, "%-12s %.3f     %.3f   %.3f  %-6d %.0f %.0f %.0f\n",
                  to_string(all_touch_gestures[g]), r.precision(g), r.recall(g), r.f1(g),
                  r.tp[g] + r.fn[g], r.latency_quantile(g, 0.5), r.latency_quantile(g, 0.9),
                  r.latency_quantile(g, 1.0));
    s += line;
  }
  std::snprintf(line, sizeof line,
                "macro-F1 %.4f; latency over all gestures p50 %.0f ms, p90 %.0f "
                "ms\nconfusion (rows truth, columns predicted; last: none)\n",
                r.macro_f1(), r.latency_quantile(TemporalEvalResult::n, 0.5),
                r.latency_quantile(TemporalEvalResult::n, 0.9));
  s += line;
  for (std::size_t a = 0; a <= TemporalEvalResult::n; ++a) {
    std::snprintf(line, sizeof line, "%-11s",
                  a < TemporalEvalResult::n ? to_string(all_touch_gestures[a]) : "none");
    s += line;
    for (std::size_t b = 0; b <= TemporalEvalResult::n; ++b) {
      std::snprintf(line, sizeof line, " %4d", r.confusion[a][b]);
      s += line;
    }
    s += '\n';
  }
  return s;
}

SHADOWSENSE_NAMESPACE_END
