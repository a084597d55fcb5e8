// What the programs that run the library's Runtime share (ss_track, ss_demo): frame times, the
// default model's location and the annotated frame (the --tuio target, the display check and
// progress are cli.hpp's, shared by every program). Programs parse flags and move data; the library
// does the rest.
//
// frame_time_ms(i, fps)        the time of frame i (from 0) of a file at fps: i * 1000 / fps, one
//                              formula for every program (so their events are the same lines).
// find_default_model(argv0)    the shipped model (common/model_path.hpp).
// default_model_text(argv0)    the model find_default_model would take, for --help.
// annotate(frame, seg, result) the frame with the shadow and contact masks tinted, each track's
//                              id and touch state, its contact point and the gesture.
// Threading: plain functions.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/output/udp_sender.hpp>
#include <shadowsense/runtime/runtime.hpp>

#include "cli.hpp"
#include "frame_source.hpp"
#include "model_path.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace runner {

namespace fs = std::filesystem;

inline double frame_time_ms(long long i, double fps) {
  return static_cast<double>(i) * 1000.0 / fps;
}

// The shipped model (common/model_path.hpp: $SHADOWSENSE_MODEL, the installed one, the source
// tree's from the build folder); throws IoError naming every place looked at.
inline fs::path find_default_model(const char* argv0) {
  return cli::find_default_model(argv0);
}
inline std::string default_model_text(const char* argv0) {
  return cli::default_model_help(argv0);
}

inline cv::Mat annotate(const cv::Mat& frame, const shadowsense::Segmentation& seg,
                        const shadowsense::RuntimeFrame& r) {
  cv::Mat out = frames::overlay(frame, seg);
  for (const shadowsense::TouchTrack& t : r.touch.tracks) {
    const std::string label = std::to_string(t.id) + " " + shadowsense::to_string(t.state);
    cv::putText(out, label, t.shadow_box.tl() + cv::Point(2, 12), cv::FONT_HERSHEY_PLAIN, 0.9,
                cv::Scalar(255, 255, 255), 1);
    if (t.contact) cv::circle(out, *t.contact, 3, cv::Scalar(0, 255, 0), cv::FILLED);
  }
  if (!r.gesture.label.empty()) {
    const std::string g = r.gesture.label + " " +
                          std::to_string(static_cast<int>(r.gesture.confidence * 100 + 0.5)) + "%";
    cv::putText(out, g, {6, 18}, cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 3,
                cv::LINE_AA);
    cv::putText(out, g, {6, 18}, cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(255, 255, 255), 1,
                cv::LINE_AA);
  }
  return out;
}

} // namespace runner
