#include "sag_hand_tracker/tracking/tracker.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

namespace sag_hand_tracker {
namespace {

// Palm-frame point that the foreground centroid is taken to be (the middle of the hand).
const Eigen::Vector3d kHandCentreInPalm(0.065, 0.0, 0.0);
constexpr size_t kCoarseKept = 24;
constexpr int kCoarseIterations = 8;
constexpr size_t kHypothesesKept = 4;

// The foreground centroid of one camera, as a ray in the root frame.
struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d direction;
};

// Orientation hypotheses: the fingers along the 26 directions of a cube's faces, edges and
// corners, each with 8 rolls of the palm about them (208 orientations, <= 45 degrees apart).
std::vector<Eigen::Matrix3d> orientationHypotheses() {
  std::vector<Eigen::Vector3d> directions;
  for (int x = -1; x <= 1; ++x) {
    for (int y = -1; y <= 1; ++y) {
      for (int z = -1; z <= 1; ++z) {
        if (x != 0 || y != 0 || z != 0) directions.push_back(Eigen::Vector3d(x, y, z).normalized());
      }
    }
  }
  std::vector<Eigen::Matrix3d> rotations;
  for (const Eigen::Vector3d& x : directions) {
    const Eigen::Vector3d helper =
        std::fabs(x.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
    const Eigen::Vector3d z0 = (helper - helper.dot(x) * x).normalized();
    for (int roll = 0; roll < 8; ++roll) {
      const Eigen::Vector3d z = Eigen::AngleAxisd(roll * M_PI / 4.0, x) * z0;
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
    : model_(model), params_(params), energy_(model, params.energy) {}

void HandTracker::reset() {
  previous_.reset();
  current_.reset();
  lost_ = false;
  typical_similarity_ = 0.0;
  frames_since_start_ = 0;
}

bool HandTracker::looksLost(double similarity) const {
  return similarity < params_.lost_similarity ||
         similarity < params_.lost_ratio * typical_similarity_;
}

void HandTracker::setParams(const TrackerParams& params) {
  params_ = params;
  energy_ = PoseEnergy(model_, params_.energy);
}

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

  // Score every orientation hypothesis of an open hand there, then refine in two stages: a few
  // iterations for the best `kCoarseKept`, all `start_iterations` for the best `kHypothesesKept`
  // of those. A raw hypothesis' energy says little until its translation has settled.
  std::vector<OptimizationResult> candidates;
  for (const Eigen::Matrix3d& rotation : orientationHypotheses()) {
    OptimizationResult candidate;
    candidate.pose = neutralPose(model_, centre - rotation * kHandCentreInPalm, rotation);
    candidate.energy = energy.evaluate(candidate.pose);
    candidates.push_back(candidate);
  }
  if (current_) candidates.push_back({*current_, energy.evaluate(*current_), 1});
  auto keep_best = [&candidates](size_t count) {
    count = std::min(count, candidates.size());
    std::partial_sort(candidates.begin(), candidates.begin() + count, candidates.end(),
                      [](const OptimizationResult& a, const OptimizationResult& b) {
                        return a.energy > b.energy;
                      });
    candidates.resize(count);
  };
  OptimizerParams stage_params = params_.optimizer;
  keep_best(kCoarseKept);
  stage_params.iterations = kCoarseIterations;
  for (OptimizationResult& candidate : candidates) {
    candidate = optimizePose(energy, candidate.pose, stage_params);
  }
  keep_best(kHypothesesKept);
  stage_params.iterations = params_.start_iterations;
  for (OptimizationResult& candidate : candidates) {
    candidate = optimizePose(energy, candidate.pose, stage_params);
  }
  keep_best(1);
  return candidates.front();
}

FrameResult HandTracker::update(const std::vector<CameraObservation>& observations, double stamp) {
  FrameResult result;
  result.stamp = stamp;
  result.num_cameras = static_cast<int>(observations.size());

  PoseEnergy& energy = energy_;
  energy.setFrame(observations);

  std::optional<OptimizationResult> optimized;
  bool started = false;
  if (current_ && !lost_) {
    const Pose start = previous_ ? extrapolatePose(*previous_, *current_) : *current_;
    optimized = optimizePose(energy, start, params_.optimizer);
    EnergyTerms terms;
    energy.evaluate(optimized->pose, nullptr, &terms);
    const bool redetect =
        params_.redetect_interval > 0 && frames_since_start_ + 1 >= params_.redetect_interval;
    const bool lost = looksLost(terms.similarity);
    if (lost || redetect) {
      // Try the start routine on this frame and keep its result if it is better (clearly better
      // for a periodic re-detection, so that the track does not jitter between near-equal poses).
      const double margin = lost ? 0.0 : params_.redetect_margin;
      const std::optional<OptimizationResult> restart = startFromHypotheses(energy, observations);
      if (restart && restart->energy > optimized->energy + margin) {
        optimized = restart;
        started = true;
      }
      if (redetect) frames_since_start_ = 0;
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

  frames_since_start_ = started ? 0 : frames_since_start_ + 1;
  // A (re)start breaks the motion history: do not extrapolate across it.
  previous_ = started ? std::optional<Pose>() : current_;
  current_ = optimized->pose;
  return result;
}

}  // namespace sag_hand_tracker
