// Writes the scene generator's datasets (docs/dataset_format.md):
//   OUT/gestures  six gesture classes on the robot rig (635x350), per-user per-lighting sessions
//   OUT/tracking  five tracking categories on the test box (200x205) with shadow/contact boxes
//   OUT/slides    slide sequences (13 fps, 8-80 frames, 10-26 cm, four directions, palm/finger)
//   OUT/temporal  temporal gesture sequences (taps, pats, strokes, rubs, holds, hits, hugs,
//                 punches, two hands) rendered on the robot rig at 15, 30 and 60 fps with
//                 dropped and duplicated frames (only with --dataset temporal; not in `all`)
//
//   ss_synth --out DIR [--dataset gestures|tracking|slides|all] [--seed N] [--paper-sizes]
//            [--users N] [--frames-per-gesture N] [--tracking-per-category N]
//            [--slides-per-combination N] [--lighting-level L] [--overwrite]
//            [--threads N] [--preview FILE.png]
//            [--temporal-users N] [--temporal-first-user K] [--temporal-gestures N]
//            [--temporal-fps F,...]
//
// Defaults are small (a few hundred frames in a few seconds); --paper-sizes gives the paper's
// 6,120 gesture frames, 500 tracking frames and 160 slide sequences. --lighting-level L in
// [0, 1] renders every dataset under one custom light (0 night, 0.5 dusk, 1 daylight) to test
// on unseen lighting conditions. --preview writes one annotated montage (ground-truth shadow
// box blue, contact box white, contact point red) of all classes; alone it writes nothing else.
#include <shadowsense/eval.hpp>
#include <shadowsense/sim/touch_sequence_writer.hpp>

#include "common/cli.hpp"
#include "common/frame_source.hpp"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <string>
#include <string_view>

namespace ss = shadowsense;
namespace sim = shadowsense::sim;

namespace {

cv::Mat annotated(const sim::Frame& f, const std::string& caption, double scale) {
  cv::Mat img;
  cv::resize(f.image, img, cv::Size(), scale, scale, cv::INTER_AREA);
  const auto box = [&](const cv::Rect& r) {
    return cv::Rect(cvRound(r.x * scale), cvRound(r.y * scale), cvRound(r.width * scale),
                    cvRound(r.height * scale));
  };
  if (f.gt.shadow_box) cv::rectangle(img, box(*f.gt.shadow_box), {255, 80, 0}, 1);
  if (f.gt.contact_box) cv::rectangle(img, box(*f.gt.contact_box), {255, 255, 255}, 1);
  if (f.gt.contact_point)
    cv::circle(
        img,
        cv::Point(cvRound(f.gt.contact_point->x * scale), cvRound(f.gt.contact_point->y * scale)),
        3, {0, 0, 255}, cv::FILLED);
  cv::putText(img, caption, {4, 14}, cv::FONT_HERSHEY_SIMPLEX, 0.4, {0, 255, 0}, 1, cv::LINE_AA);
  return img;
}

// Row 1: the six gestures (robot rig, half size), one per lighting in turn. Row 2: the five
// tracking categories and the first and last frame of a palm and a finger slide.
cv::Mat preview(std::uint64_t seed) {
  sim::Renderer robot(sim::Rig::robot()), box(sim::Rig::tracking_box());
  std::vector<cv::Mat> top, bottom;
  const double levels[3] = {1.0, 0.5, 0.0};
  for (std::size_t g = 0; g < sim::all_gestures.size(); ++g) {
    const sim::GestureSession session(sim::derive_seed(seed, 77 + g), sim::dataset_user(seed, 1),
                                      levels[g % 3],
                                      {.frames_per_gesture = 1, .distractor_probability = 0});
    sim::Frame f;
    sim::GestureFrameInfo info;
    session.render(robot, static_cast<int>(g), f, &info);
    top.push_back(annotated(f,
                            std::string(sim::to_string(info.gesture)) + " / " +
                                std::string(sim::to_string(info.light.label)),
                            0.5));
  }
  for (sim::TrackCategory c : sim::all_track_categories) {
    sim::TrackingSampleConfig cfg;
    cfg.lighting_weights = {1, 0, 0};
    sim::TrackingSample s;
    const sim::Frame f = sim::render_random_tracking_frame(
        box, c, sim::derive_seed(seed, 900 + static_cast<int>(c)), cfg, &s);
    bottom.push_back(annotated(f, std::string(sim::to_string(c)), 1.0));
  }
  for (sim::SlideGesture g : {sim::SlideGesture::palm, sim::SlideGesture::finger}) {
    const sim::SlidePlan plan = sim::plan_slide(sim::derive_seed(seed, 950 + static_cast<int>(g)),
                                                g, sim::Direction::right);
    const std::string name = std::string(sim::to_string(g)) + " slide right";
    bottom.push_back(annotated(sim::render_slide_frame(box, plan, 0), name + " 0", 1.0));
    bottom.push_back(annotated(sim::render_slide_frame(box, plan, plan.num_frames() - 1),
                               name + " " + std::to_string(plan.num_frames() - 1), 1.0));
  }
  cv::Mat a, b;
  cv::hconcat(top, a);
  cv::hconcat(bottom, b);
  const int width = std::max(a.cols, b.cols);
  cv::copyMakeBorder(a, a, 0, 0, 0, width - a.cols, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  cv::copyMakeBorder(b, b, 0, 0, 0, width - b.cols, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  cv::Mat out;
  cv::vconcat(a, b, out);
  return out;
}

} // namespace

int main(int argc, char** argv) {
  return cli::run("ss_synth", [&] {
    std::string out, dataset = "all", preview_path;
    std::uint64_t seed = 1;
    bool paper = false, overwrite = false;
    int threads = 1;
    const sim::GestureDatasetConfig g0, gp = sim::GestureDatasetConfig::paper();
    const sim::TrackingDatasetConfig t0, tp = sim::TrackingDatasetConfig::paper();
    const sim::SlideDatasetConfig s0, sp = sim::SlideDatasetConfig::paper();
    int users = g0.users, frames_per_gesture = g0.frames_per_gesture,
        tracking_per_category = t0.frames_per_category,
        slides_per_combination = s0.sequences_per_combination;
    const auto or_paper = [](int small, int paper) {
      return std::to_string(small) + ", " + std::to_string(paper) + " with --paper-sizes";
    };
    double lighting_level = 0;
    cli::Parser p("ss_synth",
                  "Writes the scene generator's datasets: DIR/gestures (six gesture classes on "
                  "the robot rig), DIR/tracking (five tracking categories on the test box), "
                  "DIR/slides (slide sequences). Defaults are small; --paper-sizes gives the "
                  "paper's sizes.");
    p.usage("ss_synth --out DIR [options]");
    p.usage("ss_synth --preview FILE.png [--seed N]");
    p.option("--out", "DIR", "output folder", out);
    p.option("--dataset", "NAME", "which dataset to write", dataset)
        .choices({"gestures", "tracking", "slides", "all", "temporal"})
        .default_text("all (gestures, tracking and slides; temporal only when named)");
    p.option("--seed", "N", "random seed", seed);
    p.flag("--paper-sizes",
           "the paper's sizes (6,120 gesture frames, 500 tracking frames, 160 "
           "slide sequences)",
           paper);
    p.option("--users", "N", "number of users", users).range(1, 1000);
    p.option("--frames-per-gesture", "N", "gesture frames per gesture and session",
             frames_per_gesture)
        .range(1, 100000)
        .default_text(or_paper(frames_per_gesture, gp.frames_per_gesture));
    p.option("--tracking-per-category", "N", "tracking frames per category", tracking_per_category)
        .range(1, 1000000)
        .default_text(or_paper(tracking_per_category, tp.frames_per_category));
    p.option("--slides-per-combination", "N", "slide sequences per direction x gesture",
             slides_per_combination)
        .range(1, 100000)
        .default_text(or_paper(slides_per_combination, sp.sequences_per_combination));
    p.option("--lighting-level", "L",
             "render every dataset under one custom light (0 night, 0.5 dusk, 1 daylight)",
             lighting_level)
        .range(0.0, 1.0)
        .default_text("the datasets' own lightings");
    sim::TouchSequenceDatasetConfig q;
    std::uint64_t temporal_first_user = 1000;
    p.option("--temporal-users", "N",
             "temporal: generated users (one sequence each per frame rate; user seeds K..K+N-1)",
             q.users)
        .range(1, 10000);
    p.option("--temporal-first-user", "K", "temporal: the first user seed", temporal_first_user);
    p.option("--temporal-gestures", "N", "temporal: gestures per sequence", q.sequence.gestures)
        .range(1, 100000);
    p.list("--temporal-fps", "F", "temporal: frame rates", q.fps).range(5.0, 240.0);
    p.flag("--overwrite", "replace existing dataset folders", overwrite);
    p.option("--threads", "N", "rendering threads", threads).range(1, 256);
    p.option("--preview", "FILE.png",
             "write one annotated montage of all classes (alone, nothing else is written)",
             preview_path);
    p.parse(argc, argv);
    if (!preview_path.empty()) {
      frames::write_png_atomically(preview_path, preview(seed)); // temp + rename, checked
      std::cout << "preview -> " << preview_path << "\n";
      if (out.empty()) return 0;
    }
    if (out.empty()) throw cli::UsageError("missing required option --out DIR");
    const bool all = dataset == "all";

    auto g = paper ? sim::GestureDatasetConfig::paper() : sim::GestureDatasetConfig{};
    auto t = paper ? sim::TrackingDatasetConfig::paper() : sim::TrackingDatasetConfig{};
    auto s = paper ? sim::SlideDatasetConfig::paper() : sim::SlideDatasetConfig{};
    if (p.given("--users")) g.users = t.users = s.users = users;
    if (p.given("--frames-per-gesture")) g.frames_per_gesture = frames_per_gesture;
    if (p.given("--tracking-per-category")) t.frames_per_category = tracking_per_category;
    if (p.given("--slides-per-combination")) s.sequences_per_combination = slides_per_combination;
    if (p.given("--lighting-level")) {
      g.lighting_levels = {lighting_level};
      t.sample.lighting_level = s.slide.variety.lighting_level = lighting_level;
    }
    g.overwrite = t.overwrite = s.overwrite = q.overwrite = overwrite;
    g.threads = t.threads = s.threads = q.threads = threads;

    {
      // Validate everything before writing anything.
      g.validate();
      t.validate();
      s.validate();
      q.validate();
      const std::filesystem::path root(out);
      const auto run = [&](const char* name, auto&& write) {
        const auto t0 = std::chrono::steady_clock::now();
        const sim::DatasetSummary r = write(root / name);
        const double sec =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::cout << name << ": " << r.images << " images";
        if (r.sequences) std::cout << " in " << r.sequences << " sequences";
        std::cout << " -> " << r.root.string() << " (" << sec << " s)\n";
      };
      if (all || dataset == "gestures")
        run("gestures", [&](const auto& p) { return sim::write_gesture_dataset(p, seed, g); });
      if (all || dataset == "tracking")
        run("tracking", [&](const auto& p) { return sim::write_tracking_dataset(p, seed, t); });
      if (all || dataset == "slides")
        run("slides", [&](const auto& p) { return sim::write_slide_dataset(p, seed, s); });
      if (dataset == "temporal")
        run("temporal", [&](const auto& p) {
          return sim::write_touch_sequence_dataset(p, temporal_first_user, q);
        });
    }
    return 0;
  });
}
