// A nearly pinhole rig for the generator's geometry tests (test_sim_scale, test_sim_silhouette).
//
// sim::Rig pinhole_rig()
//   ensures: the camera 10 m below a 60 x 60 cm rectangular skin, 600 x 600 px at 10 px per cm on
//     the axis, so the fisheye's compression over the scene (at most 1 - atan(0.03) / 0.03 = 0.03%
//     in radius) is far below a pixel and a zoom of the scene is a zoom of the image.
// Threading: no state.
#pragma once

#include <shadowsense/sim/rig.hpp>

namespace shadowsense::test {

inline sim::Rig pinhole_rig() {
  sim::Rig r;
  r.name = "pinhole";
  r.image_size = {600, 600};
  r.camera_distance_cm = 1000;
  r.focal_px_per_rad = 10000; // 10 px per cm on the axis
  r.surface = sim::Rig::Surface::rectangle;
  r.surface_half_cm = {30, 30};
  return r;
}

} // namespace shadowsense::test
