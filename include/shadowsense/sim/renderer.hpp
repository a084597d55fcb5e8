// The scene renderer: turns a Scene (layered body silhouettes with heights) into the frame
// the camera under the skin sees, plus exact ground truth derived from the same buffers
// that produce the pixels (so ground truth and pixels cannot disagree).
//
// Per frame: each part's shadow is shifted along the light direction by height x
// tan(zenith) (per vertex, so rising arms stretch), projected through the fisheye, filled,
// and blurred with a penumbra that grows with height, at an opacity that falls with height.
// Parts at height 0 are in contact: sharp, opacity 1, skin-tinted. A Scene's zoom scales the
// body's parts, shadow shifts and penumbrae in the plane about its zoom centre before the
// projection (the body seen larger or smaller in pixels; distractors keep their size). The fabric
// (weave, wrinkles), vignetting, light colour, ambient light and sensor noise are then composed.
#pragma once

#include <shadowsense/core/error.hpp>
#include <shadowsense/sim/body.hpp>
#include <shadowsense/sim/lighting.hpp>
#include <shadowsense/sim/rig.hpp>
#include <shadowsense/sim/rng.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

SHADOWSENSE_NAMESPACE_BEGIN
namespace sim {

// Ground truth of one frame, in image pixels after the fisheye projection.
struct GroundTruth {
  // Minimum enclosing rectangle (inclusive coverage: w = max_x - min_x + 1) of the pixels
  // where the combined shadow of all body parts has opacity >= 0.5, on the visible skin.
  std::optional<cv::Rect> shadow_box;
  // Minimum enclosing rectangle of the pixels of parts in contact (height 0).
  std::optional<cv::Rect> contact_box;
  // Centroid of the contact pixels.
  std::optional<cv::Point2f> contact_point;
  cv::Mat shadow_mask;    // CV_8UC1, 255 where shadow opacity >= 0.5
  cv::Mat contact_mask;   // CV_8UC1, 255 where a part touches
  cv::Mat shadow_opacity; // CV_32FC1 in [0, 1], body parts only (no distractors)
  double px_per_cm = 0;
};

struct Frame {
  cv::Mat image; // CV_8UC3, BGR
  GroundTruth gt;
};

struct RenderConfig {
  std::uint64_t fabric_seed = 0x5EED5EEDull; // the weave's fibre noise and the wrinkle fields
  double weave_amplitude = 0.035;            // relative brightness variation of the weave
  bool sensor_noise = true;                  // off: exact, noise-free frames (tests)
  double max_opacity = 0.97;                 // of a part just above the skin
  double opacity_half_height_cm = 25.0;      // opacity = max / (1 + (h / this)^2)
  double penumbra_base_cm = 0.12;            // penumbra sigma = base + per_cm * height
  double penumbra_per_cm = 0.11;
  double edge_step_cm = 1.5; // polygon edges are subdivided so the fisheye can bend them
  // Light transmitted through skin pressed on the fabric, per BGR channel, relative to lit
  // fabric: warm (R > G > B) and darker than any shadow.
  cv::Vec3f skin_transmission{0.09f, 0.16f, 0.33f};
  double interior = 0.07; // brightness of what is not skin (robot interior, box walls)

  void validate() const {
    detail::require(weave_amplitude >= 0 && weave_amplitude <= 0.3,
                    "RenderConfig: weave_amplitude must be in [0, 0.3]");
    detail::require(max_opacity > 0.5 && max_opacity <= 1,
                    "RenderConfig: max_opacity must be in (0.5, 1]");
    detail::require(opacity_half_height_cm > 0, "RenderConfig: opacity_half_height_cm must be > 0");
    detail::require(penumbra_base_cm >= 0 && penumbra_per_cm >= 0,
                    "RenderConfig: penumbra parameters must be >= 0");
    detail::require(edge_step_cm > 0.05, "RenderConfig: edge_step_cm must be > 0.05");
    for (int c = 0; c < 3; ++c)
      detail::require(skin_transmission[c] > 0 && skin_transmission[c] < 1,
                      "RenderConfig: skin_transmission channels must be in (0, 1)");
    detail::require(interior >= 0 && interior <= 1, "RenderConfig: interior must be in [0, 1]");
  }
};

namespace internal {
// A Scene's zoom as the renderer applies it (see Scene::zoom).
struct Zoom {
  double factor = 1.0;
  cv::Point2d centre{0, 0};
};
} // namespace internal

// Holds the per-rig precomputed maps (surface, vignetting x weave, wrinkle fields, noise table)
// and scratch buffers: construct once per rig, reuse for every frame. Not thread-safe; use one
// Renderer per thread (frames do not depend on each other, so that parallelises trivially).
class Renderer {
public:
  static constexpr int wrinkle_fields = 4;

  explicit Renderer(Rig rig, RenderConfig config = {}) : rig_(std::move(rig)), cfg_(config) {
    rig_.validate();
    cfg_.validate();
    precompute();
  }

  const Rig& rig() const { return rig_; }
  const RenderConfig& config() const { return cfg_; }
  // Replaces the shading parameters that need no precomputation (opacity, penumbra, skin
  // transmission, interior), e.g. per session under domain randomisation.
  // requires: c.validate() passes and c.fabric_seed, c.weave_amplitude, c.sensor_noise equal
  // config()'s (those are baked into the precomputed maps); InvalidArgument otherwise.
  void set_shading(const RenderConfig& c) {
    c.validate();
    detail::require(c.fabric_seed == cfg_.fabric_seed &&
                        c.weave_amplitude == cfg_.weave_amplitude &&
                        c.sensor_noise == cfg_.sensor_noise,
                    "Renderer::set_shading: fabric_seed, weave_amplitude and sensor_noise are "
                    "fixed at construction; build another Renderer to change them");
    cfg_ = c;
  }
  // 255 where the pixel shows the skin surface.
  const cv::Mat& surface_mask() const { return surface_; }

  // Opacity of a part's shadow at mean height h (cm), before blurring.
  double opacity_at(double h) const {
    const double q = h / cfg_.opacity_half_height_cm;
    return cfg_.max_opacity / (1.0 + q * q);
  }
  double penumbra_cm(double h) const { return cfg_.penumbra_base_cm + cfg_.penumbra_per_cm * h; }

  Frame render(const Scene& scene, const Light& light, std::uint64_t noise_seed) {
    Frame f;
    render(scene, light, noise_seed, f);
    return f;
  }

  // Renders into `out`, reusing its buffers (no allocation after the first frame of a size).
  void render(const Scene& scene, const Light& light, std::uint64_t noise_seed, Frame& out) {
    scene.validate();
    light.validate();
    const cv::Size size = rig_.image_size;
    GroundTruth& gt = out.gt;
    gt.shadow_opacity.create(size, CV_32FC1);
    gt.shadow_opacity.setTo(0);
    gt.contact_mask.create(size, CV_8UC1);
    gt.contact_mask.setTo(0);
    distractor_.create(size, CV_32FC1);
    distractor_.setTo(0);

    const double tz = std::tan(light.zenith_deg * internal::deg);
    const double az = light.shadow_azimuth_deg * internal::deg;
    const cv::Point2d shift_per_cm{tz * std::cos(az), tz * std::sin(az)};

    bool any_contact = false;
    const internal::Zoom zoom{scene.zoom, scene.zoom_centre_cm};
    for (const BodyPart& part : scene.parts) {
      if (part.in_contact()) {
        project(part.outline_cm, &part.height_cm, {0, 0}, zoom);
        fill(gt.contact_mask, 1, 255.0);
        any_contact = true;
        continue;
      }
      const double h = part.mean_height();
      const double alpha = opacity_at(h);
      if (alpha < 1.0 / 512) continue;
      const cv::Point2d c = project(part.outline_cm, &part.height_cm, shift_per_cm, zoom);
      draw_soft(gt.shadow_opacity, alpha, penumbra_cm(h) * zoom.factor * rig_.local_px_per_cm(c));
    }
    bool any_distractor = false;
    for (const Distractor& d : scene.distractors) {
      const cv::Point2d c = project(d.outline_cm, nullptr, {0, 0});
      draw_soft(distractor_, d.opacity, d.blur_cm * rig_.local_px_per_cm(c));
      any_distractor = true;
    }
    // Clip to the visible skin; contact parts are fully opaque.
    gt.shadow_opacity.setTo(0, not_surface_);
    if (any_contact) {
      cv::bitwise_and(gt.contact_mask, surface_, gt.contact_mask);
      gt.shadow_opacity.setTo(1.0, gt.contact_mask);
    }
    cv::compare(gt.shadow_opacity, 0.5, gt.shadow_mask, cv::CMP_GE);
    gt.px_per_cm = rig_.px_per_cm();
    gt.shadow_box.reset();
    gt.contact_box.reset();
    gt.contact_point.reset();
    const cv::Rect sb = cv::boundingRect(gt.shadow_mask);
    if (sb.area() > 0) gt.shadow_box = sb;
    if (any_contact) {
      const cv::Moments m = cv::moments(gt.contact_mask, true);
      if (m.m00 > 0) {
        gt.contact_box = cv::boundingRect(gt.contact_mask);
        gt.contact_point =
            cv::Point2f(static_cast<float>(m.m10 / m.m00), static_cast<float>(m.m01 / m.m00));
      }
    }
    compose(scene, light, noise_seed, any_distractor, out.image, gt);
  }

private:
  Rig rig_;
  RenderConfig cfg_;
  cv::Mat surface_, not_surface_;               // CV_8U
  cv::Mat base_;                                // CV_32F: weave x vignetting
  std::array<cv::Mat, wrinkle_fields> wrinkle_; // CV_32F in [-1, 1]
  cv::Mat distractor_, scratch_, scratch_big_;
  std::vector<float> noise_table_; // N(0, 1) samples
  std::vector<float> row_texture_, row_opacity_, row_skin_, row_touch_;
  std::array<cv::Mat, 3> planes_;
  cv::Mat merged_;
  std::vector<cv::Point2d> plane_, px_;
  std::vector<cv::Point> fixed_;

  static constexpr int shift_bits = 4; // fillPoly sub-pixel precision: 1/16 px

  void precompute() {
    const cv::Size size = rig_.image_size;
    surface_.create(size, CV_8UC1);
    base_.create(size, CV_32FC1);
    Rng rng(derive_seed(cfg_.fabric_seed, 1));
    // Wrinkles: soft ridges along random lines on the skin plane (cm), 3 per field.
    struct Ridge {
      cv::Point2d p, n;
      double width, sign;
    };
    std::array<std::array<Ridge, 3>, wrinkle_fields> ridges{};
    const double ext = std::min(rig_.camera_distance_cm, 30.0);
    for (auto& field : ridges)
      for (auto& r : field) {
        const double a = rng.uniform(0, 3.14159265358979323846);
        r.p = {rng.uniform(-ext, ext), rng.uniform(-ext, ext) * 0.7};
        r.n = {-std::sin(a), std::cos(a)};
        r.width = rng.uniform(0.3, 1.4);
        r.sign = rng.chance(0.5) ? 1.0 : -1.0;
      }
    for (auto& w : wrinkle_) w.create(size, CV_32FC1);
    for (int y = 0; y < size.height; ++y) {
      auto* s = surface_.ptr<std::uint8_t>(y);
      auto* b = base_.ptr<float>(y);
      for (int x = 0; x < size.width; ++x) {
        const cv::Point2d px{static_cast<double>(x), static_cast<double>(y)};
        s[x] = rig_.on_surface(px) ? 255 : 0;
        const double c = std::cos(rig_.off_axis_rad(px));
        const double vig = 1.0 - rig_.vignetting * (1.0 - c * c);
        const double weave =
            std::sin(6.283185307179586 * x / 3.1) * std::sin(6.283185307179586 * y / 2.9);
        const double fibre = 0.4 * rng.normal();
        b[x] = static_cast<float>(vig * (1.0 + cfg_.weave_amplitude * (weave + fibre)));
        const cv::Point2d p = rig_.unproject(px);
        for (int k = 0; k < wrinkle_fields; ++k) {
          double v = 0;
          for (const Ridge& r : ridges[static_cast<std::size_t>(k)]) {
            const double d = (p - r.p).dot(r.n) / r.width;
            v += r.sign * std::exp(-0.5 * d * d);
          }
          wrinkle_[static_cast<std::size_t>(k)].ptr<float>(y)[x] =
              static_cast<float>(std::clamp(v, -1.0, 1.0));
        }
      }
    }
    cv::bitwise_not(surface_, not_surface_);
    // Wrinkles only on the skin: the interior keeps the plain (vignetted) texture.
    for (auto& w : wrinkle_) w.setTo(0, not_surface_);
    Rng noise_rng(derive_seed(cfg_.fabric_seed, 2));
    noise_table_.resize(std::max<std::size_t>(1 << 16, 8 * static_cast<std::size_t>(size.width)));
    for (float& v : noise_table_) v = static_cast<float>(noise_rng.normal());
  }

  // Subdivides the outline, shifts each vertex by its height along the light, scales it by the
  // zoom about its centre, projects it into the image. Fills px_ and returns the projected
  // (shifted, zoomed) centroid in plane cm. Zoom 1 leaves the plane points untouched (bit for
  // bit the frames of before the zoom existed).
  cv::Point2d project(const std::vector<cv::Point2d>& outline, const std::vector<double>* heights,
                      cv::Point2d shift_per_cm, internal::Zoom zoom = {}) {
    plane_.clear();
    const std::size_t n = outline.size();
    const bool zoomed = zoom.factor != 1.0;
    for (std::size_t i = 0; i < n; ++i) {
      const cv::Point2d a = outline[i], b = outline[(i + 1) % n];
      const double ha = heights ? (*heights)[i] : 0.0, hb = heights ? (*heights)[(i + 1) % n] : 0.0;
      // Edge steps in the zoomed plane, so the fisheye bends a zoomed edge as finely.
      const int steps = std::max(1, static_cast<int>(std::ceil(std::hypot(b.x - a.x, b.y - a.y) *
                                                               zoom.factor / cfg_.edge_step_cm)));
      for (int s = 0; s < steps; ++s) {
        const double t = static_cast<double>(s) / steps;
        const cv::Point2d q = a + (b - a) * t + shift_per_cm * (ha + (hb - ha) * t);
        plane_.push_back(zoomed ? zoom.centre + (q - zoom.centre) * zoom.factor : q);
      }
    }
    px_.resize(plane_.size());
    cv::Point2d c{0, 0};
    for (std::size_t i = 0; i < plane_.size(); ++i) {
      px_[i] = rig_.project(plane_[i]);
      c += plane_[i];
    }
    return c * (1.0 / static_cast<double>(plane_.size()));
  }

  // A rows x cols view of `buffer`, enlarging it only when it is too small.
  static cv::Mat grow_view(cv::Mat& buffer, int rows, int cols) {
    if (buffer.rows < rows || buffer.cols < cols)
      buffer.create(std::max(rows, buffer.rows), std::max(cols, buffer.cols), CV_32FC1);
    return buffer(cv::Rect(0, 0, cols, rows));
  }

  // Fills px_ (scaled by 1/scale, offset by -origin) into dst with value v.
  void fill(cv::Mat& dst, double scale, double v, cv::Point2d origin = {0, 0}) {
    fixed_.resize(px_.size());
    constexpr double one = 1 << shift_bits;
    for (std::size_t i = 0; i < px_.size(); ++i) {
      const double x = (px_[i].x - origin.x + 0.5) / scale - 0.5;
      const double y = (px_[i].y - origin.y + 0.5) / scale - 0.5;
      fixed_[i] = {static_cast<int>(std::lround(std::clamp(x, -1e5, 1e5) * one)),
                   static_cast<int>(std::lround(std::clamp(y, -1e5, 1e5) * one))};
    }
    const cv::Point* pts = fixed_.data();
    const int npts = static_cast<int>(fixed_.size());
    cv::fillPoly(dst, &pts, &npts, 1, cv::Scalar::all(v), cv::LINE_8, shift_bits);
  }

  // Draws px_ as a soft shadow of peak opacity alpha and penumbra sigma (px) into dst (max).
  // Large blurs are computed at a reduced resolution and upsampled (same result, far faster).
  void draw_soft(cv::Mat& dst, double alpha, double sigma_px) {
    if (px_.empty()) return;
    double x0 = px_[0].x, x1 = x0, y0 = px_[0].y, y1 = y0;
    for (const auto& p : px_) {
      x0 = std::min(x0, p.x), x1 = std::max(x1, p.x);
      y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
    }
    const int margin = static_cast<int>(std::ceil(3.0 * sigma_px)) + 2;
    const cv::Size size = dst.size();
    // Virtual region: the polygon's box plus the blur margin, limited to the image plus margin.
    int rx0 = std::max(static_cast<int>(std::floor(x0)) - margin, -margin);
    int ry0 = std::max(static_cast<int>(std::floor(y0)) - margin, -margin);
    int rx1 = std::min(static_cast<int>(std::ceil(x1)) + margin, size.width + margin);
    int ry1 = std::min(static_cast<int>(std::ceil(y1)) + margin, size.height + margin);
    if (rx1 <= std::max(rx0, 0) || ry1 <= std::max(ry0, 0) || rx0 >= size.width ||
        ry0 >= size.height)
      return;
    const int scale = sigma_px > 3.0 ? std::max(1, static_cast<int>(sigma_px / 2.0)) : 1;
    const int sw = (rx1 - rx0 + scale - 1) / scale, sh = (ry1 - ry0 + scale - 1) / scale;
    // Views into buffers that only grow: no allocation once the largest part has been seen.
    cv::Mat small = grow_view(scratch_, sh, sw);
    small.setTo(0);
    fill(small, scale, alpha, {static_cast<double>(rx0), static_cast<double>(ry0)});
    const double s = sigma_px / scale;
    if (s > 0.2) {
      const int k = 2 * static_cast<int>(std::ceil(3.0 * s)) + 1;
      cv::GaussianBlur(small, small, cv::Size(k, k), s, s,
                       cv::BORDER_CONSTANT | cv::BORDER_ISOLATED);
    }
    cv::Mat upsampled;
    const cv::Mat* big = &small;
    if (scale > 1) {
      upsampled = grow_view(scratch_big_, sh * scale, sw * scale);
      cv::resize(small, upsampled, upsampled.size(), 0, 0, cv::INTER_LINEAR);
      big = &upsampled;
    }
    const cv::Rect virt(rx0, ry0, big->cols, big->rows);
    const cv::Rect img = virt & cv::Rect(0, 0, size.width, size.height);
    if (img.area() <= 0) return;
    cv::Mat d = dst(img);
    cv::max(d, (*big)(img - virt.tl()), d);
  }

  void compose(const Scene& scene, const Light& light, std::uint64_t noise_seed,
               bool any_distractor, cv::Mat& image, const GroundTruth& gt) {
    const cv::Size size = rig_.image_size;
    const int width = size.width;
    const cv::Vec3f lc = colour_of_temperature(light.colour_temp_k);
    const cv::Vec3f ac = colour_of_temperature(light.ambient_temp_k);
    const float bright = static_cast<float>(light.brightness());
    const float amb = static_cast<float>(light.ambient);
    const float tone = static_cast<float>(1.15 - 0.35 * scene.skin_tone);
    float ambient[3], direct[3], contact[3], interior[3];
    for (int c = 0; c < 3; ++c) {
      ambient[c] = ac[c] * bright * amb;
      direct[c] = lc[c] * bright * (1.0f - amb);
      contact[c] = bright * lc[c] * cfg_.skin_transmission[c] * tone;
      interior[c] = lc[c] * static_cast<float>(bright * cfg_.interior);
    }
    const float sigma = cfg_.sensor_noise ? static_cast<float>(light.noise()) : 0.0f;
    Rng rng(derive_seed(noise_seed, 0xC0FFEE));
    const float w0 = scene.wrinkle[0], w1 = scene.wrinkle[1], w2 = scene.wrinkle[2],
                w3 = scene.wrinkle[3];
    row_texture_.resize(static_cast<std::size_t>(width));
    row_opacity_.resize(static_cast<std::size_t>(width));
    row_skin_.resize(static_cast<std::size_t>(width));
    row_touch_.resize(static_cast<std::size_t>(width));
    float* tex = row_texture_.data();
    float* opa = row_opacity_.data();
    float* skin = row_skin_.data();
    float* touch = row_touch_.data();
    for (auto& p : planes_) p.create(size, CV_32FC1);
    const std::uint64_t noise_span = noise_table_.size() - 3 * static_cast<std::size_t>(width);

    // Branch-free passes over plain arrays so the compiler vectorises them.
    for (int y = 0; y < size.height; ++y) {
      const auto* s = surface_.ptr<std::uint8_t>(y);
      const auto* b = base_.ptr<float>(y);
      const auto* op = gt.shadow_opacity.ptr<float>(y);
      const auto* ct = gt.contact_mask.ptr<std::uint8_t>(y);
      const float* wr0 = wrinkle_[0].ptr<float>(y);
      const float* wr1 = wrinkle_[1].ptr<float>(y);
      const float* wr2 = wrinkle_[2].ptr<float>(y);
      const float* wr3 = wrinkle_[3].ptr<float>(y);
      for (int x = 0; x < width; ++x)
        tex[x] = b[x] * (1.0f + w0 * wr0[x] + w1 * wr1[x] + w2 * wr2[x] + w3 * wr3[x]);
      if (any_distractor) {
        const auto* dop = distractor_.ptr<float>(y);
        for (int x = 0; x < width; ++x) opa[x] = std::max(op[x], dop[x]);
      } else {
        for (int x = 0; x < width; ++x) opa[x] = op[x];
      }
      // Sensor noise: each row reads a window of a fixed table of normal samples at a random
      // offset (one random draw per row instead of one per sample).
      const float* noise = noise_table_.data() + (sigma > 0.0f ? rng.next() % noise_span : 0);
      for (int x = 0; x < width; ++x) {
        skin[x] = s[x] != 0 ? 1.0f : 0.0f;
        touch[x] = ct[x] != 0 ? 1.0f : 0.0f;
      }
      for (int c = 0; c < 3; ++c) {
        float* dst = planes_[static_cast<std::size_t>(c)].ptr<float>(y);
        const float a = ambient[c], d = direct[c], k = contact[c], in = interior[c];
        const float* nz = noise + c * width;
        for (int x = 0; x < width; ++x) {
          const float t = tex[x];
          const float fabric = t * (a + d * (1.0f - opa[x]));
          const float on_skin = fabric + touch[x] * (t * k - fabric);
          dst[x] = in * t + skin[x] * (on_skin - in * t) + sigma * nz[x];
        }
      }
    }
    // Interleave to BGR and round/saturate to 8 bit (OpenCV's vectorised paths).
    cv::merge(planes_.data(), 3, merged_);
    merged_.convertTo(image, CV_8U);
  }
};

} // namespace sim
SHADOWSENSE_NAMESPACE_END
