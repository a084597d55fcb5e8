// What the programs that run the library's Runtime share (ss_track, ss_demo): frame times, the
// default model's location, the --tuio target, the display check for --show, progress on
// stderr and the annotated frame. Programs parse flags and move data; the library does the rest.
//
// frame_time_ms(i, fps)        the time of frame i (from 0) of a file at fps: i * 1000 / fps, one
//                              formula for every program (so their events are the same lines).
// find_default_model(argv0)    the shipped model (common/model_path.hpp).
// default_model_text(argv0)    the model find_default_model would take, for --help.
// parse_tuio_target(spec, option) HOST, HOST:PORT, [IPV6] or [IPV6]:PORT (port
//                              3333 when not given; a bare IPv6 address without port too); throws
//                              cli::UsageError naming the option.
// require_display(option)      throws cli::UsageError when no window can open (no highgui in
//                              this build, or neither DISPLAY nor WAYLAND_DISPLAY set).
// Progress                     "program: frame i of n" on stderr at most once a second.
// annotate(frame, seg, result) the frame with the shadow and contact masks tinted, each track's
//                              id and touch state, its contact point and the gesture.
// Threading: plain functions; a Progress is used by one thread.
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

inline std::pair<std::string, std::uint16_t> parse_tuio_target(const std::string& spec,
                                                               const std::string& option) {
  const auto bad = [&](const std::string& why) {
    return cli::UsageError(option + ": " + why + " in '" + spec +
                           "'; expected HOST, HOST:PORT, [IPV6] or [IPV6]:PORT with PORT in "
                           "1..65535 (default 3333)");
  };
  if (spec.empty() || spec.front() == ':') throw bad("no host");
  std::string with_port = spec;
  if (spec.front() == '[') {
    const auto close = spec.find(']');
    if (close == std::string::npos) throw bad("no ']'");
    if (close + 1 == spec.size()) with_port = spec + ":3333";
  } else {
    const auto colons = std::count(spec.begin(), spec.end(), ':');
    if (colons == 0) with_port = spec + ":3333";
    if (colons > 1) with_port = "[" + spec + "]:3333"; // a bare IPv6 address
  }
  try {
    const shadowsense::HostPort hp = shadowsense::parse_host_port(with_port);
    return {hp.host, hp.port};
  } catch (const shadowsense::InvalidArgument&) {
    throw bad("bad host or port");
  }
}

inline void require_display(const std::string& option) {
#ifndef SHADOWSENSE_HAVE_HIGHGUI
  throw cli::UsageError(option + ": this build has no OpenCV highgui (no window can open)");
#else
  const char* x = std::getenv("DISPLAY");
  const char* w = std::getenv("WAYLAND_DISPLAY");
  if (!(x && *x) && !(w && *w))
    throw cli::UsageError(option + ": no display (neither DISPLAY nor WAYLAND_DISPLAY is set); use "
                                   "--annotate DIR to write the annotated frames instead");
#endif
}

class Progress {
public:
  Progress(std::string program, bool quiet, std::optional<std::size_t> total)
      : program_(std::move(program)), total_(total), on_(!quiet && (!total || *total > 100)),
        last_(std::chrono::steady_clock::now()) {}

  void tick(long long done) {
    if (!on_) return;
    const auto now = std::chrono::steady_clock::now();
    if (now - last_ < std::chrono::seconds(1)) return;
    last_ = now;
    std::cerr << "\r" << program_ << ": frame " << done;
    if (total_) std::cerr << " of " << *total_;
    std::cerr << std::flush;
  }
  void done(long long frames) {
    if (on_) std::cerr << "\r" << program_ << ": " << frames << " frames\n";
  }

private:
  std::string program_;
  std::optional<std::size_t> total_;
  bool on_;
  std::chrono::steady_clock::time_point last_;
};

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
