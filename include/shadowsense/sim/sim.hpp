// The scene generator (core only: OpenCV core + imgproc). Its dataset writers are in
// <shadowsense/sim/dataset_writer.hpp> (needs imgcodecs); the dataset reader in
// <shadowsense/io/dataset.hpp>.
#pragma once

#include <shadowsense/sim/body.hpp>
#include <shadowsense/sim/gestures.hpp>
#include <shadowsense/sim/lighting.hpp>
#include <shadowsense/sim/randomise.hpp>
#include <shadowsense/sim/renderer.hpp>
#include <shadowsense/sim/rig.hpp>
#include <shadowsense/sim/rng.hpp>
#include <shadowsense/sim/silhouette_hand.hpp>
#include <shadowsense/sim/touch_sequences.hpp>
#include <shadowsense/sim/tracking.hpp>
