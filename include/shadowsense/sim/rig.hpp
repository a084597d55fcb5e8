// Camera rigs of the scene generator: where the camera sits under the skin, its fisheye
// projection, the visible skin surface and the image scale. Two presets match the paper:
// the inflatable robot (635x350, elliptical top surface) and the tracking test box
// (200x205 crop of a 26 x 26.6 cm box top, camera 45 cm below).
#pragma once

#include <shadowsense/core/error.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <string>

SHADOWSENSE_NAMESPACE_BEGIN
namespace sim {

// Skin coordinates ("plane", in cm): origin on the camera axis, x to the image's right, y to
// the image's bottom. The skin is modelled as a plane camera_distance_cm above the camera.
struct Rig {
  enum class Surface {
    ellipse,  // robot: ellipse inscribed in the frame with the margins below (image space)
    rectangle // box top: |x| <= surface_half_cm.width, |y| <= surface_half_cm.height (plane)
  };

  std::string name = "custom";
  cv::Size image_size{200, 205};
  double camera_distance_cm = 45.0;
  // Equidistant fisheye: image radius = focal_px_per_rad * angle from the optical axis.
  double focal_px_per_rad = 356.0;
  double field_of_view_deg = 170.0; // of the full fisheye image circle (the frame is a crop)
  Surface surface = Surface::rectangle;
  cv::Size2d surface_half_cm{13.0, 13.3}; // rectangle surface
  cv::Size2d ellipse_margin_px{8.0, 7.0}; // ellipse surface: gap to the frame edge
  double vignetting = 0.55;               // brightness lost at 90 deg off-axis (cos^2 law mix)

  // The paper's inflatable robot: camera 32 cm under the top, ~170 deg fisheye, 635x350.
  static Rig robot() {
    Rig r;
    r.name = "robot";
    r.image_size = {635, 350};
    r.camera_distance_cm = 32.0;
    r.focal_px_per_rad = 242.5; // frame half-width = 75 deg off-axis
    r.surface = Surface::ellipse;
    r.vignetting = 0.6;
    return r;
  }
  // The paper's tracking test box: 26 x 26.6 cm top, 45 cm above the fisheye, 200x205 crop.
  static Rig tracking_box() {
    Rig r;
    r.name = "tracking";
    r.image_size = {200, 205};
    r.camera_distance_cm = 45.0;
    // Chosen so the box top (13 cm half-width) spans the frame's half-width of 100 px.
    r.focal_px_per_rad = 100.0 / std::atan(13.0 / 45.0);
    r.surface = Surface::rectangle;
    r.surface_half_cm = {13.0, 13.3};
    r.vignetting = 0.5;
    return r;
  }

  void validate() const {
    detail::require(image_size.width >= 8 && image_size.height >= 8 && image_size.width <= 8192 &&
                        image_size.height <= 8192,
                    "Rig '" + name + "': image_size " + std::to_string(image_size.width) + "x" +
                        std::to_string(image_size.height) + " is invalid; expected 8..8192 px");
    detail::require(std::isfinite(camera_distance_cm) && camera_distance_cm > 0.5,
                    "Rig '" + name + "': camera_distance_cm must be > 0.5");
    detail::require(std::isfinite(focal_px_per_rad) && focal_px_per_rad > 1.0,
                    "Rig '" + name + "': focal_px_per_rad must be > 1");
    const double max_radius = std::hypot(image_size.width, image_size.height) / 2.0;
    detail::require(max_radius / focal_px_per_rad < 1.55,
                    "Rig '" + name + "': the frame corners lie beyond 89 deg off-axis; " +
                        "increase focal_px_per_rad");
    detail::require(surface_half_cm.width > 0 && surface_half_cm.height > 0,
                    "Rig '" + name + "': surface_half_cm must be positive");
    detail::require(ellipse_margin_px.width >= 0 && ellipse_margin_px.height >= 0 &&
                        ellipse_margin_px.width * 2 < image_size.width &&
                        ellipse_margin_px.height * 2 < image_size.height,
                    "Rig '" + name + "': ellipse_margin_px must be >= 0 and leave a surface");
    detail::require(vignetting >= 0 && vignetting < 1,
                    "Rig '" + name + "': vignetting must be in [0, 1)");
  }

  cv::Point2d centre_px() const {
    return {image_size.width / 2.0 - 0.5, image_size.height / 2.0 - 0.5};
  }

  // Image scale at the skin on the optical axis (px per cm), for converting errors to cm.
  double px_per_cm() const { return focal_px_per_rad / camera_distance_cm; }

  // Plane point (cm) -> image pixel (pixel centres at integer coordinates).
  cv::Point2d project(cv::Point2d plane_cm) const {
    const double r = std::hypot(plane_cm.x, plane_cm.y);
    const cv::Point2d c = centre_px();
    if (r < 1e-9) return c;
    const double rp = focal_px_per_rad * std::atan2(r, camera_distance_cm);
    return {c.x + plane_cm.x / r * rp, c.y + plane_cm.y / r * rp};
  }
  // Image pixel -> plane point (cm). Inverse of project().
  cv::Point2d unproject(cv::Point2d pixel) const {
    const cv::Point2d c = centre_px();
    const double dx = pixel.x - c.x, dy = pixel.y - c.y;
    const double rp = std::hypot(dx, dy);
    if (rp < 1e-9) return {0.0, 0.0};
    const double theta = std::min(rp / focal_px_per_rad, 1.56);
    const double r = camera_distance_cm * std::tan(theta);
    return {dx / rp * r, dy / rp * r};
  }
  // Local image scale (px per cm) at a plane point: geometric mean of the radial and
  // tangential scales of the fisheye. Used to size the penumbra blur in pixels.
  double local_px_per_cm(cv::Point2d plane_cm) const {
    const double d = camera_distance_cm;
    const double r2 = plane_cm.x * plane_cm.x + plane_cm.y * plane_cm.y;
    const double radial = focal_px_per_rad * d / (d * d + r2);
    const double r = std::sqrt(r2);
    const double tangential = r < 1e-6 ? px_per_cm() : focal_px_per_rad * std::atan2(r, d) / r;
    return std::sqrt(radial * tangential);
  }
  // Angle of a pixel from the optical axis (rad).
  double off_axis_rad(cv::Point2d pixel) const {
    const cv::Point2d c = centre_px();
    return std::hypot(pixel.x - c.x, pixel.y - c.y) / focal_px_per_rad;
  }
  // True where a pixel shows the skin surface (vs. the robot interior / box walls).
  bool on_surface(cv::Point2d pixel) const {
    if (surface == Surface::ellipse) {
      const cv::Point2d c = centre_px();
      const double ax = image_size.width / 2.0 - ellipse_margin_px.width;
      const double ay = image_size.height / 2.0 - ellipse_margin_px.height;
      const double u = (pixel.x - c.x) / ax, v = (pixel.y - c.y) / ay;
      return u * u + v * v <= 1.0;
    }
    const cv::Point2d p = unproject(pixel);
    return std::abs(p.x) <= surface_half_cm.width && std::abs(p.y) <= surface_half_cm.height;
  }
};

} // namespace sim
SHADOWSENSE_NAMESPACE_END
