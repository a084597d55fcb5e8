// Writes the scene generator's datasets (docs/dataset_format.md):
//   OUT/gestures  six gesture classes on the robot rig (635x350), per-user per-lighting sessions
//   OUT/tracking  five tracking categories on the test box (200x205) with shadow/contact boxes
//   OUT/slides    slide sequences (13 fps, 8-80 frames, 10-26 cm, four directions, palm/finger)
//
//   ss_synth --out DIR [--dataset gestures|tracking|slides|all] [--seed N] [--paper-sizes]
//            [--users N] [--frames-per-gesture N] [--tracking-per-category N]
//            [--slides-per-combination N] [--lighting-level L] [--overwrite]
//
// Defaults are small (a few hundred frames in a few seconds); --paper-sizes gives the paper's
// 6,120 gesture frames, 500 tracking frames and 160 slide sequences. --lighting-level L in
// [0, 1] renders every dataset under one custom light (0 night, 0.5 dusk, 1 daylight) to test
// on unseen lighting conditions.
#include <shadowsense/io.hpp>

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
            << "                [--lighting-level L] [--overwrite]\n";
  return 2;
}

template <class T>
bool parse(std::string_view s, T& out) {
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return !s.empty() && ec == std::errc() && p == s.data() + s.size();
}

} // namespace

int main(int argc, char** argv) {
  std::string out, dataset = "all";
  std::uint64_t seed = 1;
  bool paper = false, overwrite = false;
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
    else if (a == "--seed") {
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
