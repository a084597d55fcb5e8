// Runtime: the whole system of the paper in one type - touch events (segmenter, multi-touch
// tracker, one state machine per track) and the hand-shape gesture (the classifier, run only
// while a shadow is seen) - returning one result per camera frame.
//
// Each update(frame, t): the TouchPipeline runs on the frame; when it found at least one shadow
// blob (the gate is open) and the runtime has a classifier, the classifier runs on the whole
// frame (its model's own encoding: lighting normalisation, dark-frame rule, preprocessing) every
// Config::classify_every-th frame of the shadow's presence, starting with the first; between,
// the last reading is carried with the frame it was computed on. While no shadow is seen the
// reading is empty (label ""): no inference, as in the paper's gating. Frames are numbered from
// 1 (the first update) and the number is the sinks' frame_index, so every program and sink
// counts frames one way.
//
// The temporal gestures: after the classifier, a TemporalRecogniser (by default
// TemporalGestureRecogniser, sense/temporal_gestures.hpp) is fed the frame's TouchFrame and the
// hand-shape reading; its events are RuntimeFrame::touch_gestures and the sinks'
// OutputFrame::touch_gestures. Config::temporal_gestures = false leaves it out (no events).
//
// BasicRuntime<Rule, Backend, Recogniser>(pipeline, classifier, config = {})
//   requires: config.classify_every >= 1 (InvalidArgument); a valid config.temporal when the
//             recogniser is TemporalGestureRecogniser (it is built from it; another recogniser
//             type is default-constructed). classifier may be std::nullopt: touch events only
//             (RuntimeFrame::gesture.available is false), the temporal gestures then decide
//             palm or fingertip by the contact area.
//   ensures:  the runtime owns both (moved in).
// BasicRuntime(pipeline, classifier, config, recogniser): the same with the caller's recogniser.
// update(frame, timestamp_ms) -> const RuntimeFrame&
//   requires: as TouchPipeline::update (a frame the segmenter accepts, strictly increasing
//             finite timestamps).
//   ensures:  frame_index = previous + 1; touch = the pipeline's TouchFrame of this frame;
//             gesture as above; classified = the classifier ran on this frame. output() is the
//             same frame as sinks take it (OutputFrameBuilder, with the gesture). After warm-up
//             no heap allocation (the pipeline's, the classifier's and the result's buffers are
//             reused). The reference stays valid until the next update/flush.
//   throws:   what the pipeline or the classifier throws (InvalidArgument for a bad frame or
//             timestamp, Error for a broken backend); the runtime is then still usable.
// flush(timestamp_ms) -> const RuntimeFrame&
//   requires: as TouchPipeline::flush.
//   ensures:  the stream ends: the pipeline's pending lifts and disappears, and the
//             recogniser's flush (every contact ends as a lift at timestamp_ms), as one more
//             frame (frame_index = previous + 1, the last frame's size, no gesture).
// output() -> const OutputFrame&: the last update/flush as the event sinks take it.
// Threading: one instance per thread; an owner check (core/thread_owner.hpp) throws
// ConcurrentUseError when one instance is used from two threads at once (update, flush and the
// accessors: output(), last(), pipeline(), segmentation()). The classifier's own
// thread pool (DenseNet::Config::threads) works inside update().
#pragma once

#include <shadowsense/classify/backend.hpp>
#include <shadowsense/classify/classifier.hpp>
#include <shadowsense/core/error.hpp>
#include <shadowsense/core/thread_owner.hpp>
#include <shadowsense/output/event_sink.hpp>
#include <shadowsense/sense/temporal_gestures.hpp>
#include <shadowsense/sense/touch_pipeline.hpp>

#include <opencv2/core.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN

struct RuntimeConfig {
  // While a shadow is seen, classify every n-th frame of its presence (1 = every frame); the
  // reading is carried in between.
  int classify_every = 1;
  // Recognise temporal touch gestures (RuntimeFrame::touch_gestures), with this configuration.
  bool temporal_gestures = true;
  TemporalGestureConfig temporal{};
};

// Everything one frame produced.
struct RuntimeFrame {
  std::int64_t frame_index = 0; // 1 for the first update
  double timestamp_ms = 0;
  cv::Size frame_size{};
  TouchFrame touch;        // tracks, shadow boxes, contact points, touch events
  OutputGesture gesture{}; // the hand shape (available: the runtime has a classifier)
  bool classified = false; // the classifier ran on this frame
  std::vector<GestureEvent> touch_gestures; // the temporal gestures decided in this frame
};

template <PixelRule Rule, ClassifierBackend Backend,
          TemporalRecogniser Recogniser = TemporalGestureRecogniser>
class BasicRuntime {
public:
  using Config = RuntimeConfig;

  BasicRuntime(BasicTouchPipeline<Rule> pipeline, std::optional<Classifier<Backend>> classifier,
               const Config& config = {})
      : BasicRuntime(std::move(pipeline), std::move(classifier), config, make_recogniser(config)) {}

  BasicRuntime(BasicTouchPipeline<Rule> pipeline, std::optional<Classifier<Backend>> classifier,
               const Config& config, Recogniser recogniser)
      : pipeline_(std::move(pipeline)), classifier_(std::move(classifier)), config_(config),
        recogniser_(std::move(recogniser)) {
    result_.touch_gestures.reserve(32);
    if (!(config.classify_every >= 1))
      SHADOWSENSE_THROW(InvalidArgument("Runtime: classify_every is " +
                                        std::to_string(config.classify_every) +
                                        "; expected 1 or more (1 = every frame)"));
    // Room for typical scenes up front, as the pipeline's own buffers (32 blobs and tracks):
    // copying its frame into these then never allocates.
    constexpr std::size_t typical = 32;
    result_.touch.tracks.reserve(typical);
    result_.touch.shadow_boxes.reserve(typical);
    result_.touch.contact_points.reserve(typical);
    result_.touch.events.reserve(4 * typical);
    OutputGesture& g = result_.gesture;
    g.available = classifier_.has_value();
    if (classifier_) {
      for (const std::string& c : classifier_->class_names()) g.class_names.push_back(c);
      g.probabilities.reserve(g.class_names.size());
      reading_.probabilities.reserve(g.class_names.size());
      reading_.label.reserve(32);
      g.label.reserve(32);
    }
  }

  const RuntimeFrame& update(const cv::Mat& frame, double timestamp_ms) {
    const auto guard = owner_.enter("Runtime");
    const TouchFrame& touch = pipeline_.update(frame, timestamp_ms);
    const std::int64_t index = frame_index_ + 1;
    result_.touch = touch; // vector assignments: storage reused
    result_.frame_index = index;
    result_.timestamp_ms = timestamp_ms;
    result_.frame_size = frame.size();
    result_.classified = false;
    OutputGesture& g = result_.gesture;
    const bool gate_open = !touch.shadow_boxes.empty();
    if (classifier_ && gate_open) {
      if (g.label.empty() || index - g.frame_index >= config_.classify_every) {
        frame_index_ = index; // a failing classifier still consumes the frame number
        classifier_->classify(frame, reading_);
        g.label = reading_.label;
        g.probabilities.assign(reading_.probabilities.begin(), reading_.probabilities.end());
        g.confidence = reading_.probabilities[static_cast<std::size_t>(reading_.index)];
        g.frame_index = index;
        result_.classified = true;
      }
    } else {
      clear_reading();
    }
    frame_index_ = index;
    result_.touch_gestures.clear();
    if (config_.temporal_gestures) {
      const auto& events = recogniser_.update(result_.touch, g);
      result_.touch_gestures.assign(events.begin(), events.end());
    }
    output_ = &builder_.build(result_.touch, result_.frame_size, g, result_.touch_gestures);
    return result_;
  }

  const RuntimeFrame& flush(double timestamp_ms) {
    const auto guard = owner_.enter("Runtime");
    const TouchFrame& touch = pipeline_.flush(timestamp_ms);
    result_.touch = touch;
    result_.frame_index = ++frame_index_;
    result_.timestamp_ms = timestamp_ms;
    result_.classified = false;
    clear_reading();
    result_.touch_gestures.clear();
    if (config_.temporal_gestures) {
      const auto& events = recogniser_.flush(timestamp_ms);
      result_.touch_gestures.assign(events.begin(), events.end());
    }
    if (result_.frame_size.empty()) result_.frame_size = cv::Size(1, 1); // flushed before a frame
    output_ =
        &builder_.build(result_.touch, result_.frame_size, result_.gesture, result_.touch_gestures);
    return result_;
  }

  // The last update/flush as the event sinks take it (requires: one update or flush before).
  const OutputFrame& output() const {
    const auto guard = owner_.enter("Runtime");
    if (!output_)
      SHADOWSENSE_THROW(InvalidArgument("Runtime::output: no frame yet; call update() first"));
    return *output_;
  }
  // The accessors take the owner check as update() does (a read during another thread's update
  // is a data race): ConcurrentUseError instead.
  const RuntimeFrame& last() const {
    const auto guard = owner_.enter("Runtime");
    return result_;
  }

  BasicTouchPipeline<Rule>& pipeline() {
    const auto guard = owner_.enter("Runtime");
    return pipeline_;
  }
  const BasicTouchPipeline<Rule>& pipeline() const {
    const auto guard = owner_.enter("Runtime");
    return pipeline_;
  }
  // The last frame's segmentation (masks, blobs).
  const Segmentation& segmentation() const {
    const auto guard = owner_.enter("Runtime");
    return pipeline_.segmentation();
  }
  bool has_classifier() const { return classifier_.has_value(); }
  // The classifier, or nullptr when the runtime has none.
  Classifier<Backend>* classifier() { return classifier_ ? &*classifier_ : nullptr; }
  const Config& config() const { return config_; }
  Recogniser& recogniser() { return recogniser_; }

private:
  static Recogniser make_recogniser(const Config& config) {
    if constexpr (std::is_constructible_v<Recogniser, const TemporalGestureConfig&>)
      return Recogniser(config.temporal);
    else
      return Recogniser{};
  }

  void clear_reading() {
    OutputGesture& g = result_.gesture;
    g.label.clear();
    g.confidence = 0;
    g.frame_index = 0;
    g.probabilities.clear();
  }

  BasicTouchPipeline<Rule> pipeline_;
  std::optional<Classifier<Backend>> classifier_;
  Config config_;
  Recogniser recogniser_;
  RuntimeFrame result_;
  Classification reading_;
  OutputFrameBuilder builder_;
  const OutputFrame* output_ = nullptr;
  std::int64_t frame_index_ = 0;
  mutable ThreadOwner owner_; // mutable: the read accessors check too
};

SHADOWSENSE_NAMESPACE_END
