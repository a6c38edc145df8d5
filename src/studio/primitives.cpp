#include "sag_hand_tracker/studio/primitives.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sag_hand_tracker {
namespace studio {

namespace {

// First entry of a ray into a sphere, t > t_min.
bool intersectSphere(const Eigen::Vector3d& centre, double radius, const Eigen::Vector3d& origin,
                     const Eigen::Vector3d& dir, double t_min, RayHit* hit) {
  const Eigen::Vector3d oc = origin - centre;
  const double b = oc.dot(dir);
  const double c = oc.squaredNorm() - radius * radius;
  const double h = b * b - c;
  if (h < 0.0) return false;
  const double t = -b - std::sqrt(h);
  if (t <= t_min) return false;
  hit->t = t;
  hit->normal = (oc + t * dir) / radius;
  return true;
}

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

bool insideConvex(const std::vector<Eigen::Vector2d>& vertices, const Eigen::Vector2d& p) {
  const size_t n = vertices.size();
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& a = vertices[i];
    const Eigen::Vector2d& b = vertices[(i + 1) % n];
    if (cross2(b - a, p - a) < 0.0) return false;
  }
  return true;
}

double distanceToSegment2d(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                           const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double s = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (p - a - s * ab).norm();
}

}  // namespace

bool intersect(const RoundCone& cone, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
               RayHit* hit, double t_min) {
  const Eigen::Vector3d ba = cone.b - cone.a;
  const double m0 = ba.squaredNorm();
  // Early out (most rays of a part's bounding box miss it): the hull lies within max(ra, rb) of
  // the segment ab, so a line farther from the segment (with a margin for rounding) misses it.
  // Squared distance of the line to a + s (b - a): A s^2 + 2 B s + C, minimised over [0, 1].
  {
    const Eigen::Vector3d w = cone.a - origin;
    const double wd = w.dot(dir), ed = ba.dot(dir);
    const double A = m0 - ed * ed, B = w.dot(ba) - wd * ed, C = w.squaredNorm() - wd * wd;
    const double s = A > 1e-12 * m0 ? std::clamp(-B / A, 0.0, 1.0) : 0.0;
    const double bound = std::max(cone.ra, cone.rb);
    if ((A * s + 2.0 * B) * s + C > bound * bound * (1.0 + 1e-6) + 1e-12) return false;
  }
  const double rr = cone.ra - cone.rb;
  const double d2 = m0 - rr * rr;
  if (d2 <= 1e-12 * std::max(m0, 1e-12)) {
    // One sphere contains the other: the hull is the larger sphere.
    return cone.ra >= cone.rb ? intersectSphere(cone.a, cone.ra, origin, dir, t_min, hit)
                              : intersectSphere(cone.b, cone.rb, origin, dir, t_min, hit);
  }
  const Eigen::Vector3d oa = origin - cone.a;
  const double m1 = ba.dot(oa);
  const double m2 = ba.dot(dir);
  const double m3 = dir.dot(oa);
  const double m5 = oa.squaredNorm();

  RayHit best;
  best.t = std::numeric_limits<double>::infinity();
  bool found = false;

  // Lateral surface: the cone tangent to both spheres (both roots; the axial parameter y selects
  // the part between the two circles of tangency).
  const double k2 = d2 - m2 * m2;
  const double k1 = d2 * m3 - m1 * m2 + m2 * rr * cone.ra;
  const double k0 = d2 * m5 - m1 * m1 + 2.0 * m1 * rr * cone.ra - m0 * cone.ra * cone.ra;
  if (std::abs(k2) > 1e-14 * m0) {
    const double h = k1 * k1 - k0 * k2;
    if (h >= 0.0) {
      const double sq = std::sqrt(h);
      for (const double t : {(-k1 - sq) / k2, (-k1 + sq) / k2}) {
        if (t <= t_min || t >= best.t) continue;
        const double y = m1 - cone.ra * rr + t * m2;
        if (y > 0.0 && y < d2) {
          best.t = t;
          best.normal = (d2 * (oa + t * dir) - ba * y).normalized();
          found = true;
        }
      }
    }
  }
  // The two end spheres.
  RayHit cap;
  if (intersectSphere(cone.a, cone.ra, origin, dir, t_min, &cap) && cap.t < best.t) {
    best = cap;
    found = true;
  }
  if (intersectSphere(cone.b, cone.rb, origin, dir, t_min, &cap) && cap.t < best.t) {
    best = cap;
    found = true;
  }
  if (found) *hit = best;
  return found;
}

bool intersect(const SweptPolygon& polygon, const Eigen::Vector3d& origin,
               const Eigen::Vector3d& dir, RayHit* hit, double t_min) {
  // The swept polygon is the union of the prism {inside, |height| <= r} and the capsules along
  // its edges; the prism's side walls lie inside the capsules, so the first hit is the nearest of
  // the two face planes (within the polygon) and the edge capsules.
  RayHit best;
  best.t = std::numeric_limits<double>::infinity();
  bool found = false;
  const Eigen::Vector3d n = polygon.normal();
  const double dn = dir.dot(n);
  if (std::abs(dn) > 1e-12) {
    const double h0 = (origin - polygon.origin).dot(n);
    for (const double side : {1.0, -1.0}) {
      const double t = (side * polygon.radius - h0) / dn;
      if (t <= t_min || t >= best.t) continue;
      const Eigen::Vector3d p = origin + t * dir - polygon.origin;
      if (insideConvex(polygon.vertices, Eigen::Vector2d(p.dot(polygon.u), p.dot(polygon.v)))) {
        best.t = t;
        best.normal = side * n;
        found = true;
      }
    }
  }
  const size_t count = polygon.vertices.size();
  RayHit edge;
  for (size_t i = 0; i < count; ++i) {
    RoundCone capsule{polygon.vertex(i), polygon.vertex((i + 1) % count), polygon.radius,
                      polygon.radius};
    if (intersect(capsule, origin, dir, &edge, t_min) && edge.t < best.t) {
      best = edge;
      found = true;
    }
  }
  if (found) *hit = best;
  return found;
}

double signedDistance(const RoundCone& cone, const Eigen::Vector3d& p) {
  const Eigen::Vector3d ba = cone.b - cone.a;
  const double length = ba.norm();
  const double rr = cone.ra - cone.rb;
  if (length <= std::abs(rr)) {
    return cone.ra >= cone.rb ? (p - cone.a).norm() - cone.ra : (p - cone.b).norm() - cone.rb;
  }
  // 2D profile: s along the axis from a, q radial distance.
  const Eigen::Vector3d axis = ba / length;
  const double s = (p - cone.a).dot(axis);
  const double q = (p - cone.a - s * axis).norm();
  const double sin_alpha = rr / length;
  const double cos_alpha = std::sqrt(1.0 - sin_alpha * sin_alpha);
  // Outward normal of the lateral side and its direction from the tangent point on sphere a.
  const Eigen::Vector2d n(sin_alpha, cos_alpha);
  const Eigen::Vector2d side(cos_alpha, -sin_alpha);
  const Eigen::Vector2d point(s, q);
  const double lambda = (point - cone.ra * n).dot(side);
  if (lambda < 0.0) return point.norm() - cone.ra;
  if (lambda > length * cos_alpha) return (point - Eigen::Vector2d(length, 0.0)).norm() - cone.rb;
  return point.dot(n) - cone.ra;
}

double signedDistance(const SweptPolygon& polygon, const Eigen::Vector3d& p) {
  const Eigen::Vector3d d = p - polygon.origin;
  const Eigen::Vector2d q(d.dot(polygon.u), d.dot(polygon.v));
  const double h = d.dot(polygon.normal());
  double distance;
  if (insideConvex(polygon.vertices, q)) {
    distance = std::abs(h);
  } else {
    double edge = std::numeric_limits<double>::infinity();
    const size_t n = polygon.vertices.size();
    for (size_t i = 0; i < n; ++i) {
      edge = std::min(edge,
                      distanceToSegment2d(q, polygon.vertices[i], polygon.vertices[(i + 1) % n]));
    }
    distance = std::sqrt(edge * edge + h * h);
  }
  return distance - polygon.radius;
}

void bounds(const RoundCone& cone, Eigen::Vector3d* lo, Eigen::Vector3d* hi) {
  *lo = (cone.a.array() - cone.ra).min(cone.b.array() - cone.rb);
  *hi = (cone.a.array() + cone.ra).max(cone.b.array() + cone.rb);
}

void bounds(const SweptPolygon& polygon, Eigen::Vector3d* lo, Eigen::Vector3d* hi) {
  lo->setConstant(std::numeric_limits<double>::infinity());
  hi->setConstant(-std::numeric_limits<double>::infinity());
  for (size_t i = 0; i < polygon.vertices.size(); ++i) {
    const Eigen::Vector3d v = polygon.vertex(i);
    *lo = lo->cwiseMin(v);
    *hi = hi->cwiseMax(v);
  }
  lo->array() -= polygon.radius;
  hi->array() += polygon.radius;
}

RoundCone transformed(const RoundCone& cone, const Eigen::Isometry3d& transform) {
  return RoundCone{transform * cone.a, transform * cone.b, cone.ra, cone.rb};
}

SweptPolygon transformed(const SweptPolygon& polygon, const Eigen::Isometry3d& transform) {
  SweptPolygon out = polygon;
  out.origin = transform * polygon.origin;
  out.u = transform.linear() * polygon.u;
  out.v = transform.linear() * polygon.v;
  return out;
}

std::vector<Eigen::Vector2d> convexHull(std::vector<Eigen::Vector2d> points) {
  std::sort(points.begin(), points.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  if (points.size() < 3) return points;
  std::vector<Eigen::Vector2d> hull(2 * points.size());
  size_t k = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    while (k >= 2 && cross2(hull[k - 1] - hull[k - 2], points[i] - hull[k - 2]) <= 0.0) --k;
    hull[k++] = points[i];
  }
  for (size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && cross2(hull[k - 1] - hull[k - 2], points[i] - hull[k - 2]) <= 0.0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);
  return hull;
}

}  // namespace studio
}  // namespace sag_hand_tracker
