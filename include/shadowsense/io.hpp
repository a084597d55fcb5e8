// I/O umbrella header (target shadowsense::io, adds OpenCV imgcodecs): the dataset format
// (docs/dataset_format.md), reading image files and finding the images of a folder.
#pragma once

#include <shadowsense/io/dataset.hpp>
#include <shadowsense/io/image_file.hpp>
#include <shadowsense/io/image_folder.hpp>
#include <shadowsense/io/temporal_dataset.hpp>
#include <shadowsense/shadowsense.hpp>
