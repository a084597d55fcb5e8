// The whole pipeline on a generated sequence, no arguments needed:
//
//   ss_demo [--out DIR] [--model models/default.ssm] [--no-lighting-normalise] [--threads N]
//
// A person approaches the robot, touches it with a palm, slides, lifts, punches and hugs while
// the light fades from daylight to dusk and towards night. Every frame is rendered by the scene
// generator on the robot rig; the segmenter (calibrated on a few generated frames) finds shadow
// and contact; the contact tracker keeps ids; the classifier runs only while a shadow is seen
// (gating); the touch state machine emits events. Prints an event log (time, state, position in
// cm, gesture, confidence) and writes DIR/demo_strip.png (annotated frames) and DIR/events.csv.
#include <shadowsense/eval.hpp>
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/train.hpp>

#include "common/cli.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>

namespace ss = shadowsense;
namespace sim = shadowsense::sim;
namespace fs = std::filesystem;

namespace {

double smooth(double a, double b, double t) { // a -> b as t goes 0 -> 1, eased
  t = std::clamp(t, 0.0, 1.0);
  t = t * t * (3 - 2 * t);
  return a + (b - a) * t;
}

// The scripted scene at time t (seconds) and a short description of what happens.
sim::Scene scene_at(double t, const sim::User& user, std::string& what) {
  sim::Scene s;
  s.skin_tone = user.skin_tone;
  auto hand = [&](sim::HandShape shape, cv::Point2d at, double height, double rot = -90) {
    sim::HandPose h;
    h.shape = shape;
    h.position_cm = at;
    h.height_cm = height;
    h.rotation_deg = rot;
    h.spread = 0.6;
    h.arm_elevation_deg = shape == sim::HandShape::fist ? 55 : 35;
    sim::add_hand(s.parts, user, h);
  };
  const cv::Point2d palm_start{-16, 2}, palm_end{12, 2}, fist{14, -4};
  if (t < 1.0) {
    what = "empty skin";
  } else if (t < 2.5) {
    what = "person approaches";
    sim::GesturePose p;
    p.position_cm = {-20, 14};
    p.rotation_deg = 90;
    p.body_height_cm = smooth(90, 34, (t - 1.0) / 1.5);
    return sim::gesture_scene(sim::Gesture::nothing, user, p);
  } else if (t < 3.0) {
    what = "hand comes down";
    hand(sim::HandShape::open, palm_start, smooth(12, 0.5, (t - 2.5) / 0.5));
  } else if (t < 4.0) {
    what = "palm touch";
    hand(sim::HandShape::open, palm_start, 0);
  } else if (t < 5.5) {
    what = "palm slides right";
    const double a = smooth(0, 1, (t - 4.0) / 1.5);
    hand(sim::HandShape::open, palm_start + (palm_end - palm_start) * a, 0);
  } else if (t < 6.0) {
    what = "lift";
    hand(sim::HandShape::open, palm_end, smooth(0.5, 20, (t - 5.5) / 0.5));
  } else if (t < 6.8) {
    what = "nothing near";
  } else if (t < 7.2) {
    what = "fist comes down";
    hand(sim::HandShape::fist, fist, smooth(10, 0.5, (t - 6.8) / 0.4), -100);
  } else if (t < 8.2) {
    what = "punch";
    hand(sim::HandShape::fist, fist, 0, -100);
  } else if (t < 8.6) {
    what = "lift";
    hand(sim::HandShape::fist, fist, smooth(0.5, 20, (t - 8.2) / 0.4), -100);
  } else if (t < 9.4) {
    what = "nothing near";
  } else if (t < 11.4) {
    what = "hug";
    sim::GesturePose p;
    p.rotation_deg = 90;
    p.position_cm = {0, 19};
    p.hug_reach = smooth(0.8, 1.1, (t - 9.4) / 2.0);
    return sim::gesture_scene(sim::Gesture::hug, user, p);
  } else {
    what = "person leaves";
  }
  return s;
}

// Light: daylight for 3 s, fading to dusk by 8 s and to a dim evening (level 0.15) by 12 s.
double light_level_at(double t) {
  return t < 3 ? 1.0 : t < 8 ? smooth(1.0, 0.5, (t - 3) / 5) : smooth(0.5, 0.15, (t - 8) / 4);
}

fs::path find_model(const char* argv0) {
  const fs::path exe = fs::absolute(argv0).parent_path();
  for (const fs::path& p :
       {fs::path("models/default.ssm"), exe / "../../models/default.ssm",
        exe / "../models/default.ssm", exe / "../share/shadowsense/models/default.ssm"})
    if (fs::is_regular_file(p)) return p;
  throw ss::IoError(
      "cannot find models/default.ssm (run from the repository root or pass --model PATH)");
}

// The segmenter, calibrated from a few generated frames (empty skin + labelled touches, three
// light levels), as a robot would calibrate at start-up.
ss::Segmenter calibrated_segmenter(sim::Renderer& renderer) {
  std::vector<cv::Mat> empty;
  std::vector<ss::LabelledFrame> labelled;
  sim::Rng rng(99);
  const sim::User cal_user = sim::User::random(900, rng);
  for (double level : {1.0, 0.5, 0.0}) {
    for (int k = 0; k < 2; ++k)
      empty.push_back(
          renderer.render(sim::Scene{}, sim::light_from_level(level, 30), 1000 + k).image);
    sim::GestureSession session(7 + static_cast<std::uint64_t>(level * 10), cal_user, level);
    for (int f = 0; f < session.size(); f += 2) {
      if (session.info(f).gesture == sim::Gesture::nothing) continue;
      sim::Frame fr;
      session.render(renderer, f, fr);
      labelled.push_back({fr.image.clone(), fr.gt.shadow_mask.clone(), fr.gt.contact_mask.clone()});
    }
  }
  ss::Segmenter::Config sc;
  sc.calibration = ss::fit_calibration(empty, labelled, sc, 3);
  // Guard: older fits could return shadow_darkness 1.0 (no shadow pixel) on the robot rig;
  // keep the contact thresholds and fall back to the default shadow threshold then.
  for (auto& b : sc.calibration.by_light)
    if (b.shadow_darkness > 0.9f) b.shadow_darkness = ss::LightThresholds{}.shadow_darkness;
  ss::Segmenter segmenter(sc);
  segmenter.set_empty_skin(empty);
  return segmenter;
}

// What the pipeline saw in one frame.
struct FrameResult {
  double t = 0;           // seconds
  std::string scene;      // the script's description
  std::string label{'-'}; // gesture, "-" when gated off
  float confidence = 0;   // of `label`
  cv::Point2f centre;     // image centre, px
  double px_per_cm = 1;
};

// One line per touch event on stdout and one row in the events csv.
void log_event(const ss::TouchEvent& e, const FrameResult& r, std::ostream& csv) {
  char pos[32] = "-";
  if (e.position)
    std::snprintf(pos, sizeof pos, "(%+5.1f, %+5.1f)", (e.position->x - r.centre.x) / r.px_per_cm,
                  (e.position->y - r.centre.y) / r.px_per_cm);
  char conf_s[16] = "-";
  const bool classified = r.label != "-";
  if (classified) std::snprintf(conf_s, sizeof conf_s, "%.2f", r.confidence);
  std::printf("%6.1fs  %-7s %-7s %15s  %-6s %-10s %6s  %s\n", r.t, ss::to_string(e.from),
              ss::to_string(e.to), pos,
              e.direction == ss::Direction::none ? "-" : ss::to_string(e.direction),
              r.label.c_str(), conf_s, r.scene.c_str());
  csv << r.t << ',' << ss::to_string(e.from) << ',' << ss::to_string(e.to) << ',';
  if (e.position)
    csv << (e.position->x - r.centre.x) / r.px_per_cm << ','
        << (e.position->y - r.centre.y) / r.px_per_cm;
  else
    csv << ',';
  csv << ',' << (e.direction == ss::Direction::none ? "" : ss::to_string(e.direction)) << ','
      << (classified ? r.label : "") << ',' << (classified ? r.confidence : 0.0f) << ',' << r.scene
      << '\n';
}

struct Shot {
  cv::Mat image;
  std::string caption;
};

// The frame with the found shadow box (blue), contact box (red) and matched tracks (yellow),
// captioned with time, scene, touch state and gesture.
Shot annotated_shot(const sim::Frame& frame, const ss::Segmentation& seg,
                    const std::vector<ss::Track>& tracks, const FrameResult& r,
                    ss::TouchState state) {
  cv::Mat img = frame.image.clone();
  if (seg.shadow_box) cv::rectangle(img, *seg.shadow_box, {255, 160, 0}, 2);
  if (seg.contact_box) cv::rectangle(img, *seg.contact_box, {0, 0, 255}, 2);
  for (const auto& tr : tracks)
    if (tr.matched) cv::circle(img, tr.position, 6, {0, 255, 255}, cv::FILLED);
  char cap[160];
  std::snprintf(
      cap, sizeof cap, "t=%.1fs %s | %s %s", r.t, r.scene.c_str(), ss::to_string(state),
      r.label == "-"
          ? ""
          : (r.label + " " + std::to_string(static_cast<int>(r.confidence * 100)) + "%").c_str());
  return {img, cap};
}

// Frame strip: 4 x 2 tiles at half size, caption under each.
void write_strip(const std::vector<Shot>& shots, const fs::path& path) {
  const int tw = 635 / 2, th = 350 / 2, cap_h = 24;
  cv::Mat strip(2 * (th + cap_h), 4 * tw, CV_8UC3, cv::Scalar(255, 255, 255));
  for (std::size_t k = 0; k < shots.size(); ++k) {
    const int x = static_cast<int>(k % 4) * tw, y = static_cast<int>(k / 4) * (th + cap_h);
    cv::Mat small;
    cv::resize(shots[k].image, small, {tw, th}, 0, 0, cv::INTER_AREA);
    small.copyTo(strip(cv::Rect(x, y, tw, th)));
    cv::putText(strip, shots[k].caption, {x + 4, y + th + 17}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
                {0, 0, 0}, 1, cv::LINE_AA);
  }
  if (!cv::imwrite(path.string(), strip)) throw ss::IoError("cannot write " + path.string());
}

} // namespace

int main(int argc, char** argv) {
  return cli::run("ss_demo", [&] {
    fs::path out = "shadowsense_demo", model_path;
    bool normalise = true;
    int threads = 1;
    cli::Parser p("ss_demo",
                  "The whole pipeline on a generated 12.6 s sequence (approach, palm touch, "
                  "slide, punch, hug while the light fades): prints an event log and writes "
                  "DIR/demo_strip.png and DIR/events.csv.");
    p.option("--out", "DIR", "output folder", out);
    p.option("--model", "PATH", "model file", model_path)
        .default_text("models/default.ssm, searched from here and beside the program");
    p.flag("--no-lighting-normalise", "paper preprocessing (no lighting normalisation)", normalise,
           false);
    p.option("--threads", "N", "classifier worker threads", threads).range(1, 256);
    p.parse(argc, argv);
    if (model_path.empty()) model_path = find_model(argv[0]);
    const auto t_start = std::chrono::steady_clock::now();
    auto model = ss::ModelFile::load(model_path);
    // On by default (version-1 files do not record it; the shipped version-2 model does).
    model.preprocess.lighting_normalise = normalise;
    auto clf = ss::make_densenet_classifier(model, {.threads = threads}); // owns the encoding

    sim::Renderer renderer(sim::Rig::robot());
    ss::Segmenter segmenter = calibrated_segmenter(renderer);
    ss::ContactTracker tracker;
    ss::TouchStateMachine fsm;

    sim::Rng urng(2024);
    const sim::User user = sim::User::random(42, urng);
    const double fps = 10, duration_s = 12.6;
    const int frames = static_cast<int>(duration_s * fps);
    sim::Frame frame;
    fs::create_directories(out);
    std::ostringstream csv;
    csv << "time_s,from,to,x_cm,y_cm,direction,gesture,confidence,scene\n";
    std::printf("shadowsense demo: %d frames at %.0f fps, model %s (%zu classes), lighting "
                "normalisation %s\n",
                frames, fps, model_path.string().c_str(), model.class_names.size(),
                normalise ? "on" : "off");
    std::printf("%7s  %-7s %-7s %15s  %-6s %-10s %6s  %s\n", "time", "from", "to", "position cm",
                "dir", "gesture", "conf", "scene");
    std::vector<Shot> shots;
    std::string last_scene;
    int classified = 0, gated = 0;
    std::map<std::string, int> shot_for_scene;
    for (int i = 0; i < frames; ++i) {
      FrameResult r;
      r.t = i / fps;
      const double t_ms = 1000.0 * r.t;
      const sim::Scene scene = scene_at(r.t, user, r.scene);
      renderer.render(scene, sim::light_from_level(light_level_at(r.t), 30),
                      5000 + static_cast<std::uint64_t>(i), frame);
      r.px_per_cm = frame.gt.px_per_cm;
      r.centre = cv::Point2f(frame.image.cols / 2.0f, frame.image.rows / 2.0f);
      const ss::Segmentation seg = segmenter.segment(frame.image);
      std::vector<ss::Detection> dets;
      for (const auto& b : seg.contacts) dets.push_back({b.centroid, b.box});
      const auto& tracks = tracker.update(dets, t_ms);
      // Gate: no inference while nothing is near the skin.
      if (seg.shadow_box) {
        const auto c = clf.classify(frame.image); // the model's lighting and dark-frame rules
        r.label = c.label;
        r.confidence = c.probabilities[static_cast<std::size_t>(c.index)];
        ++classified;
      } else {
        ++gated;
      }
      for (const auto& e : fsm.update(t_ms, {seg.shadow_box.has_value(), seg.contact_point}))
        log_event(e, r, csv);
      // One annotated frame per scripted phase, in the middle of it.
      if (r.scene != last_scene) shot_for_scene[r.scene] = i;
      last_scene = r.scene;
      if ((i - shot_for_scene[r.scene]) == 4 && shots.size() < 8 && r.scene != "empty skin" &&
          r.scene != "nothing near")
        shots.push_back(annotated_shot(frame, seg, tracks, r, fsm.state()));
    }
    ss::write_file_atomically(out / "events.csv", csv.str());
    const fs::path strip_path = out / "demo_strip.png";
    write_strip(shots, strip_path);
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    std::printf("classifier ran on %d frames, gated off on %d (nothing near); %.1f s in total\n",
                classified, gated, secs);
    std::printf("wrote %s and %s\n", strip_path.string().c_str(),
                (out / "events.csv").string().c_str());
    return 0;
  });
}
