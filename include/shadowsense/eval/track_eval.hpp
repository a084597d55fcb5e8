// The tracker's evaluation against the scene generator, one header per part; this header
// includes them all, so an include of it gives everything as before:
//   eval/track_metrics.hpp    box IoU, box centre, running mean / SD;
//   eval/sim_calibration.hpp  the Segmenter calibrated on generator frames (calibrate_on_sim);
//   eval/hover_eval.hpp       the hover-height estimate measured on generator frames;
//   eval/contact_roc.hpp      the contact-vs-hover ROC (docs/tracking_eval.md).
// Used by ss_track_eval, the benchmarks and the tests.
#pragma once

#include <shadowsense/eval/contact_roc.hpp>
#include <shadowsense/eval/hover_eval.hpp>
#include <shadowsense/eval/sim_calibration.hpp>
#include <shadowsense/eval/track_metrics.hpp>
