// The generator's pixel scale of the body (Scene::zoom, GestureSessionConfig::pixel_scale):
// areas grow with the zoom squared, shadow shifts and penumbrae scale with it, and sessions
// draw it per gesture block without changing anything else.
#include <shadowsense/sim.hpp>

#include <doctest/doctest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "common/pinhole_rig.hpp"
#include <cmath>
#include <cstdint>

using namespace shadowsense;
using namespace shadowsense::sim;

namespace {

// Penumbra sigma 0.05 + 0.04 x 2 cm = 0.13 cm: 0.8 to 2.6 px over zooms 0.6 to 2, so every
// shadow is blurred at full resolution (draw_soft works at a reduced one above 3 px, whose
// coarser polygon fill is not self-similar across zooms).
RenderConfig exact_config() {
  return RenderConfig{.sensor_noise = false, .penumbra_base_cm = 0.05, .penumbra_per_cm = 0.04};
}
constexpr double hover_cm = 2.0;

Light overhead(double zenith_deg) {
  Light l = preset(Lighting::daylight, 0);
  l.zenith_deg = zenith_deg;
  return l;
}

Scene one_part(double height_cm, double zoom, cv::Point2d centre) {
  Scene s;
  s.parts.push_back(internal::blob(PartKind::palm, {3, 1}, {1, 0}, 5, 3, height_cm));
  s.zoom = zoom;
  s.zoom_centre_cm = centre;
  return s;
}

cv::Point2d centroid(const cv::Mat& m) {
  const cv::Moments mo = cv::moments(m, false);
  return {mo.m10 / mo.m00, mo.m01 / mo.m00};
}

} // namespace

TEST_CASE("zoomed contact: area grows with the zoom squared, the part moves about the centre") {
  Renderer r(test::pinhole_rig(), exact_config());
  const cv::Point2d centre{2, 1};
  const Frame base = r.render(one_part(0, 1.0, centre), overhead(0), 0);
  const double a1 = cv::countNonZero(base.gt.contact_mask);
  REQUIRE(a1 > 3000); // the superellipse is ~0.93 x 10 x 6 cm = ~5600 px
  for (double z : {0.6, 1.45, 2.0}) {
    CAPTURE(z);
    const Frame f = r.render(one_part(0, z, centre), overhead(0), 0);
    const double az = cv::countNonZero(f.gt.contact_mask);
    // Pixel rounding along the outline (~300 px long at zoom 1) is the only error on a
    // pinhole rig: well under 1% of the area.
    CHECK(az / a1 == doctest::Approx(z * z).epsilon(0.01));
    // The contact centroid lands at centre + z (part centre - centre), projected.
    const cv::Point2d want = r.rig().project(centre + (cv::Point2d{3, 1} - centre) * z);
    REQUIRE(f.gt.contact_point);
    CHECK(std::abs(f.gt.contact_point->x - want.x) < 0.5);
    CHECK(std::abs(f.gt.contact_point->y - want.y) < 0.5);
  }
}

TEST_CASE("zoomed hover: the shadow's area, penumbra and shift along the light scale with it") {
  Renderer r(test::pinhole_rig(), exact_config());
  const cv::Point2d centre{2, 1};
  // Light straight above: the soft shadow is the blurred part, shape and blur scaled alike, so
  // its >= 0.5 region grows with z^2 as the contact does.
  const Frame base = r.render(one_part(hover_cm, 1.0, centre), overhead(0), 0);
  const double a1 = cv::countNonZero(base.gt.shadow_mask);
  REQUIRE(a1 > 3000);
  REQUIRE(cv::countNonZero(base.gt.contact_mask) == 0);
  // The penumbra's weight: the sum of o (peak - o) over the frame, zero inside the shadow and
  // outside it, so it is perimeter x a multiple of sigma (pixel counts of a thin band would be
  // dominated by rounding). Scaled blur: z^2; an unscaled one: z.
  const auto penumbra = [](const cv::Mat& o) {
    double lo, peak;
    cv::minMaxLoc(o, &lo, &peak);
    cv::Mat w = o.mul(peak - o);
    return cv::sum(w)[0];
  };
  const double p1 = penumbra(base.gt.shadow_opacity);
  for (double z : {0.6, 1.5, 2.0}) {
    CAPTURE(z);
    const Frame f = r.render(one_part(hover_cm, z, centre), overhead(0), 0);
    // The polygon fill adds about half a pixel around the outline, a constant in pixels that
    // does not scale: the area ratio falls short of z^2 by up to (z - 1) P / (2 A z) = 1.4%
    // at zoom 2 (outline P = 300 px, area A = 5600 px at zoom 1).
    CHECK(cv::countNonZero(f.gt.shadow_mask) / a1 == doctest::Approx(z * z).epsilon(0.02));
    CHECK(penumbra(f.gt.shadow_opacity) / p1 == doctest::Approx(z * z).epsilon(0.03));
    // Opacity is physical (height), not zoomed.
    double lo, hi1, hiz;
    cv::minMaxLoc(base.gt.shadow_opacity, &lo, &hi1);
    cv::minMaxLoc(f.gt.shadow_opacity, &lo, &hiz);
    CHECK(hiz == doctest::Approx(hi1).epsilon(0.002));
  }
  // Light at 40 deg: the shadow shifts by height x tan(40) = 1.68 cm, and the zoomed shadow's
  // centroid sits z times as far from the zoom centre as the unzoomed one's.
  const cv::Point2d c_px = r.rig().project(centre);
  const cv::Point2d s1 =
      centroid(r.render(one_part(hover_cm, 1.0, centre), overhead(40), 0).gt.shadow_opacity) - c_px;
  CHECK(s1.x == doctest::Approx((3 - 2 + hover_cm * std::tan(40 * 3.14159265358979 / 180)) * 10)
                    .epsilon(0.01));
  CHECK(std::abs(s1.y) < 0.3);
  for (double z : {0.6, 2.0}) {
    CAPTURE(z);
    const cv::Point2d sz =
        centroid(r.render(one_part(hover_cm, z, centre), overhead(40), 0).gt.shadow_opacity) - c_px;
    CHECK(std::abs(sz.x - z * s1.x) < 0.3); // px: a fraction of a pixel of edge rounding
    CHECK(std::abs(sz.y) < 0.3); // the shift is along x: the centroid stays on the centre's row
  }
}

TEST_CASE("sessions draw a pixel scale per gesture block and change nothing else") {
  User user;
  user.id = 7;
  const GestureSessionConfig plain{.frames_per_gesture = 2, .randomise = true};
  GestureSessionConfig scaled = plain;
  scaled.pixel_scale = {0.6, 2.0};
  const GestureSession a(77, user, 0.5, plain), b(77, user, 0.5, scaled), c(77, user, 0.5, scaled),
      d(78, user, 0.5, scaled);
  int distinct = 0;
  for (Gesture g : all_gestures) {
    CAPTURE(to_string(g));
    CHECK(a.zoom(g) == 1.0);
    CHECK(b.zoom(g) >= 0.6);
    CHECK(b.zoom(g) <= 2.0);
    CHECK(b.zoom(g) == c.zoom(g)); // a function of the seed
    distinct += b.zoom(g) != d.zoom(g);
    const int i = 2 * static_cast<int>(g) + 1;
    const Scene sa = a.scene(i), sb = b.scene(i);
    CHECK(sa.zoom == 1.0);
    CHECK(sb.zoom == b.zoom(g));
    // Same parts, heights, distractors, light: only the zoom differs.
    REQUIRE(sa.parts.size() == sb.parts.size());
    for (std::size_t k = 0; k < sa.parts.size(); ++k) {
      CHECK(sa.parts[k].outline_cm == sb.parts[k].outline_cm);
      CHECK(sa.parts[k].height_cm == sb.parts[k].height_cm);
    }
    CHECK(sa.distractors.size() == sb.distractors.size());
    CHECK(a.info(i).light.brightness() == b.info(i).light.brightness());
  }
  CHECK(distinct == 6);
  // The palm block's contact area on the robot rig follows the zoom (the fisheye bends the
  // larger hand more: within 15% of z^2 for a palm within 40 cm of the axis).
  Renderer r(Rig::robot());
  Frame fa, fb;
  const int palm = 2 * static_cast<int>(Gesture::palm);
  a.render(r, palm, fa);
  b.render(r, palm, fb);
  const double z = b.zoom(Gesture::palm);
  CHECK(static_cast<double>(cv::countNonZero(fb.gt.contact_mask)) /
            cv::countNonZero(fa.gt.contact_mask) ==
        doctest::Approx(z * z).epsilon(0.15));
}

TEST_CASE("bad zooms are rejected with a message naming them") {
  Scene s = one_part(0, 0.1, {0, 0});
  CHECK_THROWS_WITH_AS(s.validate(), doctest::Contains("zoom must be in [0.25, 4]"),
                       InvalidArgument);
  s.zoom = std::nan("");
  CHECK_THROWS_AS(s.validate(), InvalidArgument);
  s.zoom = 1;
  s.zoom_centre_cm = {std::nan(""), 0};
  CHECK_THROWS_WITH_AS(s.validate(), doctest::Contains("zoom_centre_cm"), InvalidArgument);
  GestureSessionConfig c;
  c.pixel_scale = {2.0, 1.0};
  CHECK_THROWS_WITH_AS(c.validate(), doctest::Contains("pixel_scale"), InvalidArgument);
  c.pixel_scale = {0.1, 1.0};
  CHECK_THROWS_WITH_AS(c.validate(), doctest::Contains("pixel_scale"), InvalidArgument);
}
