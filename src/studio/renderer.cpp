#include "sag_hand_tracker/studio/renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <limits>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace studio {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// ---- procedural textures --------------------------------------------------------------------

// mixSeed's splitmix64, inlinable here (the exported mixSeed is called through the PLT).
inline std::uint64_t mix64(std::uint64_t a, std::uint64_t b) {
  std::uint64_t z = a + 0x9e3779b97f4a7c15ULL * (b + 1);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// Smooth value noise in [0, 1]. The lattice value of (x, y, z) is
// mix(mix(mix(seed, x), y), z) scaled to [0, 1); the eight corners share their x and xy hashes.
double valueNoise(const Eigen::Vector3d& p, std::uint64_t seed) {
  const Eigen::Vector3d f = p.array().floor();
  const Eigen::Vector3d r = p - f;
  const Eigen::Vector3d s = r.array() * r.array() * (3.0 - 2.0 * r.array());
  const auto ix = static_cast<std::int64_t>(f.x());
  const auto iy = static_cast<std::int64_t>(f.y());
  const auto iz = static_cast<std::int64_t>(f.z());
  std::uint64_t hx[2], hxy[4];
  for (int dx = 0; dx < 2; ++dx) hx[dx] = mix64(seed, static_cast<std::uint64_t>(ix + dx));
  for (int c = 0; c < 4; ++c) hxy[c] = mix64(hx[c & 1], static_cast<std::uint64_t>(iy + (c >> 1)));
  double value = 0.0;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    const double w = (dx ? s.x() : 1 - s.x()) * (dy ? s.y() : 1 - s.y()) * (dz ? s.z() : 1 - s.z());
    const std::uint64_t h = mix64(hxy[c & 3], static_cast<std::uint64_t>(iz + dz));
    value += w * (static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0));
  }
  return value;
}

// Fractal noise in about [0, 1]: octaves of value noise, the first with period `period` metres.
double fractalNoise(const Eigen::Vector3d& p, double period, int octaves, std::uint64_t seed) {
  double sum = 0.0, norm = 0.0, amplitude = 1.0, frequency = 1.0 / period;
  for (int o = 0; o < octaves; ++o) {
    sum += amplitude * valueNoise(p * frequency, mix64(seed, static_cast<std::uint64_t>(o)));
    norm += amplitude;
    amplitude *= 0.5;
    frequency *= 2.0;
  }
  return sum / norm;
}

Eigen::Vector3f srgb(double r, double g, double b) {
  return Eigen::Vector3f(srgbToLinear(static_cast<float>(r)), srgbToLinear(static_cast<float>(g)),
                         srgbToLinear(static_cast<float>(b)));
}

// 1 inside a band of half-width `half` around the multiples of `period`, else 0.
bool onGrid(double x, double period, double half) {
  const double m = x / period - std::floor(x / period + 0.5);
  return std::abs(m) * period < half;
}

Eigen::Vector3f tableAlbedo(const Eigen::Vector3d& p, std::uint64_t seed) {
  // A blue-grey desk with a dark green cutting mat (5 cm grid) in the workspace.
  const double grain =
      fractalNoise(Eigen::Vector3d(p.x() * 0.25, p.y() * 4.0, 0.0), 0.05, 3, mix64(seed, 11));
  const double blotch = fractalNoise(p, 0.12, 3, mix64(seed, 12));
  const bool mat = p.x() > -0.32 && p.x() < 0.3 && p.y() > -0.26 && p.y() < 0.3;
  Eigen::Vector3f colour;
  if (mat) {
    colour = srgb(0.20, 0.36, 0.30) * static_cast<float>(0.85 + 0.3 * blotch);
    if (onGrid(p.x(), 0.05, 0.001) || onGrid(p.y(), 0.05, 0.001)) {
      colour = srgb(0.34, 0.50, 0.43);
    }
    if (onGrid(p.x(), 0.25, 0.002) || onGrid(p.y(), 0.25, 0.002)) {
      colour = srgb(0.62, 0.70, 0.62);
    }
  } else {
    colour = srgb(0.47, 0.52, 0.58) * static_cast<float>(0.82 + 0.22 * grain + 0.12 * blotch);
  }
  return colour;
}

Eigen::Vector3f roomAlbedo(const Eigen::Vector3d& p, const Eigen::Vector3d& n, std::uint64_t seed) {
  const double noise = fractalNoise(p, 0.4, 4, mix64(seed, 21));
  if (n.z() > 0.5) {  // floor: dark carpet
    return srgb(0.24, 0.23, 0.25) * static_cast<float>(0.8 + 0.4 * fractalNoise(p, 0.03, 3, seed));
  }
  if (n.z() < -0.5) return srgb(0.78, 0.78, 0.76);  // ceiling
  // Walls: light grey paint with a few posters and a door-like panel.
  Eigen::Vector3f colour = srgb(0.66, 0.67, 0.69) * static_cast<float>(0.9 + 0.2 * noise);
  const double along = std::abs(n.x()) > 0.5 ? p.y() : p.x();
  const int wall = std::abs(n.x()) > 0.5 ? (n.x() > 0 ? 0 : 1) : (n.y() > 0 ? 2 : 3);
  static const double kPosterCentre[4] = {0.3, -0.4, 0.1, -0.2};
  static const std::array<std::array<double, 3>, 4> kPosterColour{
      {{{0.16, 0.28, 0.55}}, {{0.22, 0.45, 0.25}}, {{0.30, 0.30, 0.34}}, {{0.45, 0.20, 0.40}}}};
  const double dx = along - kPosterCentre[wall];
  if (std::abs(dx) < 0.35 && p.z() > 0.35 && p.z() < 1.2) {
    const auto& c = kPosterColour[wall];
    colour = srgb(c[0], c[1], c[2]) * static_cast<float>(0.9 + 0.2 * noise);
    if (std::abs(dx) < 0.25 && p.z() > 0.55 && p.z() < 0.75) colour = srgb(0.85, 0.85, 0.82);
  }
  if (p.z() < 0.1) colour = srgb(0.30, 0.31, 0.34);  // skirting board
  return colour;
}

// ---- projection helpers ---------------------------------------------------------------------

struct BackgroundHit {
  double t = std::numeric_limits<double>::infinity();
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  bool on_table = false;
};

struct PixelBox {
  int u0 = 0, v0 = 0, u1 = -1, v1 = -1;  // inclusive
  bool empty() const { return u1 < u0 || v1 < v0; }
};

PixelBox projectBox(const Camera& camera, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  PixelBox box;
  if (hi.z() <= 1e-4) return box;  // entirely behind the camera
  if (lo.z() <= 1e-4) {
    box.u0 = 0;
    box.v0 = 0;
    box.u1 = camera.width - 1;
    box.v1 = camera.height - 1;
    return box;
  }
  double umin = kInf, umax = -kInf, vmin = kInf, vmax = -kInf;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d p((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(),
                            (c & 4) ? hi.z() : lo.z());
    const Eigen::Vector3d q = camera.K * p;
    const double u = q.x() / q.z(), v = q.y() / q.z();
    umin = std::min(umin, u);
    umax = std::max(umax, u);
    vmin = std::min(vmin, v);
    vmax = std::max(vmax, v);
  }
  box.u0 = std::max(0, static_cast<int>(std::floor(umin)));
  box.v0 = std::max(0, static_cast<int>(std::floor(vmin)));
  box.u1 = std::min(camera.width - 1, static_cast<int>(std::ceil(umax)));
  box.v1 = std::min(camera.height - 1, static_cast<int>(std::ceil(vmax)));
  return box;
}

void partBounds(const SurfacePart& part, Eigen::Vector3d* lo, Eigen::Vector3d* hi) {
  if (part.kind == SurfacePart::Kind::kRoundCone) {
    bounds(part.cone, lo, hi);
  } else {
    bounds(part.polygon, lo, hi);
  }
}

bool partIntersect(const SurfacePart& part, const Eigen::Vector3d& origin,
                   const Eigen::Vector3d& dir, RayHit* hit, double t_min) {
  return part.kind == SurfacePart::Kind::kRoundCone
             ? intersect(part.cone, origin, dir, hit, t_min)
             : intersect(part.polygon, origin, dir, hit, t_min);
}

SurfacePart partTransformed(const SurfacePart& part, const Eigen::Isometry3d& transform) {
  SurfacePart out = part;
  if (part.kind == SurfacePart::Kind::kRoundCone) {
    out.cone = transformed(part.cone, transform);
  } else {
    out.polygon = transformed(part.polygon, transform);
  }
  out.dorsal = transform.linear() * part.dorsal;
  return out;
}

Eigen::Vector3f surfaceAlbedo(const SurfacePart& part, const Eigen::Vector3d& point,
                              const Eigen::Vector3d& normal) {
  if (part.dorsal.squaredNorm() == 0.0) return part.albedo_dorsal;
  const double side = normal.dot(part.dorsal);
  if (part.nail_from >= 0.0 && part.kind == SurfacePart::Kind::kRoundCone) {
    const Eigen::Vector3d axis = part.cone.b - part.cone.a;
    const double length = axis.norm();
    if (length > 0.0) {
      const Eigen::Vector3d unit = axis / length;
      const double s = (point - part.cone.a).dot(unit);
      const Eigen::Vector3d radial = point - part.cone.a - s * unit;
      const double rn = radial.norm();
      if (s > part.nail_from && rn > 0.0 && radial.dot(part.dorsal) > 0.5 * rn) {
        return part.albedo_nail;
      }
    }
  }
  // Smooth transition from the palmar to the dorsal colour around the sides.
  const float w = static_cast<float>(std::clamp((side + 0.3) / 0.6, 0.0, 1.0));
  const float ws = w * w * (3.0f - 2.0f * w);
  return ws * part.albedo_dorsal + (1.0f - ws) * part.albedo_palmar;
}

// Linear albedo of an sRGB photograph at (s, t) in [0, 1]^2 (bilinear; wraps around).
Eigen::Vector3f photoAlbedo(const cv::Mat& photo, double s, double t) {
  const double x = (s - std::floor(s)) * photo.cols - 0.5;
  const double y = (t - std::floor(t)) * photo.rows - 0.5;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float ax = static_cast<float>(x - x0), ay = static_cast<float>(y - y0);
  auto at = [&photo](int i, int j) {
    i = ((i % photo.cols) + photo.cols) % photo.cols;
    j = ((j % photo.rows) + photo.rows) % photo.rows;
    const cv::Vec3b& c = photo.at<cv::Vec3b>(j, i);
    return Eigen::Vector3f(srgbToLinear(c[0] / 255.0f), srgbToLinear(c[1] / 255.0f),
                           srgbToLinear(c[2] / 255.0f));
  };
  return (1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x0 + 1, y0)) +
         ay * ((1 - ax) * at(x0, y0 + 1) + ax * at(x0 + 1, y0 + 1));
}

void checkCamera(const Camera& camera) {
  std::ostringstream problem;
  if (camera.width <= 0 || camera.height <= 0) {
    problem << "image size " << camera.width << "x" << camera.height;
  } else if (!(camera.K(0, 0) > 0.0) || !(camera.K(1, 1) > 0.0) || !camera.K.allFinite()) {
    problem << "focal length must be positive and finite";
  } else if (!camera.world_to_camera.matrix().allFinite()) {
    problem << "extrinsics are not finite";
  } else if (camera.hasDistortion()) {
    problem << "the studio renders exact pinhole cameras: set the distortion coefficients to 0";
  }
  if (!problem.str().empty()) {
    throw InputError("studio camera '" + camera.name + "': " + problem.str());
  }
}

}  // namespace

std::uint64_t mixSeed(std::uint64_t a, std::uint64_t b) { return mix64(a, b); }

float srgbToLinear(float s) {
  s = std::clamp(s, 0.0f, 1.0f);
  return s <= 0.04045f ? s / 12.92f : std::pow((s + 0.055f) / 1.055f, 2.4f);
}

float linearToSrgb(float l) {
  l = std::clamp(l, 0.0f, 1.0f);
  return l <= 0.0031308f ? 12.92f * l : 1.055f * std::pow(l, 1.0f / 2.4f) - 0.055f;
}

Eigen::Vector3f studioAlbedo(const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                             bool on_table, std::uint64_t seed) {
  return on_table ? tableAlbedo(point, seed) : roomAlbedo(point, normal, seed);
}

float StudioRenderer::ShadowMap::sample(float x, float y) const {
  if (width == 0) return 0.0f;
  const float fx = static_cast<float>((x - origin.x()) / texel) - 0.5f;
  const float fy = static_cast<float>((y - origin.y()) / texel) - 0.5f;
  const int ix = static_cast<int>(std::floor(fx)), iy = static_cast<int>(std::floor(fy));
  const float ax = fx - ix, ay = fy - iy;
  auto at = [&](int i, int j) {
    if (i < 0 || j < 0 || i >= width || j >= height) return 0.0f;
    return occlusion[static_cast<size_t>(j) * width + i];
  };
  return (1 - ay) * ((1 - ax) * at(ix, iy) + ax * at(ix + 1, iy)) +
         ay * ((1 - ax) * at(ix, iy + 1) + ax * at(ix + 1, iy + 1));
}

StudioRenderer::StudioRenderer(std::vector<Camera> cameras, const StudioSceneParams& scene,
                               const SensorParams& sensor)
    : cameras_(std::move(cameras)), scene_(scene), sensor_(sensor) {
  if (!(scene_.light_direction.norm() > 0.0)) throw InputError("studio: light direction is zero");
  if (!(scene_.shadow_texel > 0.0)) throw InputError("studio: shadow texel must be positive");
  light_ = scene_.light_direction.normalized();
  for (const cv::Mat* photo : {&scene_.table_photo, &scene_.wall_photo}) {
    if (!photo->empty() && photo->type() != CV_8UC3) {
      throw InputError("studio: a photograph must be an 8-bit RGB image (CV_8UC3)");
    }
  }
  if (!(scene_.wall_photo_size > 0.0)) throw InputError("studio: wall_photo_size must be positive");
  if (scene_.background_supersampling < 1) {
    throw InputError("studio: background_supersampling must be at least 1");
  }
  const int supersampling = scene_.background_supersampling;
  // First background surface along a world ray from inside the room: the table top, else the
  // room box's walls, floor or ceiling.
  const auto backgroundAlbedo = [this](const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                                       bool on_table) {
    if (on_table && !scene_.table_photo.empty()) {
      const Eigen::Vector2d extent = scene_.table_max - scene_.table_min;
      return photoAlbedo(scene_.table_photo, (point.x() - scene_.table_min.x()) / extent.x(),
                         (scene_.table_max.y() - point.y()) / extent.y())
          .cast<double>();
    }
    if (!on_table && std::abs(normal.z()) < 0.5 && !scene_.wall_photo.empty()) {
      const double along = std::abs(normal.x()) > 0.5 ? point.y() : point.x();
      return photoAlbedo(scene_.wall_photo, along / scene_.wall_photo_size,
                         -point.z() / scene_.wall_photo_size)
          .cast<double>();
    }
    return studioAlbedo(point, normal, on_table, scene_.texture_seed).cast<double>();
  };
  const auto traceBackground = [this](const Eigen::Vector3d& from, const Eigen::Vector3d& d) {
    BackgroundHit hit;
    for (int a = 0; a < 3; ++a) {
      if (std::abs(d[a]) < 1e-12) continue;
      const double bound = d[a] > 0 ? scene_.room_max[a] : scene_.room_min[a];
      const double ta = (bound - from[a]) / d[a];
      if (ta > 0 && ta < hit.t) {
        hit.t = ta;
        hit.normal = Eigen::Vector3d::Zero();
        hit.normal[a] = d[a] > 0 ? -1.0 : 1.0;
      }
    }
    if (std::abs(d.z()) > 1e-12) {
      const double tt = -from.z() / d.z();
      const Eigen::Vector3d p = from + tt * d;
      if (tt > 0 && tt < hit.t && p.x() > scene_.table_min.x() && p.x() < scene_.table_max.x() &&
          p.y() > scene_.table_min.y() && p.y() < scene_.table_max.y()) {
        hit.t = tt;
        hit.on_table = true;
        hit.normal = Eigen::Vector3d(0.0, 0.0, from.z() > 0 ? 1.0 : -1.0);
      }
    }
    hit.point = from + hit.t * d;
    return hit;
  };
  for (const Camera& camera : cameras_) {
    checkCamera(camera);
    CameraData data;
    const size_t n = static_cast<size_t>(camera.width) * camera.height;
    data.rays.resize(n);
    data.bg_linear.create(camera.height, camera.width, CV_32FC3);
    data.bg_depth.create(camera.height, camera.width, CV_32FC1);
    auto* bg_linear = data.bg_linear.ptr<Eigen::Vector3f>();
    data.bg_t.resize(n);
    data.bg_direct.resize(n);
    data.table_uv.resize(n);
    const Eigen::Isometry3d camera_to_world = camera.world_to_camera.inverse();
    const Eigen::Vector3d centre = camera_to_world.translation();
    const Eigen::Matrix3d k_inv = camera.K.inverse();
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        const size_t i = static_cast<size_t>(v) * camera.width + u;
        const Eigen::Vector3d ray = (k_inv * Eigen::Vector3d(u, v, 1.0)).normalized();
        data.rays[i] = ray.cast<float>();
        Eigen::Vector3d sum_lit = Eigen::Vector3d::Zero();
        double sum_direct = 0.0;
        // The exact pixel ray gives the depth and the table point (shadows).
        const BackgroundHit centre_hit = traceBackground(centre, camera_to_world.linear() * ray);
        data.bg_t[i] = static_cast<float>(centre_hit.t);
        data.bg_depth.ptr<float>()[i] = data.bg_t[i] * data.rays[i].z();
        data.table_uv[i] = centre_hit.on_table
                               ? Eigen::Vector2f(centre_hit.point.x(), centre_hit.point.y())
                               : Eigen::Vector2f::Constant(std::numeric_limits<float>::quiet_NaN());
        for (int sy = 0; sy < supersampling; ++sy) {
          for (int sx = 0; sx < supersampling; ++sx) {
            const Eigen::Vector3d pixel(u + (sx + 0.5) / supersampling - 0.5,
                                        v + (sy + 0.5) / supersampling - 0.5, 1.0);
            const BackgroundHit h =
                traceBackground(centre, camera_to_world.linear() * (k_inv * pixel).normalized());
            if (!std::isfinite(h.t)) continue;  // camera outside the room: black
            const Eigen::Vector3d albedo = backgroundAlbedo(h.point, h.normal, h.on_table);
            const double direct = scene_.light_intensity * std::max(0.0, h.normal.dot(light_));
            sum_lit += albedo * (scene_.ambient + direct);
            sum_direct += direct;
          }
        }
        const double samples = supersampling * supersampling;
        bg_linear[i] = (sum_lit / samples).cast<float>();
        // The key light's share, to darken shadowed table pixels.
        data.bg_direct[i] = static_cast<float>(sum_direct / samples);
      }
    }
    data_.push_back(std::move(data));
  }
}

StudioRenderer::ShadowMap StudioRenderer::computeShadow(
    const std::vector<SurfacePart>& parts) const {
  ShadowMap map;
  map.texel = scene_.shadow_texel;
  if (!scene_.shadows || parts.empty() || light_.z() <= 1e-3) return map;
  // Footprints of the parts' bounding boxes on the table along the light.
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> footprints(parts.size());
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(kInf), hi = Eigen::Vector2d::Constant(-kInf);
  for (size_t k = 0; k < parts.size(); ++k) {
    Eigen::Vector3d blo, bhi;
    partBounds(parts[k], &blo, &bhi);
    Eigen::Vector2d flo = Eigen::Vector2d::Constant(kInf), fhi = Eigen::Vector2d::Constant(-kInf);
    if (bhi.z() > 0.0) {
      for (int c = 0; c < 8; ++c) {
        Eigen::Vector3d p((c & 1) ? bhi.x() : blo.x(), (c & 2) ? bhi.y() : blo.y(),
                          (c & 4) ? bhi.z() : blo.z());
        p.z() = std::max(p.z(), 0.0);
        const Eigen::Vector3d q = p - (p.z() / light_.z()) * light_;
        flo = flo.cwiseMin(q.head<2>());
        fhi = fhi.cwiseMax(q.head<2>());
      }
      flo = flo.cwiseMax(scene_.table_min);
      fhi = fhi.cwiseMin(scene_.table_max);
    }
    footprints[k] = {flo, fhi};
    if ((fhi - flo).minCoeff() > 0) {
      lo = lo.cwiseMin(flo);
      hi = hi.cwiseMax(fhi);
    }
  }
  if (!((hi - lo).minCoeff() > 0)) return map;
  map.origin = lo;
  map.width = static_cast<int>(std::ceil((hi.x() - lo.x()) / map.texel)) + 1;
  map.height = static_cast<int>(std::ceil((hi.y() - lo.y()) / map.texel)) + 1;
  cv::Mat occ(map.height, map.width, CV_32F, cv::Scalar(0));
  RayHit hit;
  for (size_t k = 0; k < parts.size(); ++k) {
    const auto& [flo, fhi] = footprints[k];
    if (!((fhi - flo).minCoeff() > 0)) continue;
    const int i0 = std::max(0, static_cast<int>(std::floor((flo.x() - lo.x()) / map.texel)));
    const int j0 = std::max(0, static_cast<int>(std::floor((flo.y() - lo.y()) / map.texel)));
    const int i1 =
        std::min(map.width - 1, static_cast<int>(std::ceil((fhi.x() - lo.x()) / map.texel)));
    const int j1 =
        std::min(map.height - 1, static_cast<int>(std::ceil((fhi.y() - lo.y()) / map.texel)));
    for (int j = j0; j <= j1; ++j) {
      float* row = occ.ptr<float>(j);
      for (int i = i0; i <= i1; ++i) {
        if (row[i] > 0.0f) continue;
        const Eigen::Vector3d q(lo.x() + (i + 0.5) * map.texel, lo.y() + (j + 0.5) * map.texel,
                                0.0);
        if (partIntersect(parts[k], q, light_, &hit, 1e-6)) row[i] = 1.0f;
      }
    }
  }
  // A narrow penumbra (the key light is not a point).
  cv::GaussianBlur(occ, occ, cv::Size(5, 5), 1.2);
  map.occlusion.assign(occ.begin<float>(), occ.end<float>());
  return map;
}

namespace {

// Buffers of one camera's frame, reused from frame to frame by each rendering thread (allocating
// them per frame cost more than the shading: fresh pages are faulted in and cleared).
static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "a CV_32FC3 pixel is a Vector3f");

struct FrameScratch {
  std::vector<float> tbuf;               // nearest hit so far (the background's distance)
  std::vector<int> owner;                // index of the part seen, -1 for the background
  std::vector<Eigen::Vector3f> normals;  // its normal, where owner >= 0
  std::vector<std::uint8_t> changed;     // 1 where a sub-frame may differ from the background
  cv::Mat accum, noise;                  // CV_32FC3: sum of the sub-frames; sensor noise
};

FrameScratch& frameScratch() {
  thread_local FrameScratch scratch;
  return scratch;
}

// The 8-bit image: linear values in [0, 1] (clamped) encoded to sRGB through a 4097-entry
// table, plus the sensor noise, rounded to nearest (even) and saturated, as
// cv::saturate_cast<uchar>(table[size_t(l * 4096 + 0.5)] + noise) does, with OpenCV's universal
// intrinsics where the CPU has them.
void encodeSrgb(const float* linear, const float* noise, size_t count, std::uint8_t* out) {
  static const std::vector<float> kLut = [] {
    std::vector<float> lut(4097);
    for (size_t i = 0; i < lut.size(); ++i) lut[i] = 255.0f * linearToSrgb(i / 4096.0f);
    return lut;
  }();
  const float* lut = kLut.data();
  size_t i = 0;
#if CV_SIMD
  const int lanes = cv::v_float32::nlanes;
  const cv::v_float32 zero = cv::vx_setzero_f32(), one = cv::vx_setall_f32(1.0f);
  const cv::v_float32 scale = cv::vx_setall_f32(4096.0f), half = cv::vx_setall_f32(0.5f);
  auto level = [&](size_t at) {
    const cv::v_float32 l = cv::v_min(cv::v_max(cv::vx_load(linear + at), zero), one);
    const cv::v_int32 index = cv::v_trunc(l * scale + half);
    return cv::v_round(cv::v_lut(lut, index) + cv::vx_load(noise + at));
  };
  for (; i + 4 * lanes <= count; i += 4 * lanes) {
    const cv::v_int16 low = cv::v_pack(level(i), level(i + lanes));
    const cv::v_int16 high = cv::v_pack(level(i + 2 * lanes), level(i + 3 * lanes));
    cv::v_store(out + i, cv::v_pack_u(low, high));
  }
#endif
  for (; i < count; ++i) {
    const float l = std::clamp(linear[i], 0.0f, 1.0f);
    out[i] = cv::saturate_cast<uchar>(lut[static_cast<size_t>(l * 4096.0f + 0.5f)] + noise[i]);
  }
}

PixelBox unite(const PixelBox& a, const PixelBox& b) {
  if (a.empty()) return b;
  if (b.empty()) return a;
  return PixelBox{std::min(a.u0, b.u0), std::min(a.v0, b.v0), std::max(a.u1, b.u1),
                  std::max(a.v1, b.v1)};
}

// Pixels whose view ray meets the table (z = 0) inside the world rectangle [lo, hi].
PixelBox projectTableRectangle(const Camera& camera, const Eigen::Vector2d& lo,
                               const Eigen::Vector2d& hi) {
  Eigen::Vector3d clo = Eigen::Vector3d::Constant(kInf), chi = Eigen::Vector3d::Constant(-kInf);
  for (int c = 0; c < 4; ++c) {
    const Eigen::Vector3d corner((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(), 0.0);
    const Eigen::Vector3d p = camera.world_to_camera * corner;
    clo = clo.cwiseMin(p);
    chi = chi.cwiseMax(p);
  }
  // The rectangle's corners bound it; a camera-frame box around them projects (projectBox) to
  // pixels bounding the rectangle's image, or to the whole image if it reaches behind the camera.
  return projectBox(camera, clo, chi);
}

}  // namespace

std::vector<StudioRenderer::ShadowMap> StudioRenderer::computeShadows(
    const std::vector<std::vector<SurfacePart>>& subframes) const {
  std::vector<ShadowMap> shadows;
  shadows.reserve(subframes.size());
  for (const auto& parts : subframes) shadows.push_back(computeShadow(parts));
  return shadows;
}

StudioImage StudioRenderer::renderCamera(int camera,
                                         const std::vector<std::vector<SurfacePart>>& subframes,
                                         std::uint64_t noise_seed, double light_gain) const {
  if (camera < 0 || camera >= static_cast<int>(cameras_.size())) {
    throw InputError("studio: no camera " + std::to_string(camera));
  }
  return renderCamera(camera, subframes, computeShadows(subframes), noise_seed, light_gain, false);
}

StudioImage StudioRenderer::renderCameraFullFrame(
    int camera, const std::vector<std::vector<SurfacePart>>& subframes, std::uint64_t noise_seed,
    double light_gain) const {
  if (camera < 0 || camera >= static_cast<int>(cameras_.size())) {
    throw InputError("studio: no camera " + std::to_string(camera));
  }
  return renderCamera(camera, subframes, computeShadows(subframes), noise_seed, light_gain, true);
}

StudioImage StudioRenderer::renderCamera(int camera_index,
                                         const std::vector<std::vector<SurfacePart>>& subframes,
                                         const std::vector<ShadowMap>& shadows,
                                         std::uint64_t noise_seed, double light_gain,
                                         bool full_frame) const {
  const Camera& camera = cameras_[camera_index];
  const CameraData& data = data_[camera_index];
  const int width = camera.width, height = camera.height;
  const size_t n = static_cast<size_t>(width) * height;
  FrameScratch& scratch = frameScratch();
  scratch.tbuf.resize(n);
  scratch.owner.resize(n);
  scratch.normals.resize(n);
  scratch.changed.assign(n, full_frame ? 1 : 0);

  // The sum of the sub-frames' colours starts as the background added up once per sub-frame (in
  // the order the sub-frames add up): what every pixel that no sub-frame changes holds.
  const size_t count = std::max<size_t>(1, subframes.size());
  const size_t middle = subframes.size() / 2;
  data.bg_linear.copyTo(scratch.accum);
  for (size_t s = 1; s < count; ++s) cv::add(scratch.accum, data.bg_linear, scratch.accum);
  auto* acc = scratch.accum.ptr<Eigen::Vector3f>();

  // The pixels any sub-frame may change: its parts' projected bounds and its shadow's footprint
  // (where ShadowMap::sample can be non-zero: half a texel beyond the map; one texel here).
  PixelBox region = full_frame ? PixelBox{0, 0, width - 1, height - 1} : PixelBox{};
  auto mark = [&](const PixelBox& box) {
    if (box.empty()) return;
    for (int v = box.v0; v <= box.v1; ++v) {
      std::fill_n(scratch.changed.begin() + static_cast<size_t>(v) * width + box.u0,
                  box.u1 - box.u0 + 1, 1);
    }
    region = unite(region, box);
  };
  std::vector<std::vector<SurfacePart>> local(subframes.size());  // in the camera frame
  std::vector<std::vector<PixelBox>> boxes(subframes.size());
  for (size_t s = 0; s < subframes.size(); ++s) {
    local[s].reserve(subframes[s].size());
    for (const SurfacePart& part : subframes[s]) {
      local[s].push_back(partTransformed(part, camera.world_to_camera));
      Eigen::Vector3d lo, hi;
      partBounds(local[s].back(), &lo, &hi);
      boxes[s].push_back(projectBox(camera, lo, hi));
      if (!full_frame) mark(boxes[s].back());
    }
    const ShadowMap& shadow = shadows[s];
    if (!full_frame && shadow.width > 0) {
      const Eigen::Vector2d margin = Eigen::Vector2d::Constant(shadow.texel);
      const Eigen::Vector2d extent(shadow.width * shadow.texel, shadow.height * shadow.texel);
      mark(projectTableRectangle(camera, shadow.origin - margin, shadow.origin + extent + margin));
    }
  }

  StudioImage image;
  image.labels = cv::Mat(height, width, CV_8UC1, cv::Scalar(kLabelBackground));
  image.depth = data.bg_depth.clone();
  if (!subframes.empty() && !region.empty()) {
    for (int v = region.v0; v <= region.v1; ++v) {
      for (int u = region.u0; u <= region.u1; ++u) {
        const size_t i = static_cast<size_t>(v) * width + u;
        if (scratch.changed[i]) acc[i] = Eigen::Vector3f::Zero();
      }
    }
  }
  const Eigen::Matrix3d world_to_camera_rotation = camera.world_to_camera.linear();
  const Eigen::Vector3d light = world_to_camera_rotation * light_;
  const Eigen::Vector3d up = world_to_camera_rotation * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  RayHit hit;
  for (size_t s = 0; s < subframes.size() && !region.empty(); ++s) {
    // Depth test of the parts inside their boxes, over the background's distances.
    for (int v = region.v0; v <= region.v1; ++v) {
      const size_t row = static_cast<size_t>(v) * width;
      std::copy(data.bg_t.begin() + row + region.u0, data.bg_t.begin() + row + region.u1 + 1,
                scratch.tbuf.begin() + row + region.u0);
      std::fill(scratch.owner.begin() + row + region.u0,
                scratch.owner.begin() + row + region.u1 + 1, -1);
    }
    const std::vector<SurfacePart>& parts = local[s];
    for (size_t k = 0; k < parts.size(); ++k) {
      const PixelBox& box = boxes[s][k];
      // Most rays of the box miss the part: a sphere around it (radius with a margin for
      // rounding) rejects them before the exact intersection.
      Eigen::Vector3d centre;
      double radius;
      if (parts[k].kind == SurfacePart::Kind::kRoundCone) {
        const RoundCone& cone = parts[k].cone;
        centre = 0.5 * (cone.a + cone.b);
        radius = 0.5 * (cone.b - cone.a).norm() + std::max(cone.ra, cone.rb);
      } else {
        Eigen::Vector3d lo, hi;
        partBounds(parts[k], &lo, &hi);
        centre = 0.5 * (lo + hi);
        radius = 0.5 * (hi - lo).norm();
      }
      const double reject = radius * radius * (1.0 + 1e-6) + 1e-12;
      const double centre_sq = centre.squaredNorm();
      for (int v = box.v0; v <= box.v1; ++v) {
        for (int u = box.u0; u <= box.u1; ++u) {
          const size_t i = static_cast<size_t>(v) * width + u;
          const Eigen::Vector3d dir = data.rays[i].cast<double>();
          const double along = centre.dot(dir);
          if (centre_sq - along * along > reject) continue;
          if (partIntersect(parts[k], origin, dir, &hit, 1e-4) && hit.t < scratch.tbuf[i]) {
            scratch.tbuf[i] = static_cast<float>(hit.t);
            scratch.owner[i] = static_cast<int>(k);
            scratch.normals[i] = hit.normal.cast<float>();
          }
        }
      }
    }
    // Shading of the changed pixels: the parts, and the background with the shadow.
    const ShadowMap& shadow = shadows[s];
    const auto* bg_linear = data.bg_linear.ptr<Eigen::Vector3f>();
    for (int v = region.v0; v <= region.v1; ++v) {
      for (int u = region.u0; u <= region.u1; ++u) {
        const size_t i = static_cast<size_t>(v) * width + u;
        if (!scratch.changed[i]) continue;
        const int k = scratch.owner[i];
        if (k < 0) {
          Eigen::Vector3f c = bg_linear[i];
          if (shadow.width > 0 && !std::isnan(data.table_uv[i].x())) {
            const float occ = shadow.sample(data.table_uv[i].x(), data.table_uv[i].y());
            if (occ > 0.0f) {
              const float lit = static_cast<float>(scene_.ambient) + data.bg_direct[i];
              c *= (lit - occ * data.bg_direct[i]) / lit;
            }
          }
          acc[i] += c;
          continue;
        }
        const SurfacePart& part = parts[k];
        const Eigen::Vector3d normal = scratch.normals[i].cast<double>();
        const Eigen::Vector3d point =
            static_cast<double>(scratch.tbuf[i]) * data.rays[i].cast<double>();
        const Eigen::Vector3f albedo = surfaceAlbedo(part, point, normal);
        const double ambient = scene_.ambient * (0.8 + 0.2 * normal.dot(up));
        const double direct = scene_.light_intensity * std::max(0.0, normal.dot(light));
        acc[i] += albedo * static_cast<float>(ambient + direct);
      }
    }
    if (s == middle) {
      float* depth = image.depth.ptr<float>();
      for (int v = region.v0; v <= region.v1; ++v) {
        for (int u = region.u0; u <= region.u1; ++u) {
          const size_t i = static_cast<size_t>(v) * width + u;
          const int k = scratch.owner[i];
          if (k < 0) continue;
          image.labels.data[i] = parts[k].label;
          depth[i] = scratch.tbuf[i] * data.rays[i].z();
        }
      }
    }
  }

  cv::Mat& accum = scratch.accum;
  accum *= light_gain / static_cast<double>(count);
  if (sensor_.blur_sigma > 0.0) cv::GaussianBlur(accum, accum, cv::Size(0, 0), sensor_.blur_sigma);

  // Encode (sRGB), add sensor noise, quantise.
  scratch.noise.create(height, width, CV_32FC3);
  if (sensor_.noise_sigma > 0.0) {
    cv::RNG rng(mixSeed(noise_seed, static_cast<std::uint64_t>(camera_index)));
    rng.fill(scratch.noise, cv::RNG::NORMAL, cv::Scalar::all(0),
             cv::Scalar::all(sensor_.noise_sigma));
  } else {
    scratch.noise.setTo(cv::Scalar::all(0));
  }
  image.rgb = cv::Mat(height, width, CV_8UC3);
  encodeSrgb(accum.ptr<float>(), scratch.noise.ptr<float>(), 3 * n, image.rgb.ptr<std::uint8_t>());
  return image;
}

std::vector<StudioImage> StudioRenderer::render(
    const std::vector<std::vector<SurfacePart>>& subframes, std::uint64_t noise_seed,
    double light_gain) const {
  const std::vector<ShadowMap> shadows = computeShadows(subframes);
  std::vector<StudioImage> images(cameras_.size());
  const auto render_view = [&](int c) {
    images[c] = renderCamera(c, subframes, shadows, noise_seed, light_gain, false);
  };
  if (pool_) {
    pool_->run(static_cast<int>(cameras_.size()), render_view);
  } else {
    for (size_t c = 0; c < cameras_.size(); ++c) render_view(static_cast<int>(c));
  }
  return images;
}

void StudioRenderer::setRenderThreads(int threads) {
  pool_ = threads > 1 ? std::make_shared<ThreadPool>(threads) : nullptr;
}

cv::Mat contactSheet(const std::vector<StudioImage>& images, const std::vector<Camera>& cameras,
                     const Fingertips* fingertips, const std::string& caption) {
  if (images.empty()) return cv::Mat();
  if (images.size() != cameras.size()) {
    throw InputError("contactSheet: " + std::to_string(images.size()) + " images for " +
                     std::to_string(cameras.size()) + " cameras");
  }
  const int tile_w = images[0].rgb.cols, tile_h = images[0].rgb.rows;
  const int columns = std::min<int>(3, static_cast<int>(images.size()) + 1);
  const int tiles = static_cast<int>(images.size()) + 1;  // the views and the label image
  const int rows = (tiles + columns - 1) / columns;
  cv::Mat sheet(rows * tile_h, columns * tile_w, CV_8UC3, cv::Scalar::all(255));
  auto place = [&](int tile) {
    return cv::Rect((tile % columns) * tile_w, (tile / columns) * tile_h, tile_w, tile_h);
  };
  static const cv::Scalar kTipColours[kNumFingers] = {
      {255, 60, 60}, {255, 220, 0}, {60, 220, 60}, {0, 200, 255}, {200, 80, 255}};
  for (size_t c = 0; c < images.size(); ++c) {
    cv::Mat tile;
    cv::resize(images[c].rgb, tile, cv::Size(tile_w, tile_h), 0, 0, cv::INTER_NEAREST);
    cv::putText(tile, cameras[c].name, cv::Point(5, 15), cv::FONT_HERSHEY_SIMPLEX, 0.45,
                cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
    tile.copyTo(sheet(place(static_cast<int>(c))));
  }
  // Last tile: camera 0's labels (skin parts coloured by finger, sleeve dark) with the
  // ground-truth fingertips.
  cv::Mat labels(tile_h, tile_w, CV_8UC3, cv::Scalar(235, 235, 235));
  for (int v = 0; v < std::min(tile_h, images[0].labels.rows); ++v) {
    for (int u = 0; u < std::min(tile_w, images[0].labels.cols); ++u) {
      const std::uint8_t label = images[0].labels.at<std::uint8_t>(v, u);
      cv::Vec3b colour(235, 235, 235);
      if (label == kLabelSleeve) {
        colour = cv::Vec3b(40, 40, 40);
      } else if (label == kLabelForearm || label == kLabelPalm) {
        colour = cv::Vec3b(225, 170, 140);
      } else if (label >= kLabelFirstFingerBone) {
        const int finger = (label - kLabelFirstFingerBone) / 3;
        const int phalanx = (label - kLabelFirstFingerBone) % 3;
        const cv::Scalar& c = kTipColours[finger];
        const double shade = 0.55 + 0.15 * phalanx;
        colour = cv::Vec3b(cv::saturate_cast<uchar>(c[0] * shade),
                           cv::saturate_cast<uchar>(c[1] * shade),
                           cv::saturate_cast<uchar>(c[2] * shade));
      }
      labels.at<cv::Vec3b>(v, u) = colour;
    }
  }
  if (fingertips != nullptr) {
    for (int f = 0; f < kNumFingers; ++f) {
      const Eigen::Vector3d p = cameras[0].world_to_camera * (*fingertips)[f];
      if (p.z() <= 0) continue;
      const Eigen::Vector2d px = (cameras[0].K * p).hnormalized();
      const cv::Point centre(static_cast<int>(std::lround(px.x())),
                             static_cast<int>(std::lround(px.y())));
      cv::drawMarker(labels, centre, cv::Scalar(0, 0, 0), cv::MARKER_CROSS, 9, 1);
    }
  }
  cv::putText(labels, cameras[0].name + " labels, + = fingertips", cv::Point(5, 15),
              cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  labels.copyTo(sheet(place(static_cast<int>(images.size()))));
  if (!caption.empty()) {
    cv::putText(sheet, caption, cv::Point(5, sheet.rows - 8), cv::FONT_HERSHEY_SIMPLEX, 0.45,
                cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  }
  return sheet;
}

}  // namespace studio
}  // namespace sag_hand_tracker
