// The scene generator (core only: OpenCV core + imgproc). Dataset writers are in
// <shadowsense/io/dataset.hpp> (needs imgcodecs).
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
