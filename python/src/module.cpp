// The `shadowsense` Python module (pybind11): the runtime as users compose it in C++ -
// calibration, Segmenter, TouchPipeline, the DenseNet Classifier, Runtime and the event sinks -
// on HxWx3 uint8 numpy frames read in place. python/README.md describes the contracts; the
// docstrings follow the specification comments of the headers named in each.
//
// Contracts kept here:
//   - frames: frame_view() is the only place a numpy array becomes a cv::Mat, a header over the
//     array's own buffer (no copy); anything but a non-empty C-contiguous HxWx3 uint8 array is a
//     one-line ValueError. The array is referenced by the call's argument while the GIL is
//     released and by nothing after the call returns.
//   - the GIL is released while a frame is processed (segment, update, classify, calibrate).
//   - one instance per thread: every wrapper holds a ThreadOwner entered for the whole call,
//     result conversion included, so a second thread gets ConcurrentUseError (a Python
//     exception), never a half-written result.
//   - errors: each library error type is its own Python exception class, with the same message.
#include <shadowsense/core/atomic_file.hpp>
#include <shadowsense/output/csv_sink.hpp>
#include <shadowsense/output/json_lines_sink.hpp>
#include <shadowsense/output/tuio_sink.hpp>
#include <shadowsense/runtime/densenet_runtime.hpp>
#include <shadowsense/sense/calibration.hpp>
#include <shadowsense/sense/calibration_file.hpp>
#include <shadowsense/shadowsense.hpp>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <opencv2/core.hpp>

#include <climits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace py = pybind11;
namespace ss = shadowsense;

namespace {

// ---------------------------------------------------------------------------------------------
// Frames

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

// A cv::Mat header over the array's buffer (no copy), or a one-line ValueError naming what is
// wrong. The caller keeps `a` alive for as long as the header is used.
cv::Mat frame_view(const py::array& a, const char* what) {
  const std::string expected = "; expected a non-empty C-contiguous HxWx3 uint8 array (BGR)";
  if (a.ndim() != 3 || a.shape(2) != 3)
    throw py::value_error(std::string(what) + ": the frame has shape " + shape_text(a) + expected);
  if (!a.dtype().is(py::dtype::of<std::uint8_t>()))
    throw py::value_error(std::string(what) + ": the frame has dtype " +
                          py::str(a.dtype()).cast<std::string>() + expected);
  if (a.shape(0) == 0 || a.shape(1) == 0)
    throw py::value_error(std::string(what) + ": the frame is empty, shape " + shape_text(a) +
                          expected);
  if (a.shape(0) > INT_MAX || a.shape(1) > INT_MAX / 3)
    throw py::value_error(std::string(what) + ": the frame has shape " + shape_text(a) +
                          ", too large for an image");
  if (!(a.flags() & py::array::c_style))
    throw py::value_error(std::string(what) +
                          ": the frame is not C-contiguous (a slice or transpose?); pass "
                          "numpy.ascontiguousarray(frame)");
  return cv::Mat(static_cast<int>(a.shape(0)), static_cast<int>(a.shape(1)), CV_8UC3,
                 const_cast<void*>(a.data()));
}

py::tuple rect_tuple(const cv::Rect& r) {
  return py::make_tuple(r.x, r.y, r.width, r.height);
}
py::tuple point_tuple(const cv::Point2f& p) {
  return py::make_tuple(p.x, p.y);
}
py::object optional_point(const std::optional<cv::Point2f>& p) {
  return p ? py::object(point_tuple(*p)) : py::object(py::none());
}
py::object optional_rect(const std::optional<cv::Rect>& r) {
  return r ? py::object(rect_tuple(*r)) : py::object(py::none());
}
py::array_t<float> float_array(const std::vector<float>& v) {
  return py::array_t<float>(static_cast<py::ssize_t>(v.size()), v.data());
}
std::optional<cv::Rect> rect_from(const py::object& o, const std::string& what) {
  if (o.is_none()) return std::nullopt;
  const auto t = o.cast<std::vector<int>>();
  if (t.size() != 4) throw py::value_error(what + ": expected a box (x, y, width, height) or None");
  return cv::Rect(t[0], t[1], t[2], t[3]);
}

// ---------------------------------------------------------------------------------------------
// The wrapped stateful types: the library object and the binding's own owner check, entered for
// the whole call (the library's check covers the C++ call only, not the conversion after it).

struct PySegmenter {
  ss::Segmenter segmenter;
  ss::Segmentation result;
  ss::ThreadOwner owner;
};

struct PyTouchPipeline {
  ss::TouchPipeline pipeline;
  ss::ThreadOwner owner;
};

struct PyClassifier {
  std::optional<ss::Classifier<ss::DenseNet>> classifier; // empty once moved into a Runtime
  ss::Classification result;
  ss::ThreadOwner owner;

  ss::Classifier<ss::DenseNet>& get() {
    if (!classifier)
      throw ss::InvalidArgument(
          "Classifier: this instance was moved into a Runtime; use runtime.classify or load "
          "another Classifier");
    return *classifier;
  }
};

struct PyRuntime {
  PyRuntime(const ss::TouchPipeline& pipeline, std::optional<ss::Classifier<ss::DenseNet>> c,
            const ss::RuntimeConfig& config)
      : runtime(pipeline, std::move(c), config) {}
  ss::Runtime runtime; // built in place: it is not moved after construction
  ss::ThreadOwner owner;
};

// A file sink: the library's sink over an atomic file writer; the file appears on close().
template <class Sink>
struct FileSink {
  std::unique_ptr<ss::AtomicFileWriter> file;
  std::optional<Sink> sink;
  ss::ThreadOwner owner;

  FileSink(const std::string& path, typename Sink::Config config)
      : file(std::make_unique<ss::AtomicFileWriter>(path)) {
    sink.emplace(file->stream(), std::move(config));
  }
  void write(const ss::OutputFrame& frame) {
    const auto guard = owner.enter("event sink");
    if (!sink) throw ss::InvalidArgument("event sink: write after close()");
    sink->write(frame);
  }
  void close() {
    const auto guard = owner.enter("event sink");
    if (!sink) return;
    sink.reset();
    file->commit();
  }
};

struct PyTuioSink {
  PyTuioSink(const std::string& host, std::uint16_t port) : sink(host, port) {}
  ss::TuioSink sink;
  ss::ThreadOwner owner;
};

// ---------------------------------------------------------------------------------------------
// Exceptions: one Python class per library error type (derived first when translating).

struct Exceptions {
  py::object error, invalid_argument, model_file_error, calibration_file_error, dataset_error,
      io_error, concurrent_use;
};

py::object make_exception(py::module_& m, const char* name, const char* doc, py::tuple bases) {
  const std::string qualified = std::string("shadowsense.") + name;
  py::object type = py::reinterpret_steal<py::object>(
      PyErr_NewExceptionWithDoc(qualified.c_str(), doc, bases.ptr(), nullptr));
  if (!type) throw py::error_already_set();
  m.attr(name) = type;
  return type;
}

void bind_exceptions(py::module_& m) {
  // Never destroyed: the translator may run until the interpreter ends, and a Python object
  // must not be released after it.
  static Exceptions& e = *new Exceptions;
  const py::object builtins = py::module_::import("builtins");
  e.error = make_exception(m, "Error", "Base of every shadowsense error (C++ shadowsense::Error).",
                           py::make_tuple(builtins.attr("RuntimeError")));
  e.invalid_argument =
      make_exception(m, "InvalidArgument",
                     "A function argument or configuration value is outside what it accepts.",
                     py::make_tuple(e.error, builtins.attr("ValueError")));
  e.model_file_error = make_exception(
      m, "ModelFileError",
      "A model file is malformed, truncated, of another version or inconsistent (also the base "
      "of CalibrationFileError).",
      py::make_tuple(e.error));
  e.calibration_file_error = make_exception(
      m, "CalibrationFileError",
      "A calibration file is malformed, truncated, of another version or inconsistent.",
      py::make_tuple(e.model_file_error));
  e.dataset_error = make_exception(m, "DatasetError",
                                   "A dataset folder or metadata file is missing or malformed.",
                                   py::make_tuple(e.error));
  e.io_error = make_exception(m, "IoError", "Reading or writing a file (or socket) failed.",
                              py::make_tuple(e.error, builtins.attr("OSError")));
  e.concurrent_use = make_exception(
      m, "ConcurrentUseError",
      "One instance was used from two threads at once: give each thread its own instance.",
      py::make_tuple(e.error));
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const ss::InvalidArgument& x) {
      PyErr_SetString(e.invalid_argument.ptr(), x.what());
    } catch (const ss::CalibrationFileError& x) {
      PyErr_SetString(e.calibration_file_error.ptr(), x.what());
    } catch (const ss::ModelFileError& x) {
      PyErr_SetString(e.model_file_error.ptr(), x.what());
    } catch (const ss::DatasetError& x) {
      PyErr_SetString(e.dataset_error.ptr(), x.what());
    } catch (const ss::IoError& x) {
      PyErr_SetString(e.io_error.ptr(), x.what());
    } catch (const ss::ConcurrentUseError& x) {
      PyErr_SetString(e.concurrent_use.ptr(), x.what());
    } catch (const ss::Error& x) {
      PyErr_SetString(e.error.ptr(), x.what());
    }
  });
}

// ---------------------------------------------------------------------------------------------
// Result types: the C++ structs, read-only, positions as tuples and states as their schema names.

void bind_results(py::module_& m) {
  py::class_<ss::Blob>(m, "Blob", "A shadow or contact blob (sense/blobs.hpp).")
      .def_property_readonly(
          "box", [](const ss::Blob& b) { return rect_tuple(b.box); },
          "(x, y, width, height), image pixels")
      .def_property_readonly("centroid", [](const ss::Blob& b) { return point_tuple(b.centroid); })
      .def_readonly("area", &ss::Blob::area, "mask pixels in the blob")
      .def_readonly("darkness", &ss::Blob::darkness);

  py::class_<ss::Segmentation>(m, "Segmentation",
                               "One frame's segmentation (sense/segmenter.hpp); masks not kept.")
      .def_readonly("shadows", &ss::Segmentation::shadows, "shadow blobs, largest first")
      .def_readonly("contacts", &ss::Segmentation::contacts, "contact blobs, largest first")
      .def_property_readonly("shadow_box",
                             [](const ss::Segmentation& s) { return optional_rect(s.shadow_box); })
      .def_property_readonly("contact_box",
                             [](const ss::Segmentation& s) { return optional_rect(s.contact_box); })
      .def_property_readonly(
          "contact_point",
          [](const ss::Segmentation& s) { return optional_point(s.contact_point); })
      .def_readonly("dropped_shadow_blobs", &ss::Segmentation::dropped_shadow_blobs)
      .def_readonly("dropped_contact_blobs", &ss::Segmentation::dropped_contact_blobs);

  py::class_<ss::TouchTrack>(m, "TouchTrack", "One tracked hand in one frame.")
      .def_readonly("id", &ss::TouchTrack::id, "tracker id (stable, never reused)")
      .def_readonly("matched", &ss::TouchTrack::matched, "seen in this frame (else coasting)")
      .def_property_readonly("shadow_box",
                             [](const ss::TouchTrack& t) { return rect_tuple(t.shadow_box); })
      .def_property_readonly("position",
                             [](const ss::TouchTrack& t) { return point_tuple(t.position); })
      .def_property_readonly("contact",
                             [](const ss::TouchTrack& t) { return optional_point(t.contact); })
      .def_property_readonly(
          "state", [](const ss::TouchTrack& t) { return ss::to_string(t.state); },
          "none|appear|touch|move|lift")
      .def_readonly("contact_area", &ss::TouchTrack::contact_area);

  py::class_<ss::TrackEvent>(m, "TrackEvent", "A touch event with its track.")
      .def_readonly("track_id", &ss::TrackEvent::track_id)
      .def_property_readonly("timestamp_ms",
                             [](const ss::TrackEvent& e) { return e.event.timestamp_ms; })
      .def_property_readonly("from_state",
                             [](const ss::TrackEvent& e) { return ss::to_string(e.event.from); })
      .def_property_readonly(
          "to_state", [](const ss::TrackEvent& e) { return ss::to_string(e.event.to); },
          "to_state 'none' is the paper's disappear")
      .def_property_readonly(
          "direction", [](const ss::TrackEvent& e) { return ss::to_string(e.event.direction); })
      .def_property_readonly(
          "position", [](const ss::TrackEvent& e) { return optional_point(e.event.position); })
      .def("__repr__", [](const ss::TrackEvent& e) {
        return "<TrackEvent track " + std::to_string(e.track_id) + " " +
               ss::to_string(e.event.from) + "->" + ss::to_string(e.event.to) + " at " +
               std::to_string(e.event.timestamp_ms) + " ms>";
      });

  py::class_<ss::TouchFrame>(m, "TouchFrame", "Everything TouchPipeline.update produced.")
      .def_readonly("timestamp_ms", &ss::TouchFrame::timestamp_ms)
      .def_readonly("tracks", &ss::TouchFrame::tracks, "increasing id")
      .def_property_readonly("shadow_boxes",
                             [](const ss::TouchFrame& f) {
                               py::list l;
                               for (const cv::Rect& r : f.shadow_boxes) l.append(rect_tuple(r));
                               return l;
                             })
      .def_property_readonly("contact_points",
                             [](const ss::TouchFrame& f) {
                               py::list l;
                               for (const auto& p : f.contact_points) l.append(point_tuple(p));
                               return l;
                             })
      .def_readonly("events", &ss::TouchFrame::events, "increasing track id, then in order")
      .def_readonly("dropped_shadow_blobs", &ss::TouchFrame::dropped_shadow_blobs)
      .def_readonly("dropped_contact_blobs", &ss::TouchFrame::dropped_contact_blobs)
      .def_property_readonly(
          "camera", [](const ss::TouchFrame& f) { return std::string(ss::to_string(f.camera)); },
          "this frame's camera fault: 'none', 'dark', 'saturated' or 'frozen' "
          "(sense/camera_health.hpp)")
      .def_property_readonly(
          "camera_before",
          [](const ss::TouchFrame& f) { return std::string(ss::to_string(f.camera_before)); },
          "the previous frame's camera fault");

  py::class_<ss::GestureEvent>(m, "GestureEvent",
                               "A temporal touch gesture (sense/gesture_event.hpp).")
      .def_property_readonly(
          "gesture", [](const ss::GestureEvent& g) { return ss::to_string(g.gesture); },
          "tap|double_tap|pat|stroke|rub|hold|hit|hug|punch|two_hands")
      .def_property_readonly(
          "phase", [](const ss::GestureEvent& g) { return ss::to_string(g.phase); },
          "complete|began|ended|revised")
      .def_readonly("track_id", &ss::GestureEvent::track_id, "0: a whole-frame gesture")
      .def_readonly("start_ms", &ss::GestureEvent::start_ms)
      .def_readonly("end_ms", &ss::GestureEvent::end_ms)
      .def_readonly("decided_ms", &ss::GestureEvent::decided_ms)
      .def_property_readonly("position",
                             [](const ss::GestureEvent& g) { return point_tuple(g.position); })
      .def_property_readonly("direction",
                             [](const ss::GestureEvent& g) { return ss::to_string(g.direction); })
      .def_readonly("length_px", &ss::GestureEvent::length_px)
      .def_readonly("speed_px_s", &ss::GestureEvent::speed_px_s)
      .def_readonly("repetitions", &ss::GestureEvent::repetitions)
      .def_property_readonly(
          "hand_shape", [](const ss::GestureEvent& g) { return std::string(g.hand_shape.view()); })
      .def_readonly("confidence", &ss::GestureEvent::confidence);

  py::class_<ss::OutputGesture>(m, "Gesture", "The classifier's reading of a frame.")
      .def_readonly("available", &ss::OutputGesture::available, "the runtime has a classifier")
      .def_readonly("label", &ss::OutputGesture::label, "'' while gated off (no shadow)")
      .def_readonly("confidence", &ss::OutputGesture::confidence)
      .def_readonly("frame_index", &ss::OutputGesture::frame_index, "frame it was computed on")
      .def_readonly("class_names", &ss::OutputGesture::class_names)
      .def_property_readonly(
          "probabilities", [](const ss::OutputGesture& g) { return float_array(g.probabilities); },
          "float32 array, one per class (empty when gated off)");

  py::class_<ss::RuntimeFrame>(m, "RuntimeFrame", "Everything Runtime.update produced.")
      .def_readonly("frame_index", &ss::RuntimeFrame::frame_index, "1 for the first update")
      .def_readonly("timestamp_ms", &ss::RuntimeFrame::timestamp_ms)
      .def_property_readonly(
          "frame_size",
          [](const ss::RuntimeFrame& f) {
            return py::make_tuple(f.frame_size.width, f.frame_size.height);
          },
          "(width, height)")
      .def_readonly("touch", &ss::RuntimeFrame::touch)
      .def_readonly("gesture", &ss::RuntimeFrame::gesture)
      .def_readonly("classified", &ss::RuntimeFrame::classified, "the classifier ran on it")
      .def_readonly("touch_gestures", &ss::RuntimeFrame::touch_gestures);

  py::class_<ss::OutputFrame>(m, "OutputFrame",
                              "A frame as the event sinks take it (output/event_sink.hpp).")
      .def_readonly("frame_index", &ss::OutputFrame::frame_index)
      .def_readonly("timestamp_ms", &ss::OutputFrame::timestamp_ms);

  py::class_<ss::Classification>(m, "Classification", "Classifier.classify's result.")
      .def_readonly("label", &ss::Classification::label)
      .def_readonly("index", &ss::Classification::index)
      .def_property_readonly(
          "probabilities", [](const ss::Classification& c) { return float_array(c.probabilities); },
          "float32 array, one per class, in the model's class order");
}

// ---------------------------------------------------------------------------------------------
// Calibration

void bind_calibration(py::module_& m) {
  py::class_<ss::SegmenterCalibration>(
      m, "Calibration",
      "The segmenter's calibration: thresholds and the empty-skin model (sense/pixel_rule.hpp).")
      .def_property_readonly("mode",
                             [](const ss::SegmenterCalibration& c) {
                               return c.mode == ss::SegmentMode::relative ? "relative"
                                                                          : "fixed_ranges";
                             })
      .def_readonly("shadow_darkness", &ss::SegmenterCalibration::shadow_darkness)
      .def_readonly("contact_darkness", &ss::SegmenterCalibration::contact_darkness)
      .def_readonly("contact_warmth", &ss::SegmenterCalibration::contact_warmth)
      .def_property_readonly(
          "empty_skin_size",
          [](const ss::SegmenterCalibration& c) -> py::object {
            if (c.empty_skin.empty()) return py::none();
            return py::make_tuple(c.empty_skin.cols, c.empty_skin.rows);
          },
          "(width, height) of the empty-skin model, or None")
      .def_readwrite("px_per_cm", &ss::SegmenterCalibration::px_per_cm,
                     "the camera's scale, px per cm of skin at the image centre (0: not "
                     "measured); save_calibration checks it (0 or 0.05..10000)");

  m.def(
      "load_calibration", [](const std::string& path) { return ss::load_calibration(path); },
      py::arg("path"),
      "Load a calibration file (version 1, 2 or 3; sense/calibration_file.hpp).\n\n"
      "Raises CalibrationFileError naming the file (and line) for anything malformed, cut or "
      "changed;\n"
      "IoError when the path cannot be read, is not a regular file or is over 512 MiB.");
  m.def(
      "save_calibration",
      [](const ss::SegmenterCalibration& c, const std::string& path) {
        ss::save_calibration(c, path);
      },
      py::arg("calibration"), py::arg("path"),
      "Write a calibration file (format version 2, 3 with px_per_cm) atomically: the old file "
      "stays intact on failure.\n\nRaises InvalidArgument for a bad calibration, IoError naming "
      "the path.");

  py::class_<ss::CalibrationWarning>(m, "CalibrationWarning",
                                     "A degenerate part of a calibration (sense/calibration.hpp).")
      .def_property_readonly(
          "issue", [](const ss::CalibrationWarning& w) { return ss::to_string(w.issue); },
          "no_touch_frames|too_few_pixels|threshold_at_edge|shadow_near_noise|"
          "light_group_without_touch|touch_without_empty_light|"
          "contact_not_separated")
      .def_readonly("message", &ss::CalibrationWarning::message)
      .def("__repr__", [](const ss::CalibrationWarning& w) {
        return std::string("<CalibrationWarning ") + ss::to_string(w.issue) + ": " + w.message +
               ">";
      });
  py::class_<ss::LightGroupReport>(m, "LightGroupReport", "One light level of the empty frames.")
      .def_readonly("luminance", &ss::LightGroupReport::luminance)
      .def_readonly("empty_frames", &ss::LightGroupReport::empty_frames)
      .def_readonly("touch_frames", &ss::LightGroupReport::touch_frames)
      .def_readonly("noise_darkness", &ss::LightGroupReport::noise_darkness)
      .def_readonly("core_darkness", &ss::LightGroupReport::core_darkness)
      .def_readonly("fitted", &ss::LightGroupReport::fitted);
  py::class_<ss::CalibrationResult>(m, "CalibrationResult", "calibrate_from_frames's result.")
      .def_readonly("calibration", &ss::CalibrationResult::calibration)
      .def_readonly("warnings", &ss::CalibrationResult::warnings)
      .def_readonly("groups", &ss::CalibrationResult::groups);

  m.def(
      "calibrate_from_frames",
      [](const py::sequence& empty, const py::sequence& touch) {
        std::vector<py::array> keep; // references to every frame for the call
        std::vector<cv::Mat> empty_frames;
        std::vector<ss::BoxLabelledFrame> touch_frames;
        for (const py::handle& h : empty) {
          keep.push_back(py::array::ensure(h));
          if (!keep.back())
            throw py::value_error("calibrate_from_frames: an empty frame is not an array");
          empty_frames.push_back(frame_view(keep.back(), "calibrate_from_frames (empty frame)"));
        }
        for (const py::handle& h : touch) {
          ss::BoxLabelledFrame f;
          py::object image = py::reinterpret_borrow<py::object>(h);
          if (py::isinstance<py::tuple>(h)) {
            const py::tuple t = py::reinterpret_borrow<py::tuple>(h);
            if (t.size() < 3 || t.size() > 4)
              throw py::value_error("calibrate_from_frames: a touch frame is (image, shadow_box, "
                                    "contact_box[, name]) or an unlabelled image");
            image = t[0];
            f.shadow_box = rect_from(t[1], "calibrate_from_frames: shadow_box");
            f.contact_box = rect_from(t[2], "calibrate_from_frames: contact_box");
            if (t.size() == 4) f.name = t[3].cast<std::string>();
          } else {
            f.labelled = false;
          }
          keep.push_back(py::array::ensure(image));
          if (!keep.back())
            throw py::value_error("calibrate_from_frames: a touch frame is not an array");
          f.image = frame_view(keep.back(), "calibrate_from_frames (touch frame)");
          touch_frames.push_back(std::move(f));
        }
        py::gil_scoped_release release;
        return ss::calibrate_from_frames(empty_frames, touch_frames);
      },
      py::arg("empty_frames"), py::arg("touch_frames") = py::list(),
      "Calibrate the segmenter from a robot's own frames (sense/calibration.hpp).\n\n"
      "empty_frames: HxWx3 uint8 BGR frames of the empty skin (at least one).\n"
      "touch_frames: (image, shadow_box, contact_box[, name]) with boxes (x, y, w, h) or None\n"
      "  (coarse boxes around the whole shadow and the part in contact; None contact: a hover),\n"
      "  or an image alone (unlabelled: clustered).\n"
      "Returns CalibrationResult: .calibration (ready for save_calibration), .warnings (each\n"
      "degenerate part, CalibrationWarning), .groups (one report per light level).\n"
      "Raises InvalidArgument for bad input (naming the frame), black empty frames, or when no\n"
      "touch frame shows a shadow darker than the empty skin's noise.");
}

// ---------------------------------------------------------------------------------------------
// Segmenter, TouchPipeline, Classifier, Runtime

ss::Segmenter make_segmenter(const std::optional<ss::SegmenterCalibration>& calibration,
                             bool adaptive) {
  ss::SegmenterConfig config;
  if (calibration) config.calibration = *calibration;
  config.adaptive = adaptive;
  return ss::Segmenter(config);
}

void bind_pipeline(py::module_& m) {
  py::class_<PySegmenter>(
      m, "Segmenter",
      "Shadow and contact segmentation (sense/segmenter.hpp): a box per class and per blob and\n"
      "the contact point. calibration: from load_calibration or calibrate_from_frames (holds\n"
      "the empty-skin model); None: the default thresholds and no empty-skin model.\n"
      "adaptive: the empty-skin model follows slow changes (the first frame is the model).\n"
      "Threading: one instance per thread (ConcurrentUseError otherwise).")
      .def(py::init([](std::optional<ss::SegmenterCalibration> calibration, bool adaptive) {
             return PySegmenter{make_segmenter(calibration, adaptive), {}, {}};
           }),
           py::arg("calibration") = py::none(), py::kw_only(), py::arg("adaptive") = false)
      .def(
          "segment",
          [](PySegmenter& self, const py::array& frame) {
            const auto guard = self.owner.enter("Segmenter");
            const cv::Mat image = frame_view(frame, "Segmenter.segment");
            {
              py::gil_scoped_release release;
              self.segmenter.segment(image, self.result);
            }
            ss::Segmentation out; // the masks stay behind (the result is what Python reads)
            out.shadows = self.result.shadows;
            out.contacts = self.result.contacts;
            out.shadow_box = self.result.shadow_box;
            out.contact_box = self.result.contact_box;
            out.contact_point = self.result.contact_point;
            out.dropped_shadow_blobs = self.result.dropped_shadow_blobs;
            out.dropped_contact_blobs = self.result.dropped_contact_blobs;
            return out;
          },
          py::arg("frame"),
          "Segment one HxWx3 uint8 BGR frame (read in place; the model's size when a model is\n"
          "set). Raises ValueError for a wrong array, InvalidArgument for a frame the segmenter\n"
          "refuses.")
      .def_property_readonly("has_empty_skin",
                             [](PySegmenter& self) { return self.segmenter.has_empty_skin(); });

  py::class_<PyTouchPipeline>(
      m, "TouchPipeline",
      "Segmenter + multi-touch tracker + one touch state machine per track, one call per frame\n"
      "(sense/touch_pipeline.hpp).\n\n"
      "TouchPipeline(segmenter, uncalibrated=False): copies the segmenter (with its model). A\n"
      "relative-mode segmenter without an empty-skin model, not adaptive, reports phantom\n"
      "shadows on an empty skin: refused with InvalidArgument unless uncalibrated=True.\n"
      "update(frame, t_ms) -> TouchFrame: the frame's tracks (live ones, matched or coasting),\n"
      "  shadow boxes, contact points and the events this frame caused. Requires a frame the\n"
      "  segmenter accepts and a finite timestamp greater than the previous one.\n"
      "flush(t_ms) -> TouchFrame: ends the stream; every pending lift / disappear is reported.\n"
      "Threading: one instance per thread (ConcurrentUseError otherwise); the GIL is released\n"
      "while a frame is processed.")
      .def(py::init([](const PySegmenter& segmenter, bool uncalibrated) {
             if (uncalibrated)
               return PyTouchPipeline{ss::TouchPipeline(ss::uncalibrated, segmenter.segmenter), {}};
             return PyTouchPipeline{ss::TouchPipeline(segmenter.segmenter), {}};
           }),
           py::arg("segmenter"), py::kw_only(), py::arg("uncalibrated") = false)
      .def(
          "update",
          [](PyTouchPipeline& self, const py::array& frame, double t_ms) {
            const auto guard = self.owner.enter("TouchPipeline");
            const cv::Mat image = frame_view(frame, "TouchPipeline.update");
            py::gil_scoped_release release;
            return ss::TouchFrame(self.pipeline.update(image, t_ms));
          },
          py::arg("frame"), py::arg("t_ms"))
      .def(
          "flush",
          [](PyTouchPipeline& self, double t_ms) {
            const auto guard = self.owner.enter("TouchPipeline");
            return ss::TouchFrame(self.pipeline.flush(t_ms));
          },
          py::arg("t_ms"));

  py::class_<PyClassifier>(
      m, "Classifier",
      "The gesture classifier with the reference DenseNet backend\n"
      "(backends/densenet/classifier.hpp, classify/classifier.hpp).\n\n"
      "Classifier(model_path, threads=1, calibration=None, scale_to_network=False): loads the\n"
      "model file (its preprocessing, lighting normalisation and dark-frame rule come from it)\n"
      "and runs its embedded self-test. calibration: the robot's Calibration, whose empty-skin\n"
      "model a model with a calibrated input encoding needs; scale_to_network: bring frames to\n"
      "the network's scale with its px_per_cm (off by default: it lowers the shipped model's\n"
      "accuracy; docs/input_encodings.md).\n"
      "Raises ModelFileError for a malformed file, IoError when it cannot be read.\n"
      "classify(frame) -> Classification: label, index and one probability per class.\n"
      "Threading: one instance per thread (ConcurrentUseError otherwise); the GIL is released\n"
      "while a frame is classified. Moved into a Runtime, the instance is empty.")
      .def(py::init([](const std::string& path, int threads,
                       const std::optional<ss::SegmenterCalibration>& calibration,
                       bool scale_to_network) {
             if (scale_to_network && !(calibration && calibration->px_per_cm > 0))
               throw ss::InvalidArgument("Classifier: scale_to_network needs a calibration "
                                         "whose px_per_cm is set (the camera's scale)");
             ss::DenseNet::Config config;
             config.threads = threads;
             auto c = std::make_unique<PyClassifier>();
             c->classifier.emplace(ss::make_densenet_classifier(
                 ss::ModelFile::load(path), config, ss::ChannelOrder::bgr,
                 calibration ? calibration->empty_skin : cv::Mat(),
                 scale_to_network ? calibration->px_per_cm : 0.0));
             return c;
           }),
           py::arg("model_path"), py::kw_only(), py::arg("threads") = 1,
           py::arg("calibration") = py::none(), py::arg("scale_to_network") = false)
      .def_property_readonly("class_names",
                             [](PyClassifier& self) {
                               const auto names = self.get().class_names();
                               return std::vector<std::string>(names.begin(), names.end());
                             })
      .def(
          "classify",
          [](PyClassifier& self, const py::array& frame) {
            const auto guard = self.owner.enter("Classifier");
            ss::Classifier<ss::DenseNet>& classifier = self.get();
            const cv::Mat image = frame_view(frame, "Classifier.classify");
            {
              py::gil_scoped_release release;
              classifier.classify(image, self.result);
            }
            return self.result; // a copy for Python
          },
          py::arg("frame"),
          "Classify one HxWx3 uint8 BGR frame (read in place) -> Classification.");

  py::class_<PyRuntime>(
      m, "Runtime",
      "The whole system: the touch pipeline and the classifier gated by the shadow, one result\n"
      "per frame (runtime/runtime.hpp).\n\n"
      "Runtime(pipeline, classifier=None, classify_every=1, temporal_gestures=True): copies the\n"
      "pipeline and moves the classifier in (the Classifier object is empty afterwards). While\n"
      "a shadow is seen the classifier runs every classify_every-th frame, the reading carried\n"
      "between; with no shadow the reading is empty (label ''). The temporal gestures (tap,\n"
      "stroke, hug, ...) are recognised per track unless temporal_gestures=False.\n"
      "update(frame, t_ms) -> RuntimeFrame: frame_index (1 first), touch (TouchFrame), gesture,\n"
      "  classified, touch_gestures. Requires a frame the segmenter accepts and strictly\n"
      "  increasing finite timestamps (InvalidArgument otherwise; the runtime stays usable).\n"
      "flush(t_ms) -> RuntimeFrame: ends the stream (pending lifts, the recogniser's flush).\n"
      "output() -> OutputFrame: the last update/flush as the event sinks take it.\n"
      "Threading: one instance per thread (ConcurrentUseError otherwise); the GIL is released\n"
      "while a frame is processed.")
      .def(py::init([](const PyTouchPipeline& pipeline, PyClassifier* classifier,
                       int classify_every, bool temporal_gestures) {
             std::optional<ss::Classifier<ss::DenseNet>> c;
             if (classifier) {
               const auto guard = classifier->owner.enter("Classifier");
               c.emplace(std::move(classifier->get()));
               classifier->classifier.reset();
             }
             ss::RuntimeConfig config;
             config.classify_every = classify_every;
             config.temporal_gestures = temporal_gestures;
             return std::make_unique<PyRuntime>(pipeline.pipeline, std::move(c), config);
           }),
           py::arg("pipeline"), py::arg("classifier") = py::none(), py::kw_only(),
           py::arg("classify_every") = 1, py::arg("temporal_gestures") = true)
      .def(
          "update",
          [](PyRuntime& self, const py::array& frame, double t_ms) {
            const auto guard = self.owner.enter("Runtime");
            const cv::Mat image = frame_view(frame, "Runtime.update");
            py::gil_scoped_release release;
            return ss::RuntimeFrame(self.runtime.update(image, t_ms));
          },
          py::arg("frame"), py::arg("t_ms"))
      .def(
          "flush",
          [](PyRuntime& self, double t_ms) {
            const auto guard = self.owner.enter("Runtime");
            return ss::RuntimeFrame(self.runtime.flush(t_ms));
          },
          py::arg("t_ms"))
      .def(
          "output",
          [](PyRuntime& self) {
            const auto guard = self.owner.enter("Runtime");
            return self.runtime.output();
          },
          "The last update/flush as the event sinks take it (requires one update or flush).")
      .def_property_readonly("has_classifier",
                             [](PyRuntime& self) { return self.runtime.has_classifier(); });
}

// ---------------------------------------------------------------------------------------------
// Event sinks

template <class Sink>
void bind_file_sink(py::module_& m, const char* name, const char* doc) {
  using S = FileSink<Sink>;
  py::class_<S>(m, name, doc)
      .def(py::init([](const std::string& path, const std::string& source) {
             typename Sink::Config config;
             config.source = source;
             return std::make_unique<S>(path, config);
           }),
           py::arg("path"), py::kw_only(), py::arg("source") = "")
      .def("write", &S::write, py::arg("frame"), "Write one frame's events (OutputFrame).")
      .def("close", &S::close, "Write the file: it appears, complete, under its name.")
      .def(
          "__enter__", [](S& self) -> S& { return self; }, py::return_value_policy::reference)
      .def("__exit__", [](S& self, const py::object& type, const py::object&, const py::object&) {
        if (type.is_none()) self.close(); // on an exception the file is not written
      });
}

void bind_sinks(py::module_& m) {
  bind_file_sink<ss::CsvSink>(
      m, "CsvSink",
      "Touch events and temporal gestures as CSV, the project's event schema (docs/output.md;\n"
      "output/csv_sink.hpp), one row per event. The file is written atomically: it appears,\n"
      "complete, on close() (or leaving a with block without an exception); a sink dropped\n"
      "without close() leaves no file. Raises IoError naming the path.\n"
      "Threading: one thread per instance.");
  bind_file_sink<ss::JsonLinesSink>(
      m, "JsonLinesSink",
      "Touch events and temporal gestures as JSON Lines, the same fields as CsvSink\n"
      "(output/json_lines_sink.hpp). Written atomically on close(), as CsvSink.\n"
      "Threading: one thread per instance.");
  py::class_<PyTuioSink>(m, "TuioSink",
                         "TUIO 1.1 over UDP: contacts as /tuio/2Dcur, shadows as /tuio/2Dblb, the\n"
                         "gesture as /shadowsense/gesture (output/tuio_sink.hpp).\n"
                         "Threading: one thread per instance.")
      .def(py::init([](const std::string& host, int port) {
             if (port < 1 || port > 65535)
               throw ss::InvalidArgument("TuioSink: port " + std::to_string(port) +
                                         " is outside 1..65535");
             return std::make_unique<PyTuioSink>(host, static_cast<std::uint16_t>(port));
           }),
           py::arg("host") = "127.0.0.1", py::arg("port") = 3333)
      .def(
          "write",
          [](PyTuioSink& self, const ss::OutputFrame& frame) {
            const auto guard = self.owner.enter("TuioSink");
            self.sink.write(frame);
          },
          py::arg("frame"))
      .def_property_readonly("destination",
                             [](PyTuioSink& self) { return self.sink.destination(); });
}

} // namespace

// The calibrated input encoding (stage 0 of the classifier's frame encoder) of one session.
struct PyInputEncoder {
  ss::FrameEncoder encoder;
  ss::ThreadOwner owner;
};

// what: the caller's name for the error message (encode_input or InputEncoder).
PyInputEncoder make_input_encoder(const std::string& encoding,
                                  const ss::SegmenterCalibration& calibration, const char* what) {
  const std::optional<ss::InputEncoding> e = ss::parse_input_encoding(encoding);
  if (!e || *e == ss::InputEncoding::colour)
    throw py::value_error(std::string(what) + ": input encoding '" + encoding +
                          "', expected skin_relative, darkness_warmth, masks or "
                          "darkness_contact (colour is the frame itself)");
  ss::PreprocessParams p;
  p.input_encoding = *e;
  return PyInputEncoder{
      ss::FrameEncoder(ss::FrameEncoder::Config{p, ss::ChannelOrder::bgr, calibration.empty_skin}),
      {}};
}

py::array_t<float> encode_with(ss::FrameEncoder& encoder, const py::array& frame,
                               const char* what) {
  const cv::Mat image = frame_view(frame, what);
  cv::Mat out;
  {
    py::gil_scoped_release release;
    encoder.encode_input(image, out);
  }
  return py::array_t<float>(
      {static_cast<py::ssize_t>(out.rows), static_cast<py::ssize_t>(out.cols), py::ssize_t{3}},
      out.ptr<float>());
}

PYBIND11_MODULE(_shadowsense, m) {
  m.doc() = "shadowsense: touch sensing from shadow images (the C++ library's runtime).";
  m.attr("__version__") = ss::version_string;
  m.attr("event_schema_version") = ss::event_schema_version;
  m.attr("event_csv_header") = ss::event_csv_header;
  bind_exceptions(m);
  bind_results(m);
  bind_calibration(m);
  bind_pipeline(m);
  bind_sinks(m);
  // Stage 0 of the classifier's frame encoder, for training on exactly what inference sees
  // (tools/train.py --input-encoding masks / darkness_contact run the library's own segmenter
  // through this).
  py::class_<PyInputEncoder>(
      m, "InputEncoder",
      "The input encoding of a calibrated classifier (classify/frame_encoder.hpp, stage 0).\n"
      "InputEncoder(encoding, calibration): encoding skin_relative, darkness_warmth, masks or\n"
      "darkness_contact; calibration holds the empty-skin model (InvalidArgument naming the\n"
      "encoding otherwise). encode(frame): one HxWx3 uint8 BGR frame -> HxWx3 float32 in 0..1,\n"
      "B G R slots, the same values as encode_input; the empty-skin model is resized once per\n"
      "frame size, not per call (what makes it faster than encode_input over many frames).\n"
      "Threading: one instance per thread (ConcurrentUseError otherwise).")
      .def(py::init([](const std::string& encoding, const ss::SegmenterCalibration& calibration) {
             return make_input_encoder(encoding, calibration, "InputEncoder");
           }),
           py::arg("encoding"), py::arg("calibration"))
      .def(
          "encode",
          [](PyInputEncoder& self, const py::array& frame) {
            const auto guard = self.owner.enter("InputEncoder");
            return encode_with(self.encoder, frame, "InputEncoder.encode");
          },
          py::arg("frame"))
      .def_property_readonly("encoding", [](const PyInputEncoder& self) {
        return std::string(ss::to_string(self.encoder.input_encoding()));
      });
  m.def(
      "encode_input",
      [](const py::array& frame, const std::string& encoding,
         const ss::SegmenterCalibration& calibration) {
        PyInputEncoder e = make_input_encoder(encoding, calibration, "encode_input");
        return encode_with(e.encoder, frame, "encode_input");
      },
      py::arg("frame"), py::arg("encoding"), py::arg("calibration"),
      "The input encoding of a calibrated classifier (classify/frame_encoder.hpp, stage 0) of\n"
      "one HxWx3 uint8 BGR frame -> HxWx3 float32 in 0..1, BGR slots. encoding: skin_relative,\n"
      "darkness_warmth, masks or darkness_contact; calibration: holds the empty-skin model\n"
      "(InvalidArgument naming the encoding otherwise). A new encoder per call: over many\n"
      "frames, InputEncoder is faster.");
  // The frame check alone, for the zero-copy test: the address the cv::Mat header points at.
  m.def(
      "_frame_address",
      [](const py::array& frame) {
        return reinterpret_cast<std::uintptr_t>(frame_view(frame, "_frame_address").data);
      },
      py::arg("frame"));
  // The C++ side of bench/python_overhead.py's in-process comparison: the same calls on the
  // same frames in a C++ loop (no Python call, no result object per frame).
  m.def(
      "_update_loop",
      [](PyTouchPipeline& self, const std::vector<py::array>& frames, double t0, double dt) {
        const auto guard = self.owner.enter("TouchPipeline");
        std::vector<cv::Mat> images;
        for (const py::array& f : frames) images.push_back(frame_view(f, "_update_loop"));
        py::gil_scoped_release release;
        double t = t0;
        for (const cv::Mat& image : images) {
          self.pipeline.update(image, t);
          t += dt;
        }
        return t;
      },
      py::arg("pipeline"), py::arg("frames"), py::arg("t0"), py::arg("dt"));
  m.def(
      "_classify_loop",
      [](PyClassifier& self, const std::vector<py::array>& frames) {
        const auto guard = self.owner.enter("Classifier");
        ss::Classifier<ss::DenseNet>& classifier = self.get();
        std::vector<cv::Mat> images;
        for (const py::array& f : frames) images.push_back(frame_view(f, "_classify_loop"));
        py::gil_scoped_release release;
        for (const cv::Mat& image : images) classifier.classify(image, self.result);
      },
      py::arg("classifier"), py::arg("frames"));
}
