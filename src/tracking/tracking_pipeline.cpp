#include "sag_hand_tracker/tracking/tracking_pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "sag_hand_tracker/energy/hand_projection.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/util/timing.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace {

PipelineParams adjusted(PipelineParams params) {
  if (params.background_frames < 0) {
    throw InputError("background_frames must be >= 0, got " +
                     std::to_string(params.background_frames));
  }
  if (params.background_frames > 0) {
    params.segmentation.background.frames = params.background_frames;
  }
  if (!(params.skin_gate_start_area_weight >= 0.0) ||
      !std::isfinite(params.skin_gate_start_area_weight)) {
    throw InputError("skin_gate_start_area_weight must be a finite number >= 0, got " +
                     std::to_string(params.skin_gate_start_area_weight));
  }
  validate(params.segmentation);
  validate(params.multi_view);
  // What the tracker runs with a plate and not without one.
  const bool without_plate = params.background_frames == 0;
  params.tracker.curled_refine_iterations = curledRefineIterations(params, without_plate);
  params.tracker.toggle_curled_flexion = toggleCurledFlexion(params, without_plate);
  params.tracker.size_step = sizeStep(params, without_plate);
  return params;
}

}  // namespace

cv::Rect projectedHandBox(const HandModel& model, const Pose& pose, const Camera& camera,
                          double margin, int margin_pixels) {
  const PosedHand hand = forwardKinematics(model, pose);
  double u0 = INFINITY, v0 = INFINITY, u1 = -INFINITY, v1 = -INFINITY;
  for (const WorldGaussian& g : hand.gaussians) {
    const Eigen::Vector3d p = camera.world_to_camera * g.mean;
    if (p.z() < 0.02) return cv::Rect();                   // at or behind the camera: no box
    const double radius = 2.5 * std::sqrt(g.cov.trace());  // >= 2.5 sigma along any axis
    const double u = camera.K(0, 0) * p.x() / p.z() + camera.K(0, 2);
    const double v = camera.K(1, 1) * p.y() / p.z() + camera.K(1, 2);
    const double ru = camera.K(0, 0) * radius / p.z(), rv = camera.K(1, 1) * radius / p.z();
    u0 = std::min(u0, u - ru);
    u1 = std::max(u1, u + ru);
    v0 = std::min(v0, v - rv);
    v1 = std::max(v1, v + rv);
  }
  if (!(u1 > u0) || !(v1 > v0)) return cv::Rect();
  const double grow_u = margin * (u1 - u0) + margin_pixels;
  const double grow_v = margin * (v1 - v0) + margin_pixels;
  const int x0 = static_cast<int>(std::floor(std::max(u0 - grow_u, -1.0)));
  const int y0 = static_cast<int>(std::floor(std::max(v0 - grow_v, -1.0)));
  const int x1 = static_cast<int>(std::ceil(std::min(u1 + grow_u, camera.width + 1.0)));
  const int y1 = static_cast<int>(std::ceil(std::min(v1 + grow_v, camera.height + 1.0)));
  return cv::Rect(x0, y0, x1 - x0, y1 - y0) & cv::Rect(0, 0, camera.width, camera.height);
}

cv::Mat projectedHandMask(const PosedHand& hand, const Camera& camera, int margin_pixels,
                          double radius_scale) {
  cv::Mat mask(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  if (!handInFrontOf(hand, camera)) return mask;
  for (const WorldGaussian& g : hand.gaussians) {
    const Eigen::Vector3d p = camera.world_to_camera * g.mean;
    const double radius =
        radius_scale * std::sqrt(g.cov.trace()) * camera.K(0, 0) / p.z() + margin_pixels;
    const double u = camera.K(0, 0) * p.x() / p.z() + camera.K(0, 2);
    const double v = camera.K(1, 1) * p.y() / p.z() + camera.K(1, 2);
    if (std::fabs(u) > 4.0 * camera.width || std::fabs(v) > 4.0 * camera.height) continue;
    cv::circle(mask, cv::Point(static_cast<int>(std::lround(u)), static_cast<int>(std::lround(v))),
               static_cast<int>(std::ceil(radius)), cv::Scalar(255), cv::FILLED);
  }
  return mask;
}

double modelOnForeground(const PosedHand& hand, const std::vector<Camera>& cameras,
                         const std::vector<cv::Mat>& foregrounds) {
  if (foregrounds.size() != cameras.size()) {
    throw InputError("modelOnForeground: " + std::to_string(cameras.size()) + " cameras but " +
                     std::to_string(foregrounds.size()) + " foreground masks");
  }
  double core = 0.0, on_foreground = 0.0;
  for (size_t c = 0; c < cameras.size(); ++c) {
    if (foregrounds[c].empty()) continue;
    const Camera& camera = cameras[c];
    if (foregrounds[c].type() != CV_8UC1 || foregrounds[c].cols != camera.width ||
        foregrounds[c].rows != camera.height) {
      throw InputError("modelOnForeground: the foreground of camera '" + camera.name +
                       "' is not a CV_8UC1 mask of its image size");
    }
    const cv::Mat mask = projectedHandMask(hand, camera, 0, kModelCoreRadius);
    core += cv::countNonZero(mask);
    on_foreground += cv::countNonZero(mask & foregrounds[c]);
  }
  return core > 0.0 ? on_foreground / core : 0.0;
}

double startModelAreaWeight(const PipelineParams& params, bool generic_skin_gate_without_plate) {
  return generic_skin_gate_without_plate
             ? std::max(params.tracker.start_model_area_weight, params.skin_gate_start_area_weight)
             : params.tracker.start_model_area_weight;
}

int curledRefineIterations(const PipelineParams& params, bool without_plate) {
  return without_plate && !params.curled_refine_without_plate
             ? 0
             : params.tracker.curled_refine_iterations;
}

double toggleCurledFlexion(const PipelineParams& params, bool without_plate) {
  return without_plate && !params.open_toggles_without_plate
             ? std::numeric_limits<double>::infinity()
             : params.tracker.toggle_curled_flexion;
}

double sizeStep(const PipelineParams& params, bool without_plate) {
  return without_plate && !params.size_adaptation_without_plate ? 0.0 : params.tracker.size_step;
}

bool redetectsInStartedRegion(const PipelineParams& params, bool generic_skin_gate_without_plate,
                              bool room_cues) {
  return params.redetect_in_started_region && generic_skin_gate_without_plate && room_cues;
}

std::optional<StillStart> startOnStillScene(
    const HandModel& model, const TrackerParams& params,
    const std::vector<std::vector<CameraObservation>>& trials, const std::vector<Camera>& cameras,
    const std::vector<cv::Mat>& foregrounds, double min_score, double stamp,
    std::int64_t frame_id) {
  TrackerParams trial_params = params;
  trial_params.asynchronous_search = false;  // the start's pose is wanted now, on this set
  std::optional<StillStart> best;
  for (size_t h = 0; h < trials.size(); ++h) {
    HandTracker tracker(model, trial_params);
    const FrameResult result = tracker.update(trials[h], stamp, frame_id);
    if (!result.has_pose || result.status == TrackStatus::kLost) continue;
    const double score =
        result.energy.similarity *
        modelOnForeground(forwardKinematics(tracker.model(), result.pose), cameras, foregrounds);
    if (score < min_score || score <= (best ? best->score : 0.0)) continue;
    if (!best) best.emplace();
    best->hypothesis = static_cast<int>(h);
    best->result = result;
    best->score = score;
    best->tracker = std::move(tracker);
  }
  return best;
}

TrackingPipeline::TrackingPipeline(const HandModel& model, const std::vector<Camera>& cameras,
                                   const PipelineParams& params)
    : cameras_(cameras), params_(adjusted(params)), tracker_(model, params_.tracker) {
  if (static_cast<int>(cameras_.size()) < params_.tracker.min_cameras_for_start) {
    throw InputError("the tracker starts from at least " +
                     std::to_string(params_.tracker.min_cameras_for_start) +
                     " cameras that see the hand, but there are " +
                     std::to_string(cameras_.size()));
  }
  if (params_.skin_gate_from_model && model.colours_fitted) {
    try {
      params_.segmentation.skin = personalSkinGate(model, params_.personal_skin_gate);
      skin_gate_from_model_ = true;
    } catch (const InputError& e) {
      skin_gate_problem_ = e.what();  // the generic gate stays
    }
  }
  // The generic skin gate keeps the wood, the coffee and the photographs beside the hand: the
  // starts are scored with the model's area charged and searched again on the next set; the
  // user's own gate drops those things (the plate's other settings: adjusted).
  const bool generic_gate_without_plate = params_.background_frames == 0 && !skin_gate_from_model_;
  const double start_weight = startModelAreaWeight(params_, generic_gate_without_plate);
  if (start_weight != params_.tracker.start_model_area_weight) {
    params_.tracker.start_model_area_weight = start_weight;
    tracker_.setParams(params_.tracker);
  }
  redetect_in_started_region_ = redetectsInStartedRegion(params_, generic_gate_without_plate,
                                                         params_.segmentation.room.enabled);
  for (const Camera& camera : cameras_) {
    validateCamera(camera);
    segmenters_.emplace_back(params_.segmentation);
  }
}

void TrackingPipeline::reset() {
  tracker_.reset();
  for (ImageSegmenter& segmenter : segmenters_) {
    segmenter.resetBackground();
    segmenter.resetRoomState();
  }
  sets_seen_ = 0;
  tracked_regions_ = false;
  redetect_next_set_ = false;
  sets_since_recheck_ = 0;
  provisional_track_ = false;
  still_kept_.clear();
}

cv::Mat TrackingPipeline::foregroundMask(int camera) const {
  const ImageSegmenter& segmenter = segmenters_.at(camera);
  if (camera < static_cast<int>(still_kept_.size()) && !still_kept_[camera].empty()) {
    return still_kept_[camera];
  }
  return segmenter.lastForegroundMask();
}

void TrackingPipeline::checkImage(const CameraImage& image) const {
  if (image.camera < 0 || image.camera >= static_cast<int>(cameras_.size())) {
    throw InputError("image of unknown camera index " + std::to_string(image.camera) + " (" +
                     std::to_string(cameras_.size()) + " cameras)");
  }
  const Camera& camera = cameras_[image.camera];
  if (image.rgb.cols != camera.width || image.rgb.rows != camera.height) {
    throw InputError("camera '" + camera.name + "': image is " + std::to_string(image.rgb.cols) +
                     "x" + std::to_string(image.rgb.rows) + " but its calibration says " +
                     std::to_string(camera.width) + "x" + std::to_string(camera.height));
  }
}

bool TrackingPipeline::chooseRegionsAcrossViews(const FrameSet& set, bool tracking,
                                                StillRegions* still_regions) {
  std::vector<std::vector<HandCandidate>> candidates(cameras_.size());
  for (const CameraImage& image : set.images) {
    candidates[image.camera] = segmenters_[image.camera].handCandidates(
        image.rgb, params_.multi_view.max_candidates_per_view);
  }
  const MultiViewChoice choice =
      chooseConsistentCandidates(cameras_, candidates, params_.multi_view);
  if (tracking) {
    // A track started on a still scene yields to a hand that moves elsewhere and that as many
    // views see (the still start may have taken a prop before the hand came into view).
    const MultiViewChoice at_track =
        supportAt(cameras_, candidates, tracked_centre_, params_.multi_view);
    const bool replace = provisional_track_
                             ? replacesProvisionalTrack(choice, at_track, params_.multi_view)
                             : replacesTrack(choice, at_track, params_.multi_view);
    if (!replace) return false;
    tracker_.reset();
    // A provisional track was on something still (a face, a photograph): what the segmenters
    // learned from it as the hand's colours would keep the hand out (a fitted model's own skin
    // gate made the office's face such a start: 12.9 mm instead of 3.6 on adbadd, doc/
    // segmentation.md "Session 22"). A confirmed track that is replaced was on moving skin: its
    // colours are kept (forgetting them too cost daylight pinch 0.6 mm).
    if (provisional_track_) {
      for (ImageSegmenter& segmenter : segmenters_) segmenter.forgetTrackedHand();
    }
    tracked_regions_ = false;
    provisional_track_ = false;
  }
  const int margin = params_.multi_view.region_margin_cells;
  // Per camera, the region of `hypothesis`' candidate there (all zero where it has none).
  auto regionsOf = [&](const MultiViewChoice& hypothesis) {
    std::vector<cv::Mat> regions(cameras_.size());
    for (const CameraImage& image : set.images) {
      const int c = image.camera;
      const int chosen = hypothesis.chosen[c];
      regions[c] = candidateRegion(chosen >= 0 ? &candidates[c][chosen] : nullptr,
                                   cameras_[c].width, cameras_[c].height, margin);
    }
    return regions;
  };
  std::vector<cv::Mat> regions = regionsOf(choice);
  if (!choice.found && !tracking && still_regions != nullptr &&
      params_.multi_view.still_hypotheses > 0) {
    for (const MultiViewChoice& hypothesis :
         stillHypotheses(cameras_, candidates, params_.multi_view)) {
      still_regions->push_back(regionsOf(hypothesis));
      for (const CameraImage& image : set.images) {
        regions[image.camera] |= still_regions->back()[image.camera];
      }
    }
  }
  // Nothing agrees across the views (an all-zero region): no blob of this view is the hand.
  for (const CameraImage& image : set.images) {
    segmenters_[image.camera].setRegionOfInterest(regions[image.camera], RegionSource::kCandidates);
  }
  return true;
}

std::optional<FrameResult> TrackingPipeline::startOnStillHypotheses(
    const FrameSet& set, const StillRegions& still_regions,
    std::vector<CameraObservation>* observations) {
  // This set's foreground (inside the union of the hypotheses' regions) per camera; empty for a
  // camera without an image in the set.
  std::vector<cv::Mat> foregrounds(cameras_.size());
  for (const CameraImage& image : set.images) {
    foregrounds[image.camera] = segmenters_[image.camera].lastForegroundMask();
  }
  std::vector<std::vector<CameraObservation>> trials;
  for (const std::vector<cv::Mat>& regions : still_regions) {
    std::vector<CameraObservation>& trial = trials.emplace_back(*observations);
    for (CameraObservation& observation : trial) {
      const int camera = set.images[&observation - trial.data()].camera;
      observation.sog = keepInsideRegion(observation.sog, regions[camera]);
      // The sleeve beside this hypothesis' blob only (the set's was beside all of them).
      segmenters_[camera].sleeveEvidence(foregrounds[camera] & regions[camera], &observation.sog);
      undistortImageSoG(observation.camera, &observation.sog);
    }
  }
  std::optional<StillStart> start =
      startOnStillScene(tracker_.model(), params_.tracker, trials, cameras_, foregrounds,
                        params_.multi_view.still_min_score, set.stamp(), sets_seen_ - 1);
  // What the set keeps (foregroundMask): the chosen hypothesis' regions, or nothing.
  still_kept_.assign(cameras_.size(), cv::Mat());
  for (const CameraImage& image : set.images) {
    const int c = image.camera;
    still_kept_[c] = start ? foregrounds[c] & still_regions[start->hypothesis][c]
                           : cv::Mat(foregrounds[c].size(), CV_8UC1, cv::Scalar(0));
  }
  if (!start) {
    for (CameraObservation& observation : *observations) observation.sog.gaussians.clear();
    return std::nullopt;
  }
  *observations = std::move(trials[start->hypothesis]);
  tracker_ = std::move(*start->tracker);
  return start->result;
}

ProcessedFrame TrackingPipeline::process(const FrameSet& set,
                                         std::vector<CameraObservation>* observations_out) {
  for (const CameraImage& image : set.images) checkImage(image);
  if (observations_out) observations_out->clear();
  ProcessedFrame processed;
  processed.result.stamp = set.stamp();
  processed.result.num_cameras = static_cast<int>(set.images.size());

  if (sets_seen_ < params_.background_frames) {
    ++sets_seen_;
    for (const CameraImage& image : set.images) {
      segmenters_[image.camera].addBackgroundFrame(image.rgb);
    }
    processed.background = true;
    processed.result.status = TrackStatus::kWaiting;
    return processed;
  }
  ++sets_seen_;

  const auto segmentation_start = std::chrono::steady_clock::now();
  for (cv::Mat& kept : still_kept_) kept.release();
  StillRegions still_regions;
  if (params_.segmentation.room.enabled && params_.multi_view.enabled) {
    if (!tracked_regions_) {
      chooseRegionsAcrossViews(set, false, &still_regions);
    } else if (provisional_track_ ||
               (params_.multi_view.recheck_interval > 0 &&
                ++sets_since_recheck_ >= params_.multi_view.recheck_interval)) {
      sets_since_recheck_ = 0;
      chooseRegionsAcrossViews(set, true);
    }
  }
  // Still hypotheses are told apart after segmentation, in raw pixels: undistorted later.
  const bool still = !still_regions.empty();
  std::vector<CameraObservation> observations;
  observations.reserve(set.images.size());
  for (const CameraImage& image : set.images) {
    CameraObservation observation;
    observation.camera = cameras_[image.camera];
    observation.sog = segmenters_[image.camera].segmentFrame(image.rgb);
    if (!still) undistortImageSoG(observation.camera, &observation.sog);
    observations.push_back(std::move(observation));
  }
  processed.segmentation_seconds = secondsSince(segmentation_start);

  const auto tracking_start = std::chrono::steady_clock::now();
  std::optional<FrameResult> still_start;
  if (still) still_start = startOnStillHypotheses(set, still_regions, &observations);
  // The first set segmented in a started hand's region (PipelineParams::
  // redetect_in_started_region).
  if (redetect_next_set_ && !still_start) tracker_.requestRedetection();
  redetect_next_set_ = false;
  processed.result =
      still_start ? *still_start : tracker_.update(observations, set.stamp(), sets_seen_ - 1);
  processed.late = tracker_.takeLateResults();
  processed.tracking_seconds = secondsSince(tracking_start);
  for (const CameraObservation& observation : observations) {
    processed.image_gaussians += static_cast<int>(observation.sog.gaussians.size());
  }

  if (params_.segmentation.room.enabled) {
    const FrameResult& result = processed.result;
    const bool tracked = result.has_pose && result.status != TrackStatus::kLost;
    // Posed once for every camera's region and the centre.
    const PosedHand hand = tracked ? forwardKinematics(tracker_.model(), result.pose) : PosedHand();
    for (size_t c = 0; c < segmenters_.size(); ++c) {
      if (!tracked) {
        segmenters_[c].setRegionOfInterest(cv::Mat());
        continue;
      }
      segmenters_[c].setRegionOfInterest(projectedHandMask(hand, cameras_[c]), RegionSource::kTrack,
                                         segmenters_[c].usesModelSilhouette()
                                             ? projectedModelSilhouette(hand, cameras_[c])
                                             : cv::Mat());
    }
    tracked_regions_ = tracked;
    redetect_next_set_ =
        redetect_in_started_region_ && tracked && result.status == TrackStatus::kStarted;
    if (tracked) {
      tracked_centre_.setZero();
      for (const WorldGaussian& g : hand.gaussians) tracked_centre_ += g.mean;
      tracked_centre_ /= static_cast<double>(std::max<size_t>(hand.gaussians.size(), 1));
      if (still_start) {
        provisional_track_ = true;
        provisional_origin_ = tracked_centre_;
      } else if (provisional_track_ && (tracked_centre_ - provisional_origin_).norm() >=
                                           params_.multi_view.still_confirm_distance) {
        provisional_track_ = false;  // it moved: a hand in use
      }
    } else {
      sets_since_recheck_ = 0;
      provisional_track_ = false;
    }
  }
  if (observations_out) *observations_out = std::move(observations);
  return processed;
}

}  // namespace sag_hand_tracker
