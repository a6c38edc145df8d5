#include "sag_hand_tracker/tracker.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

namespace sag_hand_tracker {
namespace {

// Palm-frame point that the foreground centroid is taken to be (the middle of the hand).
const Eigen::Vector3d kHandCentreInPalm(0.065, 0.0, 0.0);
constexpr int kHypothesesKept = 4;

// The foreground centroid of one camera, as a ray in the root frame.
struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d direction;
};

// Orientation hypotheses: the fingers along 14 directions (axes and diagonals), each with 4 rolls
// of the palm about them.
std::vector<Eigen::Matrix3d> orientationHypotheses() {
  std::vector<Eigen::Vector3d> directions;
  for (int axis = 0; axis < 3; ++axis) {
    directions.push_back(Eigen::Vector3d::Unit(axis));
    directions.push_back(-Eigen::Vector3d::Unit(axis));
  }
  for (int sx : {-1, 1}) {
    for (int sy : {-1, 1}) {
      for (int sz : {-1, 1}) directions.push_back(Eigen::Vector3d(sx, sy, sz).normalized());
    }
  }
  std::vector<Eigen::Matrix3d> rotations;
  for (const Eigen::Vector3d& x : directions) {
    const Eigen::Vector3d helper =
        std::fabs(x.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
    const Eigen::Vector3d z0 = (helper - helper.dot(x) * x).normalized();
    for (int roll = 0; roll < 4; ++roll) {
      const Eigen::Vector3d z = Eigen::AngleAxisd(roll * M_PI / 2.0, x) * z0;
      Eigen::Matrix3d rotation;
      rotation.col(0) = x;
      rotation.col(1) = z.cross(x);
      rotation.col(2) = z;
      rotations.push_back(rotation);
    }
  }
  return rotations;
}

// Least-squares point closest to all rays.
bool triangulate(const std::vector<Ray>& rays, Eigen::Vector3d* point) {
  if (rays.size() < 2) return false;
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const Ray& ray : rays) {
    const Eigen::Matrix3d projector =
        Eigen::Matrix3d::Identity() - ray.direction * ray.direction.transpose();
    A += projector;
    b += projector * ray.origin;
  }
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(A);
  if (lu.rank() < 3) return false;
  *point = lu.solve(b);
  return point->allFinite();
}

}  // namespace

std::string toString(TrackStatus status) {
  switch (status) {
    case TrackStatus::kWaiting:
      return "waiting";
    case TrackStatus::kStarted:
      return "started";
    case TrackStatus::kTracking:
      return "tracking";
    case TrackStatus::kLost:
      return "lost";
  }
  return "unknown";
}

HandTracker::HandTracker(const HandModel& model, const TrackerParams& params)
    : model_(model), params_(params) {
  validateHandModel(model_);
}

void HandTracker::reset() {
  previous_.reset();
  current_.reset();
  lost_ = false;
  typical_similarity_ = 0.0;
}

bool HandTracker::looksLost(double similarity) const {
  return similarity < params_.lost_similarity ||
         similarity < params_.lost_ratio * typical_similarity_;
}

void HandTracker::setParams(const TrackerParams& params) { params_ = params; }

std::optional<OptimizationResult> HandTracker::startFromHypotheses(
    const PoseEnergy& energy, const std::vector<CameraObservation>& observations) const {
  // Where is the hand? Triangulate the foreground centroids of the cameras that see it.
  std::vector<Ray> rays;
  for (const CameraObservation& observation : observations) {
    const auto& gaussians = observation.sog.gaussians;
    if (static_cast<int>(gaussians.size()) < params_.min_foreground_gaussians) continue;
    Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
    double mass = 0.0;
    for (const ImageGaussian& g : gaussians) {
      const double weight = g.sigma * g.sigma;
      centroid += weight * g.mean;
      mass += weight;
    }
    centroid /= mass;
    const Eigen::Isometry3d camera_to_world = observation.camera.world_to_camera.inverse();
    const Eigen::Vector3d direction_camera =
        observation.camera.K.inverse() * Eigen::Vector3d(centroid.x(), centroid.y(), 1.0);
    rays.push_back({camera_to_world.translation(),
                    (camera_to_world.linear() * direction_camera).normalized()});
  }
  Eigen::Vector3d centre;
  if (static_cast<int>(rays.size()) < params_.min_cameras_for_start ||
      !triangulate(rays, &centre)) {
    return std::nullopt;
  }

  // Score every orientation hypothesis of an open hand there; refine the best few.
  struct Scored {
    double energy;
    Pose pose;
  };
  std::vector<Scored> scored;
  for (const Eigen::Matrix3d& rotation : orientationHypotheses()) {
    const Pose pose = neutralPose(model_, centre - rotation * kHandCentreInPalm, rotation);
    scored.push_back({energy.evaluate(pose), pose});
  }
  if (current_) scored.push_back({energy.evaluate(*current_), *current_});
  const size_t kept = std::min<size_t>(kHypothesesKept, scored.size());
  std::partial_sort(scored.begin(), scored.begin() + kept, scored.end(),
                    [](const Scored& a, const Scored& b) { return a.energy > b.energy; });

  OptimizerParams start_params = params_.optimizer;
  start_params.iterations = params_.start_iterations;
  std::optional<OptimizationResult> best;
  for (size_t i = 0; i < kept; ++i) {
    const OptimizationResult result = optimizePose(energy, scored[i].pose, start_params);
    if (!best || result.energy > best->energy) best = result;
  }
  return best;
}

FrameResult HandTracker::update(const std::vector<CameraObservation>& observations, double stamp) {
  FrameResult result;
  result.stamp = stamp;
  result.num_cameras = static_cast<int>(observations.size());

  PoseEnergy energy(model_, params_.energy);
  energy.setFrame(observations);

  std::optional<OptimizationResult> optimized;
  bool started = false;
  if (current_ && !lost_) {
    const Pose start = previous_ ? extrapolatePose(*previous_, *current_) : *current_;
    optimized = optimizePose(energy, start, params_.optimizer);
    EnergyTerms terms;
    energy.evaluate(optimized->pose, nullptr, &terms);
    if (looksLost(terms.similarity)) {
      // The track looks lost: try the start routine on this frame and keep the better one.
      const std::optional<OptimizationResult> restart = startFromHypotheses(energy, observations);
      if (restart && restart->energy > optimized->energy) {
        optimized = restart;
        started = true;
      }
    }
  } else {
    optimized = startFromHypotheses(energy, observations);
    started = optimized.has_value();
  }

  if (!optimized || !optimized->pose.allFinite()) {
    result.status = current_ ? TrackStatus::kLost : TrackStatus::kWaiting;
    lost_ = current_.has_value();
    return result;
  }

  energy.evaluate(optimized->pose, nullptr, &result.energy);
  result.has_pose = true;
  result.pose = optimized->pose;
  result.fingertips = fingertips(model_, result.pose);
  result.restarted = started && current_.has_value();
  lost_ = looksLost(result.energy.similarity);
  if (!lost_) {
    // A fresh start resets the reference; tracking frames update it slowly.
    typical_similarity_ = started ? result.energy.similarity
                                  : 0.9 * typical_similarity_ + 0.1 * result.energy.similarity;
  }
  result.status =
      lost_ ? TrackStatus::kLost : (started ? TrackStatus::kStarted : TrackStatus::kTracking);

  // A (re)start breaks the motion history: do not extrapolate across it.
  previous_ = started ? std::optional<Pose>() : current_;
  current_ = optimized->pose;
  return result;
}

}  // namespace sag_hand_tracker
