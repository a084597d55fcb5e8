// The whole pipeline on a generated sequence, no arguments needed:
//
//   ss_demo [--out DIR] [--model FILE] [--no-lighting-normalise] [--threads N] [--save-frames]
//           [--source NAME] [--calibration FILE]
//
// A person approaches the robot, touches it with a palm, slides, pats twice, lifts, punches and
// hugs while the light fades from daylight to dusk and towards night. Every frame is rendered by
// the scene generator on the robot rig; the segmenter is calibrated on a few generated frames (as a
// robot would calibrate at start-up; the calibration is written to DIR/skin.calib); the library's
// Runtime (runtime/runtime.hpp: touch pipeline + classifier gated by the shadow) does the rest,
// exactly as ss_track does on a robot's frames. Prints an event log (time, track, state,
// position in cm, gesture, confidence; and a `gesture` line per temporal touch gesture: the
// palm's hold, its stroke to the right, its pat (revised to two pats), the punch, the hug -
// docs/temporal_gestures.md) and writes DIR/demo_strip.png (annotated frames) and
// DIR/events.csv (the project's event schema, docs/output.md). With --save-frames the rendered
// frames go to DIR/frames/ (frame_000001.png, ...): `ss_track --input DIR/frames --calibration
// DIR/skin.calib --fps 10` then prints the same event lines. --calibration FILE uses that
// calibration (e.g. an earlier run's DIR/skin.calib) instead of calibrating on generated frames.
// The classifier gets the calibration's empty-skin model, which a model with a calibrated input
// encoding (docs/input_encodings.md) divides every frame by; a colour model does not use it.
#include <shadowsense/eval.hpp>
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/runtime/densenet_runtime.hpp>

#include "common/cli.hpp"
#include "common/frame_source.hpp"
#include "common/model_calibration.hpp"
#include "common/runner.hpp"

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
  } else if (t < 6.6) {
    // Two pats where the slide ended: 0.2 s on the skin each, the palm hovering 3 cm above it
    // for 0.3 s and 0.4 s around them (docs/temporal_gestures.md: pat <= 350 ms of contact,
    // <= 600 ms between).
    const bool down = (t >= 5.8 && t < 6.0) || (t >= 6.4 && t < 6.6);
    what = down ? "pat" : "palm hovers";
    hand(sim::HandShape::open, palm_end, down ? 0 : 3);
  } else if (t < 7.0) {
    what = "lift";
    hand(sim::HandShape::open, palm_end, smooth(3, 20, (t - 6.6) / 0.4));
  } else if (t < 7.8) {
    what = "nothing near";
  } else if (t < 8.2) {
    what = "fist comes down";
    hand(sim::HandShape::fist, fist, smooth(10, 0.5, (t - 7.8) / 0.4), -100);
  } else if (t < 9.2) {
    what = "punch";
    hand(sim::HandShape::fist, fist, 0, -100);
  } else if (t < 9.6) {
    what = "lift";
    hand(sim::HandShape::fist, fist, smooth(0.5, 20, (t - 9.2) / 0.4), -100);
  } else if (t < 10.4) {
    what = "nothing near";
  } else if (t < 12.4) {
    what = "hug";
    sim::GesturePose p;
    p.rotation_deg = 90;
    p.position_cm = {0, 19};
    p.hug_reach = smooth(0.8, 1.1, (t - 10.4) / 2.0);
    return sim::gesture_scene(sim::Gesture::hug, user, p);
  } else {
    what = "person leaves";
  }
  return s;
}

// Light: daylight for 3 s, fading to dusk by 9 s and to a dim evening (level 0.15) by 13 s.
double light_level_at(double t) {
  return t < 3 ? 1.0 : t < 9 ? smooth(1.0, 0.5, (t - 3) / 6) : smooth(0.5, 0.15, (t - 9) / 4);
}

// The calibration from a few generated frames (empty skin + labelled touches, three light
// levels, with the empty-skin model), as a robot would calibrate at start-up.
ss::SegmenterCalibration generated_calibration(sim::Renderer& renderer) {
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
  sc.calibration.empty_skin = segmenter.empty_skin_model().clone();
  return sc.calibration;
}

// The scene's geometry for the human-readable log (positions in cm from the image centre).
struct Scale {
  cv::Point2f centre;
  double px_per_cm = 1;
};

// One line per touch event on stdout, with the frame's gesture and what the script is doing.
void log_event(const ss::TrackEvent& te, const ss::RuntimeFrame& r, const Scale& sc,
               const std::string& scene) {
  const ss::TouchEvent& e = te.event;
  char pos[32] = "-";
  if (e.position)
    std::snprintf(pos, sizeof pos, "(%+5.1f, %+5.1f)", (e.position->x - sc.centre.x) / sc.px_per_cm,
                  (e.position->y - sc.centre.y) / sc.px_per_cm);
  char conf_s[16] = "-";
  const bool classified = !r.gesture.label.empty();
  if (classified) std::snprintf(conf_s, sizeof conf_s, "%.2f", r.gesture.confidence);
  std::printf("%6.1fs %5d  %-7s %-7s %15s  %-6s %-10s %6s  %s\n", e.timestamp_ms / 1000.0,
              te.track_id, ss::to_string(e.from), ss::to_string(e.to), pos,
              e.direction == ss::Direction::none ? "-" : ss::to_string(e.direction),
              classified ? r.gesture.label.c_str() : "-", conf_s, scene.c_str());
}

// One line per temporal touch gesture (docs/temporal_gestures.md), between the touch events.
void log_gesture(const ss::GestureEvent& g, const std::string& scene) {
  const std::string shape(g.hand_shape.view());
  std::printf("%6.1fs %5d  gesture %-10s %-8s %4.1f-%4.1fs  %-6s x%-3d %-10s %4.2f  %s\n",
              g.decided_ms / 1000.0, g.track_id, ss::to_string(g.gesture), ss::to_string(g.phase),
              g.start_ms / 1000.0, g.end_ms / 1000.0,
              g.direction == ss::Direction::none ? "-" : ss::to_string(g.direction), g.repetitions,
              shape.empty() ? "-" : shape.c_str(), static_cast<double>(g.confidence),
              scene.c_str());
}

struct Shot {
  cv::Mat image;
  std::string caption;
};

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
  frames::write_png_atomically(path, strip);
}

} // namespace

int main(int argc, char** argv) {
  return cli::run("ss_demo", [&] {
    fs::path out = "shadowsense_demo", model_path, calibration_path;
    std::string source = "ss_demo";
    bool normalise = true, save_frames = false;
    int threads = 1;
    cli::Parser p(
        "ss_demo",
        "The whole pipeline on a generated 13.6 s sequence (approach, palm touch, "
        "slide, two pats, punch, hug while the light fades): prints an event log and writes "
        "DIR/demo_strip.png, DIR/events.csv and DIR/skin.calib.");
    p.option("--out", "DIR", "output folder", out);
    p.option("--model", "FILE", "model file", model_path)
        .default_text("the installed model: " + runner::default_model_text(argv[0]));
    p.flag("--no-lighting-normalise", "paper preprocessing (no lighting normalisation)", normalise,
           false);
    p.option("--threads", "N", "classifier worker threads", threads).range(1, 256);
    p.flag("--save-frames", "also write the rendered frames to DIR/frames/", save_frames);
    p.option("--source", "NAME", "the events' source field in events.csv", source);
    p.option("--calibration", "FILE",
             "use this calibration (segmenter, and the empty-skin model of calibrated input "
             "encodings) instead of calibrating on generated frames",
             calibration_path);
    p.parse(argc, argv);
    if (model_path.empty()) model_path = runner::find_default_model(argv[0]);
    const auto t_start = std::chrono::steady_clock::now();
    auto model = ss::ModelFile::load(model_path);
    // On by default (version-1 files do not record it; the shipped version-2 model does), but
    // never for a darkness_warmth or masks model, which has the light divided out and takes none.
    normalise = normalise && !ss::light_independent(model.preprocess.input_encoding);
    model.preprocess.lighting_normalise = normalise;

    sim::Renderer renderer(sim::Rig::robot());
    const ss::SegmenterCalibration calibration = calibration_path.empty()
                                                     ? generated_calibration(renderer)
                                                     : ss::load_calibration(calibration_path);
    const cli::EncoderCalibration ec = cli::encoder_calibration_from(
        model, model_path.string(), calibration, calibration_path.string(), false);
    fs::create_directories(out);
    ss::save_calibration(calibration, (out / "skin.calib").string());
    ss::Runtime sense(ss::TouchPipeline{ss::Segmenter({.calibration = calibration})},
                      ss::make_densenet_classifier(model, {.threads = threads},
                                                   ss::ChannelOrder::bgr, ec.empty_skin));
    if (save_frames) fs::create_directories(out / "frames");

    sim::Rng urng(2024);
    const sim::User user = sim::User::random(42, urng);
    const double fps = 10, duration_s = 13.6;
    const int frames = static_cast<int>(duration_s * fps);
    sim::Frame frame;
    std::ostringstream csv;
    ss::CsvSink events(csv, {.source = source});
    std::printf("shadowsense demo: %d frames at %.0f fps, model %s (%zu classes), lighting "
                "normalisation %s\n",
                frames, fps, model_path.string().c_str(), model.class_names.size(),
                normalise ? "on" : "off");
    std::printf("%7s %5s  %-7s %-7s %15s  %-6s %-10s %6s  %s\n", "time", "track", "from", "to",
                "position cm", "dir", "gesture", "conf", "scene");
    std::vector<Shot> shots;
    std::string last_scene, scene;
    int classified = 0, gated = 0;
    std::map<std::string, int> shot_for_scene;
    Scale scale;
    double last_t = 0;
    for (int i = 0; i < frames; ++i) {
      const double t_ms = runner::frame_time_ms(i, fps); // as ss_track times a folder
      const double t_s = t_ms / 1000.0;
      const sim::Scene s = scene_at(t_s, user, scene);
      renderer.render(s, sim::light_from_level(light_level_at(t_s), 30),
                      5000 + static_cast<std::uint64_t>(i), frame);
      scale = {cv::Point2f(frame.image.cols / 2.0f, frame.image.rows / 2.0f), frame.gt.px_per_cm};
      if (save_frames) {
        char name[32];
        std::snprintf(name, sizeof name, "frame_%06d.png", i + 1);
        frames::write_png_atomically(out / "frames" / name, frame.image);
      }
      const ss::RuntimeFrame& r = sense.update(frame.image, t_ms);
      events.write(sense.output());
      if (r.classified)
        ++classified;
      else if (r.gesture.label.empty())
        ++gated; // nothing near: no inference
      for (const ss::TrackEvent& e : r.touch.events) log_event(e, r, scale, scene);
      for (const ss::GestureEvent& g : r.touch_gestures) log_gesture(g, scene);
      if (scene != last_scene) shot_for_scene[scene] = i;
      last_scene = scene;
      // One annotated frame per scripted phase, in the middle of it (the second of a pat's two).
      if ((i - shot_for_scene[scene]) == (scene == "pat" ? 1 : 4) && shots.size() < 8 &&
          scene != "empty skin" && scene != "nothing near") {
        char cap[160];
        std::snprintf(cap, sizeof cap, "t=%.1fs %s", t_s, scene.c_str());
        shots.push_back({runner::annotate(frame.image, sense.segmentation(), r), cap});
      }
      last_t = t_ms;
    }
    const ss::RuntimeFrame& end = sense.flush(last_t + 1000.0 / fps); // as ss_track ends a file
    events.write(sense.output());
    for (const ss::TrackEvent& e : end.touch.events) log_event(e, end, scale, "stream ends");
    for (const ss::GestureEvent& g : end.touch_gestures) log_gesture(g, "stream ends");
    ss::write_file_atomically(out / "events.csv", csv.str());
    const fs::path strip_path = out / "demo_strip.png";
    write_strip(shots, strip_path);
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    std::printf("classifier ran on %d frames, gated off on %d (nothing near); %.1f s in total\n",
                classified, gated, secs);
    std::printf("wrote %s, %s and %s%s\n", strip_path.string().c_str(),
                (out / "events.csv").string().c_str(), (out / "skin.calib").string().c_str(),
                save_frames ? (" and " + (out / "frames").string() + "/").c_str() : "");
    return 0;
  });
}
