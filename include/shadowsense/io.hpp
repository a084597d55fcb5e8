// I/O umbrella header (target shadowsense::io, adds OpenCV imgcodecs): the dataset format
// (docs/dataset_format.md) and reading image files.
#pragma once

#include <shadowsense/io/dataset.hpp>
#include <shadowsense/io/image_file.hpp>
#include <shadowsense/shadowsense.hpp>
