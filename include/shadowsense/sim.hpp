// Scene generator umbrella header (target shadowsense::sim): both of the paper's rigs, body
// parts, lighting, fisheye, exact ground truth, and the dataset writers.
#pragma once

#include <shadowsense/io.hpp>
#include <shadowsense/sim/dataset_writer.hpp>
#include <shadowsense/sim/hand_silhouette_file.hpp>
#include <shadowsense/sim/sim.hpp>
