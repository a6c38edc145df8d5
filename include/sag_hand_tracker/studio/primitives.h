// Surface primitives of the synthetic studio's hand (not Gaussians: the renderer must not share the
// tracker's model) and their exact ray intersections.
//
// - RoundCone: a sphere-swept cone, the convex hull of two spheres (centres a, b, radii ra, rb).
//   With ra == rb it is a capsule, with a == b a sphere.
// - SweptPolygon: a planar convex polygon swept by a sphere of radius r (a rounded slab), the set
//   of points within r of the polygon.
//
// Intersections take a ray origin and a UNIT direction and return the first hit in front of the
// origin (t > 0) with its outward unit normal. The signed distance functions are exact and are
// used by the tests to check the intersections.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace sag_hand_tracker {
namespace studio {

struct RoundCone {
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  double ra = 0.0;
  double rb = 0.0;
};

struct SweptPolygon {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // a point of the polygon's plane
  Eigen::Vector3d u = Eigen::Vector3d::UnitX();      // orthonormal in-plane axes
  Eigen::Vector3d v = Eigen::Vector3d::UnitY();
  std::vector<Eigen::Vector2d> vertices;  // convex, counter-clockwise in (u, v) coordinates
  double radius = 0.0;

  Eigen::Vector3d normal() const { return u.cross(v); }
  Eigen::Vector3d vertex(size_t i) const {
    return origin + vertices[i].x() * u + vertices[i].y() * v;
  }
};

struct RayHit {
  double t = 0.0;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
};

// First intersection with t > t_min; false if none.
bool intersect(const RoundCone& cone, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
               RayHit* hit, double t_min = 0.0);
bool intersect(const SweptPolygon& polygon, const Eigen::Vector3d& origin,
               const Eigen::Vector3d& dir, RayHit* hit, double t_min = 0.0);

// Exact signed distance (negative inside).
double signedDistance(const RoundCone& cone, const Eigen::Vector3d& p);
double signedDistance(const SweptPolygon& polygon, const Eigen::Vector3d& p);

// Axis-aligned bounds.
void bounds(const RoundCone& cone, Eigen::Vector3d* lo, Eigen::Vector3d* hi);
void bounds(const SweptPolygon& polygon, Eigen::Vector3d* lo, Eigen::Vector3d* hi);

// Rigid transform of a primitive.
RoundCone transformed(const RoundCone& cone, const Eigen::Isometry3d& transform);
SweptPolygon transformed(const SweptPolygon& polygon, const Eigen::Isometry3d& transform);

// Convex hull of 2D points, counter-clockwise, without collinear points (Andrew's monotone chain).
std::vector<Eigen::Vector2d> convexHull(std::vector<Eigen::Vector2d> points);

}  // namespace studio
}  // namespace sag_hand_tracker
