// Umbrella header: everything that needs only OpenCV core + imgproc and Eigen.
// Image-file I/O (datasets, the scene generator's writers) is in <shadowsense/io.hpp>.
#pragma once

#include <shadowsense/classify.hpp>
#include <shadowsense/densenet.hpp>
#include <shadowsense/direction.hpp>
#include <shadowsense/error.hpp>
#include <shadowsense/fsm.hpp>
#include <shadowsense/head_trainer.hpp>
#include <shadowsense/image_check.hpp>
#include <shadowsense/lighting_normalise.hpp>
#include <shadowsense/model_file.hpp>
#include <shadowsense/preprocess.hpp>
#include <shadowsense/segment.hpp>
#include <shadowsense/sim/sim.hpp>
#include <shadowsense/tensor.hpp>
#include <shadowsense/track.hpp>
#include <shadowsense/version.hpp>
