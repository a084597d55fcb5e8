// Evaluation umbrella header (target shadowsense::eval): the paper's tracking evaluation on
// generated scenes.
#pragma once

#include <shadowsense/eval/temporal_eval.hpp>
#include <shadowsense/eval/track_eval.hpp>
#include <shadowsense/sim.hpp>
#include <shadowsense/train.hpp>
