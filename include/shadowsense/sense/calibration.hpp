// Calibration: the segmenter's thresholds (and colour ranges) fitted on frames, two ways, each
// in its own header; this header includes both (and the shared fit), so an include of it gives
// everything as before:
//   fit_calibration        frames labelled pixel by pixel (sense/fit_calibration.hpp);
//   calibrate_from_frames  a robot's own frames: empty skin plus coarse boxes or no labels
//                          (sense/calibrate_from_frames.hpp; docs/calibration.md).
// The calibration file is sense/calibration_file.hpp.
// Plain functions; no shared state (any thread).
#pragma once

#include <shadowsense/sense/calibrate_from_frames.hpp>
#include <shadowsense/sense/fit_calibration.hpp>
