// Ground truth for the temporal touch gestures (sense/temporal_gestures.hpp): sequences of
// taps, double taps, pats, strokes, rubs, holds, hits, hugs, punches and two-hand touches by
// generated users, sampled at a frame rate with dropped and duplicated frames, as the per-frame
// input the recogniser takes (TouchFrame + the classifier's reading), with each gesture's label
// and interval.
//
// This generator works at the level of the touch pipeline's output (tracks, contact points and
// areas, the hand-shape label per frame), not rendered images: it checks the recogniser's rules
// against timing and motion drawn per user, at several frame rates and with frame loss, not the
// segmenter. Timing is drawn around published values where they exist (docs/temporal_gestures.md:
// stroking at 3-15 cm/s, inside the 1-10 cm/s C-tactile range of Loken et al. 2009 and above
// it; double taps within Android's 300 ms) and around the recogniser's design values otherwise;
// per user a tempo factor (0.8-1.2) scales every duration and gap, a size factor the contact
// area and a speed factor the strokes and rubs.
//
// make_touch_sequence(config, seed)
//   requires: config.validate() (fps in [5, 240], rates in [0, 0.5), gestures >= 1), else
//             InvalidArgument.
//   ensures:  a sequence of config.gestures gestures by the user `seed` (deterministic: the same
//             seed and config give the same sequence on every platform), one after another with
//             empty pauses, each on a new track id (from 1); frames at k * 1000 / fps ms (k from
//             0), each dropped with probability drop_rate (no frame at all) or, with probability
//             duplicate_rate, carrying the previous frame's observations at its own time; contact
//             points with Gaussian noise (position_noise_px); the classifier's label per frame
//             (palm or point swapped with probability label_noise during palm/point contacts).
//             truth: one TouchGestureTruth per gesture (two for a punch: the punch label interval
//             on track 0 and the hit of its contact), in time order. hands, frame_index and
//             content_index say what each frame shows, for rendering it.
// Plain values; no shared state (any thread).
#pragma once

#include <shadowsense/core/direction.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/output/event_sink.hpp>
#include <shadowsense/sense/gesture_event.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>
#include <shadowsense/sim/rng.hpp>

#include <opencv2/core.hpp>

#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN
namespace sim {

struct TouchSequenceConfig {
  double fps = 30;
  double drop_rate = 0.03;      // a frame is lost
  double duplicate_rate = 0.02; // a frame repeats the previous one's content
  int gestures = 20;
  double position_noise_px = 0.7;
  double label_noise = 0.05;
  double px_per_cm = 7.6;
  cv::Size image_size{635, 350}; // the robot rig

  void validate() const {
    detail::require(std::isfinite(fps) && fps >= 5 && fps <= 240,
                    "TouchSequenceConfig: fps must be in [5, 240]");
    detail::require(drop_rate >= 0 && drop_rate < 0.5 && duplicate_rate >= 0 &&
                        duplicate_rate < 0.5 && label_noise >= 0 && label_noise < 0.5,
                    "TouchSequenceConfig: drop_rate, duplicate_rate and label_noise must be in "
                    "[0, 0.5)");
    detail::require(gestures >= 1, "TouchSequenceConfig: gestures must be >= 1");
    detail::require(position_noise_px >= 0 && px_per_cm > 0,
                    "TouchSequenceConfig: position_noise_px must be >= 0, px_per_cm > 0");
  }
};

struct TouchGestureTruth {
  TouchGesture gesture = TouchGesture::tap;
  int track_id = 0; // 0 for hug, punch, two_hands
  double start_ms = 0, end_ms = 0;
  int repetitions = 1;
  Direction direction = Direction::none; // strokes
};

namespace detail_touch {

// One hand's script: contact intervals with a position function, and the label.
struct Contact {
  double t0 = 0, t1 = 0;
  cv::Point2d from{}, to{};
  double rub_amplitude = 0, rub_hz = 0; // back and forth along (to - from)'s direction
  double area = 0;
};

struct HandScript {
  int track_id = 0;
  double appear = 0, leave = 0;
  cv::Point2d hover_at{};
  std::vector<Contact> contacts;
  std::string label; // the classifier's label while the hand is seen
};

inline std::optional<cv::Point2d> contact_at(const HandScript& h, double t, double& area) {
  for (const Contact& c : h.contacts) {
    if (t < c.t0 || t >= c.t1) continue;
    area = c.area;
    const double u = (t - c.t0) / (c.t1 - c.t0);
    if (c.rub_amplitude > 0) {
      const cv::Point2d d = c.to - c.from;
      const double n = std::hypot(d.x, d.y);
      const cv::Point2d dir = n > 0 ? d * (1.0 / n) : cv::Point2d(1, 0);
      const double s = c.rub_amplitude * std::sin(2 * CV_PI * c.rub_hz * (t - c.t0) / 1000.0);
      return c.from + dir * s;
    }
    return c.from + (c.to - c.from) * u;
  }
  return std::nullopt;
}

} // namespace detail_touch

struct TouchSequence {
  std::vector<TouchFrame> frames;
  std::vector<OutputGesture> shapes; // the classifier's reading per frame
  std::vector<TouchGestureTruth> truth;
  // What the frames show, for rendering them as images (sim/touch_sequence_writer.hpp): each
  // hand's script (image pixels, ms), and per kept frame its index k (time k * 1000 / fps) and
  // the index whose content it carries (an earlier k for a duplicated frame, else k).
  std::vector<detail_touch::HandScript> hands;
  std::vector<std::int64_t> frame_index, content_index;
};

inline TouchSequence make_touch_sequence(const TouchSequenceConfig& config, std::uint64_t seed) {
  using namespace detail_touch;
  config.validate();
  Rng user(derive_seed(seed, 0x05E4));
  const double tempo = user.uniform(0.8, 1.2);  // scales durations and gaps
  const double size = user.uniform(0.8, 1.25);  // scales contact areas
  const double speed = user.uniform(0.8, 1.25); // scales stroke and rub speeds
  const double cm = config.px_per_cm;
  Rng rng(derive_seed(seed, 0x5E9));
  std::vector<HandScript> hands;
  TouchSequence out;
  double t = 300;
  const cv::Point2d centre(config.image_size.width / 2.0, config.image_size.height / 2.0);
  auto place = [&] {
    return centre + cv::Point2d(rng.uniform(-12, 12) * cm, rng.uniform(-6, 6) * cm);
  };
  for (int g = 0; g < config.gestures; ++g) {
    const auto kind = static_cast<TouchGesture>(rng.integer(0, 9));
    HandScript h;
    h.track_id = g + 1;
    h.appear = t;
    const cv::Point2d at = place();
    h.hover_at = at;
    double c0 = t + tempo * rng.uniform(350, 700); // a gentle approach: hovering first
    TouchGestureTruth truth;
    truth.gesture = kind;
    truth.track_id = h.track_id;
    const double finger_area = size * rng.uniform(1.0, 2.0) * cm * cm;
    const double palm_area = size * rng.uniform(25, 60) * cm * cm;
    auto still = [&](double t0, double d, double area) {
      h.contacts.push_back({t0, t0 + d, at, at, 0, 0, area});
      return t0 + d;
    };
    double end = c0;
    switch (kind) {
    case TouchGesture::tap:
      h.label = "point";
      end = still(c0, tempo * rng.uniform(80, 230), finger_area);
      break;
    case TouchGesture::double_tap: {
      h.label = "point";
      const double e1 = still(c0, tempo * rng.uniform(80, 200), finger_area);
      end = still(e1 + tempo * rng.uniform(90, 230), tempo * rng.uniform(80, 200), finger_area);
      truth.repetitions = 2;
      break;
    }
    case TouchGesture::pat: {
      h.label = "palm";
      const int n = rng.integer(2, 4);
      double s = c0;
      for (int k = 0; k < n; ++k) {
        end = still(s, tempo * rng.uniform(100, 260), palm_area);
        s = end + tempo * rng.uniform(150, 450);
      }
      truth.repetitions = n;
      break;
    }
    case TouchGesture::stroke: {
      h.label = rng.chance(0.5) ? "palm" : "point";
      const double length = rng.uniform(5, 14) * cm;
      const double v = speed * rng.uniform(3, 15) * cm / 1000.0; // px per ms
      const int d = rng.integer(0, 3);
      const cv::Point2d dir = d == 0   ? cv::Point2d(1, 0)
                              : d == 1 ? cv::Point2d(-1, 0)
                              : d == 2 ? cv::Point2d(0, -1)
                                       : cv::Point2d(0, 1);
      truth.direction = d == 0   ? Direction::right
                        : d == 1 ? Direction::left
                        : d == 2 ? Direction::front
                                 : Direction::back;
      const cv::Point2d from = at - dir * (length / 2);
      end = c0 + length / v;
      h.contacts.push_back(
          {c0, end, from, from + dir * length, 0, 0, h.label == "palm" ? palm_area : finger_area});
      break;
    }
    case TouchGesture::rub: {
      h.label = "palm";
      const double hz = speed * rng.uniform(1.5, 3.0);
      const double cycles = rng.integer(2, 4) + 0.25; // ends at a turning point
      const double angle = rng.uniform(0, CV_PI);
      end = c0 + 1000.0 * cycles / hz;
      h.contacts.push_back({c0, end, at, at + cv::Point2d(std::cos(angle), std::sin(angle)),
                            rng.uniform(2.5, 5) * cm, hz, palm_area});
      truth.repetitions = static_cast<int>(2 * cycles);
      break;
    }
    case TouchGesture::hold:
      h.label = rng.chance(0.5) ? "palm" : "point";
      end = still(c0, tempo * rng.uniform(1300, 3000), h.label == "palm" ? palm_area : finger_area);
      break;
    case TouchGesture::hit:
      h.label = "palm";
      c0 = t + rng.uniform(0, 120); // a fast approach
      end = still(c0, rng.uniform(60, 190), palm_area);
      break;
    case TouchGesture::hug:
    case TouchGesture::two_hands:
      h.label = kind == TouchGesture::hug ? "hug" : "two_hands";
      end = still(c0, tempo * rng.uniform(800, 2500), palm_area * 2);
      truth.track_id = 0;
      break;
    case TouchGesture::punch:
      h.label = "punch";
      c0 = t + rng.uniform(0, 120);
      end = still(c0, rng.uniform(60, 190), palm_area * 0.6);
      truth.track_id = 0;
      break;
    }
    h.leave = end + tempo * rng.uniform(250, 600);
    truth.start_ms =
        kind == TouchGesture::hug || kind == TouchGesture::two_hands || kind == TouchGesture::punch
            ? h.appear
            : c0;
    truth.end_ms =
        kind == TouchGesture::hug || kind == TouchGesture::two_hands || kind == TouchGesture::punch
            ? h.leave
            : end;
    if (kind == TouchGesture::punch) { // the fist's contact is also a hit
      TouchGestureTruth hit;
      hit.gesture = TouchGesture::hit;
      hit.track_id = h.track_id;
      hit.start_ms = c0;
      hit.end_ms = end;
      out.truth.push_back(hit);
    }
    out.truth.push_back(truth);
    hands.push_back(h);
    t = h.leave + tempo * rng.uniform(400, 900);
  }
  // Sample the frames.
  Rng noise(derive_seed(seed, 0xF4A3E));
  const double step = 1000.0 / config.fps;
  bool have_previous = false;
  TouchFrame previous;
  OutputGesture previous_shape;
  std::int64_t previous_content = 0;
  for (std::int64_t k = 0;; ++k) {
    const double tk = static_cast<double>(k) * step;
    if (tk > t) break;
    const bool drop = noise.chance(config.drop_rate);
    const bool duplicate = noise.chance(config.duplicate_rate);
    TouchFrame f;
    OutputGesture shape;
    shape.available = true;
    std::int64_t content = k;
    if (duplicate && have_previous) {
      f = previous;
      shape = previous_shape;
      content = previous_content;
    } else {
      for (const HandScript& h : hands) {
        if (tk < h.appear || tk >= h.leave) continue;
        TouchTrack tr;
        tr.id = h.track_id;
        tr.matched = true;
        double area = 0;
        const std::optional<cv::Point2d> p = contact_at(h, tk, area);
        const cv::Point2d pos = p ? *p : h.hover_at;
        tr.position = cv::Point2f(static_cast<float>(pos.x), static_cast<float>(pos.y));
        if (p) {
          tr.contact =
              cv::Point2f(static_cast<float>(p->x + noise.normal(0, config.position_noise_px)),
                          static_cast<float>(p->y + noise.normal(0, config.position_noise_px)));
          tr.contact_area = area;
        }
        f.tracks.push_back(tr);
        shape.label = h.label;
        if (p && (h.label == "palm" || h.label == "point") && noise.chance(config.label_noise))
          shape.label = h.label == "palm" ? "point" : "palm";
        shape.confidence = 0.9f;
      }
    }
    f.timestamp_ms = tk;
    previous = f;
    previous_shape = shape;
    previous_content = content;
    have_previous = true;
    if (drop) continue;
    out.frames.push_back(f);
    out.shapes.push_back(shape);
    out.frame_index.push_back(k);
    out.content_index.push_back(content);
  }
  out.hands = std::move(hands);
  return out;
}

} // namespace sim
SHADOWSENSE_NAMESPACE_END
