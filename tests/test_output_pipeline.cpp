// The TouchPipeline's frames through OutputFrameBuilder into the CSV and TUIO sinks, on a
// sequence rendered by the scene generator whose script fixes what must come out: one finger
// hovers (frames 2-3), touches (4-5), slides right (6-8), hovers (9-10) and leaves (11-13), one
// frame every 77 ms; the state machine's 150 ms hysteresis puts the lift at frame 11.
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/output/output.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

using namespace shadowsense;

static_assert(TouchFrameLike<TouchFrame>);

namespace {
sim::HandPose finger(double x_cm, double height_cm) {
  sim::HandPose p;
  p.shape = sim::HandShape::point;
  p.position_cm = {x_cm, 0};
  p.rotation_deg = -90;
  p.height_cm = height_cm;
  p.arm_elevation_deg = 40;
  return p;
}

std::vector<std::int32_t> alive_ids(const std::vector<std::uint8_t>& bundle) {
  std::vector<OscMessage> m;
  osc_collect_messages(osc_decode(bundle), m);
  REQUIRE(m.size() >= 2);
  REQUIRE(std::get<std::string>(m[0].arguments.at(0)) == "alive");
  std::vector<std::int32_t> ids;
  for (std::size_t i = 1; i < m[0].arguments.size(); ++i)
    ids.push_back(std::get<std::int32_t>(m[0].arguments[i]));
  CHECK(std::get<std::int32_t>(m.back().arguments.at(1)) >= 1); // fseq
  return ids;
}
} // namespace

TEST_CASE("pipeline -> OutputFrameBuilder -> CSV rows and TUIO alive lists follow the script") {
  sim::Renderer renderer(sim::Rig::tracking_box());
  const SimCalibration calibration = calibrate_on_sim(renderer, 0xCA11B, 60);
  std::vector<std::vector<sim::HandPose>> script(2);
  for (int k = 0; k < 2; ++k) script.push_back({finger(0, 1.5)});
  for (int k = 0; k < 2; ++k) script.push_back({finger(0, 0)});
  for (int k = 1; k <= 3; ++k) script.push_back({finger(1.2 * k, 0)});
  for (int k = 0; k < 2; ++k) script.push_back({finger(3.6, 1.5)});
  for (int k = 0; k < 3; ++k) script.push_back({});

  TouchPipeline pipeline(segmenter_from(calibration), {.max_distance_px = 60});
  OutputFrameBuilder builder;
  std::ostringstream csv_text;
  CsvSink csv(csv_text);
  TuioEncoder tuio;
  std::vector<std::vector<std::int32_t>> cursors, blobs;
  std::vector<cv::Point2f> cursor_at;
  std::string expected_csv = std::string(event_csv_header) + "\n";
  for (std::size_t i = 0; i < script.size(); ++i) {
    sim::Scene scene;
    sim::User user;
    for (const auto& h : script[i]) sim::add_hand(scene.parts, user, h);
    const sim::Frame f = renderer.render(scene, sim::preset(sim::Lighting::dusk), 500 + i);
    const TouchFrame& r = pipeline.update(f.image, 77.0 * static_cast<double>(i));
    const OutputFrame& out = builder.build(r, f.image.size());
    CHECK(out.frame_index == static_cast<std::int64_t>(i) + 1);
    REQUIRE(out.events.size() == r.events.size());
    for (const TrackEvent& e : r.events) {
      for (const std::string& field :
           {std::to_string(event_schema_version), std::string("touch"), std::string(),
            std::to_string(i + 1), std::to_string(77 * i), std::to_string(e.track_id),
            std::string(to_string(e.event.from)), std::string(to_string(e.event.to)),
            std::string(to_string(e.event.direction))}) {
        expected_csv += field;
        expected_csv += ',';
      }
      if (e.event.position) {
        std::string xy;
        detail::append_number(xy, e.event.position->x);
        xy += ',';
        detail::append_number(xy, e.event.position->y);
        expected_csv += xy;
      } else {
        expected_csv += ",";
      }
      expected_csv += ",,,,,,,,,,,,\n"; // no classifier: no gesture; a touch row
    }
    publish(out, csv);
    int bundle = 0;
    tuio.encode(out, [&](std::span<const std::uint8_t> b) {
      const std::vector<std::uint8_t> bytes(b.begin(), b.end());
      (bundle++ == 0 ? cursors : blobs).push_back(alive_ids(bytes));
    });
    cursor_at.push_back(out.contacts.empty() ? cv::Point2f(-1, -1) : out.contacts[0].position);
  }
  // The CSV holds exactly the pipeline's events (appear 2, touch 4, move 6, lift 11, none 13).
  CHECK(csv_text.str() == expected_csv);
  CHECK(std::count(expected_csv.begin(), expected_csv.end(), '\n') == 6);
  // A TUIO cursor from the touch (frame 4) until the lift (frame 11); while the finger hovers
  // at 9-10 (hysteresis) it stays at the last contact point of frame 8.
  const std::vector<std::int32_t> none{}, one{1};
  for (std::size_t i = 0; i < script.size(); ++i) {
    CAPTURE(i);
    CHECK(cursors[i] == (i >= 4 && i <= 10 ? one : none));
  }
  CHECK(cursor_at[9] == cursor_at[8]);
  CHECK(cursor_at[10] == cursor_at[8]);
  CHECK(cursor_at[8].x > cursor_at[6].x); // it slid right
  // A TUIO blob while the hand's shadow is tracked: from the hover at frame 2 on, none at the end.
  for (std::size_t i = 2; i <= 10; ++i) {
    CAPTURE(i);
    CHECK(blobs[i] == one);
  }
  CHECK(blobs[0] == none);
  CHECK(blobs[13] == none);
}
