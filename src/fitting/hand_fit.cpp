#include "sag_hand_tracker/fitting/hand_fit.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "sag_hand_tracker/energy/colour.h"
#include "sag_hand_tracker/energy/hand_projection.h"
#include "sag_hand_tracker/energy/projection.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/studio/hand_surface.h"
#include "sag_hand_tracker/tracking/colour_adaptation.h"

namespace sag_hand_tracker {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

bool positiveFactor(double value) { return std::isfinite(value) && value > 0.0; }

// Mean MCP + PIP flexion of the four fingers in degrees: what tells an open hand from a fist, for
// the routine check and for the frames the fit takes.
double fingerFlexionDeg(const HandModel& model, const Pose& pose) {
  return meanFingerFlexion(model, pose) * kRadToDeg;
}

// Per frame, per observation, its foreground (foregroundsOf): the silhouette score's part that does
// not depend on the shape, made once.
using FrameForegrounds = std::vector<std::vector<cv::Mat>>;

FrameForegrounds foregroundsOf(const std::vector<const CalibrationFrame*>& frames) {
  FrameForegrounds foregrounds;
  foregrounds.reserve(frames.size());
  for (const CalibrationFrame* frame : frames)
    foregrounds.push_back(foregroundsOf(frame->observations));
  return foregrounds;
}

// The mean over the frames of the shape score (params.score) at the given poses; `foregrounds`
// (foregroundsOf `frames`) only for the silhouette score.
double meanShapeScore(const HandModel& model, const HandFitParams& params,
                      const std::vector<const CalibrationFrame*>& frames,
                      const FrameForegrounds& foregrounds, const std::vector<Pose>& poses) {
  double sum = 0.0;
  for (size_t f = 0; f < frames.size(); ++f) {
    const std::vector<CameraObservation>& observations = frames[f]->observations;
    sum += params.score == HandFitParams::Score::kSilhouette
               ? silhouetteScore(model, observations, foregrounds[f], poses[f],
                                 params.silhouette_sigmas, params.sleeve_charge)
               : shapeScore(model, params.energy, observations, poses[f], params.model_mass_weight);
  }
  return frames.empty() ? 0.0 : sum / frames.size();
}

// Re-optimises every frame's pose for `model`, warm-started from `poses`; returns the new poses
// and their mean tracking energy.
std::vector<Pose> optimizePoses(const HandModel& model, const HandFitParams& params,
                                const std::vector<const CalibrationFrame*>& frames,
                                const std::vector<Pose>& poses, const OptimizerParams& optimizer,
                                double* mean_energy) {
  PoseEnergy energy(model, params.energy);
  std::vector<Pose> result(poses.size());
  double sum = 0.0;
  for (size_t f = 0; f < frames.size(); ++f) {
    energy.setFrame(frames[f]->observations);
    const OptimizationResult optimized = optimizePose(energy, poses[f], optimizer);
    result[f] = optimized.pose;
    sum += optimized.energy;
  }
  if (mean_energy) *mean_energy = frames.empty() ? 0.0 : sum / frames.size();
  return result;
}

double meanEnergy(const HandModel& model, const EnergyParams& params,
                  const std::vector<const CalibrationFrame*>& frames,
                  const std::vector<Pose>& poses) {
  PoseEnergy energy(model, params);
  double sum = 0.0;
  for (size_t f = 0; f < frames.size(); ++f) {
    energy.setFrame(frames[f]->observations);
    sum += energy.evaluate(poses[f]);
  }
  return frames.empty() ? 0.0 : sum / frames.size();
}

}  // namespace

EnergyParams calibrationEnergyParams() {
  EnergyParams params;
  params.wrist_weight = 0.0;
  return params;
}

RoutineTracking RoutineTracking::of(const TrackerParams& params) {
  RoutineTracking routine;
  routine.counter_turn_race_share = params.counter_turn_race_share;
  routine.redetect_race_iterations = params.redetect_race_iterations;
  routine.curled_refine_iterations = params.curled_refine_iterations;
  routine.rising_extra_iterations = params.rising_extra_iterations;
  routine.wrist_weight = params.energy.wrist_weight;
  return routine;
}

void RoutineTracking::applyTo(TrackerParams* params) const {
  params->counter_turn_race_share = counter_turn_race_share;
  params->redetect_race_iterations = redetect_race_iterations;
  params->curled_refine_iterations = curled_refine_iterations;
  params->rising_extra_iterations = rising_extra_iterations;
  params->energy.wrist_weight = wrist_weight;
}

bool RoutineTracking::operator==(const RoutineTracking& other) const {
  return counter_turn_race_share == other.counter_turn_race_share &&
         redetect_race_iterations == other.redetect_race_iterations &&
         curled_refine_iterations == other.curled_refine_iterations &&
         rising_extra_iterations == other.rising_extra_iterations &&
         wrist_weight == other.wrist_weight;
}

TrackerParams calibrationTrackerParams() {
  TrackerParams params;
  RoutineTracking().applyTo(&params);
  return params;
}

HandShapeParameters HandShapeParameters::identity(const HandModel& model) {
  HandShapeParameters shape;
  shape.bone_length.assign(model.bones.size(), 1.0);
  shape.gaussian_scale.assign(model.gaussians.size(), Eigen::Vector3d::Ones());
  return shape;
}

HandModel applyHandShape(const HandModel& start, const HandShapeParameters& shape) {
  if (shape.bone_length.size() != start.bones.size() ||
      shape.gaussian_scale.size() != start.gaussians.size()) {
    throw InputError("hand shape: " + std::to_string(shape.bone_length.size()) +
                     " bone factors and " + std::to_string(shape.gaussian_scale.size()) +
                     " Gaussian factors for a model of " + std::to_string(start.bones.size()) +
                     " bones and " + std::to_string(start.gaussians.size()) + " Gaussians");
  }
  bool ok = positiveFactor(shape.scale) && positiveFactor(shape.palm_width) &&
            positiveFactor(shape.finger_length) && positiveFactor(shape.thickness);
  for (double f : shape.bone_length) ok = ok && positiveFactor(f);
  for (const Eigen::Vector3d& s : shape.gaussian_scale) {
    ok = ok && positiveFactor(s.x()) && positiveFactor(s.y()) && positiveFactor(s.z());
  }
  if (!ok) throw InputError("hand shape: every factor must be positive and finite");

  HandModel model = start;
  // Per Gaussian: scale the standard deviations along the principal axes.
  for (size_t g = 0; g < model.gaussians.size(); ++g) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(model.gaussians[g].cov);
    const Eigen::Matrix3d& axes = eigen.eigenvectors();
    // The eigenvectors come sorted by eigenvalue; match each to the bone axis it is closest to,
    // so that gaussian_scale's x, y, z mean "along the bone" and the two across it.
    Eigen::Vector3d variances = eigen.eigenvalues();
    Eigen::Vector3d factor_per_eigen = Eigen::Vector3d::Ones();
    std::array<bool, 3> used{{false, false, false}};
    for (int bone_axis = 0; bone_axis < 3; ++bone_axis) {
      int best = -1;
      for (int e = 0; e < 3; ++e) {
        if (used[e]) continue;
        if (best < 0 || std::abs(axes(bone_axis, e)) > std::abs(axes(bone_axis, best))) best = e;
      }
      used[best] = true;
      const bool across = model.gaussians[g].bone == 0 ? bone_axis == 2 : bone_axis > 0;
      factor_per_eigen[best] =
          shape.gaussian_scale[g][bone_axis] * (across ? shape.thickness : 1.0);
    }
    variances = variances.cwiseProduct(factor_per_eigen.cwiseAbs2());
    model.gaussians[g].cov = axes * variances.asDiagonal() * axes.transpose();
    model.gaussians[g].cov = 0.5 * (model.gaussians[g].cov + model.gaussians[g].cov.transpose());
  }
  // Per bone: its length, the offsets of its children, its Gaussians along the bone axis.
  for (size_t b = 0; b < model.bones.size(); ++b) {
    const double k = shape.bone_length[b];
    if (k == 1.0) continue;
    model.bones[b].length *= k;
    for (Bone& child : model.bones) {
      if (child.parent == static_cast<int>(b)) child.offset.x() *= k;
    }
    const Eigen::Vector3d s(k, 1.0, 1.0);
    for (ModelGaussian& g : model.gaussians) {
      if (g.bone != static_cast<int>(b)) continue;
      g.mean = g.mean.cwiseProduct(s);
      g.cov = s.asDiagonal() * g.cov * s.asDiagonal();
    }
  }
  studio::HandShape global;
  global.scale = shape.scale;
  global.palm_width = shape.palm_width;
  global.finger_length.fill(shape.finger_length);
  return studio::shapeHandModel(model, global);
}

double shapeScore(const HandModel& model, const EnergyParams& params,
                  const std::vector<CameraObservation>& observations, const Pose& pose,
                  double model_mass_weight) {
  PoseEnergy energy(model, params);
  energy.setFrame(observations);
  EnergyTerms terms;
  energy.evaluate(pose, nullptr, &terms);
  const PosedHand hand = forwardKinematics(model, pose);

  // PoseEnergy keeps the cameras that see anything, in order; per_camera[c] is that camera's
  // O_c / sum_q E_qq divided by the number of such cameras.
  const double kept = static_cast<double>(terms.per_camera.size());
  double score = 0.0;
  size_t c = 0;
  for (const CameraObservation& observation : observations) {
    double image_mass = 0.0;
    for (const ImageGaussian& g : observation.sog.gaussians) {
      if (g.mean.allFinite() && g.sigma > 0.0 && std::isfinite(g.sigma) && g.hsv.allFinite()) {
        image_mass += M_PI * g.sigma * g.sigma;  // E_qq
      }
    }
    if (image_mass <= 0.0) continue;
    if (c >= terms.per_camera.size()) break;
    const double overlap = terms.per_camera[c] * kept * image_mass;
    ++c;
    double model_mass = 0.0;
    for (const CameraGaussian& g : projectModel(model, hand, observation.camera)) {
      if (!g.projected.valid) continue;
      const double det = g.projected.cov.determinant();
      if (det > 0.0) model_mass += model_mass_weight * 2.0 * M_PI * std::sqrt(det);
    }
    score += 2.0 * overlap / (image_mass + model_mass);
  }
  return kept > 0 ? score / kept : 0.0;
}

void sampleGaussianColours(const std::vector<CalibrationFrame>& frames,
                           const std::vector<Pose>& poses, HandModel* model) {
  GaussianColourStatistics statistics(model->gaussians.size());
  for (size_t f = 0; f < frames.size() && f < poses.size(); ++f) {
    statistics.add(*model, poses[f], frames[f].observations);
  }
  for (size_t p = 0; p < model->gaussians.size(); ++p) {
    if (const std::optional<Hsv> colour = statistics.mean(p)) model->gaussians[p].hsv = *colour;
  }
}

RoutineCheck checkCalibrationRoutine(const HandModel& model,
                                     const std::vector<CalibrationFrame>& frames,
                                     int cameras_in_recording,
                                     const RoutineRequirements& requirements) {
  RoutineCheck check;
  check.frames = static_cast<int>(frames.size());
  for (std::size_t f = 1; f < frames.size(); ++f) {
    const double gap = frames[f].stamp - frames[f - 1].stamp;
    if (gap <= requirements.max_frame_gap) check.duration += gap;
  }

  // Views: cameras (by name) that see the hand in at least a third of the frames.
  std::vector<std::pair<std::string, int>> seen;
  for (const CalibrationFrame& frame : frames) {
    for (const CameraObservation& observation : frame.observations) {
      if (static_cast<int>(observation.sog.gaussians.size()) <
          requirements.min_foreground_gaussians) {
        continue;
      }
      auto it = std::find_if(seen.begin(), seen.end(), [&](const auto& entry) {
        return entry.first == observation.camera.name;
      });
      if (it == seen.end()) {
        seen.push_back({observation.camera.name, 1});
      } else {
        ++it->second;
      }
    }
    // Poses: which side of the hand faces a camera, and how far the fingers are curled.
    const PosedHand hand = forwardKinematics(model, frame.pose);
    const Eigen::Isometry3d& palm = hand.bone_frames[0];
    const Eigen::Vector3d back_normal = palm.linear().col(2);  // z: out of the back of the hand
    const Eigen::Vector3d palm_centre = palm * Eigen::Vector3d(0.05, 0.0, 0.0);
    bool palm_seen = false, back_seen = false;
    for (const CameraObservation& observation : frame.observations) {
      if (static_cast<int>(observation.sog.gaussians.size()) <
          requirements.min_foreground_gaussians) {
        continue;
      }
      const Eigen::Vector3d to_camera = (observation.camera.centre() - palm_centre).normalized();
      const double facing = back_normal.dot(to_camera);
      if (facing >= requirements.facing_cos) back_seen = true;
      if (-facing >= requirements.facing_cos) palm_seen = true;
    }
    const double flexion = fingerFlexionDeg(model, frame.pose);
    if (palm_seen) ++check.palm_frames;
    if (back_seen) ++check.back_frames;
    if (flexion >= requirements.fist_flexion_deg) ++check.fist_frames;
    if (flexion <= requirements.open_flexion_deg) ++check.open_frames;
  }
  for (const auto& entry : seen) {
    if (3 * entry.second >= check.frames) ++check.views;
  }

  auto need = [&](bool condition, const std::string& what) {
    if (!condition) check.missing.push_back(what);
  };
  need(cameras_in_recording >= requirements.min_views,
       "the recording has " + std::to_string(cameras_in_recording) + " camera" +
           (cameras_in_recording == 1 ? "" : "s") + "; the fit needs at least " +
           std::to_string(requirements.min_views) + " views of the hand");
  if (check.frames == 0) {
    check.missing.push_back("no frame with the hand: the hand was never found in the images");
  } else {
    need(check.frames >= requirements.min_frames, "only " + std::to_string(check.frames) +
                                                      " frames with the hand, the fit needs " +
                                                      std::to_string(requirements.min_frames));
    // As many decimals as it takes to print less than the need: with one, 1.96 s read "in view
    // for 2.0 s, the fit needs 2.0 s".
    char seconds[48];
    for (int decimals = 2; decimals <= 9; ++decimals) {
      std::snprintf(seconds, sizeof(seconds), "%.*f", decimals, check.duration);
      if (std::strtod(seconds, nullptr) < requirements.min_duration) break;
    }
    char duration[128];
    std::snprintf(duration, sizeof(duration), "the hand was in view for %s s, the fit needs %.1f s",
                  seconds, requirements.min_duration);
    need(check.duration >= requirements.min_duration, duration);
    if (cameras_in_recording >= requirements.min_views) {
      need(check.views >= requirements.min_views,
           "only " + std::to_string(check.views) + " camera" + (check.views == 1 ? "" : "s") +
               " saw the hand in a third of the frames; keep it where at least " +
               std::to_string(requirements.min_views) + " cameras see it");
    }
  }
  // The poses: a fit is possible without them, the routine is not complete.
  check.ok = check.missing.empty();
  if (check.frames > 0) {
    need(check.open_frames >= requirements.min_pose_frames,
         "no open hand with the fingers spread (" + std::to_string(check.open_frames) + " frames)");
    need(check.palm_frames >= requirements.min_pose_frames,
         "the palm was not turned to a camera (" + std::to_string(check.palm_frames) + " frames)");
    need(check.back_frames >= requirements.min_pose_frames,
         "the back of the hand was not turned to a camera (" + std::to_string(check.back_frames) +
             " frames)");
    need(check.fist_frames >= requirements.min_pose_frames,
         "no fist (" + std::to_string(check.fist_frames) + " frames)");
  }
  check.complete = check.missing.empty();
  return check;
}

std::vector<int> selectCalibrationFrames(int frame_count, int max_frames) {
  std::vector<int> indices;
  if (frame_count <= 0 || max_frames <= 0) return indices;
  const int count = std::min(frame_count, max_frames);
  for (int i = 0; i < count; ++i) {
    // The middle of each of `count` equal parts.
    indices.push_back(static_cast<int>((i + 0.5) * frame_count / count));
  }
  return indices;
}

HandFitResult fitHandModel(const HandModel& start, const std::vector<CalibrationFrame>& frames,
                           const HandFitParams& params, const FitProgress& progress) {
  if (frames.empty()) throw InputError("the hand fit needs at least one frame with the hand");
  if (!(params.min_factor > 0.0 && params.min_factor <= 1.0 && params.max_factor >= 1.0)) {
    throw InputError("hand fit: the factor range must contain 1 and be positive");
  }
  validateHandModel(start);
  auto report = [&](double fraction, const std::string& status) {
    if (progress) progress(std::clamp(fraction, 0.0, 1.0), status);
  };

  HandFitResult result;
  // The frames to choose from: with open_hand_frames the open-hand ones, when there are enough.
  std::vector<int> all(frames.size()), open;
  std::iota(all.begin(), all.end(), 0);
  for (int i = 0; params.open_hand_frames && i < static_cast<int>(frames.size()); ++i) {
    if (fingerFlexionDeg(start, frames[i].pose) <= params.open_flexion_deg) open.push_back(i);
  }
  result.open_frames_only =
      params.open_hand_frames && static_cast<int>(open.size()) >= params.min_open_frames;
  const std::vector<int>& candidates = result.open_frames_only ? open : all;
  for (int k : selectCalibrationFrames(static_cast<int>(candidates.size()), params.max_frames)) {
    result.frame_indices.push_back(candidates[k]);
  }
  std::vector<const CalibrationFrame*> used;
  std::vector<Pose> poses;
  for (int index : result.frame_indices) {
    used.push_back(&frames[index]);
    poses.push_back(frames[index].pose);
  }
  const FrameForegrounds foregrounds =
      params.score == HandFitParams::Score::kSilhouette ? foregroundsOf(used) : FrameForegrounds();

  HandModel model = start;
  OptimizerParams initial = params.pose_optimizer;
  initial.iterations = params.initial_pose_iterations;
  // The tracked poses came from the start model frame by frame; refine them once.
  poses = optimizePoses(model, params, used, poses, initial, nullptr);
  result.energy_before = meanEnergy(model, params.energy, used, poses);
  result.score_before = meanShapeScore(model, params, used, foregrounds, poses);

  auto sampleColours = [&]() {
    if (!params.fit_colours) return;
    std::vector<CalibrationFrame> view;
    view.reserve(used.size());
    for (const CalibrationFrame* frame : used) view.push_back(*frame);
    HandModel coloured = model;
    sampleGaussianColours(view, poses, &coloured);
    for (size_t g = 0; g < model.gaussians.size(); ++g)
      model.gaussians[g].hsv = coloured.gaussians[g].hsv;
    model.colours_fitted = true;
  };
  // Colours first: the overlap of eq. 8 weighs every pair by d(c_p, c_q), so the shape search
  // needs the person's colours.
  sampleColours();
  HandModel base = model;  // the start model with the person's colours: what the shape acts on
  HandShapeParameters shape = HandShapeParameters::identity(base);
  poses = optimizePoses(model, params, used, poses, params.pose_optimizer, nullptr);
  double score = meanShapeScore(model, params, used, foregrounds, poses);

  // The parameters, as pointers into `shape`, in the paper's order: global, then (ours) the
  // bone lengths, then the per-Gaussian principal-axis scales.
  struct Block {
    std::string name;
    std::vector<std::vector<double*>> parameters;  // each group of factors moves together
    const std::vector<double>* steps;
  };
  std::vector<Block> blocks;
  // Thickness first: it is the largest and least ambiguous difference, and while it is wrong the
  // size would shrink the whole hand to thin it.
  blocks.push_back(
      {"global shape",
       {{&shape.thickness}, {&shape.scale}, {&shape.palm_width}, {&shape.finger_length}},
       &params.global_steps});
  if (params.fit_bones) {
    Block bones{"bone lengths", {}, &params.bone_steps};
    // Per finger either all its bones together (the default: the split between the phalanges is
    // not determined by the energy, doc/calibration.md) or each bone; the palm's length (wrist to
    // the knuckles) only on request: the open hand's silhouette does not mark the knuckles, and
    // the search trades palm length for finger length (doc/calibration.md).
    if (params.fit_palm_length) bones.parameters.push_back({&shape.bone_length[0]});
    for (const std::vector<int>& chain : studio::fingerChains(base)) {
      std::vector<double*> finger;
      for (int b : chain) finger.push_back(&shape.bone_length[b]);
      if (params.per_bone_lengths) {
        for (double* bone : finger) bones.parameters.push_back({bone});
      } else {
        bones.parameters.push_back(finger);
      }
    }
    blocks.push_back(bones);
  }
  if (params.fit_gaussians) {
    Block gaussians{"Gaussian scales", {}, &params.gaussian_steps};
    // A finger Gaussian spans its bone (mean = sigma_x = length / 2 in the start model), so its
    // extent along the bone is the bone length's; only its two widths are free. The palm's
    // Gaussians have all three.
    for (size_t g = 0; g < shape.gaussian_scale.size(); ++g) {
      for (int axis = base.gaussians[g].bone == 0 ? 0 : 1; axis < 3; ++axis) {
        gaussians.parameters.push_back({&shape.gaussian_scale[g][axis]});
      }
    }
    blocks.push_back(gaussians);
  }
  int total_sweeps = 0;
  for (const Block& block : blocks)
    total_sweeps += static_cast<int>(block.steps->size() * block.parameters.size());
  total_sweeps *= std::max(params.rounds, 1);
  int done_sweeps = 0;

  // Greedy coordinate search: a step on one factor, the poses re-optimised from where they were,
  // taken when the mean shape score rises; a taken step is tried again in the same direction.
  for (int round = 0; round < params.rounds; ++round) {
    for (const Block& block : blocks) {
      for (double step : *block.steps) {
        for (const std::vector<double*>& group : block.parameters) {
          ++done_sweeps;
          report(static_cast<double>(done_sweeps) / total_sweeps,
                 block.name + ", step " +
                     std::to_string(static_cast<int>(std::lround(step * 100))) + " %, score " +
                     std::to_string(score));
          for (double direction : {1.0, -1.0}) {
            bool improved = false;
            for (int repeat = 0; repeat < 4; ++repeat) {
              std::vector<double> old_values;
              for (double* factor : group) old_values.push_back(*factor);
              const double change = std::clamp(old_values[0] * (1.0 + direction * step),
                                               params.min_factor, params.max_factor) /
                                    old_values[0];
              if (change == 1.0) break;
              for (double* factor : group) *factor *= change;
              const HandModel candidate = applyHandShape(base, shape);
              const std::vector<Pose> candidate_poses =
                  optimizePoses(candidate, params, used, poses, params.pose_optimizer, nullptr);
              const double candidate_score =
                  meanShapeScore(candidate, params, used, foregrounds, candidate_poses);
              ++result.trials;
              if (candidate_score > score + params.min_gain) {
                score = candidate_score;
                poses = candidate_poses;
                model = candidate;
                improved = true;
                ++result.accepted;
              } else {
                for (size_t i = 0; i < group.size(); ++i) *group[i] = old_values[i];
                break;
              }
            }
            if (improved) break;  // no need to try the other direction
          }
        }
      }
    }
  }

  // The colours again, at the fitted shape and poses (paper: colours from the images).
  sampleColours();
  for (size_t g = 0; g < model.gaussians.size(); ++g)
    base.gaussians[g].hsv = model.gaussians[g].hsv;
  model = applyHandShape(base, shape);
  poses = optimizePoses(model, params, used, poses, initial, nullptr);
  model.name = start.name + "_fitted";
  result.model = model;
  result.shape = shape;
  result.poses = poses;
  result.score_after = meanShapeScore(model, params, used, foregrounds, poses);
  result.energy_after = meanEnergy(model, params.energy, used, poses);
  report(1.0, "fitted");
  return result;
}

int SkeletonErrors::bonesWithin(double tolerance) const {
  int count = 0;
  for (const auto& finger_bones : bone) {
    for (double error : finger_bones) count += std::abs(error) < tolerance ? 1 : 0;
  }
  return count;
}

SkeletonErrors compareSkeletons(const HandModel& fitted, const HandModel& truth) {
  if (fitted.bones.size() != truth.bones.size()) {
    throw InputError("comparing skeletons: the fitted model has " +
                     std::to_string(fitted.bones.size()) + " bones, the true one " +
                     std::to_string(truth.bones.size()));
  }
  for (size_t b = 0; b < truth.bones.size(); ++b) {
    if (fitted.bones[b].name != truth.bones[b].name) {
      throw InputError("comparing skeletons: bone " + std::to_string(b) + " is '" +
                       fitted.bones[b].name + "' in the fitted model, '" + truth.bones[b].name +
                       "' in the true one");
    }
  }
  const auto chains = studio::fingerChains(truth);
  SkeletonErrors errors;
  for (int f = 0; f < kNumFingers; ++f) {
    double fitted_sum = 0.0, true_sum = 0.0;
    for (int k = 0; k < 3; ++k) {
      const int b = chains[f][k];
      errors.bone[f][k] = fitted.bones[b].length / truth.bones[b].length - 1.0;
      errors.worst_bone = std::max(errors.worst_bone, std::abs(errors.bone[f][k]));
      fitted_sum += fitted.bones[b].length;
      true_sum += truth.bones[b].length;
    }
    errors.finger[f] = fitted_sum / true_sum - 1.0;
    const int root = chains[f][0];
    errors.knuckle[f] = fitted.bones[root].offset.norm() / truth.bones[root].offset.norm() - 1.0;
  }
  return errors;
}

double fingertipsOnForeground(const HandModel& model, const std::vector<CalibrationFrame>& frames,
                              const std::vector<Pose>& poses) {
  int total = 0, on = 0;
  for (size_t f = 0; f < frames.size() && f < poses.size(); ++f) {
    const auto tips = fingertips(model, poses[f]);
    for (const CameraObservation& observation : frames[f].observations) {
      for (const Eigen::Vector3d& tip : tips) {
        Eigen::Vector2d pixel;
        if (!observation.camera.project(tip, &pixel)) continue;
        if (pixel.x() < 0 || pixel.y() < 0 || pixel.x() >= observation.camera.width ||
            pixel.y() >= observation.camera.height) {
          continue;
        }
        ++total;
        for (const ImageGaussian& q : observation.sog.gaussians) {
          if ((q.mean - pixel).squaredNorm() <= 2.25 * q.sigma * q.sigma) {
            ++on;
            break;
          }
        }
      }
    }
  }
  return total > 0 ? static_cast<double>(on) / total : 0.0;
}

cv::Mat drawModelOverlay(const cv::Mat& rgb, const Camera& camera, const HandModel& model,
                         const Pose& pose) {
  cv::Mat out = rgb.clone();
  const PosedHand hand = forwardKinematics(model, pose);
  // Yellow: seen on skin and on the table.
  drawProjectedEllipses(projectModel(model, hand, camera), cv::Scalar(255, 230, 0), &out);
  for (const Eigen::Vector3d& tip : fingertips(model, hand)) {
    Eigen::Vector2d pixel;
    if (!camera.project(tip, &pixel)) continue;
    cv::drawMarker(out,
                   cv::Point(static_cast<int>(std::lround(pixel.x())),
                             static_cast<int>(std::lround(pixel.y()))),
                   cv::Scalar(0, 255, 0), cv::MARKER_CROSS, 7, 1);
  }
  return out;
}

}  // namespace sag_hand_tracker
