// Scores the temporal gesture recogniser (sense/temporal_gestures.hpp) on contact timelines from
// outside the generator: a folder with timeline.csv and truth.csv as written by
// tools/realhand/cost_timeline.py (issue 23's independent real timing; recipe and scoring rule
// pre-registered in docs/validation_protocol.md, "Issue 23").
//
//   ss_timeline_eval --input DIR [--fps F] [--px-per-cm S]
//
// timeline.csv: sequence,time_ms,track,contact,x_px,y_px,area_px (rows of one frame together,
// frames in time order within a sequence; track 0 = a frame without any track; contact 0 = the
// track hovers). truth.csv: sequence,track,gesture,start_ms,end_ms[,...] (gesture by its name).
// Each sequence is fed to a fresh TemporalGestureRecogniser with TemporalGestureConfig{} (only
// px_per_cm may be set), without a classifier reading, and flushed one frame after its end.
// Scoring (pre-registered): events collapsed to the last word per (track, start_ms); per truth,
// the predictions on its track overlapping it (widened by 1000 / fps ms) are its own; one of
// the truth's gesture is a true positive (double_tap counts as tap), further ones of that gesture
// are ignored, others are false positives; no prediction of the truth's gesture is a miss.
// Predictions overlapping no truth are false positives. Prints the table of
// eval/temporal_eval.hpp (format_temporal_eval) and the number of rows read. Both csv files
// must be regular files of at most 1 GiB (a FIFO or device is refused naming it, exit 2).
#include <shadowsense/eval/temporal_eval.hpp>
#include <shadowsense/io/dataset.hpp>

#include "common/cli.hpp"

#include <map>

using namespace shadowsense;

namespace {

double number(const std::string& s, const std::string& where) {
  double v = 0;
  const char* b = s.data();
  const auto [p, ec] = std::from_chars(b, b + s.size(), v);
  if (ec != std::errc() || p != b + s.size() || !std::isfinite(v))
    throw InvalidArgument(where + ": not a number: '" + s + "'");
  return v;
}

// The rows after the header, empty lines skipped. The text is read as the dataset reader reads
// its csv files (io/dataset.hpp): a regular file of bounded size, so a FIFO or a device given
// as input is refused naming the file instead of hanging or growing without bound.
std::vector<std::vector<std::string>> read_csv(const std::filesystem::path& path,
                                               std::size_t min_columns,
                                               const std::string& first_header) {
  const std::string text = detail::read_csv_text(path);
  const std::vector<std::string> lines = detail::csv_lines(text, path);
  if (detail::split_csv(lines[0])[0] != first_header)
    throw InvalidArgument(path.string() + ": expected a header starting with '" + first_header +
                          "'");
  std::vector<std::vector<std::string>> rows;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    if (lines[i].empty()) continue;
    const std::vector<std::string_view> cells = detail::split_csv(lines[i]);
    if (cells.size() < min_columns)
      throw InvalidArgument(path.string() + ": line " + std::to_string(i + 1) + " has " +
                            std::to_string(cells.size()) + " columns, expected at least " +
                            std::to_string(min_columns));
    rows.emplace_back(cells.begin(), cells.end());
  }
  return rows;
}

struct Truth {
  TouchGesture gesture;
  int track;
  double start, end;
};

} // namespace

int main(int argc, char** argv) {
  return cli::run("ss_timeline_eval", [&] {
    std::string input;
    double fps = 30;
    TemporalGestureConfig config;
    cli::Parser p("ss_timeline_eval",
                  "Scores the temporal gesture recogniser on contact timelines (timeline.csv, "
                  "truth.csv; tools/realhand/cost_timeline.py).");
    p.option("--input", "DIR", "folder with timeline.csv and truth.csv", input).required();
    p.option("--fps", "F", "the timelines' frame rate (matching widens by one frame)", fps)
        .range(5.0, 240.0);
    p.option("--px-per-cm", "S", "recogniser's image scale (default 7.6)", config.px_per_cm)
        .range(0.1, 1000.0);
    p.parse(argc, argv);
    config.validate();
    const std::filesystem::path dir(input);
    if (!std::filesystem::is_directory(dir))
      throw cli::UsageError("--input: not a folder: " + input);
    const auto tl = read_csv(dir / "timeline.csv", 7, "sequence");
    const auto tr = read_csv(dir / "truth.csv", 5, "sequence");

    // frames per sequence, in file order
    std::map<long, std::vector<TouchFrame>> frames;
    for (std::size_t i = 0; i < tl.size(); ++i) {
      const auto& r = tl[i];
      const std::string where = "timeline.csv row " + std::to_string(i + 2);
      const long seq = static_cast<long>(number(r[0], where));
      const double t = number(r[1], where);
      const int track = static_cast<int>(number(r[2], where));
      auto& fs = frames[seq];
      if (fs.empty() || fs.back().timestamp_ms != t) {
        if (!fs.empty() && t <= fs.back().timestamp_ms)
          throw InvalidArgument(where + ": time_ms not increasing within its sequence");
        fs.emplace_back();
        fs.back().timestamp_ms = t;
      }
      if (track == 0) continue;
      TouchTrack k;
      k.id = track;
      k.matched = true;
      if (r[3] == "1") {
        const float x = static_cast<float>(number(r[4], where));
        const float y = static_cast<float>(number(r[5], where));
        k.contact = cv::Point2f(x, y);
        k.position = *k.contact;
        k.contact_area = number(r[6], where);
      } else if (r[3] != "0") {
        throw InvalidArgument(where + ": contact must be 0 or 1");
      }
      fs.back().tracks.push_back(k);
    }
    std::map<long, std::vector<Truth>> truth;
    for (std::size_t i = 0; i < tr.size(); ++i) {
      const auto& r = tr[i];
      const std::string where = "truth.csv row " + std::to_string(i + 2);
      truth[static_cast<long>(number(r[0], where))].push_back(
          {touch_gesture_from_string(r[2]), static_cast<int>(number(r[1], where)),
           number(r[3], where), number(r[4], where)});
    }

    TemporalEvalResult out;
    const double widen = 1000.0 / fps;
    const OutputGesture no_reading; // a pressure grid has no hand-shape reading
    // The pre-registered rule (docs/validation_protocol.md, "Issue 23").
    const TemporalScoring scoring{.match = TemporalTrackMatch::same_id,
                                  .claim = TemporalClaim::all_overlapping,
                                  .double_tap_as_tap = true,
                                  .repetitions = false};
    for (auto& [seq, fs] : frames) {
      TemporalGestureRecogniser rec(config);
      TemporalEventLog log; // the last word per (track, start), as evaluate_temporal keeps it
      for (const TouchFrame& f : fs) log.add(rec.update(f, no_reading));
      log.add(rec.flush(fs.back().timestamp_ms + widen));
      std::vector<sim::TouchGestureTruth> seq_truth;
      for (const Truth& t : truth[seq])
        seq_truth.push_back({t.gesture, t.track, t.start, t.end, 1, Direction::none});
      score_temporal(seq_truth, log.last(), widen, scoring, out);
      out.frames += fs.size();
      ++out.users;
    }
    std::cout << "sequences " << out.users << ", timeline rows " << tl.size() << ", truths "
              << tr.size() << " (double_tap counted as tap; no repetition scoring)\n"
              << format_temporal_eval(out);
    return 0;
  });
}
