// ss_classify end to end: a folder and a video of the same frames give the same lines, --truth
// counts what the per-frame lines say, JSON/CSV stay valid for awkward paths, and every bad
// argument is an error on stderr with exit status 2. ss_eval_classify --score with per-session
// calibrations against one calibration at a time.
#include <shadowsense/backends/densenet/model_file.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/sense/calibration_file.hpp>

#include <doctest/doctest.h>

#include "common/run_program.hpp"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#ifdef SHADOWSENSE_HAVE_VIDEOIO
#include <opencv2/videoio.hpp>
#endif

#include "common/files.hpp"
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#ifdef SS_CLASSIFY_PROGRAM

namespace fs = std::filesystem;

namespace {

using tests::shell_quote;

tests::ProgramRun run_classify(const std::string& args) {
  return tests::run_program(SS_CLASSIFY_PROGRAM, args,
                            fs::path(SHADOWSENSE_TEST_TMP_DIR) / "classify_program");
}

std::vector<std::string> lines(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

// Frames with a bright blob at a moving place on a textured background.
cv::Mat frame(int k) {
  cv::Mat img(120, 160, CV_8UC3);
  cv::randu(img, cv::Scalar::all(60), cv::Scalar::all(140));
  cv::circle(img, {20 + 20 * k, 40 + 8 * k}, 18, cv::Scalar(20, 20, 20), cv::FILLED);
  return img;
}

std::string numbered(const char* stem, int i) { // (avoids a GCC 12 -Wrestrict false positive)
  return std::string(stem).append(std::to_string(i)).append(".png");
}

} // namespace

TEST_CASE("--help and --version on stdout with status 0; bad arguments status 2 on stderr") {
  auto help = run_classify("--help");
  CHECK(help.status == 0);
  CHECK(help.out.find("usage: ss_classify") == 0);
  CHECK(help.err.empty());
  auto version = run_classify("--version");
  CHECK(version.status == 0);
  CHECK(version.out.find("ss_classify shadowsense 0.") == 0);
  const fs::path dir = tests::fresh_dir("classify_args");
  cv::imwrite((dir / "a.png").string(), frame(0));
  const std::string d = shell_quote(dir.string());
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"", "--input is required"},
      {"--threads 0 " + d, "--threads: expected an integer in [1, 256], got '0'"},
      {"--threads=257 " + d, "--threads: expected an integer in [1, 256], got '257'"},
      {"--threads 2x " + d, "--threads: expected an integer in [1, 256], got '2x'"},
      {"--threads", "--threads: missing value (expected N, an integer in [1, 256])"},
      {"--format xml " + d, "--format: expected one of csv, json, got 'xml'"},
      {"--bogus " + d, "unknown option '--bogus'"},
      {d + " " + d, "more than one INPUT"},
      {"--input " + d + " " + d, "more than one INPUT"},
      {d + " --input=" + d, "more than one INPUT"},
      {"--input=" + shell_quote((dir / "missing").string()), "no such folder or file"},
      {"--model /nonexistent.ssm " + d, "/nonexistent.ssm"},
      {"--model " + d + " " + d, "is a directory"},
      {"--model /dev/zero " + d, "not a regular file"},
      {shell_quote((dir / "missing").string()), "no such folder or file"},
      {shell_quote((dir / "a.png").string()) + " --truth", ""},
  };
  for (const auto& [args, message] : bad) {
    CAPTURE(args);
    const auto r = run_classify(args);
    CHECK(r.status == 2);
    CHECK(r.out.find("frame,") == std::string::npos);
    CHECK(r.err.find("ss_classify: ") == 0);
    CHECK(r.err.find(message) != std::string::npos);
  }
  fs::create_directories(dir / "empty");
  const auto empty = run_classify(shell_quote((dir / "empty").string()));
  CHECK(empty.status == 2);
  CHECK(empty.err.find("no images found") != std::string::npos);
}

TEST_CASE("--truth: accuracy and confusion counts agree with the per-frame labels") {
  const fs::path dir = tests::fresh_dir("classify_truth");
  int k = 0;
  for (const char* cls : {"palm", "punch"})
    for (int i = 0; i < 3; ++i) {
      fs::create_directories(dir / cls / (i == 2 ? "nested" : ""));
      cv::imwrite((dir / cls / (i == 2 ? "nested" : "") / numbered("f", i)).string(), frame(k++));
    }
  const auto r = run_classify("--truth " + shell_quote(dir.string()));
  REQUIRE(r.status == 0);
  const auto out = lines(r.out);
  REQUIRE(out.size() == 7);
  CHECK(out[0] == "frame,source,dark,label,nothing,hug,palm,point,punch,two_hands");
  int correct = 0;
  std::map<std::string, int> predicted_for_palm;
  for (std::size_t i = 1; i < out.size(); ++i) {
    const bool palm = out[i].find("/palm/") != std::string::npos;
    std::stringstream row(out[i]);
    std::string frame_no, source, dark, label;
    std::getline(row, frame_no, ',');
    std::getline(row, source, ',');
    std::getline(row, dark, ',');
    std::getline(row, label, ',');
    CHECK(frame_no == std::to_string(i - 1));
    CHECK(dark == "0"); // the shipped model normalises lighting: never brightened
    if (label == (palm ? "palm" : "punch")) ++correct;
    if (palm) ++predicted_for_palm[label];
  }
  // Sorted by path: palm/f0, palm/f1, palm/nested/f2, then punch.
  CHECK(out[3].find("/palm/nested/f2.png") != std::string::npos);
  char expected[64];
  std::snprintf(expected, sizeof expected, "accuracy %.2f%% (%d of 6 frames)", 100.0 * correct / 6,
                correct);
  CHECK(r.err.find(expected) != std::string::npos);
  CHECK(r.err.find("rows: true class, columns: predicted") != std::string::npos);
  // The palm row of the confusion matrix holds what the lines said.
  std::string palm_row;
  for (const auto& l : lines(r.err))
    if (l.find("      palm") == 0) palm_row = l;
  std::stringstream cells(palm_row);
  std::string name;
  cells >> name;
  for (const char* cls : {"nothing", "hug", "palm", "point", "punch", "two_hands"}) {
    int n = -1;
    cells >> n;
    CHECK(n == predicted_for_palm[cls]);
  }
  // A folder whose name is not a class of the model is an error naming the image.
  fs::create_directories(dir / "wave");
  cv::imwrite((dir / "wave" / "x.png").string(), frame(0));
  const auto unknown = run_classify("--truth " + shell_quote(dir.string()));
  CHECK(unknown.status == 2);
  CHECK(unknown.err.find("true class 'wave'") != std::string::npos);
}

TEST_CASE("awkward paths stay valid JSON and CSV") {
  const fs::path dir = tests::fresh_dir("classify_paths");
  const fs::path odd = dir / "we\"ird,dir";
  fs::create_directories(odd);
  cv::imwrite((odd / "f.png").string(), frame(1));
  const auto json = run_classify("--format json " + shell_quote(dir.string()));
  REQUIRE(json.status == 0);
  CHECK(json.out.find("\"source\":\"" + dir.string() + "/we\\\"ird,dir/f.png\"") !=
        std::string::npos);
  CHECK(json.out.find("\"probabilities\":{\"nothing\":") != std::string::npos);
  const auto csv = run_classify(shell_quote(dir.string()));
  REQUIRE(csv.status == 0);
  CHECK(csv.out.find("0,\"" + dir.string() + "/we\"\"ird,dir/f.png\",0,") != std::string::npos);
}

TEST_CASE("--input and the last word are one input; options take '=' too; progress on stderr") {
  // 101 frames: above the 100 of the progress rule, so the closing line is printed.
  const fs::path dir = tests::fresh_dir("classify_forms");
  for (int i = 0; i < 101; ++i) cv::imwrite((dir / numbered("f", i)).string(), frame(i % 3));
  const auto positional = run_classify("--format json " + shell_quote(dir.string()));
  const auto named = run_classify("--format=json --input=" + shell_quote(dir.string()));
  REQUIRE(positional.status == 0);
  REQUIRE(named.status == 0);
  CHECK(lines(named.out).size() == 101);
  CHECK(named.out == positional.out);
  // Progress: at most one line a second while classifying, and the closing count.
  CHECK(named.err.ends_with("\rss_classify: 101 frames\n"));
  CHECK(named.err.find("error") == std::string::npos);
}

#ifdef SHADOWSENSE_HAVE_VIDEOIO
TEST_CASE("a video file gives the same lines as its decoded frames in a folder") {
  const fs::path dir = tests::fresh_dir("classify_video");
  const fs::path video = dir / "clip.avi";
  {
    cv::VideoWriter w(video.string(), cv::CAP_OPENCV_MJPEG,
                      cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0, {160, 120});
    REQUIRE(w.isOpened());
    for (int k = 0; k < 5; ++k) w.write(frame(k));
  }
  // The frames as ss_classify's reader decodes them, written losslessly to a folder.
  cv::VideoCapture cap(video.string());
  REQUIRE(cap.isOpened());
  fs::create_directories(dir / "frames");
  int n = 0;
  for (cv::Mat f; cap.read(f) && !f.empty(); ++n)
    cv::imwrite((dir / "frames" / numbered("f", n)).string(), f);
  REQUIRE(n == 5);
  const auto from_video = lines(run_classify(shell_quote(video.string())).out);
  const auto from_folder = lines(run_classify(shell_quote((dir / "frames").string())).out);
  REQUIRE(from_video.size() == 6);
  REQUIRE(from_folder.size() == 6);
  CHECK(from_video[0] == from_folder[0]);
  for (std::size_t i = 1; i < 6; ++i) {
    // Same frame number, dark flag, label and probabilities; only the source differs.
    const auto tail = [](const std::string& l) {
      const auto a = l.find(',');
      return l.substr(0, a) + l.substr(l.find(',', a + 1));
    };
    CHECK(tail(from_video[i]) == tail(from_folder[i]));
    CHECK(from_video[i].find(video.string() + "#" + std::to_string(i - 1)) != std::string::npos);
  }
  const auto truth = run_classify("--truth " + shell_quote(video.string()));
  CHECK(truth.status == 2);
  CHECK(truth.err.find("--truth needs a folder of images") != std::string::npos);
}
#endif

namespace {
// CRC-32 (ISO-HDLC, as PNG chunks use) of bytes.
std::uint32_t crc32(const unsigned char* p, std::size_t n) {
  std::uint32_t c = 0xffffffffu;
  for (std::size_t i = 0; i < n; ++i) {
    c ^= p[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return ~c;
}
} // namespace

TEST_CASE("a small PNG claiming 30000x30000 pixels is refused from its header, never decoded") {
  std::vector<unsigned char> png;
  REQUIRE(cv::imencode(".png", cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(90)), png));
  // IHDR: length (4) "IHDR" (4) width (4) height (4) ... at byte 8; patch the size, fix the CRC.
  REQUIRE(png.size() > 33);
  for (int k = 0; k < 2; ++k)
    for (int b = 0; b < 4; ++b)
      png[16 + 4 * k + b] = static_cast<unsigned char>((30000u >> (24 - 8 * b)) & 0xff);
  const std::uint32_t crc = crc32(png.data() + 12, 17);
  for (int b = 0; b < 4; ++b)
    png[29 + b] = static_cast<unsigned char>((crc >> (24 - 8 * b)) & 0xff);
  const fs::path dir = tests::fresh_dir("classify_huge");
  {
    std::FILE* f = std::fopen((dir / "huge.png").string().c_str(), "wb");
    REQUIRE(f);
    REQUIRE(std::fwrite(png.data(), 1, png.size(), f) == png.size());
    std::fclose(f);
  }
  const tests::ProgramRun r = run_classify("--input " + shell_quote(dir.string()) + " --quiet");
  CHECK(r.status == 2);
  CHECK(r.err.find("huge.png") != std::string::npos);
  CHECK(r.err.find("30000") != std::string::npos);
  CHECK(r.err.find("8192") != std::string::npos);
  CHECK(r.out.find("huge.png") == std::string::npos);
}

// The committed tiny model re-saved at PATH recording input encoding E (a darkness_warmth model
// without lighting normalisation, which that encoding refuses); returns what it saved.
static shadowsense::ModelFile save_tiny_model_with(shadowsense::InputEncoding e,
                                                   const fs::path& path) {
  shadowsense::ModelFile m =
      shadowsense::ModelFile::load(SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn");
  m.preprocess.input_encoding = e;
  if (e == shadowsense::InputEncoding::darkness_warmth) m.preprocess.lighting_normalise = false;
  m.save(path);
  return m;
}

// A fresh folder NAME holding three frames in NAME/frames.
static fs::path fresh_dir_with_frames(const std::string& name) {
  const fs::path dir = tests::fresh_dir(name);
  fs::create_directories(dir / "frames");
  for (int i = 0; i < 3; ++i) cv::imwrite((dir / "frames" / numbered("f", i)).string(), frame(i));
  return dir;
}

TEST_CASE("--calibration: a skin_relative model needs one, a colour model ignores one") {
  namespace ss = shadowsense;
  const fs::path dir = fresh_dir_with_frames("classify_calibration");
  // The committed tiny model, once as it is (colour) and once recording skin_relative.
  const std::string tiny = SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn";
  const fs::path skin_model = dir / "skin.ssm";
  save_tiny_model_with(ss::InputEncoding::skin_relative, skin_model);
  const std::string frames = shell_quote((dir / "frames").string());
  const std::string cal = SHADOWSENSE_TEST_DATA_DIR "/encoding_calibration.calib";
  const auto missing = run_classify("--model " + shell_quote(skin_model.string()) + " " + frames);
  CHECK(missing.status == 2);
  CHECK(missing.out.empty());
  CHECK(missing.err.find("model " + skin_model.string() +
                         " was trained with input encoding skin_relative and needs "
                         "--calibration FILE") != std::string::npos);
  const auto with = run_classify("--model " + shell_quote(skin_model.string()) + " --calibration " +
                                 shell_quote(cal) + " " + frames);
  REQUIRE(with.status == 0);
  CHECK(lines(with.out).size() == 4);
  // A calibration without an empty-skin model is refused, naming both files.
  const fs::path bare = dir / "bare.calib";
  ss::save_calibration(ss::SegmenterCalibration{}, bare.string());
  const auto no_model = run_classify("--model " + shell_quote(skin_model.string()) +
                                     " --calibration " + shell_quote(bare.string()) + " " + frames);
  CHECK(no_model.status == 2);
  CHECK(no_model.err.find("calibration " + bare.string() + " holds no empty-skin model") !=
        std::string::npos);
  CHECK(no_model.err.find(skin_model.string()) != std::string::npos);
  // A colour model gives the same lines with or without a calibration.
  const auto plain = run_classify("--model " + shell_quote(tiny) + " " + frames);
  const auto plain_cal = run_classify("--model " + shell_quote(tiny) + " --calibration " +
                                      shell_quote(cal) + " " + frames);
  REQUIRE(plain.status == 0);
  CHECK(plain_cal.status == 0);
  CHECK(plain_cal.out == plain.out);
  CHECK(plain.out != with.out); // the encoding changes what the network sees
}

TEST_CASE("--calibration: a darkness_warmth model needs one and refuses --lighting-normalise") {
  const fs::path dir = fresh_dir_with_frames("classify_darkness_warmth");
  const fs::path model = dir / "dw.ssm";
  save_tiny_model_with(shadowsense::InputEncoding::darkness_warmth, model);
  const std::string frames = shell_quote((dir / "frames").string());
  const std::string cal = SHADOWSENSE_TEST_DATA_DIR "/encoding_calibration.calib";
  const auto missing = run_classify("--model " + shell_quote(model.string()) + " " + frames);
  CHECK(missing.status == 2);
  CHECK(missing.out.empty());
  CHECK(missing.err.find("was trained with input encoding darkness_warmth and needs "
                         "--calibration FILE") != std::string::npos);
  const std::string with_cal =
      "--model " + shell_quote(model.string()) + " --calibration " + shell_quote(cal) + " ";
  const auto with = run_classify(with_cal + frames);
  REQUIRE(with.status == 0);
  CHECK(lines(with.out).size() == 4);
  const auto forced = run_classify(with_cal + "--lighting-normalise " + frames);
  CHECK(forced.status == 2);
  CHECK(forced.out.empty());
  CHECK(forced.err.find("--lighting-normalise with model " + model.string() +
                        ", whose input encoding is darkness_warmth") != std::string::npos);
  CHECK(forced.err.find("drop the option") != std::string::npos);
  // ss_eval_classify refuses it with the same words (one check, cli::load_model, serves all
  // four programs that take the option), before it reads any data.
  const auto scored =
      tests::run_program(SS_EVAL_CLASSIFY_PROGRAM,
                         "--score " + shell_quote(model.string()) + " --input " + frames +
                             " --calibration " + shell_quote(cal) + " --lighting-normalise",
                         dir / "eval_run");
  CHECK(scored.status == 2);
  CHECK(scored.out.empty());
  CHECK(scored.err.find("--lighting-normalise with model " + model.string() +
                        ", whose input encoding is darkness_warmth") != std::string::npos);
}

// The confusion matrix of one key ("daylight", "all", ...) in ss_eval_classify --score's JSON, as
// its text ("[[1,0],[0,2]]"); empty when the key is missing.
static std::string confusion_of(const std::string& json, const std::string& key) {
  const std::size_t c = json.find("\"confusion\"");
  if (c == std::string::npos) return {};
  const std::size_t k = json.find("\"" + key + "\"", c);
  if (k == std::string::npos) return {};
  const std::size_t open = json.find('[', k);
  int depth = 0;
  std::string out;
  for (std::size_t i = open; i < json.size(); ++i) {
    const char ch = json[i];
    if (ch == ' ' || ch == '\n') continue;
    out += ch;
    depth += ch == '[' ? 1 : ch == ']' ? -1 : 0;
    if (depth == 0) break;
  }
  return out;
}

TEST_CASE("ss_eval_classify --score --session-calibrations: each session's own empty-skin model") {
  namespace ss = shadowsense;
  const fs::path dir = tests::fresh_dir("eval_session_calibrations");
  const fs::path data = dir / "data";
  // The committed tiny model recording skin_relative, two sessions (one per lighting, so the
  // per-lighting confusions are per session) whose calibrations differ.
  const std::string model = (dir / "skin.ssm").string();
  const ss::ModelFile m = save_tiny_model_with(ss::InputEncoding::skin_relative, model);
  const ss::SegmenterCalibration base =
      ss::load_calibration(SHADOWSENSE_TEST_DATA_DIR "/encoding_calibration.calib");
  ss::SegmenterCalibration dark = base;
  dark.empty_skin = base.empty_skin.clone();
  for (int y = 0; y < dark.empty_skin.rows; ++y) // a different model, still skin everywhere
    for (int x = 0; x < dark.empty_skin.cols; ++x)
      dark.empty_skin.at<cv::Vec3f>(y, x) *= (x * 4 < dark.empty_skin.cols * 3) ? 0.6f : 1.4f;
  fs::create_directories(data / "empty_skin");
  ss::save_calibration(base, (data / "empty_skin" / "sa.calib").string());
  ss::save_calibration(dark, (data / "empty_skin" / "sb.calib").string());
  std::string csv = "file_name,class,user,lighting,lighting_level,session,frame_index,"
                    "timestamp_ms,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,"
                    "contact_w,contact_h,contact_cx,contact_cy,px_per_cm\n";
  const std::size_t n_classes = m.class_names.size();
  for (const auto& [session, lighting, level] :
       {std::tuple{"sa", "daylight", "1"}, std::tuple{"sb", "dusk", "0.5"}})
    for (int i = 0; i < 12; ++i) {
      const std::string cls = m.class_names[static_cast<std::size_t>(i) % n_classes];
      fs::create_directories(data / cls);
      const std::string file = cls + "/" + session + "_" + std::to_string(i) + ".png";
      REQUIRE(cv::imwrite((data / file).string(), frame(i % 7)));
      csv += file + "," + cls + ",1," + lighting + "," + level + "," + session + "," +
             std::to_string(i) + "," + std::to_string(100 * i) + ",,,,,,,,,,,7.6\n";
    }
  REQUIRE(tests::write_file(data / "metadata.csv", csv));
  auto score = [&](const std::string& extra, const std::string& json) {
    return tests::run_program(SS_EVAL_CLASSIFY_PROGRAM,
                              "--score " + shell_quote(model) + " --input " +
                                  shell_quote(data.string()) + " --quiet --json " +
                                  shell_quote((dir / json).string()) + " " + extra,
                              dir / "run");
  };
  const auto per_session = score("--session-calibrations", "per_session.json");
  REQUIRE(per_session.status == 0);
  const auto with_a =
      score("--calibration " + shell_quote((data / "empty_skin/sa.calib").string()), "a.json");
  const auto with_b =
      score("--calibration " + shell_quote((data / "empty_skin/sb.calib").string()), "b.json");
  REQUIRE(with_a.status == 0);
  REQUIRE(with_b.status == 0);
  const std::string js = tests::read_file(dir / "per_session.json");
  const std::string ja = tests::read_file(dir / "a.json");
  const std::string jb = tests::read_file(dir / "b.json");
  // The two calibrations change what the model says on the dusk session (else the comparison
  // below could not tell them apart) ...
  REQUIRE(!confusion_of(ja, "dusk").empty());
  REQUIRE(confusion_of(ja, "dusk") != confusion_of(jb, "dusk"));
  // ... and each session is scored with its own.
  CHECK(confusion_of(js, "daylight") == confusion_of(ja, "daylight"));
  CHECK(confusion_of(js, "dusk") == confusion_of(jb, "dusk"));

  // --speed times a calibrated model with --calibration (its encoding included), and names the
  // model and the option without one.
  const auto speed =
      tests::run_program(SS_EVAL_CLASSIFY_PROGRAM,
                         "--speed " + shell_quote(model) + " --calibration " +
                             shell_quote((data / "empty_skin/sa.calib").string()) + " --quiet",
                         dir / "run");
  CHECK(speed.status == 0);
  CHECK(speed.out.find("skin.ssm") != std::string::npos);
  const auto speed_without =
      tests::run_program(SS_EVAL_CLASSIFY_PROGRAM, "--speed " + shell_quote(model), dir / "run");
  CHECK(speed_without.status == 2);
  CHECK(
      speed_without.err.find("model " + model + " was trained with input encoding skin_relative") !=
      std::string::npos);

  // A session without its file, both ways of calibrating at once, and the flag without --score.
  fs::remove(data / "empty_skin" / "sb.calib");
  const auto missing = score("--session-calibrations", "missing.json");
  CHECK(missing.status == 2);
  CHECK(missing.err.find((data / "empty_skin" / "sb.calib").string() + ": missing") !=
        std::string::npos);
  const auto both = score("--session-calibrations --calibration " +
                              shell_quote((data / "empty_skin/sa.calib").string()),
                          "both.json");
  CHECK(both.status == 2);
  CHECK(both.err.find("give one of them") != std::string::npos);
  const auto no_score = tests::run_program(
      SS_EVAL_CLASSIFY_PROGRAM, "--input " + shell_quote(data.string()) + " --session-calibrations",
      dir / "run");
  CHECK(no_score.status == 2);
  CHECK(no_score.err.find("--session-calibrations: only with --score MODEL") != std::string::npos);
}

TEST_CASE("ss_eval_classify --tables: a class with no frame in the data is absent, not an error") {
  namespace ss = shadowsense;
  const fs::path dir = tests::fresh_dir("eval_tables_absent_class");
  const std::string model = SHADOWSENSE_TEST_DATA_DIR "/densenet_tiny.ssdn";
  const std::vector<std::string> names = ss::ModelFile::load(model).class_names;
  REQUIRE(names.size() >= 3);
  const std::string absent = names.back(); // never in the data
  const std::string partial = names[0];    // `only_user`: in the data for user 1 only
  // Two users x three lightings, 4 frames per session x class; `only_user` decides whether the
  // first class is kept for user 2 too.
  auto make = [&](const fs::path& data, bool only_user) {
    std::string csv = "file_name,class,user,lighting,lighting_level,session,frame_index,"
                      "timestamp_ms,shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,"
                      "contact_w,contact_h,contact_cx,contact_cy,px_per_cm\n";
    int k = 0;
    for (const char* user : {"1", "2"})
      for (const auto& [lighting, level] :
           {std::pair{"daylight", "1"}, std::pair{"dusk", "0.5"}, std::pair{"night", "0"}})
        for (std::size_t c = 0; c + 1 < names.size(); ++c) {
          if (only_user && c == 0 && std::string(user) == "2") continue;
          const std::string session = std::string("u") + user + "_" + lighting;
          fs::create_directories(data / names[c]);
          for (int i = 0; i < 4; ++i, ++k) {
            const std::string file = names[c] + "/" + session + "_" + std::to_string(i) + ".png";
            REQUIRE(cv::imwrite((data / file).string(), frame(static_cast<int>(c) + i % 2)));
            csv += file + "," + names[c] + "," + user + "," + lighting + "," + level + "," +
                   session + "," + std::to_string(i) + "," + std::to_string(100 * k) +
                   ",,,,,,,,,,,7.6\n";
          }
        }
    REQUIRE(tests::write_file(data / "metadata.csv", csv));
  };
  auto tables = [&](const fs::path& data, const std::string& json) {
    return tests::run_program(SS_EVAL_CLASSIFY_PROGRAM,
                              "--input " + shell_quote(data.string()) + " --backbone " +
                                  shell_quote(model) +
                                  " --tables 1,2 --head-val-fraction 0 --head-epochs 3 --json " +
                                  shell_quote((dir / json).string()),
                              dir / "run");
  };
  make(dir / "without_last", false);
  const auto r = tables(dir / "without_last", "t.json");
  REQUIRE(r.status == 0);
  CHECK(r.err.find("note: class '" + absent + "' has no frame in") != std::string::npos);
  const std::string js = tests::read_file(dir / "t.json");
  CHECK(js.find("\"absent_classes\": [\"" + absent + "\"]") != std::string::npos);
  CHECK(js.find("\"table1\"") != std::string::npos);
  CHECK(js.find("\"table2\"") != std::string::npos);
  // A class in the data that one split lacks (leaving user 1 out leaves no frame of it to
  // train on) is still an error naming it.
  make(dir / "partial", true);
  const auto p = tables(dir / "partial", "p.json");
  CHECK(p.status == 2);
  CHECK(p.err.find("class '" + partial + "' of the model has no training frames") !=
        std::string::npos);
}

#else
// Reported as skipped (not passed): the program is not built.
TEST_CASE("ss_classify is not built (SHADOWSENSE_BUILD_EXAMPLES=OFF)" * doctest::skip()) {}
#endif
