// The temporal gesture dataset (io/temporal_dataset.hpp, sim/touch_sequence_writer.hpp): a
// small rendered dataset round-trips through writer and reader exactly as make_touch_sequence
// made it; scoring the recogniser against the truth read back gives evaluate_temporal's figures;
// ss_track_eval --temporal on it prints the figures of the same pipeline run here (with the
// dataset's shape column, or with the classifier in the Runtime and --json); bad files
// give a DatasetError naming file, line and column.
#include <shadowsense/eval.hpp>
#include <shadowsense/eval/temporal_eval.hpp>
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/io/temporal_dataset.hpp>
#include <shadowsense/runtime/densenet_runtime.hpp>
#include <shadowsense/sim/touch_sequence_writer.hpp>

#include "common/files.hpp"
#include "common/run_program.hpp"

#include <doctest/doctest.h>

#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <fstream>
#include <string>

using namespace shadowsense;
namespace fs = std::filesystem;

namespace {

const fs::path kDir = fs::path(SHADOWSENSE_TEST_TMP_DIR) / "temporal_dataset";

sim::TouchSequenceDatasetConfig small_config() {
  sim::TouchSequenceDatasetConfig c;
  c.fps = {15, 30};
  c.users = 2;
  c.sequence.gestures = 3;
  c.overwrite = true;
  return c;
}

// Written once for the cases below (2 users x 2 frame rates, 3 gestures each).
const fs::path& small_dataset() {
  static const fs::path dir = [] {
    const fs::path d = kDir / "small";
    sim::write_touch_sequence_dataset(d, 4100, small_config());
    return d;
  }();
  return dir;
}

void write_text(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

std::string reader_error(const fs::path& dir) {
  try {
    for (const TemporalSequenceRow& r : read_temporal_sequences(dir))
      (void)read_temporal_sequence(dir, r);
  } catch (const DatasetError& e) {
    return e.what();
  }
  return "";
}

} // namespace

TEST_CASE("a rendered temporal dataset reads back exactly as the generator made it") {
  const fs::path& dir = small_dataset();
  const sim::TouchSequenceDatasetConfig c = small_config();
  const std::vector<TemporalSequenceRow> rows = read_temporal_sequences(dir);
  REQUIRE(rows.size() == 4);
  int duplicates = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const TemporalSequenceRow& row = rows[i];
    sim::TouchSequenceConfig sc = c.sequence;
    sc.fps = c.fps[i / 2];
    const std::uint64_t seed = 4100 + i % 2;
    CAPTURE(row.sequence);
    CHECK(row.fps == sc.fps);
    CHECK(row.user == static_cast<int>(seed));
    CHECK(row.px_per_cm == sc.px_per_cm);
    const sim::TouchSequence seq = sim::make_touch_sequence(sc, seed);
    const TemporalSequence got = read_temporal_sequence(dir, row);
    REQUIRE(got.frames.size() == seq.frames.size());
    for (std::size_t k = 0; k < seq.frames.size(); ++k) {
      const TemporalFrameRow& f = got.frames[k];
      CHECK(f.frame == seq.frame_index[k]);
      CHECK(f.timestamp_ms == seq.frames[k].timestamp_ms); // exact: shortest round-trip text
      CHECK(f.duplicate == (seq.content_index[k] != seq.frame_index[k]));
      CHECK(f.shape == seq.shapes[k].label);
      if (!f.shape.empty())
        CHECK(static_cast<float>(f.shape_confidence) == seq.shapes[k].confidence);
      // A duplicated frame is the earlier frame's image, byte for byte.
      if (f.duplicate && k > 0 && seq.content_index[k] == seq.content_index[k - 1]) {
        ++duplicates;
        CHECK(tests::read_file(got.image_path(f)) ==
              tests::read_file(got.image_path(got.frames[k - 1])));
      }
    }
    CHECK(cv::imread(got.image_path(got.frames[0]).string()).size() ==
          sim::Rig::robot().image_size);
    REQUIRE(got.gestures.size() == seq.truth.size());
    for (std::size_t k = 0; k < seq.truth.size(); ++k) {
      CHECK(got.gestures[k].gesture == seq.truth[k].gesture);
      CHECK(got.gestures[k].track_id == seq.truth[k].track_id);
      CHECK(got.gestures[k].start_ms == seq.truth[k].start_ms);
      CHECK(got.gestures[k].end_ms == seq.truth[k].end_ms);
      CHECK(got.gestures[k].repetitions == seq.truth[k].repetitions);
      CHECK(got.gestures[k].direction == seq.truth[k].direction);
    }
    // The rows written back give the same bytes.
    CHECK(temporal_frames_csv(got.frames) == tests::read_file(got.frames_csv));
    CHECK(temporal_gestures_csv(got.gestures) == tests::read_file(got.gestures_csv));
  }
  CHECK(temporal_sequences_csv(rows) == tests::read_file(dir / "sequences.csv"));
  CHECK(duplicates > 0); // the byte-for-byte check above ran (2 % of frames are duplicated)
}

TEST_CASE("the truth read back scores the recogniser as evaluate_temporal does") {
  const fs::path& dir = small_dataset();
  const sim::TouchSequenceDatasetConfig c = small_config();
  const std::vector<TemporalSequenceRow> rows = read_temporal_sequences(dir);
  for (std::size_t r = 0; r < 2; ++r) { // per frame rate: its two users
    sim::TouchSequenceConfig sc = c.sequence;
    sc.fps = c.fps[r];
    const TemporalEvalResult expected = evaluate_temporal(sc, 4100, 2);
    TemporalEvalResult got;
    for (std::size_t u = 0; u < 2; ++u) {
      const TemporalSequence disk = read_temporal_sequence(dir, rows[r * 2 + u]);
      const sim::TouchSequence seq = sim::make_touch_sequence(sc, 4100 + u);
      TemporalGestureRecogniser rec;
      TemporalEventLog log;
      for (std::size_t k = 0; k < seq.frames.size(); ++k)
        log.add(rec.update(seq.frames[k], seq.shapes[k]));
      log.add(rec.flush(disk.frames.back().timestamp_ms + 1000.0 / disk.row.fps));
      std::vector<sim::TouchGestureTruth> truth;
      for (const TemporalGestureRow& g : disk.gestures)
        truth.push_back({g.gesture, g.track_id, g.start_ms, g.end_ms, g.repetitions, g.direction});
      score_temporal(truth, log.last(), 1000.0 / disk.row.fps, TemporalTrackMatch::same_id, got);
      got.frames += disk.frames.size();
      ++got.users;
    }
    CHECK(format_temporal_eval(got) == format_temporal_eval(expected));
    CHECK(got.confusion == expected.confusion);
    CHECK(got.latency_ms == expected.latency_ms);
  }
}

#ifdef SHADOWSENSE_SS_TRACK_EVAL
// ss_track_eval --temporal on small_dataset() in `work` with `args` appended. One calibration
// for the program and the test's own pipeline: fitted here on generator frames (`seed`), handed
// to the program as a file; returned as that file loads.
namespace {
struct TrackEvalRun {
  tests::ProgramRun run;
  SegmenterCalibration calibration;
};
TrackEvalRun run_track_eval_temporal(const fs::path& work, std::uint64_t seed,
                                     const std::string& args) {
  fs::create_directories(work);
  sim::Renderer renderer(sim::Rig::robot());
  const SimCalibration cal = calibrate_on_sim(renderer, seed, 20);
  const fs::path calib = work / "skin.calib";
  save_calibration(cal.config.calibration, calib.string());
  return {tests::run_program(SHADOWSENSE_SS_TRACK_EVAL,
                             "--temporal " + tests::shell_quote(small_dataset().string()) +
                                 " --calibration " + tests::shell_quote(calib.string()) +
                                 " --calib-frames 10 " + args,
                             work),
          load_calibration(calib.string())};
}
} // namespace

TEST_CASE("ss_track_eval --temporal prints the figures of the pipeline run on the same frames") {
  const fs::path& dir = small_dataset();
  const fs::path work = kDir / "program";
  const TrackEvalRun program = run_track_eval_temporal(
      work, 77, "--temporal-confusion " + tests::shell_quote((work / "confusion").string()));
  const tests::ProgramRun& run = program.run;
  const SegmenterCalibration& loaded = program.calibration;
  INFO(run.err);
  REQUIRE(run.status == 0);
  const std::vector<TemporalSequenceRow> rows = read_temporal_sequences(dir);
  for (double fps : {15.0, 30.0}) {
    TemporalEvalResult expected;
    for (const TemporalSequenceRow& row : rows) {
      if (row.fps != fps) continue;
      const TemporalSequence seq = read_temporal_sequence(dir, row);
      Segmenter::Config sc;
      sc.calibration = loaded;
      sc.calibration.mode = SegmentMode::relative; // as the program's default --mode
      TouchPipeline pipeline{Segmenter(sc)};
      TemporalGestureRecogniser rec;
      TemporalEventLog log;
      for (const TemporalFrameRow& f : seq.frames) {
        const cv::Mat img = cv::imread(seq.image_path(f).string());
        OutputGesture shape;
        shape.available = !f.shape.empty();
        shape.label = f.shape;
        shape.confidence = static_cast<float>(f.shape_confidence);
        log.add(rec.update(pipeline.update(img, f.timestamp_ms), shape));
      }
      log.add(rec.flush(seq.frames.back().timestamp_ms + 1000.0 / fps));
      std::vector<sim::TouchGestureTruth> truth;
      for (const TemporalGestureRow& g : seq.gestures)
        truth.push_back({g.gesture, g.track_id, g.start_ms, g.end_ms, g.repetitions, g.direction});
      score_temporal(truth, log.last(), 1000.0 / fps, TemporalTrackMatch::any_track, expected);
      expected.frames += seq.frames.size();
      ++expected.users;
    }
    CAPTURE(fps);
    CHECK(expected.users == 2);
    CHECK(run.out.find(format_temporal_eval(expected)) != std::string::npos);
    char summary[128];
    std::snprintf(summary, sizeof summary, "summary %g fps: macro-F1 %.4f, latency p50 %.0f ms",
                  fps, expected.macro_f1(), expected.latency_quantile(TemporalEvalResult::n, 0.5));
    CHECK(run.out.find(summary) != std::string::npos);
    char png[64];
    std::snprintf(png, sizeof png, "temporal_confusion_%gfps.png", fps);
    CHECK(cv::imread((work / "confusion" / png).string()).rows > 0);
  }
}
TEST_CASE("ss_track_eval --temporal --temporal-shapes model: the Runtime's events, also as JSON") {
  const fs::path& dir = small_dataset();
  const fs::path work = kDir / "program_model";
  const fs::path model_path = fs::path(SHADOWSENSE_SOURCE_DIR) / "models" / "default.ssm";
  const fs::path json = work / "temporal.json";
  const TrackEvalRun program = run_track_eval_temporal(
      work, 78,
      "--temporal-shapes model --model " + tests::shell_quote(model_path.string()) + " --json " +
          tests::shell_quote(json.string()));
  const tests::ProgramRun& run = program.run;
  INFO(run.err);
  REQUIRE(run.status == 0);
  const std::string text = tests::read_file(json);
  CHECK(text.find("\"schema\": \"shadowsense.temporal_eval/1\"") != std::string::npos);
  CHECK(text.find("\"shapes\": \"model\"") != std::string::npos);
  const ModelFile model = ModelFile::load(model_path);
  Segmenter::Config sc;
  sc.calibration = program.calibration;
  sc.calibration.mode = SegmentMode::relative;
  const std::vector<TemporalSequenceRow> rows = read_temporal_sequences(dir);
  for (double fps : {15.0, 30.0}) {
    TemporalEvalResult expected;
    std::size_t classified = 0;
    for (const TemporalSequenceRow& row : rows) {
      if (row.fps != fps) continue;
      const TemporalSequence seq = read_temporal_sequence(dir, row);
      Runtime sense(TouchPipeline{Segmenter(sc)}, make_densenet_classifier(model),
                    RuntimeConfig{.temporal = {.px_per_cm = row.px_per_cm}});
      TemporalEventLog log;
      for (const TemporalFrameRow& f : seq.frames) {
        const RuntimeFrame& r =
            sense.update(cv::imread(seq.image_path(f).string()), f.timestamp_ms);
        log.add(r.touch_gestures);
        classified += r.classified ? 1 : 0;
      }
      log.add(sense.flush(seq.frames.back().timestamp_ms + 1000.0 / fps).touch_gestures);
      std::vector<sim::TouchGestureTruth> truth;
      for (const TemporalGestureRow& g : seq.gestures)
        truth.push_back({g.gesture, g.track_id, g.start_ms, g.end_ms, g.repetitions, g.direction});
      score_temporal(truth, log.last(), 1000.0 / fps, TemporalTrackMatch::any_track, expected);
      expected.frames += seq.frames.size();
      ++expected.users;
    }
    CAPTURE(fps);
    CHECK(classified > 0);
    CHECK(run.out.find(format_temporal_eval(expected)) != std::string::npos);
    CHECK(text.find("\"classified_frames\": " + std::to_string(classified)) != std::string::npos);
    for (std::size_t g = 0; g < TemporalEvalResult::n; ++g) {
      const std::string counts = "\"" + std::string(to_string(all_touch_gestures[g])) +
                                 "\": {\"tp\": " + std::to_string(expected.tp[g]) +
                                 ", \"fp\": " + std::to_string(expected.fp[g]) +
                                 ", \"fn\": " + std::to_string(expected.fn[g]) + ",";
      CAPTURE(counts);
      CHECK(text.find(counts) != std::string::npos);
    }
  }
  // --model belongs to the classifier's reading only.
  const tests::ProgramRun misuse =
      tests::run_program(SHADOWSENSE_SS_TRACK_EVAL,
                         "--temporal " + tests::shell_quote(dir.string()) + " --model " +
                             tests::shell_quote(model_path.string()),
                         work);
  CHECK(misuse.status == 2);
  CHECK(misuse.err.find("--model needs --temporal-shapes model") != std::string::npos);
}
#endif

TEST_CASE("bad temporal datasets: a DatasetError naming file, line and column") {
  const fs::path root = kDir / "bad";
  fs::remove_all(root);
  const std::string seqs = "sequence,fps,user,frames,gestures,lighting_level,px_per_cm\n"
                           "s,30,1,3,1,,7.6\n";
  const std::string frames = "frame,file_name,timestamp_ms,duplicate,shape,shape_confidence\n"
                             "0,f0.png,0,0,,\n"
                             "1,f1.png,33.3,0,palm,0.9\n"
                             "2,f2.png,66.7,1,palm,0.9\n";
  const std::string gestures = "gesture,track_id,start_ms,end_ms,repetitions,direction\n"
                               "tap,1,10,40,1,\n";
  auto make = [&](const std::string& name, const std::string& s, const std::string& f,
                  const std::string& g) {
    const fs::path d = root / name;
    write_text(d / "sequences.csv", s);
    write_text(d / "s" / "frames.csv", f);
    write_text(d / "s" / "gestures.csv", g);
    return d;
  };
  CHECK(reader_error(make("good", seqs, frames, gestures)).empty());
  CHECK(reader_error(root / "missing").find("sequences.csv") != std::string::npos);
  {
    const fs::path d = make("no_gestures", seqs, frames, gestures);
    fs::remove(d / "s" / "gestures.csv");
    CHECK(reader_error(d).find("gestures.csv") != std::string::npos);
  }
  std::string back = frames;
  back.replace(back.find("66.7"), 4, "20.0");
  CHECK(reader_error(make("time_goes_back", seqs, back, gestures))
            .find("frames.csv:4: column 3 'timestamp_ms': timestamps must be strictly "
                  "increasing (the previous row has 33.300)") != std::string::npos);
  // Truncated labels: a row cut short, and a file with fewer rows than sequences.csv says.
  CHECK(reader_error(make("cut_row", seqs, frames, gestures.substr(0, gestures.size() - 8)))
            .find("gestures.csv:2: row has 3 columns; expected 6") != std::string::npos);
  CHECK(reader_error(make("few_rows", seqs, frames.substr(0, frames.rfind("2,f2")), gestures))
            .find("has 2 frame rows") != std::string::npos);
  CHECK(reader_error(make("hug_on_track", seqs, frames,
                          "gesture,track_id,start_ms,end_ms,repetitions,direction\n"
                          "hug,3,10,40,1,\n"))
            .find("column 2 'track_id': expected track id 0 for hug") != std::string::npos);
  CHECK(reader_error(make("bad_gesture", seqs, frames,
                          "gesture,track_id,start_ms,end_ms,repetitions,direction\n"
                          "poke,1,10,40,1,\n"))
            .find("unknown gesture 'poke'") != std::string::npos);
  CHECK(reader_error(make("empty_interval", seqs, frames,
                          "gesture,track_id,start_ms,end_ms,repetitions,direction\n"
                          "tap,1,40,40,1,\n"))
            .find("'end_ms': must be after start_ms") != std::string::npos);
  std::string no_conf = frames;
  no_conf.replace(no_conf.find("palm,0.9"), 8, "palm,");
  CHECK(reader_error(make("shape_without_confidence", seqs, no_conf, gestures))
            .find("must be given exactly when the shape column is") != std::string::npos);
  CHECK(reader_error(make("escape",
                          "sequence,fps,user,frames,gestures,lighting_level,px_per_cm\n"
                          "../s,30,1,3,1,,7.6\n",
                          frames, gestures))
            .find("must not leave the dataset folder") != std::string::npos);
}
