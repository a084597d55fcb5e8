// Training umbrella header (target shadowsense::train, adds Eigen): on-device training of the
// classifier head and the labelled gesture samples it trains on.
#pragma once

#include <shadowsense/io.hpp>
#include <shadowsense/train/frame_augment.hpp>
#include <shadowsense/train/gesture_samples.hpp>
#include <shadowsense/train/head_trainer.hpp>
