// Writes the scene generator's datasets (docs/dataset_format.md):
//   OUT/gestures  six gesture classes on the robot rig (635x350), per-user per-lighting sessions
//   OUT/tracking  five tracking categories on the test box (200x205) with shadow/contact boxes
//   OUT/slides    slide sequences (13 fps, 8-80 frames, 10-26 cm, four directions, palm/finger)
//
//   ss_synth --out DIR [--dataset gestures|tracking|slides|all] [--seed N] [--paper-sizes]
//            [--users N] [--frames-per-gesture N] [--tracking-per-category N]
//            [--slides-per-combination N] [--lighting-level L] [--overwrite]
//            [--threads N] [--preview FILE.png]
//
// Defaults are small (a few hundred frames in a few seconds); --paper-sizes gives the paper's
// 6,120 gesture frames, 500 tracking frames and 160 slide sequences. --lighting-level L in
// [0, 1] renders every dataset under one custom light (0 night, 0.5 dusk, 1 daylight) to test
// on unseen lighting conditions. --preview writes one annotated montage (ground-truth shadow
// box blue, contact box white, contact point red) of all classes; alone it writes nothing else.
#include <shadowsense/eval.hpp>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <charconv>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <string>
#include <string_view>

namespace ss = shadowsense;
namespace sim = shadowsense::sim;

namespace {

int usage(const std::string& error) {
  std::cerr << "ss_synth: " << error << "\n"
            << "usage: ss_synth --out DIR [--dataset gestures|tracking|slides|all] [--seed N]\n"
            << "                [--paper-sizes] [--users N] [--frames-per-gesture N]\n"
            << "                [--tracking-per-category N] [--slides-per-combination N]\n"
            << "                [--lighting-level L] [--overwrite] [--threads N]\n"
            << "                [--preview FILE.png]\n";
  return 2;
}

template <class T>
bool parse(std::string_view s, T& out) {
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return !s.empty() && ec == std::errc() && p == s.data() + s.size();
}

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
  std::string out, dataset = "all", preview_path;
  std::uint64_t seed = 1;
  bool paper = false, overwrite = false;
  int threads = 1;
  int users = -1, frames_per_gesture = -1, tracking_per_category = -1, slides_per_combination = -1;
  double lighting_level = -1;
  bool have_level = false;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    auto value = [&](std::string_view& v) {
      if (i + 1 >= argc) return false;
      v = argv[++i];
      return true;
    };
    std::string_view v;
    if (a == "--paper-sizes")
      paper = true;
    else if (a == "--overwrite")
      overwrite = true;
    else if (a == "--help" || a == "-h")
      return usage("help"), 0;
    else if (!value(v))
      return usage("missing value after " + std::string(a));
    else if (a == "--out")
      out = std::string(v);
    else if (a == "--dataset")
      dataset = std::string(v);
    else if (a == "--preview")
      preview_path = std::string(v);
    else if (a == "--threads") {
      if (!parse(v, threads)) return usage("--threads expects an integer");
    } else if (a == "--seed") {
      if (!parse(v, seed)) return usage("--seed expects an unsigned integer");
    } else if (a == "--users") {
      if (!parse(v, users)) return usage("--users expects an integer");
    } else if (a == "--frames-per-gesture") {
      if (!parse(v, frames_per_gesture)) return usage("--frames-per-gesture expects an integer");
    } else if (a == "--tracking-per-category") {
      if (!parse(v, tracking_per_category))
        return usage("--tracking-per-category expects an integer");
    } else if (a == "--slides-per-combination") {
      if (!parse(v, slides_per_combination))
        return usage("--slides-per-combination expects an integer");
    } else if (a == "--lighting-level") {
      if (!parse(v, lighting_level)) return usage("--lighting-level expects a number in [0, 1]");
      have_level = true;
    } else
      return usage("unknown option " + std::string(a));
  }
  if (!preview_path.empty()) {
    try {
      if (!cv::imwrite(preview_path, preview(seed)))
        return usage("cannot write " + preview_path), 1;
    } catch (const std::exception& e) {
      std::cerr << "ss_synth: " << e.what() << "\n";
      return 1;
    }
    std::cout << "preview -> " << preview_path << "\n";
    if (out.empty()) return 0;
  }
  if (out.empty()) return usage("--out DIR is required");
  const bool all = dataset == "all";
  if (!all && dataset != "gestures" && dataset != "tracking" && dataset != "slides")
    return usage("unknown --dataset '" + dataset + "'; expected gestures, tracking, slides or all");

  auto g = paper ? sim::GestureDatasetConfig::paper() : sim::GestureDatasetConfig{};
  auto t = paper ? sim::TrackingDatasetConfig::paper() : sim::TrackingDatasetConfig{};
  auto s = paper ? sim::SlideDatasetConfig::paper() : sim::SlideDatasetConfig{};
  if (users != -1) g.users = t.users = s.users = users;
  if (frames_per_gesture != -1) g.frames_per_gesture = frames_per_gesture;
  if (tracking_per_category != -1) t.frames_per_category = tracking_per_category;
  if (slides_per_combination != -1) s.sequences_per_combination = slides_per_combination;
  if (have_level) {
    g.lighting_levels = {lighting_level};
    t.sample.lighting_level = s.slide.variety.lighting_level = lighting_level;
  }
  g.overwrite = t.overwrite = s.overwrite = overwrite;
  g.threads = t.threads = s.threads = threads;

  try {
    // Validate everything before writing anything.
    g.validate();
    t.validate();
    s.validate();
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
  } catch (const ss::Error& e) {
    std::cerr << "ss_synth: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
