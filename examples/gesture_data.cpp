// Writes a gesture-classification dataset (paper 5.1's six classes on the robot rig) in the
// library's dataset format: root/<class>/<session>_<frame>.png + root/metadata.csv. One
// recording session per user and lighting, frames in time order. Used by tools/train.py,
// ss_train_head and ss_eval_classify; the training data of the shipped model comes from it.
//
//   ss_gesture_data --out DIR [--users N] [--first-user K] [--frames F]
//                   [--lightings daylight,dusk,night | levels 0..1] [--seed S] [--randomise]
//                   [--scale-range LO,HI] [--hands DIR [--hands-split NAME]
//                   [--real-hand-probability P]] [--empty-skin]
//
// --randomise: domain randomisation (include/shadowsense/sim/randomise.hpp, ranges in
// docs/scene_generator.md): fabric, light, camera, lens, noise, compression, body, occluders.
// --scale-range LO,HI: every gesture block's body drawn at a pixel scale log-uniform in
// [LO, HI] (Scene::zoom about the gesture's anchor: a camera seeing hands smaller or larger).
// --hands DIR: real hand silhouettes (DIR/manifest.csv, rows of split NAME, default train; see
// include/shadowsense/sim/hand_silhouette_file.hpp) replace each hand of palm, point, punch,
// two_hands and hug frames with probability P (default 0.5), rendered by the same renderer.
//
// --empty-skin: per session also DIR/empty_skin/<session>_<k>.png (k = 0..2: three frames of the
// session's empty skin, its light and rig) and DIR/empty_skin/<session>.calib (the calibration
// file of a default Segmenter with the empty-skin model made from those frames, as ss_calibrate
// --empty would store it): what tools/train.py --input-encoding skin_relative divides that
// session's frames by (docs/dataset_format.md, docs/input_encodings.md).
//
// Users get ids K..K+N-1 and their body from the id and the seed, so disjoint id ranges give
// disjoint people (a backbone trained on ids 100+ never saw users 0..N-1).
#include <shadowsense/eval.hpp>
#include <shadowsense/sense/calibration_file.hpp>
#include <shadowsense/sense/segmenter.hpp>

#include "common/cli.hpp"

#include <opencv2/imgcodecs.hpp>

#include <charconv>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

namespace ss = shadowsense;
namespace fs = std::filesystem;

namespace {
std::string box(const std::optional<cv::Rect>& r) {
  if (!r) return ",,,";
  return std::to_string(r->x) + "," + std::to_string(r->y) + "," + std::to_string(r->width) + "," +
         std::to_string(r->height);
}
double level_of(const std::string& s) {
  if (s == "daylight" || s == "dusk" || s == "night")
    return ss::sim::lighting_level(ss::sim::lighting_from_string(s));
  double v = -1;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size() || !(v >= 0 && v <= 1))
    throw cli::UsageError(
        "--lightings: expected daylight, dusk, night or a level in [0, 1], got '" + s + "'");
  return v;
}
} // namespace

int main(int argc, char** argv) {
  return cli::run("ss_gesture_data", [&] {
    std::string out;
    std::vector<std::string> levels{"daylight", "dusk", "night"};
    int users = 4, first_user = 0, frames = 20;
    std::uint64_t seed = 1;
    bool randomise = false, overwrite = false, empty_skin = false;
    std::vector<double> scale_range{1.0, 1.0};
    std::string hands_dir, hands_split = "train";
    double real_probability = 0.5;
    cli::Parser p("ss_gesture_data",
                  "Writes a gesture-classification dataset (six classes on the robot rig): "
                  "DIR/<class>/<session>_<frame>.png and DIR/metadata.csv.");
    p.option("--out", "DIR", "output folder", out).required();
    p.option("--users", "N", "number of users (ids K..K+N-1)", users).range(1, 1000);
    p.option("--first-user", "K", "id of the first user", first_user).range(0, 1000000);
    p.option("--frames", "F", "frames per gesture and session", frames).range(1, 100000);
    p.list("--lightings", "LIST", "lightings: daylight, dusk, night or levels in [0, 1]", levels);
    p.option("--seed", "S", "random seed", seed).range(0, std::uint64_t{1} << 30);
    p.flag("--empty-skin",
           "per session, also write 3 empty-skin frames and a calibration file with its empty-skin "
           "model to DIR/empty_skin/",
           empty_skin);
    p.flag("--randomise", "domain randomisation (fabric, light, camera, lens, noise, body)",
           randomise);
    p.list("--scale-range", "LO,HI",
           "pixel scale of the body per gesture block, log-uniform in [LO, HI] (1,1: none)",
           scale_range)
        .range(0.25, 4.0)
        .default_text("1,1");
    p.option("--hands", "DIR",
             "real hand silhouettes: DIR/manifest.csv (file,pose[,split][,length_cm])", hands_dir);
    p.option("--hands-split", "NAME", "use the manifest rows of this split (empty: all)",
             hands_split);
    p.option("--real-hand-probability", "P", "chance that a hand is a real silhouette (--hands)",
             real_probability)
        .range(0.0, 1.0);
    p.flag("--overwrite", "write into a non-empty folder (its old metadata.csv goes first)",
           overwrite);
    p.parse(argc, argv);
    if (scale_range.size() != 2 || scale_range[0] > scale_range[1])
      throw cli::UsageError("--scale-range: expected two values LO,HI with LO <= HI, got " +
                            std::to_string(scale_range.size()) + " value(s)" +
                            (scale_range.size() == 2 ? " with LO > HI" : ""));
    for (const auto& l : levels) level_of(l); // check every lighting before writing anything
    std::shared_ptr<const std::vector<ss::sim::HandSilhouette>> real_hands;
    if (!hands_dir.empty()) {
      real_hands = std::make_shared<const std::vector<ss::sim::HandSilhouette>>(
          ss::sim::load_hand_silhouettes(hands_dir, hands_split));
      int n[3] = {0, 0, 0};
      for (const auto& h : *real_hands) ++n[static_cast<int>(h.shape)];
      std::cout << "real hands: " << n[0] << " open, " << n[2] << " point, " << n[1]
                << " fist from " << hands_dir << "\n";
    }
    // A new or empty folder, or --overwrite: then the old metadata.csv is removed before any
    // frame is written, so the folder never pairs an old csv with new frames.
    ss::sim::internal::prepare_output(out, overwrite, {"metadata.csv"});
    fs::create_directories(out);
    for (auto g : ss::sim::all_gestures)
      fs::create_directories(fs::path(out) / ss::sim::to_string(g));
    // The csv is written last and atomically: the dataset is complete exactly when it exists.
    ss::AtomicFileWriter csv_file(fs::path(out) / "metadata.csv");
    std::ostream& csv = csv_file.stream();
    csv << "file_name,class,user,lighting,lighting_level,session,frame_index,timestamp_ms,"
           "shadow_x,shadow_y,shadow_w,shadow_h,contact_x,contact_y,contact_w,contact_h,"
           "contact_cx,contact_cy,px_per_cm\n";
    ss::sim::Renderer renderer(ss::sim::Rig::robot());
    ss::sim::Frame frame;
    ss::sim::GestureSessionConfig cfg;
    cfg.frames_per_gesture = frames;
    cfg.randomise = randomise;
    cfg.pixel_scale = {scale_range[0], scale_range[1]};
    cfg.real_hands = real_hands;
    cfg.real_hand_probability = real_probability;
    int written = 0;
    for (int u = first_user; u < first_user + users; ++u) {
      ss::sim::Rng urng(ss::sim::derive_seed(seed, 0x05E40000ull + static_cast<std::uint64_t>(u)));
      const auto user = ss::sim::User::random(u, urng);
      for (std::size_t li = 0; li < levels.size(); ++li) {
        const double level = level_of(levels[li]);
        const std::uint64_t sseed =
            ss::sim::derive_seed(seed, (static_cast<std::uint64_t>(u) << 16) + li * 7919 +
                                           static_cast<std::uint64_t>(level * 1000));
        ss::sim::GestureSession session(sseed, user, level, cfg);
        if (empty_skin) { // before the csv: the dataset is complete only once it exists
          const fs::path dir = fs::path(out) / "empty_skin";
          fs::create_directories(dir);
          std::vector<cv::Mat> empties;
          for (int k = 0; k < 3; ++k) {
            session.render_empty_skin(renderer, k, frame);
            ss::sim::internal::write_png(dir / (session.name() + "_" + std::to_string(k) + ".png"),
                                         frame.image);
            empties.push_back(frame.image.clone());
          }
          ss::Segmenter segmenter;
          segmenter.set_empty_skin(empties);
          ss::SegmenterCalibration cal;
          cal.empty_skin = segmenter.empty_skin_model().clone();
          ss::save_calibration(cal, (dir / (session.name() + ".calib")).string());
        }
        for (int f = 0; f < session.size(); ++f) {
          ss::sim::GestureFrameInfo info;
          session.render(renderer, f, frame, &info);
          char name[64];
          std::snprintf(name, sizeof name, "%s_%05d.png", session.name().c_str(), f);
          const std::string rel = std::string(ss::sim::to_string(info.gesture)) + "/" + name;
          // Atomic (temp + rename): a kill or a full disk never leaves a truncated PNG.
          ss::sim::internal::write_png(fs::path(out) / rel, frame.image);
          const auto& gt = frame.gt;
          csv << rel << ',' << ss::sim::to_string(info.gesture) << ',' << info.user << ','
              << ss::sim::to_string(session.light().label) << ',' << session.light().level << ','
              << info.session << ',' << info.frame_index << ',' << info.timestamp_ms << ','
              << box(gt.shadow_box) << ',' << box(gt.contact_box) << ',';
          if (gt.contact_point)
            csv << gt.contact_point->x << ',' << gt.contact_point->y;
          else
            csv << ',';
          csv << ',' << gt.px_per_cm << '\n';
          ++written;
        }
      }
      std::cout << "user " << u << ": " << written << " frames\n" << std::flush;
    }
    ss::sync_filesystem(out); // the frames' deferred writes reach the disk before the csv
    csv_file.commit();        // complete only once every image exists
    std::cout << "wrote " << written << " frames to " << out << "\n";
    return 0;
  });
}
