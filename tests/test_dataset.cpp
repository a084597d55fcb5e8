// The dataset format: writers (deterministic, validated, never half-written) and the strict
// csv reader.
#include <shadowsense/eval.hpp>
#include <shadowsense/io/temporal_dataset.hpp>

#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>

#include "common/files.hpp"
#include <sys/stat.h>

using namespace shadowsense;
namespace fs = std::filesystem;

namespace {

// A path under the test temp folder that does not exist yet (its parent does).
fs::path absent_dir(const std::string& name) {
  const fs::path p = fs::path(SHADOWSENSE_TEST_TMP_DIR) / "dataset" / name;
  fs::remove_all(p);
  fs::create_directories(p.parent_path());
  return p;
}

// Every regular file under root, by relative path, with its bytes.
std::map<std::string, std::string> tree(const fs::path& root) {
  std::map<std::string, std::string> m;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file())
      m[fs::relative(e.path(), root).generic_string()] = tests::read_file(e.path());
  return m;
}

sim::GestureDatasetConfig tiny_gestures() {
  sim::GestureDatasetConfig c;
  c.users = 1;
  c.frames_per_gesture = 1;
  c.lighting_levels = {1.0, 0.0};
  return c;
}
sim::SlideDatasetConfig tiny_slides() {
  sim::SlideDatasetConfig c;
  c.slide.min_frames = 8;
  c.slide.max_frames = 9;
  return c;
}

// Writes a csv file with the given body under the metadata header.
fs::path
csv_with(const std::string& name, const std::string& body,
         const std::string& header = "file_name,class,user,lighting,lighting_level,session,"
                                     "frame_index,timestamp_ms,shadow_x,shadow_y,shadow_w,"
                                     "shadow_h,contact_x,contact_y,contact_w,contact_h,"
                                     "contact_cx,contact_cy,px_per_cm") {
  const fs::path dir = fs::path(SHADOWSENSE_TEST_TMP_DIR) / "dataset" / "csv";
  fs::create_directories(dir);
  const fs::path p = dir / name;
  std::ofstream(p, std::ios::binary) << header << "\n" << body;
  return p;
}

const std::string good_row =
    "palm/a.png,palm,1,dusk,0.5,u1_dusk,3,300.0,10,20,30,40,12,22,5,6,14.5,24.5,7.5\n";

} // namespace

TEST_CASE("the same seed writes byte-identical datasets (any thread count); another seed differs") {
  const fs::path a = absent_dir("det_a"), b = absent_dir("det_b"), c = absent_dir("det_c");
  sim::TrackingDatasetConfig t;
  t.frames_per_category = 2;
  for (const fs::path& root : {a, b}) {
    // b is written by 3 worker threads: the output must not depend on the thread count.
    const int threads = root == b ? 3 : 1;
    auto g = tiny_gestures();
    auto s = tiny_slides();
    auto tt = t;
    g.threads = s.threads = tt.threads = threads;
    sim::write_gesture_dataset(root / "gestures", 5, g);
    sim::write_tracking_dataset(root / "tracking", 5, tt);
    sim::write_slide_dataset(root / "slides", 5, s);
  }
  sim::write_tracking_dataset(c / "tracking", 6, t);
  const auto ta = tree(a), tb = tree(b);
  CHECK(ta.size() == (12 + 1) + (10 + 1) + tree(a / "slides").size()); // images + csv
  CHECK(ta == tb);
  CHECK(tree(a / "tracking") != tree(c / "tracking"));
  CHECK_FALSE(fs::exists(a / "gestures" / "metadata.csv.tmp"));
}

TEST_CASE("written datasets read back with consistent rows and images") {
  const fs::path root = absent_dir("readback");
  const auto gs = sim::write_gesture_dataset(root / "gestures", 2, tiny_gestures());
  CHECK(gs.images == 12);
  const Metadata g = read_metadata(root / "gestures" / "metadata.csv");
  REQUIRE(g.rows.size() == 12);
  CHECK_FALSE(g.slide_columns);
  for (const MetadataRow& r : g.rows) {
    CAPTURE(r.file_name);
    CHECK(r.file_name.rfind(r.label + "/", 0) == 0);
    const cv::Mat img = read_image(g, r);
    CHECK(img.size() == cv::Size(635, 350));
    if (r.label == "nothing")
      CHECK_FALSE(r.shadow_box);
    else
      CHECK(r.contact_box);
    if (r.contact_box) {
      CHECK((*r.contact_box & *r.shadow_box) == *r.contact_box);
      CHECK(r.contact_box->contains(
          cv::Point(cvRound(r.contact_point->x), cvRound(r.contact_point->y))));
    }
    CHECK(r.px_per_cm == doctest::Approx(sim::Rig::robot().px_per_cm()).epsilon(1e-5));
  }
  CHECK(g.rows[0].session == "u1_daylight");
  CHECK(g.rows[6].session == "u1_night");
  CHECK(g.rows[6].lighting == sim::Lighting::night);

  sim::TrackingDatasetConfig t;
  t.frames_per_category = 3;
  sim::write_tracking_dataset(root / "tracking", 2, t);
  const Metadata tr = read_metadata(root / "tracking" / "metadata.csv");
  REQUIRE(tr.rows.size() == 15);
  for (const MetadataRow& r : tr.rows) {
    CAPTURE(r.file_name);
    const auto category = sim::track_category_from_string(r.label);
    CHECK(read_image(tr, r).size() == cv::Size(200, 205));
    CHECK(r.shadow_box.has_value() == (category != sim::TrackCategory::nothing));
    CHECK(r.contact_box.has_value() ==
          (category != sim::TrackCategory::nothing && category != sim::TrackCategory::hover));
  }

  const auto ss = sim::write_slide_dataset(root / "slides", 2, tiny_slides());
  CHECK(ss.sequences == 8);
  const auto seqs = read_sequences(root / "slides" / "sequences.csv");
  REQUIRE(seqs.size() == 8);
  int frames = 0;
  for (const SequenceRow& q : seqs) {
    const Metadata m = read_metadata(root / "slides" / q.sequence / "metadata.csv");
    CHECK(m.slide_columns);
    CHECK(static_cast<int>(m.rows.size()) == q.num_frames);
    CHECK(q.sequence.rfind(std::string(sim::to_string(q.direction)) + "/", 0) == 0);
    CHECK(q.fps == doctest::Approx(13.0));
    for (const MetadataRow& r : m.rows) {
      CHECK(*r.direction == q.direction);
      CHECK(*r.gesture == q.gesture);
      CHECK(r.label == std::string(sim::to_string(q.direction)));
    }
    frames += q.num_frames;
  }
  CHECK(frames == ss.images);
}

TEST_CASE("bad configuration is rejected before anything is written") {
  const fs::path root = absent_dir("badcfg");
  sim::GestureDatasetConfig g;
  g.frames_per_gesture = -1;
  CHECK_THROWS_WITH_AS(sim::write_gesture_dataset(root / "g", 1, g),
                       doctest::Contains("frames_per_gesture"), InvalidArgument);
  g = {};
  g.users = 0;
  CHECK_THROWS_AS(sim::write_gesture_dataset(root / "g", 1, g), InvalidArgument);
  g = {};
  g.lighting_levels = {1.4};
  CHECK_THROWS_WITH_AS(sim::write_gesture_dataset(root / "g", 1, g),
                       doctest::Contains("outside [0, 1]"), InvalidArgument);
  sim::TrackingDatasetConfig t;
  t.threads = 0;
  CHECK_THROWS_WITH_AS(sim::write_tracking_dataset(root / "t", 1, t), doctest::Contains("threads"),
                       InvalidArgument);
  t = {};
  t.frames_per_category = -5;
  CHECK_THROWS_AS(sim::write_tracking_dataset(root / "t", 1, t), InvalidArgument);
  sim::SlideDatasetConfig s;
  s.slide.min_distance_cm = -1;
  CHECK_THROWS_AS(sim::write_slide_dataset(root / "s", 1, s), InvalidArgument);
  CHECK_FALSE(fs::exists(root)); // nothing was created
  CHECK_THROWS_WITH_AS(sim::write_tracking_dataset("", 1, {}),
                       doctest::Contains("output folder path is empty"), InvalidArgument);
  CHECK_THROWS_WITH_AS(sim::gesture_from_string("tickle"),
                       doctest::Contains("unknown gesture class"), InvalidArgument);
}

TEST_CASE(
    "unwritable or occupied output folders fail clearly and leave no complete-looking dataset") {
  const fs::path root = absent_dir("unwritable");
  fs::create_directories(root);
  std::ofstream(root / "a_file") << "x";
  sim::TrackingDatasetConfig t;
  t.frames_per_category = 1;
  // A folder below a regular file can never be created (even as root).
  CHECK_THROWS_WITH_AS(sim::write_tracking_dataset(root / "a_file" / "tracking", 1, t),
                       doctest::Contains("cannot create"), IoError);
  // An existing, non-empty folder is not overwritten unless asked.
  CHECK_THROWS_WITH_AS(sim::write_tracking_dataset(root, 1, t), doctest::Contains("not empty"),
                       IoError);
  // A write failing half-way (an image path taken by a folder) leaves no metadata.csv.
  const fs::path half = root / "half";
  fs::create_directories(half / "finger" / "finger_0000.png");
  t.overwrite = true;
  CHECK_THROWS_AS(sim::write_tracking_dataset(half, 1, t), IoError);
  CHECK_FALSE(fs::exists(half / "metadata.csv"));
  // Overwriting a complete dataset first removes its csv.
  const fs::path done = root / "done";
  sim::write_tracking_dataset(done, 1, t);
  REQUIRE(fs::exists(done / "metadata.csv"));
  fs::remove_all(done / "palm");
  fs::create_directories(done / "palm" / "palm_0000.png");
  CHECK_THROWS_AS(sim::write_tracking_dataset(done, 1, t), IoError);
  CHECK_FALSE(fs::exists(done / "metadata.csv"));
}

TEST_CASE("overwriting slides killed early leaves no old csv beside new frames") {
  // Issue 11: `ss_synth --overwrite` stopped early left old per-sequence metadata.csv files
  // beside new frames. The writer now removes sequences.csv, then every metadata.csv, before
  // writing a frame; a failure at the first frame stands for a kill.
  const fs::path root = absent_dir("slides_overwrite");
  sim::SlideDatasetConfig c = tiny_slides();
  sim::write_slide_dataset(root, 3, c);
  int old_csvs = 0;
  for (const auto& e : fs::recursive_directory_iterator(root))
    old_csvs += e.path().filename() == "metadata.csv" ? 1 : 0;
  REQUIRE(old_csvs == 8);
  fs::remove(root / "left" / "palm_0000" / "frame_0000.png");
  fs::create_directories(root / "left" / "palm_0000" / "frame_0000.png");
  c.overwrite = true;
  CHECK_THROWS_AS(sim::write_slide_dataset(root, 4, c), IoError);
  CHECK_FALSE(fs::exists(root / "sequences.csv"));
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    CAPTURE(e.path());
    CHECK(e.path().filename() != "metadata.csv");
    CHECK(e.path().filename().string().find(".tmp") == std::string::npos);
  }
}

TEST_CASE("the csv reader accepts well-formed rows") {
  const Metadata m = read_metadata(csv_with(
      "good.csv", good_row + "nothing/b.png,nothing,2,custom,0.3,s,0,0,,,,,,,,,,,7.5\r\n"));
  REQUIRE(m.rows.size() == 2);
  CHECK(m.rows[0].shadow_box == cv::Rect(10, 20, 30, 40));
  CHECK(m.rows[0].contact_box == cv::Rect(12, 22, 5, 6));
  CHECK(m.rows[0].contact_point->x == doctest::Approx(14.5));
  CHECK(m.rows[0].lighting == sim::Lighting::dusk);
  CHECK(m.rows[0].line == 2);
  CHECK(m.rows[1].lighting_level == doctest::Approx(0.3));
  CHECK_FALSE(m.rows[1].shadow_box);
  CHECK(m.image_path(m.rows[0]) == m.folder() / "palm/a.png");
  // Writing the rows and reading them back gives the same values.
  const fs::path again = fs::path(SHADOWSENSE_TEST_TMP_DIR) / "dataset" / "csv" / "again.csv";
  write_metadata(again, m.rows, false);
  const Metadata n = read_metadata(again);
  REQUIRE(n.rows.size() == 2);
  CHECK(n.rows[0].shadow_box == m.rows[0].shadow_box);
  CHECK(n.rows[0].contact_point->y == doctest::Approx(24.5));
  CHECK(n.rows[1].session == "s");
}

TEST_CASE("the csv reader rejects malformed rows naming file, line and column") {
  struct Case {
    const char* name;
    std::string body;
    std::string expected;
  };
  const Case cases[] = {
      {"user.csv", good_row + "palm/a.png,palm,x1,dusk,0.5,s,3,300,,,,,,,,,,,7.5\n",
       "user.csv:3: column 3 'user': expected an integer; got 'x1'"},
      {"light.csv", "palm/a.png,palm,1,noon,0.5,s,3,300,,,,,,,,,,,7.5\n",
       "light.csv:2: column 4 'lighting'"},
      {"level.csv", "palm/a.png,palm,1,dusk,0.7,s,3,300,,,,,,,,,,,7.5\n",
       "level.csv:2: column 5 'lighting_level': does not match the lighting preset 'dusk'"},
      {"box.csv", "palm/a.png,palm,1,dusk,0.5,s,3,300,10,20,,40,,,,,,,7.5\n",
       "box.csv:2: column 11 'shadow_w': a box needs all of x, y, w, h or none"},
      {"width.csv", "palm/a.png,palm,1,dusk,0.5,s,3,300,10,20,0,40,,,,,,,7.5\n",
       "width.csv:2: column 11 'shadow_w'"},
      {"cols.csv", "palm/a.png,palm,1,dusk,0.5,s,3\n",
       "cols.csv:2: row has 7 columns; expected 19"},
      {"empty.csv", "palm/a.png,,1,dusk,0.5,s,3,300,,,,,,,,,,,7.5\n",
       "empty.csv:2: column 2 'class': must not be empty"},
      {"abs.csv", "/etc/a.png,palm,1,dusk,0.5,s,3,300,,,,,,,,,,,7.5\n",
       "abs.csv:2: column 1 'file_name'"},
      {"up.csv", "../a.png,palm,1,dusk,0.5,s,3,300,,,,,,,,,,,7.5\n",
       "up.csv:2: column 1 'file_name'"},
      {"point.csv", "palm/a.png,palm,1,dusk,0.5,s,3,300,10,20,30,40,12,22,5,6,,,7.5\n",
       "point.csv:2: column 17 'contact_cx': the contact point must be present exactly when the "
       "contact box is"},
      {"scale.csv", "palm/a.png,palm,1,dusk,0.5,s,3,300,,,,,,,,,,,nan\n",
       "scale.csv:2: column 19 'px_per_cm'"},
      {"time.csv", "palm/a.png,palm,1,dusk,0.5,s,3,-4,,,,,,,,,,,7.5\n",
       "time.csv:2: column 8 'timestamp_ms'"},
      {"quote.csv", "\"palm/a.png\",palm,1,dusk,0.5,s,3,300,,,,,,,,,,,7.5\n",
       "quote.csv:2: quoted fields"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.name);
    const fs::path p = csv_with(c.name, c.body);
    CHECK_THROWS_WITH_AS(read_metadata(p), doctest::Contains(c.expected.c_str()), DatasetError);
  }
  CHECK_THROWS_WITH_AS(read_metadata(csv_with("header.csv", good_row, "file_name,class")),
                       doctest::Contains("header.csv:1: unexpected header"), DatasetError);
  CHECK_THROWS_WITH_AS(
      read_metadata(fs::path(SHADOWSENSE_TEST_TMP_DIR) / "dataset" / "missing.csv"),
      doctest::Contains("cannot open"), DatasetError);
  CHECK_THROWS_WITH_AS(
      read_sequences(csv_with("seq.csv", "left/p,palm,up,10,12,13,1,dusk,0.5\n",
                              "sequence,gesture,direction,num_frames,distance_cm,fps,user,"
                              "lighting,lighting_level")),
      doctest::Contains("seq.csv:2: column 3 'direction': unknown direction 'up'"), DatasetError);
}

namespace {
// What the shared corpus checks: a metadata.csv with its images, a sequences.csv with every
// sequence and its images, or a temporal sequences.csv with every sequence and the headers of
// its frames' images, resolved as ss_track_eval --temporal reads them (examples/track_eval.cpp,
// read_temporal_frame) (tools/dataset_reader.py read_case does the same).
void read_case(const std::string& kind, const fs::path& csv) {
  if (kind == "metadata") {
    check_images(read_metadata(csv));
  } else if (kind == "sequences") {
    for (const SequenceRow& s : read_sequences(csv)) check_images(read_sequence_metadata(csv, s));
  } else {
    REQUIRE(kind == "temporal");
    const fs::path dir = csv.parent_path();
    for (const TemporalSequenceRow& row : read_temporal_sequences(dir)) {
      const TemporalSequence s = read_temporal_sequence(dir, row);
      for (const TemporalFrameRow& f : s.frames) {
        const std::string at = s.frames_csv.string() + ":" + std::to_string(f.line) + ": ";
        const fs::path p =
            detail::inside_folder(s.folder, f.file_name, at + "column 2 'file_name': ");
        (void)detail::image_header(p, {}, at + "cannot read image: ", true);
      }
    }
  }
}
} // namespace

TEST_CASE("the shared bad-input corpus: the C++ reader gives the verdicts of cases.txt") {
  // tests/data/bad_inputs/cases.txt is also run by tools/dataset_reader.py (ctest
  // dataset_reader_corpus): both readers must agree on every file.
  const fs::path root = fs::path(SHADOWSENSE_TEST_DATA_DIR) / "bad_inputs";
  std::ifstream in(root / "cases.txt");
  REQUIRE(in);
  std::string line;
  int cases = 0, rejects = 0;
  std::map<std::string, int> kinds;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::string kind, rel, verdict, expect;
    ls >> kind >> rel >> verdict;
    std::getline(ls >> std::ws, expect);
    CAPTURE(line);
    ++cases;
    ++kinds[kind];
    std::string got = "accept", message;
    try {
      read_case(kind, root / rel);
    } catch (const DatasetError& e) {
      got = "reject";
      message = e.what();
    }
    CAPTURE(message);
    CHECK(got == verdict);
    CHECK(message.find(expect) != std::string::npos);
    rejects += got == "reject" ? 1 : 0;
  }
  CHECK(cases == 39);
  CHECK(rejects == 36);
  CHECK(kinds == std::map<std::string, int>{{"metadata", 17}, {"sequences", 6}, {"temporal", 16}});
}

TEST_CASE("bounded image reading: header sizes before decoding, no FIFO hang, no /dev/zero") {
  const fs::path dir = absent_dir("image_file");
  fs::create_directories(dir);
  cv::Mat img(37, 53, CV_8UC3, cv::Scalar(10, 200, 30));
  for (const char* ext : {".png", ".jpg", ".bmp"}) {
    CAPTURE(ext);
    const fs::path p = dir / (std::string("img") + ext);
    REQUIRE(cv::imwrite(p.string(), img));
    const ImageHeader h = read_image_header(p);
    CHECK(h.width == 53);
    CHECK(h.height == 37);
    CHECK(read_image_file(p).size() == img.size());
    // The limit applies to the header, before decoding.
    CHECK_THROWS_WITH_AS(read_image_file(p, cv::IMREAD_COLOR, {.max_width = 52}),
                         doctest::Contains("the image is 53x37 pixels; the limit is 52x8192"),
                         IoError);
  }
  // A PNG that claims 20000x20000 (issue 11: decoded to 1.23 GB before any check).
  const fs::path huge = fs::path(SHADOWSENSE_TEST_DATA_DIR) / "bad_inputs/huge_png/palm/b.png";
  CHECK(fs::file_size(huge) < 2000);
  CHECK_THROWS_WITH_AS(read_image_file(huge),
                       doctest::Contains("the image is 20000x20000 pixels; the limit is 8192x8192"),
                       IoError);
  // Not regular files: refused without reading (a FIFO with no writer would block forever).
  const fs::path fifo = dir / "fifo.png";
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  CHECK_THROWS_WITH_AS(read_image_file(fifo), doctest::Contains("not a regular file"), IoError);
  CHECK_THROWS_WITH_AS(read_image_file("/dev/zero"), doctest::Contains("not a regular file"),
                       IoError);
  CHECK_THROWS_WITH_AS(read_image_file(dir), doctest::Contains("not a regular file"), IoError);
  // File size bound and truncated headers.
  CHECK_THROWS_WITH_AS(read_image_file(dir / "img.png", cv::IMREAD_COLOR, {.max_file_bytes = 10}),
                       doctest::Contains("bytes; the limit is 10"), IoError);
  std::ofstream(dir / "cut.png", std::ios::binary) << std::string("\x89PNG\r\n\x1a\n\0\0", 10);
  CHECK_THROWS_WITH_AS(read_image_header(dir / "cut.png"), doctest::Contains("truncated PNG"),
                       IoError);
}

TEST_CASE("a header-only csv is an error, not an empty dataset (ss_track_eval exited 0)") {
  CHECK_THROWS_WITH_AS(read_metadata(csv_with("header_only.csv", "")),
                       doctest::Contains("header_only.csv:2: no data rows"), DatasetError);
}
