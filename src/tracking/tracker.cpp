#include "sag_hand_tracker/tracking/tracker.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <numeric>
#include <optional>
#include <utility>

#include "sag_hand_tracker/energy/silhouette.h"
#include "sag_hand_tracker/util/parallel_for.h"
#include "sag_hand_tracker/util/thread_priority.h"

namespace sag_hand_tracker {
namespace {

// Palm-frame point that the foreground centroid is taken to be (the middle of the hand).
const Eigen::Vector3d kHandCentreInPalm(0.065, 0.0, 0.0);

Eigen::Vector3d handCentre(const Pose& pose) {
  return pose.translation + pose.rotation * kHandCentreInPalm;
}

// The root translation that puts the hand centre at `centre` with the root turned to `rotation`.
Eigen::Vector3d rootAt(const Eigen::Vector3d& centre, const Eigen::Matrix3d& rotation) {
  return centre - rotation * kHandCentreInPalm;
}

// The angle (radians) of the rotation between two orientations.
double rotationAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::Quaterniond(a).angularDistance(Eigen::Quaterniond(b));
}
constexpr size_t kCoarseKept = 24;
constexpr int kCoarseIterations = 8;
constexpr size_t kRedetectionKept = 4;

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

// Pixel of a root-frame point in a camera; empty behind it.
std::optional<Eigen::Vector2d> projectPoint(const Camera& camera, const Eigen::Vector3d& point) {
  const Eigen::Vector3d p = camera.world_to_camera * point;
  if (!(p.z() > 1e-6)) return std::nullopt;
  const Eigen::Vector3d h = camera.K * (p / p.z());
  return Eigen::Vector2d(h.x(), h.y());
}

// The foreground centroid of one camera's image SoG (area-weighted), if it sees enough.
std::optional<Eigen::Vector2d> foregroundCentroid(const ImageSoG& sog, int min_gaussians) {
  if (static_cast<int>(sog.gaussians.size()) < std::max(min_gaussians, 1)) return std::nullopt;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  double mass = 0.0;
  for (const ImageGaussian& g : sog.gaussians) {
    const double weight = g.sigma * g.sigma;
    centroid += weight * g.mean;
    mass += weight;
  }
  if (!(mass > 0.0)) return std::nullopt;
  return Eigen::Vector2d(centroid / mass);
}

double axisAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0));
}

}  // namespace

double knuckleAxisAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return axisAngle(a.col(0), b.col(0));
}

double palmNormalAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return axisAngle(a.col(2), b.col(2));
}

bool isFlip(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return knuckleAxisAngle(a, b) > M_PI / 2 || palmNormalAngle(a, b) > M_PI / 2;
}

void preferBackFacingCameras(const std::vector<CameraObservation>& observations, double margin,
                             std::vector<OptimizationResult>* candidates) {
  if (!(margin > 0.0) || candidates->size() < 2) return;
  auto facing = [&observations](const Pose& pose) {
    const Eigen::Vector3d centre = handCentre(pose);
    double sum = 0.0;
    for (const CameraObservation& observation : observations) {
      const Eigen::Vector3d camera_centre =
          observation.camera.world_to_camera.inverse().translation();
      sum += pose.rotation.col(2).dot((camera_centre - centre).normalized());
    }
    return sum;
  };
  const double best_energy = candidates->front().energy;
  size_t chosen = 0;
  double chosen_facing = facing(candidates->front().pose);
  for (size_t i = 1; i < candidates->size(); ++i) {
    const OptimizationResult& candidate = (*candidates)[i];
    if (candidate.energy < best_energy - margin) break;  // sorted best first
    // Only the roll is in question: candidates of about the best one's palm side add nothing.
    if (palmNormalAngle(candidate.pose.rotation, candidates->front().pose.rotation) <= M_PI / 2) {
      continue;
    }
    const double f = facing(candidate.pose);
    if (f > chosen_facing) {
      chosen = i;
      chosen_facing = f;
    }
  }
  std::rotate(candidates->begin(), candidates->begin() + chosen, candidates->begin() + chosen + 1);
}

std::optional<double> forearmVote(const Pose& pose,
                                  const std::vector<CameraObservation>& observations,
                                  int min_arm_cells) {
  if (min_arm_cells <= 0) return std::nullopt;
  const Eigen::Vector3d wrist = pose.translation;
  const Eigen::Vector3d knuckle = pose.translation + pose.rotation * (2.0 * kHandCentreInPalm);
  double votes = 0.0, weights = 0.0;
  for (const CameraObservation& observation : observations) {
    if (observation.sog.arm_cells < min_arm_cells) continue;
    const std::optional<Eigen::Vector2d> hand = foregroundCentroid(observation.sog, 1);
    const std::optional<Eigen::Vector2d> w = projectPoint(observation.camera, wrist);
    const std::optional<Eigen::Vector2d> k = projectPoint(observation.camera, knuckle);
    if (!hand || !w || !k) continue;
    const Eigen::Vector2d image_direction = *hand - observation.sog.arm_centroid;
    const Eigen::Vector2d model_direction = *k - *w;
    // A hand pointing at the camera, or an arm centroid on the hand's, says little.
    constexpr double kFullWeightPixels = 20.0;
    if (image_direction.norm() < 2.0 || model_direction.norm() < 1e-9) continue;
    const double weight = std::min(1.0, model_direction.norm() / kFullWeightPixels) *
                          std::min(1.0, image_direction.norm() / kFullWeightPixels);
    votes += weight * model_direction.normalized().dot(image_direction.normalized());
    weights += weight;
  }
  if (weights < 0.5) return std::nullopt;
  return votes / weights;
}

Eigen::Matrix3d boundedRotation(const Eigen::Matrix3d& reference, const Eigen::Matrix3d& rotation,
                                double max_angle) {
  const double angle = rotationAngle(reference, rotation);
  if (!(max_angle > 0.0) || angle <= max_angle) return rotation;
  const Eigen::Quaterniond from(reference), to(rotation);
  return from.slerp(max_angle / angle, to).normalized().toRotationMatrix();
}

RedetectionChoice chooseRedetection(const HandModel& model, const OptimizationResult& tracked,
                                    const std::vector<OptimizationResult>& candidates,
                                    const TrackerParams& params, bool carrying,
                                    const std::vector<Eigen::Matrix3d>& recent) {
  RedetectionChoice choice;
  const double tracked_flexion = meanFingerFlexion(model, tracked.pose);
  // The track's recent orientations of which it is itself a flip (where it was before it turned
  // over): found once, at the first candidate that is a flip of the track.
  std::optional<std::vector<const Eigen::Matrix3d*>> turned_from;
  for (size_t i = 0; i < candidates.size(); ++i) {
    const OptimizationResult& candidate = candidates[i];
    bool flip = isFlip(candidate.pose.rotation, tracked.pose.rotation);
    // A flip of the track that returns to where the track was before it turned over.
    bool returning = false;
    if (flip) {
      if (!turned_from) {
        turned_from.emplace();
        for (const Eigen::Matrix3d& before : recent) {
          if (isFlip(tracked.pose.rotation, before)) turned_from->push_back(&before);
        }
      }
      for (const Eigen::Matrix3d* before : *turned_from) {
        if (!isFlip(candidate.pose.rotation, *before)) {
          returning = true;
          break;
        }
      }
    }
    if (returning) flip = false;
    // A large turn that is no flip, or a fist opened or closed, still needs the flip's margin.
    const bool turned =
        !returning && params.redetect_turn_angle > 0.0 &&
        rotationAngle(candidate.pose.rotation, tracked.pose.rotation) > params.redetect_turn_angle;
    const bool recurled = !returning && params.redetect_flexion_change > 0.0 &&
                          std::abs(meanFingerFlexion(model, candidate.pose) - tracked_flexion) >
                              params.redetect_flexion_change;
    const double margin = turned || recurled ? std::max(params.flip_margin, params.redetect_margin)
                                             : params.redetect_margin;
    if (!flip && choice.adopt < 0 && candidate.energy > tracked.energy + margin) {
      choice.adopt = static_cast<int>(i);
    }
    if (flip && (choice.carry < 0 || candidate.energy > candidates[choice.carry].energy)) {
      choice.carry = static_cast<int>(i);
    }
  }
  // The best flip is carried when it beats what the track will be after this frame (the adopted
  // candidate, if any) by flip_margin. An adoption replaces the alternative being carried, so a
  // flip may then be carried anew: a better pose of the wrong palm side must not hide a far
  // better flip (the studio's rolled-over `fastturn` and `random` tracks adopted same-side poses
  // 0.03-0.1 below a flip to the true side, and the flip was never carried).
  const double reference = choice.adopt >= 0 ? candidates[choice.adopt].energy : tracked.energy;
  if (choice.carry >= 0 && (params.flip_confirm_frames <= 0 || (carrying && choice.adopt < 0) ||
                            !(candidates[choice.carry].energy > reference + params.flip_margin))) {
    choice.carry = -1;
  }
  return choice;
}

AlternativeVerdict judgeAlternative(double track_energy, double challenger_energy,
                                    const TrackerParams& params, int* wins, int* frames) {
  if (!(challenger_energy > track_energy + params.flip_keep_margin)) {
    return AlternativeVerdict::kDrop;
  }
  ++*frames;
  if (challenger_energy > track_energy + params.flip_margin &&
      ++*wins >= params.flip_confirm_frames) {
    return AlternativeVerdict::kConfirm;
  }
  if (params.flip_max_frames > 0 && *frames >= params.flip_max_frames) {
    return AlternativeVerdict::kDrop;
  }
  return AlternativeVerdict::kKeep;
}

bool forearmMayBeBare(const HandModel& model, const PoseEnergy& energy, const Pose& pose,
                      double min_gain) {
  // The forearm straight on from the pose's palm, and from the same hand reversed about its centre
  // (fingers where its wrist is, open): a reversed start is what the second search corrects, and
  // at a reversed pose a bare forearm gains little. A sleeved forearm gains about 0.01 at the
  // pose but up to 0.1 reversed, where it lies over the real fingers
  // (TrackerParams::forearm_start_gain).
  const Eigen::Matrix3d reversed =
      pose.rotation * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Pose twin = neutralPose(model, rootAt(handCentre(pose), reversed), reversed);
  for (const Pose* candidate : {&pose, &twin}) {
    const double gain = energy.evaluateWithForearm(*candidate, -candidate->rotation.col(0)) -
                        energy.evaluate(*candidate);
    if (gain > min_gain) return true;
  }
  return false;
}

bool isPlausiblePose(const Pose& pose, const std::vector<CameraObservation>& observations,
                     double min_camera_depth, int min_cameras) {
  if (!pose.allFinite()) return false;
  const Eigen::Vector3d centre = handCentre(pose);
  int inside = 0;
  for (const CameraObservation& observation : observations) {
    const Camera& camera = observation.camera;
    const Eigen::Vector3d p = camera.world_to_camera * centre;
    if (p.z() < min_camera_depth) return false;
    const Eigen::Vector3d h = camera.K * (p / p.z());
    if (h.x() >= 0.0 && h.y() >= 0.0 && h.x() < camera.width && h.y() < camera.height) ++inside;
  }
  return inside >= std::min(min_cameras, static_cast<int>(observations.size()));
}

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

namespace {

bool samePose(const std::optional<Pose>& a, const std::optional<Pose>& b) {
  if (a.has_value() != b.has_value()) return false;
  return !a ||
         (a->translation == b->translation && a->rotation == b->rotation && a->joints == b->joints);
}

bool sameVector(const std::optional<Eigen::Vector3d>& a, const std::optional<Eigen::Vector3d>& b) {
  return a.has_value() == b.has_value() && (!a || *a == *b);
}

}  // namespace

bool HandTracker::sameTrackState(const TrackState& a, const TrackState& b) {
  const bool same_alternative =
      a.alternative.has_value() == b.alternative.has_value() &&
      (!a.alternative || (samePose(a.alternative->previous, b.alternative->previous) &&
                          samePose(a.alternative->current, b.alternative->current) &&
                          a.alternative->wins == b.alternative->wins &&
                          a.alternative->frames == b.alternative->frames));
  return samePose(a.previous, b.previous) && samePose(a.current, b.current) && a.lost == b.lost &&
         a.typical_similarity == b.typical_similarity &&
         a.frames_since_start == b.frames_since_start &&
         a.frames_since_redetection == b.frames_since_redetection && same_alternative &&
         a.arm_reversed_streak == b.arm_reversed_streak && a.forearm_present == b.forearm_present &&
         sameVector(a.forearm, b.forearm) &&
         sameVector(a.alternative_forearm, b.alternative_forearm) &&
         a.recent_rotations == b.recent_rotations && a.tracked_streak == b.tracked_streak &&
         a.colour_samples == b.colour_samples && a.colour_statistics == b.colour_statistics &&
         a.colours == b.colours && a.size_factor == b.size_factor &&
         a.frames_to_size_trial == b.frames_to_size_trial;
}

// A set the frame path has stepped, for the worker.
struct HandTracker::HandedFrame {
  std::vector<CameraObservation> observations;
  double stamp = 0.0;
  std::int64_t frame_id = 0;
  bool reported_pose = false;          // the frame path's own result for it had a pose
  bool redetection_requested = false;  // requestRedetection before the frame path's update
};

// The worker of asynchronous_search: a synchronous tracker on its own thread that tracks the sets
// handed to it, in order, and then waits for more, until the frame path adopts it (`finish`, only
// when it is idle) or drops it (`cancelled`).
namespace {

// A worker's result is a late result when the frame path had reported its set without a pose.
bool isLateResult(bool reported_pose, const FrameResult& result) {
  return !reported_pose && result.has_pose;
}

}  // namespace

struct HandTracker::Worker {
  std::unique_ptr<HandTracker> tracker;
  mutable std::mutex mutex;
  mutable std::condition_variable changed;
  std::deque<HandedFrame> queue;                      // handed, not tracked yet
  std::vector<std::pair<bool, FrameResult>> results;  // (reported_pose, the worker's result)
  bool busy = false;
  bool finish = false;
  bool cancelled = false;
  // The frame path's state after the first set; when the worker's equals it (a re-detection that
  // changed nothing), the rest would only repeat the frame path's own steps: it stops there.
  std::optional<TrackState> frame_path_after_first;
  bool unchanged = false;
  std::exception_ptr error;  // what ended it early; rethrown by the update that adopts it
  std::future<void> done;
  std::function<void()> on_late_result;  // HandTracker::setLateResultCallback

  bool idle() const { return (queue.empty() && !busy) || error; }  // with `mutex` held

  // Dropped (reset, another model, the tracker's end): stops after the set it is tracking.
  ~Worker() {
    {
      std::lock_guard<std::mutex> lock(mutex);
      cancelled = true;
      changed.notify_all();
    }
    if (done.valid()) done.wait();
  }

  void run(const std::shared_future<void>& gate, int niceness) {
    lowerCurrentThreadPriority(niceness);  // best effort: a worker at full priority still works
    if (gate.valid()) gate.wait();
    std::unique_lock<std::mutex> lock(mutex);
    for (;;) {
      changed.wait(lock, [this] { return cancelled || finish || !queue.empty(); });
      if (cancelled || queue.empty()) return;
      HandedFrame frame = std::move(queue.front());
      queue.pop_front();
      busy = true;
      lock.unlock();
      std::optional<FrameResult> result;
      std::exception_ptr failure;
      try {
        if (frame.redetection_requested) tracker->requestRedetection();
        result = tracker->update(frame.observations, frame.stamp, frame.frame_id);
      } catch (...) {
        failure = std::current_exception();
      }
      const bool same = !failure && frame_path_after_first &&
                        sameTrackState(tracker->trackState(), *frame_path_after_first);
      frame_path_after_first.reset();
      lock.lock();
      if (failure) {
        busy = false;
        error = failure;
        changed.notify_all();
        return;
      }
      const bool late = isLateResult(frame.reported_pose, *result);
      results.emplace_back(frame.reported_pose, std::move(*result));
      // Only while no set waits for it (every set handed since had its pose on the frame path).
      if (same && std::all_of(queue.begin(), queue.end(),
                              [](const HandedFrame& next) { return next.reported_pose; })) {
        unchanged = true;
        queue.clear();
      }
      if (late && on_late_result) {
        lock.unlock();
        on_late_result();
        lock.lock();
      }
      // Idle only after the signal, so that waitForSearch returns with every set signalled.
      busy = false;
      changed.notify_all();
    }
  }
};

HandTracker::HandTracker(const HandModel& model, const TrackerParams& params)
    : model_(model),
      base_model_(model),
      params_(params),
      energy_(model, params.energy),
      finger_joints_(longFingerJoints(model)),
      thumb_joints_(thumbJoints(model)),
      start_colours_(modelColours(model)) {}

HandTracker::~HandTracker() = default;
HandTracker::HandTracker(HandTracker&&) noexcept = default;
HandTracker& HandTracker::operator=(HandTracker&&) noexcept = default;

void HandTracker::reset() {
  stopWorker();
  late_results_.clear();
  redetection_requested_ = false;
  setTrackState(TrackState());
}

void HandTracker::adoptTrack(const HandTracker& other) {
  // `other` was made with this tracker's model at its size (a still scene's trial start).
  TrackState state = other.trackState();
  state.size_factor *= size_factor_;
  reset();
  setTrackState(state);
}

HandTracker::TrackState HandTracker::trackState() const {
  TrackState state;
  state.previous = previous_;
  state.current = current_;
  state.lost = lost_;
  state.typical_similarity = typical_similarity_;
  state.frames_since_start = frames_since_start_;
  state.frames_since_redetection = frames_since_redetection_;
  state.alternative = alternative_;
  state.arm_reversed_streak = arm_reversed_streak_;
  state.forearm_present = forearm_present_;
  state.forearm = forearm_;
  state.alternative_forearm = alternative_forearm_;
  state.recent_rotations = recent_rotations_;
  state.tracked_streak = tracked_streak_;
  state.colour_samples = colour_samples_;
  state.colour_statistics = colour_statistics_;
  state.colours = modelColours(model_);
  state.size_factor = size_factor_;
  state.frames_to_size_trial = frames_to_size_trial_;
  return state;
}

void HandTracker::setTrackState(const TrackState& state) {
  previous_ = state.previous;
  current_ = state.current;
  lost_ = state.lost;
  typical_similarity_ = state.typical_similarity;
  frames_since_start_ = state.frames_since_start;
  frames_since_redetection_ = state.frames_since_redetection;
  alternative_ = state.alternative;
  arm_reversed_streak_ = state.arm_reversed_streak;
  forearm_present_ = state.forearm_present;
  forearm_ = state.forearm;
  alternative_forearm_ = state.alternative_forearm;
  recent_rotations_ = state.recent_rotations;
  tracked_streak_ = state.tracked_streak;
  colour_samples_ = state.colour_samples;
  colour_statistics_ = state.colour_statistics;
  if (state.size_factor != size_factor_) setSize(state.size_factor);
  frames_to_size_trial_ = state.frames_to_size_trial;
  setColours(state.colours);
}

void HandTracker::setColours(const std::vector<Hsv>& colours) {
  const std::vector<Hsv>& wanted = colours.empty() ? start_colours_ : colours;
  if (wanted == modelColours(model_)) return;
  for (size_t p = 0; p < model_.gaussians.size() && p < wanted.size(); ++p) {
    model_.gaussians[p].hsv = wanted[p];
  }
  energy_ = PoseEnergy(model_, params_.energy);
}

void HandTracker::forgetLearntColours() {
  colour_statistics_ = GaussianColourStatistics();
  colour_samples_ = 0;
  tracked_streak_ = 0;
  setColours({});
}

void HandTracker::adaptColours(const FrameResult& result,
                               const std::vector<CameraObservation>& observations) {
  const ColourAdaptationParams& adaptation = params_.colour_adaptation;
  if (!adaptation.enabled || model_.colours_fitted) return;
  if (result.status != TrackStatus::kTracking || result.flipped || alternative_) {
    tracked_streak_ = 0;
    return;
  }
  if (++tracked_streak_ <= adaptation.min_tracked_frames ||
      result.energy.similarity < adaptation.min_similarity_ratio * typical_similarity_) {
    return;
  }
  if (colour_statistics_.size() != model_.gaussians.size()) {
    colour_statistics_ = GaussianColourStatistics(model_.gaussians.size());
  }
  if (adaptation.memory > 1.0) colour_statistics_.scale(1.0 - 1.0 / adaptation.memory);
  colour_statistics_.add(model_, result.pose, observations);
  if (++colour_samples_ < adaptation.update_interval) return;
  colour_samples_ = 0;
  setColours(
      adaptedColours(model_, start_colours_, colour_statistics_, adaptation.min_weight_share));
}

bool HandTracker::looksLost(double similarity) const {
  return similarity < params_.lost_similarity ||
         similarity < params_.lost_ratio * typical_similarity_;
}

void HandTracker::setModel(const HandModel& model) {
  stopWorker();
  model_ = model;
  base_model_ = model;
  energy_ = PoseEnergy(model_, params_.energy);
  finger_joints_ = longFingerJoints(model_);
  thumb_joints_ = thumbJoints(model_);
  start_colours_ = modelColours(model_);
  forgetLearntColours();
  size_factor_ = 1.0;
  frames_to_size_trial_ = 0;
  if (current_) clampToLimits(model_, &*current_);
  if (previous_) clampToLimits(model_, &*previous_);
  alternative_.reset();
  forearm_.reset();
  alternative_forearm_.reset();
  typical_similarity_ = 0.0;
}

void HandTracker::setParams(const TrackerParams& params) {
  params_ = params;
  energy_ = PoseEnergy(model_, params_.energy);
  if (!params_.colour_adaptation.enabled) forgetLearntColours();
}

namespace {

bool armCallsReversed(const TrackerParams& params, const Pose& pose,
                      const std::vector<CameraObservation>& observations) {
  const std::optional<double> vote = forearmVote(pose, observations, params.min_arm_cells);
  return vote && *vote < -params.arm_vote_threshold;
}

bool plausibleFor(const TrackerParams& params, const Pose& pose,
                  const std::vector<CameraObservation>& observations) {
  return isPlausiblePose(pose, observations, params.min_camera_depth, params.min_cameras_for_start);
}

// The candidates' final order, the same for a synchronous search and for an asynchronous one
// collected on a later frame: the ones the honesty rules and the forearm refuse are dropped, the
// rest sorted best first (std::sort, not std::stable_sort: the latter's temporary buffer ignores
// the alignment that the Eigen members of OptimizationResult need with -march=native, and
// crashes), and the start prior decides near ties between the palm sides.
void rankCandidates(const TrackerParams& params, const std::vector<CameraObservation>& observations,
                    std::vector<OptimizationResult>* candidates) {
  candidates->erase(std::remove_if(candidates->begin(), candidates->end(),
                                   [&](const OptimizationResult& candidate) {
                                     return !plausibleFor(params, candidate.pose, observations) ||
                                            armCallsReversed(params, candidate.pose, observations);
                                   }),
                    candidates->end());
  std::sort(
      candidates->begin(), candidates->end(),
      [](const OptimizationResult& a, const OptimizationResult& b) { return a.energy > b.energy; });
  preferBackFacingCameras(observations, params.start_facing_margin, candidates);
}

}  // namespace

bool HandTracker::armSaysReversed(const Pose& pose,
                                  const std::vector<CameraObservation>& observations) const {
  // A bare forearm in the energy: the sleeve is far up the arm (see searchWithForearm).
  if (forearm_present_) return false;
  return armCallsReversed(params_, pose, observations);
}

bool HandTracker::plausible(const Pose& pose,
                            const std::vector<CameraObservation>& observations) const {
  return plausibleFor(params_, pose, observations);
}

std::optional<std::vector<OptimizationResult>> HandTracker::hypothesisSearch(
    const PoseEnergy& energy, const std::vector<CameraObservation>& observations,
    const TrackerParams& search_params) {
  if (!search_params.asynchronous_search) {
    return startFromHypotheses(model_, search_params, energy, observations, current_);
  }
  // A worker takes this set over after the step (update); none while one is still running.
  if (!worker_) search_wanted_ = true;
  return std::nullopt;
}

Pose HandTracker::predictedPose(const std::optional<Pose>& previous, const Pose& current) const {
  if (!previous) return current;
  Pose predicted = extrapolatePose(*previous, current);
  predicted.rotation =
      boundedRotation(current.rotation, predicted.rotation, params_.max_rotation_per_frame);
  return predicted;
}

void HandTracker::boundRotation(const PoseEnergy& energy, const Pose& current,
                                const Pose& predicted, OptimizationResult* result) const {
  Eigen::Matrix3d bounded = boundedRotation(predicted.rotation, result->pose.rotation,
                                            params_.max_rotation_change_per_frame);
  bounded = boundedRotation(current.rotation, bounded, params_.max_rotation_per_frame);
  if (bounded == result->pose.rotation) return;
  result->pose.rotation = bounded;
  result->energy = energy.evaluate(result->pose);
}

std::vector<OptimizationResult> HandTracker::startFromHypotheses(
    const HandModel& model, const TrackerParams& params, const PoseEnergy& energy,
    const std::vector<CameraObservation>& observations, const std::optional<Pose>& current) {
  // Where is the hand? Triangulate the foreground centroids of the cameras that see it.
  std::vector<Ray> rays;
  std::vector<const Camera*> ray_cameras;
  for (const CameraObservation& observation : observations) {
    const std::optional<Eigen::Vector2d> centroid =
        foregroundCentroid(observation.sog, params.min_foreground_gaussians);
    if (!centroid) continue;
    rays.push_back(pixelRay(observation.camera, *centroid));
    ray_cameras.push_back(&observation.camera);
  }
  Eigen::Vector3d centre;
  if (static_cast<int>(rays.size()) < params.min_cameras_for_start || !triangulate(rays, &centre)) {
    return {};
  }
  // Honesty: never propose a hand behind a camera that sees it.
  for (const Camera* camera : ray_cameras) {
    if ((camera->world_to_camera * centre).z() < params.min_camera_depth) return {};
  }

  // Score every orientation hypothesis of an open hand there, then refine in two stages: a few
  // iterations for the best `kCoarseKept`, all `start_iterations` for the best
  // `TrackerParams::start_kept` (`kRedetectionKept` with a pose) of those. A raw hypothesis' energy
  // says little until its translation has settled. The forearm cue removes the hypotheses whose
  // wrist points away from the arm before scoring.
  std::vector<OptimizationResult> candidates;
  for (const Eigen::Matrix3d& rotation : orientationHypotheses()) {
    OptimizationResult candidate;
    candidate.pose = neutralPose(model, rootAt(centre, rotation), rotation);
    if (armCallsReversed(params, candidate.pose, observations)) continue;
    candidates.push_back(candidate);
  }
  if (current) candidates.push_back({*current, 0.0, 1});
  parallelFor(static_cast<int>(candidates.size()), params.search_threads,
              [&](int i) { candidates[i].energy = energy.evaluate(candidates[i].pose); });
  // Each candidate refined on its own; one thread or several give the same candidates.
  auto refine_all = [&](const OptimizerParams& stage) {
    parallelFor(static_cast<int>(candidates.size()), params.search_threads,
                [&](int i) { candidates[i] = optimizePose(energy, candidates[i].pose, stage); });
  };
  auto keep_best = [&candidates](size_t count) {
    count = std::min(count, candidates.size());
    std::partial_sort(candidates.begin(), candidates.begin() + count, candidates.end(),
                      [](const OptimizationResult& a, const OptimizationResult& b) {
                        return a.energy > b.energy;
                      });
    candidates.resize(count);
  };
  OptimizerParams stage_params = params.optimizer;
  // With a pose among the candidates fewer do (TrackerParams::redetect_coarse_kept).
  keep_best(current ? static_cast<size_t>(std::max(1, params.redetect_coarse_kept)) : kCoarseKept);
  stage_params.iterations = kCoarseIterations;
  refine_all(stage_params);
  keep_best(current ? kRedetectionKept : static_cast<size_t>(std::max(1, params.start_kept)));
  // The rolled-over twin of the best candidate goes into the last stage as well: on hands unlike
  // the model the coarse stage often keeps only one palm side, and the start prior
  // (start_facing_margin) can only choose between sides that were both refined.
  if (!candidates.empty() && params.start_facing_margin > 0.0) {
    const Pose& best = candidates.front().pose;
    const Eigen::Matrix3d rolled =
        best.rotation * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
    OptimizationResult twin;
    twin.pose = neutralPose(model, rootAt(handCentre(best), rolled), rolled);
    twin.energy = energy.evaluate(twin.pose);
    candidates.push_back(twin);
  }
  stage_params.iterations = params.start_iterations;
  const int race = params.redetect_race_iterations;
  if (current && race > 0 && race < stage_params.iterations) {
    // A search with a pose: the last stage races (TrackerParams::redetect_race_iterations).
    std::vector<PoseAscent> ascents;
    ascents.reserve(candidates.size());
    for (const OptimizationResult& candidate : candidates) {
      ascents.emplace_back(energy, candidate.pose, stage_params);
    }
    const int count = static_cast<int>(ascents.size());
    parallelFor(count, params.search_threads, [&](int i) { ascents[i].iterate(race); });
    std::vector<int> order(ascents.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&ascents](int a, int b) {
      return ascents[a].bestEnergy() > ascents[b].bestEnergy();
    });
    order.resize(std::min<size_t>(order.size(), std::max(1, params.redetect_race_kept)));
    parallelFor(static_cast<int>(order.size()), params.search_threads,
                [&](int k) { ascents[order[k]].iterate(stage_params.iterations - race); });
    for (int i = 0; i < count; ++i) candidates[i] = ascents[i].finish();
  } else {
    refine_all(stage_params);
  }
  rankCandidates(params, observations, &candidates);
  return candidates;
}

FrameResult HandTracker::update(const std::vector<CameraObservation>& observations, double stamp,
                                std::int64_t frame_id) {
  late_results_.clear();
  if (retired_ && retired_->done.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
    retired_.reset();
  }
  if (worker_) {
    bool idle = false;
    {
      std::lock_guard<std::mutex> lock(worker_->mutex);
      idle = worker_->idle();
    }
    collectWorker(idle);
  }
  // The state before this set: where a worker starts when this set asks for a search.
  const TrackState before = worker_ ? TrackState() : trackState();
  search_wanted_ = false;
  const bool requested = redetection_requested_;
  FrameResult result = step(observations, stamp);
  redetection_requested_ = false;
  result.frame_id = frame_id;
  HandedFrame frame{observations, stamp, frame_id, result.has_pose, requested};
  if (worker_) {
    handToWorker(std::move(frame));
  } else if (search_wanted_) {
    // Without a pose for this set the sets wait for the worker: it keeps the frame path's priority.
    const int niceness = frame.reported_pose ? params_.worker_niceness : 0;
    startWorker(before, std::move(frame), niceness);
  }
  return result;
}

void HandTracker::startWorker(const TrackState& state, HandedFrame frame, int niceness) {
  TrackerParams synchronous = params_;
  synchronous.asynchronous_search = false;
  auto worker = std::make_unique<Worker>();
  // From the model at size 1: the state sets the size (and the colours) it had.
  worker->tracker = std::make_unique<HandTracker>(base_model_, synchronous);
  worker->tracker->start_colours_ = start_colours_;
  worker->tracker->setTrackState(state);
  worker->frame_path_after_first = trackState();  // called after the frame path's step
  worker->queue.push_back(std::move(frame));
  if (params_.catch_up_seconds > 0.0) worker->on_late_result = late_result_callback_;
  Worker* running = worker.get();
  worker->done = std::async(std::launch::async, [running, gate = search_gate_, niceness]() {
    running->run(gate, niceness);
  });
  worker_ = std::move(worker);
}

void HandTracker::handToWorker(HandedFrame frame) {
  std::lock_guard<std::mutex> lock(worker_->mutex);
  if (worker_->unchanged) return;  // the frame path's own state is the synchronous tracker's
  std::deque<HandedFrame>& queue = worker_->queue;
  queue.push_back(std::move(frame));
  // Beyond the bounds the oldest are skipped; they stay as they were reported.
  const double window = std::max(params_.catch_up_seconds, 0.0);
  while (queue.size() > 1 && (static_cast<int>(queue.size()) > kMaxCatchUpFrames ||
                              queue.back().stamp - queue.front().stamp > window)) {
    queue.pop_front();
  }
  worker_->changed.notify_all();
}

void HandTracker::collectWorker(bool adopt) {
  std::vector<std::pair<bool, FrameResult>> results;
  std::exception_ptr error;
  TrackState adopted;
  bool unchanged = false;
  {
    std::lock_guard<std::mutex> lock(worker_->mutex);
    results.swap(worker_->results);
    if (adopt) {
      // Idle: it touches its tracker no more, so its state is read here, without waiting for its
      // thread (at a lower priority it may take a while to be scheduled and end).
      error = worker_->error;
      unchanged = worker_->unchanged;
      if (!error && !unchanged) adopted = worker_->tracker->trackState();
      worker_->finish = true;
      worker_->changed.notify_all();
    }
  }
  for (auto& [reported_pose, result] : results) {
    if (!isLateResult(reported_pose, result) || !(params_.catch_up_seconds > 0.0)) continue;
    result.late = true;
    late_results_.push_back(std::move(result));
  }
  if (!adopt) return;
  // Its thread ends by itself; it is joined once it has (or by the next adoption, reset, end).
  retired_ = std::move(worker_);
  if (error) std::rethrow_exception(error);
  if (!unchanged) setTrackState(adopted);
}

void HandTracker::stopWorker() {
  worker_.reset();
  retired_.reset();
}

int HandTracker::keptFrames() const {
  if (!worker_) return 0;
  std::lock_guard<std::mutex> lock(worker_->mutex);
  return static_cast<int>(worker_->queue.size());
}

std::vector<FrameResult> HandTracker::takeReadyLateResults() {
  // late_results_ is empty here but for those of the last update that were not taken: they go
  // first, as they are older.
  if (worker_) collectWorker(/*adopt=*/false);
  return takeLateResults();
}

std::vector<FrameResult> HandTracker::takeLateResults() {
  std::vector<FrameResult> results;
  results.swap(late_results_);
  return results;
}

void HandTracker::waitForSearch() const {
  if (!worker_) return;
  std::unique_lock<std::mutex> lock(worker_->mutex);
  worker_->changed.wait(lock, [this] { return worker_->idle(); });
}

void HandTracker::updateForearmPresence(PoseEnergy& energy, const Pose& pose,
                                        const std::optional<Eigen::Vector3d>& direction,
                                        double energy_now) {
  if (params_.energy.forearm_gaussians <= 0) return;
  // The same pose with and without the forearm (along its direction, or straight on from the
  // palm while it is absent); the priors cancel, so the difference is the similarity it adds.
  const Eigen::Vector3d along = direction ? *direction : Eigen::Vector3d(-pose.rotation.col(0));
  double with_arm = energy_now, without_arm = energy_now;
  if (energy.forearmPresent()) {
    energy.setForearmPresent(false);
    without_arm = energy.evaluate(pose);
    energy.setForearmPresent(true);
  } else {
    with_arm = energy.evaluateWithForearm(pose, along);
  }
  // Hysteresis: once present, it stays while it adds half the gain that switched it on.
  const double threshold =
      forearm_present_ ? 0.5 * params_.forearm_min_gain : params_.forearm_min_gain;
  forearm_present_ = with_arm - without_arm > threshold;
}

std::optional<std::vector<OptimizationResult>> HandTracker::searchWithForearm(
    PoseEnergy& energy, const std::vector<CameraObservation>& observations) {
  // The hypotheses have the forearm straight on from the palm.
  energy.setForearmDirection(std::nullopt);
  // With a bare forearm in the energy the sleeve (TrackerParams::min_arm_cells) is far up the
  // arm, near the elbow, and its centroid says nothing about which end of a flexed hand is the
  // wrist: on wristflex it called the true pose reversed, the track was declared lost and the
  // restart could only take reversed candidates (all hands: 37.8 mm, 7.6 % reversed with the
  // cue, 14.0 mm, 0 % without). The energy's forearm tells the ends apart instead.
  TrackerParams search_params = params_;
  if (forearm_present_) search_params.min_arm_cells = 0;
  return hypothesisSearch(energy, observations, search_params);
}

void HandTracker::startWithForearmIfItIsBare(PoseEnergy& energy,
                                             const std::vector<CameraObservation>& observations,
                                             std::vector<OptimizationResult>* candidates) {
  // Only a synchronous search can be repeated on this frame.
  if (params_.energy.forearm_gaussians <= 0 || params_.asynchronous_search) return;
  // The second search doubled every start's time (in the live graph, the sets that wait for it);
  // it is skipped when a cheap test says that its candidates would be discarded anyway.
  // A start that explains the foreground poorly searches again whatever the test says: the arm it
  // left out may be why (TrackerParams::forearm_start_weak_energy).
  if (!candidates->empty() && candidates->front().energy >= params_.forearm_start_weak_energy &&
      !forearmMayBeBare(model_, energy, candidates->front().pose, params_.forearm_start_gain)) {
    return;
  }
  forearm_present_ = true;
  energy.setForearmPresent(true);
  std::optional<std::vector<OptimizationResult>> with_forearm =
      searchWithForearm(energy, observations);
  bool bare = false;
  if (with_forearm && !with_forearm->empty()) {
    const OptimizationResult& best = with_forearm->front();
    energy.setForearmPresent(false);
    const double hand_only = energy.evaluate(best.pose);
    energy.setForearmPresent(true);
    bare = best.energy - hand_only > params_.forearm_min_gain;
  }
  if (bare) {
    *candidates = std::move(*with_forearm);
  } else {
    forearm_present_ = false;
    energy.setForearmPresent(false);
  }
}

Eigen::Vector3d HandTracker::fitForearm(const PoseEnergy& energy, OptimizationResult* result,
                                        const std::optional<Eigen::Vector3d>& from) const {
  const Eigen::Vector3d start = from ? *from : Eigen::Vector3d(-result->pose.rotation.col(0));
  if (params_.energy.forearm_gaussians <= 0) return start;
  if (!energy.forearmPresent()) return start;
  return refineForearmDirection(energy, result->pose, start, ForearmSearchParams(),
                                &result->energy);
}

OptimizationResult HandTracker::trackFromPrediction(const PoseEnergy& energy,
                                                    const std::optional<Pose>& previous,
                                                    const Pose& current) const {
  const Pose start = predictedPose(previous, current);
  const int iterations = params_.optimizer.iterations;
  PoseAscent ascent(energy, start, params_.optimizer);
  // The same turn the other way, from the predicted hand centre.
  std::optional<Pose> counter;
  if (previous && params_.counter_turn_start) {
    const Eigen::Matrix3d turn = current.rotation * previous->rotation.transpose();
    if (rotationAngle(turn, Eigen::Matrix3d::Identity()) > params_.counter_turn_min_angle) {
      counter = start;
      counter->rotation = turn.transpose() * current.rotation;
      counter->translation = rootAt(handCentre(start), counter->rotation);
    }
  }
  const int rising_extra =
      frames_since_start_ >= params_.rising_min_track_frames ? params_.rising_extra_iterations : 0;
  // The rest of an ascent: its iterations up to `iterations`, then the extra ones while it rises.
  auto ascend = [&](PoseAscent* a) {
    a->iterateWhileRising(iterations - a->iterations(), rising_extra, params_.rising_chunk,
                          params_.rising_min_gain);
  };
  const int race = static_cast<int>(std::lround(params_.counter_turn_race_share * iterations));
  if (!counter || race <= 0 || race >= iterations) {
    ascend(&ascent);
    OptimizationResult result = ascent.finish();
    boundRotation(energy, current, start, &result);
    if (!counter) return result;
    // Two whole ascents, each with the same iterations (the race below is measured against this).
    PoseAscent counter_ascent(energy, *counter, params_.optimizer);
    ascend(&counter_ascent);
    OptimizationResult other = counter_ascent.finish();
    boundRotation(energy, current, *counter, &other);
    return other.energy > result.energy ? other : result;
  }
  // The race: both starts for a few iterations, then only the better one goes on.
  PoseAscent counter_ascent(energy, *counter, params_.optimizer);
  ascent.iterate(race);
  counter_ascent.iterate(race);
  const bool counter_leads = counter_ascent.bestEnergy() > ascent.bestEnergy();
  PoseAscent& leader = counter_leads ? counter_ascent : ascent;
  ascend(&leader);
  OptimizationResult result = leader.finish();
  boundRotation(energy, current, counter_leads ? *counter : start, &result);
  return result;
}

bool HandTracker::toggleFingers(const PoseEnergy& energy,
                                const std::vector<CameraObservation>& observations,
                                OptimizationResult* result,
                                std::optional<SilhouetteScorer>* silhouette_of_frame) const {
  const double weight = params_.toggle_silhouette_weight;
  if (!(weight > 0.0) || frames_since_start_ < params_.toggle_min_track_frames) return false;
  const HandModel& model = energy.model();
  // Made at the first finger to toggle: a half-curled hand's frame pays nothing.
  std::optional<SilhouetteScorer>& silhouette = *silhouette_of_frame;
  bool scored = false;
  double tracked_silhouette = 0.0;
  OptimizerParams optimizer = params_.optimizer;
  optimizer.iterations = params_.toggle_iterations;
  std::optional<OptimizationResult> best;
  double best_score = 0.0;
  const double dip_ratio = energy.params().dip_pip_ratio;
  // During a fast turn the outline changes with the turn, and a finger opened on the wrong side
  // can cover it; the hand then rolls over to fit. Two or three views do not tell which finger
  // opened either (doc/history.md "Session 40").
  const bool open_toggles =
      static_cast<int>(observations.size()) >= params_.toggle_open_min_cameras &&
      !(previous_ && current_ &&
        rotationAngle(current_->rotation, previous_->rotation) > params_.toggle_open_max_turn);
  for (const LongFingerJoints& finger : finger_joints_) {
    if (finger.mcp_flex < 0 || finger.pip_flex < 0) continue;
    Pose toggled = result->pose;
    const double flexion = toggled.joints[finger.mcp_flex] + toggled.joints[finger.pip_flex];
    if (flexion < params_.toggle_straight_flexion) {
      toggled.joints[finger.mcp_flex] = params_.toggle_mcp;
      toggled.joints[finger.pip_flex] = params_.toggle_pip;
      if (finger.dip_flex >= 0) toggled.joints[finger.dip_flex] = dip_ratio * params_.toggle_pip;
      if (finger.mcp_abd >= 0) toggled.joints[finger.mcp_abd] = 0.0;
    } else if (open_toggles && flexion > params_.toggle_curled_flexion) {
      toggled.joints[finger.mcp_flex] = 0.0;
      toggled.joints[finger.pip_flex] = 0.0;
      if (finger.dip_flex >= 0) toggled.joints[finger.dip_flex] = 0.0;
    } else {
      continue;
    }
    clampToLimits(model, &toggled);
    const double sigmas = params_.toggle_silhouette_sigmas;
    if (!scored) {
      if (!silhouette) silhouette.emplace(observations, sigmas, kSleeveChargedAsBackground);
      tracked_silhouette = silhouette->score(model, result->pose, sigmas);
      best_score = result->energy + weight * tracked_silhouette + params_.toggle_min_gain;
      scored = true;
    }
    if (silhouette->score(model, toggled, sigmas) <
        tracked_silhouette - params_.toggle_max_silhouette_loss) {
      continue;
    }
    OptimizationResult refined = optimizePose(energy, toggled, optimizer);
    const double score = refined.energy + weight * silhouette->score(model, refined.pose, sigmas);
    if (score > best_score) {
      best_score = score;
      best = refined;
    }
  }
  if (!best) return false;
  // Only a track that holds: a lost one is the start's to replace, and a toggle must not make it
  // look held. Asked only here, for the few frames with a toggle to take.
  EnergyTerms terms;
  energy.evaluate(result->pose, nullptr, &terms);
  if (looksLost(terms.similarity)) return false;
  *result = *best;
  return true;
}

bool HandTracker::refineCurledFingers(PoseEnergy& energy, OptimizationResult* result) const {
  if (params_.curled_refine_iterations <= 0 ||
      !(meanFingerFlexion(model_, result->pose) >= params_.curled_refine_flexion)) {
    return false;
  }
  const double area_weight = energy.params().model_area_weight;
  const double occlusion = energy.params().occlusion_depth_scale;
  energy.setModelAreaWeight(params_.curled_refine_model_area_weight);
  energy.setOcclusionDepthScale(params_.curled_refine_occlusion_depth_scale);
  OptimizerParams optimizer = params_.optimizer;
  optimizer.iterations = params_.curled_refine_iterations;
  optimizer.translation_step = 0.0;  // the root is held: only the fingers' shape is in question
  optimizer.rotation_step = 0.0;
  optimizer.held_joints = thumb_joints_;
  const Pose refined = optimizePose(energy, result->pose, optimizer).pose;
  energy.setModelAreaWeight(area_weight);
  energy.setOcclusionDepthScale(occlusion);
  result->pose = refined;  // result->energy: the caller scores the frame's pose once, at its end
  return true;
}

FrameResult HandTracker::step(const std::vector<CameraObservation>& observations, double stamp) {
  FrameResult result;
  result.stamp = stamp;
  result.num_cameras = static_cast<int>(observations.size());

  const bool tracking = current_ && !lost_;
  PoseEnergy& energy = energy_;
  energy.setFrame(observations);
  energy.setModelAreaWeight(
      tracking ? params_.energy.model_area_weight
               : std::max(params_.energy.model_area_weight, params_.start_model_area_weight));
  // The forearm's direction of the pose that this frame reports (fitForearm).
  std::optional<Eigen::Vector3d> forearm = forearm_;
  energy.setForearmPresent(forearm_present_);
  energy.setForearmDirection(forearm);

  std::optional<OptimizationResult> optimized;
  // The frame's silhouette scorer (finger toggles, size trial): its foregrounds made once.
  std::optional<SilhouetteScorer> silhouette;
  // The terms of the tracked pose; the frame reports them unless a start or a flip replaced it.
  EnergyTerms tracked_terms;
  bool started = false;
  bool flipped = false;
  // A re-detection that replaced the track with a pose of about its orientation: the motion
  // history that pose goes on from (see poseBeforeMotion).
  std::optional<Pose> kept_motion;
  if (tracking) {
    optimized = trackFromPrediction(energy, previous_, *current_);
    toggleFingers(energy, observations, &*optimized, &silhouette);
    const bool refined = refineCurledFingers(energy, &*optimized);
    forearm = fitForearm(energy, &*optimized, forearm);
    energy.setForearmDirection(forearm);
    energy.evaluate(optimized->pose, nullptr, &tracked_terms);
    if (refined) optimized->energy = tracked_terms.total;  // the paper's energy of the refined pose

    // The carried flip hypothesis: tracked like the main one; it takes over after
    // `flip_confirm_frames` frames with an energy clearly above the track's (judgeAlternative).
    if (alternative_) {
      Alternative& alternative = *alternative_;
      const Pose alternative_start = predictedPose(alternative.previous, alternative.current);
      // The alternative has its own forearm.
      energy.setForearmDirection(alternative_forearm_);
      OptimizationResult challenger = optimizePose(energy, alternative_start, params_.optimizer);
      boundRotation(energy, alternative.current, alternative_start, &challenger);
      alternative_forearm_ = fitForearm(energy, &challenger, alternative_forearm_);
      energy.setForearmDirection(forearm);
      const AlternativeVerdict verdict =
          plausible(challenger.pose, observations) &&
                  !armSaysReversed(challenger.pose, observations)
              ? judgeAlternative(optimized->energy, challenger.energy, params_, &alternative.wins,
                                 &alternative.frames)
              : AlternativeVerdict::kDrop;
      if (verdict == AlternativeVerdict::kDrop) {
        alternative_.reset();
      } else if (verdict == AlternativeVerdict::kConfirm) {
        optimized = challenger;
        forearm = alternative_forearm_;
        flipped = true;
        alternative_.reset();
      } else {
        alternative.previous = alternative.current;
        alternative.current = challenger.pose;
      }
    }

    const bool redetect =
        !flipped && ((params_.redetect_interval > 0 &&
                      frames_since_redetection_ + 1 >= params_.redetect_interval) ||
                     redetection_requested_);
    // The forearm says the tracked hand is reversed, frame after frame: the track is lost.
    arm_reversed_streak_ =
        armSaysReversed(optimized->pose, observations) ? arm_reversed_streak_ + 1 : 0;
    const bool implausible =
        !plausible(optimized->pose, observations) ||
        (params_.arm_reversed_frames > 0 && arm_reversed_streak_ >= params_.arm_reversed_frames);
    const bool lost = !flipped && (looksLost(tracked_terms.similarity) || implausible);
    if (lost || redetect) {
      // Try the start routine on this frame (asynchronously: hand the set to a worker, which
      // does this on its copy of the tracker). When the track is lost its best result replaces
      // the track. A periodic
      // re-detection replaces it only with a clearly better pose of about the same orientation
      // (so that the track does not jitter between near-equal poses); a better flipped pose only
      // becomes the carried alternative, which must then prove itself.
      // The search's candidates are refined with the forearm straight on from their palms (all
      // its hypotheses have no other), then each is scored with its own forearm refined.
      const std::optional<std::vector<OptimizationResult>> search =
          searchWithForearm(energy, observations);
      std::vector<OptimizationResult> restart =
          search ? *search : std::vector<OptimizationResult>();
      std::vector<Eigen::Vector3d> restart_forearms;
      for (OptimizationResult& candidate : restart) {
        restart_forearms.push_back(fitForearm(energy, &candidate, std::nullopt));
      }
      energy.setForearmDirection(forearm);
      if (!search) {
        // A worker searches: this frame keeps the warm-started pose (reported lost when lost).
      } else if (lost) {
        if (!restart.empty() && (implausible || restart.front().energy > optimized->energy)) {
          optimized = restart.front();
          forearm = restart_forearms.front();
          started = true;
          alternative_.reset();
          arm_reversed_streak_ = 0;
        }
      } else {
        const RedetectionChoice choice = chooseRedetection(
            model_, *optimized, restart, params_, alternative_.has_value(), recent_rotations_);
        if (choice.adopt >= 0) {
          // The adopted pose is of about the track's orientation: it goes on with the track's
          // motion (a hand in a fast turn keeps turning; reset, the track stopped while the hand
          // turned on and rolled over).
          const Pose& adopted = restart[choice.adopt].pose;
          if (params_.redetect_keeps_motion && previous_ &&
              rotationAngle(adopted.rotation, optimized->pose.rotation) <
                  params_.max_rotation_per_frame) {
            kept_motion = poseBeforeMotion(adopted, *current_, optimized->pose);
          }
          optimized = restart[choice.adopt];
          forearm = restart_forearms[choice.adopt];
          started = true;
          alternative_.reset();
        }
        if (choice.carry >= 0) {
          alternative_ = Alternative{std::nullopt, restart[choice.carry].pose, 1};
          alternative_forearm_ = restart_forearms[choice.carry];
        }
      }
      if (redetect) frames_since_redetection_ = 0;
    }
  } else {
    std::optional<std::vector<OptimizationResult>> start = searchWithForearm(energy, observations);
    if (start && !forearm_present_) startWithForearmIfItIsBare(energy, observations, &*start);
    if (start && !start->empty()) {
      optimized = start->front();
      forearm = fitForearm(energy, &*optimized, std::nullopt);
    }
    started = optimized.has_value();
    alternative_.reset();
    arm_reversed_streak_ = 0;
  }

  // Honesty: a frame without a plausible pose reports none.
  if (!optimized || !optimized->pose.allFinite() || !plausible(optimized->pose, observations)) {
    result.status = current_ ? TrackStatus::kLost : TrackStatus::kWaiting;
    lost_ = current_.has_value();
    alternative_.reset();
    return result;
  }

  energy.setForearmDirection(forearm);
  // The tracked pose, with the same forearm, has been scored already. A start is reported in the
  // tracking energy's terms (start_model_area_weight ranked it), which the next frames' lost test
  // and the still starts' score compare with.
  energy.setModelAreaWeight(params_.energy.model_area_weight);
  if (tracking && !started && !flipped) {
    result.energy = std::move(tracked_terms);
  } else {
    energy.evaluate(optimized->pose, nullptr, &result.energy);
  }
  result.has_pose = true;
  updateForearmPresence(energy, optimized->pose, forearm, result.energy.total);
  result.pose = optimized->pose;
  result.fingertips = fingertips(model_, result.pose);
  result.restarted = started && current_.has_value();
  result.flipped = flipped;
  lost_ = looksLost(result.energy.similarity);
  if (!lost_) {
    // A fresh start resets the reference; tracking frames update it slowly.
    typical_similarity_ = (started || flipped)
                              ? result.energy.similarity
                              : 0.9 * typical_similarity_ + 0.1 * result.energy.similarity;
  }
  result.status =
      lost_ ? TrackStatus::kLost : (started ? TrackStatus::kStarted : TrackStatus::kTracking);

  frames_since_start_ = started ? 0 : frames_since_start_ + 1;
  frames_since_redetection_ = started ? 0 : frames_since_redetection_ + 1;
  // The orientations a flip may return to (TrackerParams::flip_return_frames).
  if (started || flipped) recent_rotations_.clear();
  if (params_.flip_return_frames > 0) {
    recent_rotations_.push_back(optimized->pose.rotation);
    const size_t kept = static_cast<size_t>(params_.flip_return_frames);
    if (recent_rotations_.size() > kept) {
      recent_rotations_.erase(recent_rotations_.begin(),
                              recent_rotations_.end() - static_cast<std::ptrdiff_t>(kept));
    }
  } else {
    recent_rotations_.clear();
  }
  // A (re)start or a flip breaks the motion history: do not extrapolate across it. A
  // re-detection adopted in place of the track keeps the track's motion.
  previous_ = kept_motion ? kept_motion : (started || flipped) ? std::optional<Pose>() : current_;
  current_ = optimized->pose;
  forearm_ = forearm;
  adaptColours(result, observations);
  adaptSize(result, observations, &silhouette);
  return result;
}

void HandTracker::adaptSize(const FrameResult& result,
                            const std::vector<CameraObservation>& observations,
                            std::optional<SilhouetteScorer>* silhouette) {
  // A bare forearm continues the foreground past the wrist: a larger model that slides back along
  // it covers more, and the next trial grows it again (the studio's `wristflex`: 1.15-1.2 on
  // every hand, the wrist 27-39 mm off). During a fast turn the tracked pose lags the images.
  if (!(params_.size_step > 0.0) || (model_.colours_fitted && !params_.size_calibrated_models) ||
      result.status != TrackStatus::kTracking ||
      frames_since_start_ < params_.toggle_min_track_frames ||
      static_cast<int>(observations.size()) < params_.size_min_cameras || forearm_present_ ||
      (previous_ && current_ &&
       rotationAngle(current_->rotation, previous_->rotation) > params_.size_max_turn)) {
    return;
  }
  for (const LongFingerJoints& finger : finger_joints_) {
    if (finger.mcp_flex < 0 || finger.pip_flex < 0) continue;
    const double flexion =
        result.pose.joints[finger.mcp_flex] + result.pose.joints[finger.pip_flex];
    if (!(flexion < params_.size_open_flexion)) return;  // the silhouette hides a curled length
  }
  if (frames_to_size_trial_ > 0) {
    --frames_to_size_trial_;
    return;
  }
  frames_to_size_trial_ = params_.size_interval - 1;
  const double sigmas = params_.size_silhouette_sigmas;
  if (!*silhouette) silhouette->emplace(observations, sigmas, kSleeveChargedAsBackground);
  double best_score = (*silhouette)->score(model_, result.pose, sigmas) + params_.size_min_gain;
  double best_factor = 1.0;
  for (const double factor : {1.0 + params_.size_step, 1.0 - params_.size_step}) {
    const double size = size_factor_ * factor;
    if (size > params_.size_max || size < params_.size_min) continue;
    const HandModel scaled = scaleHandModel(model_, factor, 1.0);
    Pose pose = result.pose;
    if (params_.size_refine_iterations > 0) {
      // The tracked pose fitted to this size (see TrackerParams::size_refine_iterations).
      PoseEnergy energy(scaled, params_.energy);
      energy.setFrame(observations);
      energy.setForearmPresent(forearm_present_);
      energy.setForearmDirection(forearm_);
      OptimizerParams optimizer = params_.optimizer;
      optimizer.iterations = params_.size_refine_iterations;
      pose = optimizePose(energy, result.pose, optimizer).pose;
    }
    const double score = (*silhouette)->score(scaled, pose, sigmas);
    if (score > best_score) {
      best_score = score;
      best_factor = factor;
    }
  }
  if (best_factor != 1.0) setSize(size_factor_ * best_factor);
}

void HandTracker::setSize(double size) {
  HandModel scaled = scaleHandModel(base_model_, size, 1.0);
  for (size_t p = 0; p < scaled.gaussians.size(); ++p) {
    scaled.gaussians[p].hsv = model_.gaussians[p].hsv;  // the learnt colours
  }
  model_ = std::move(scaled);
  size_factor_ = size;
  energy_ = PoseEnergy(model_, params_.energy);  // the next frame's setFrame fills it
}

}  // namespace sag_hand_tracker
