// Umbrella header for image-file I/O; link shadowsense::io (adds OpenCV imgcodecs).
#pragma once

#include <shadowsense/dataset.hpp>
#include <shadowsense/gesture_samples.hpp>
#include <shadowsense/shadowsense.hpp>
#include <shadowsense/sim/dataset_writer.hpp>
