#include "sag_hand_tracker/tracking/tracking_pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/imgproc.hpp>

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
  validate(params.segmentation);
  validate(params.multi_view);
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
  for (const WorldGaussian& g : hand.gaussians) {
    const Eigen::Vector3d p = camera.world_to_camera * g.mean;
    if (p.z() < 0.02) return cv::Mat(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  }
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

TrackingPipeline::TrackingPipeline(const HandModel& model, const std::vector<Camera>& cameras,
                                   const PipelineParams& params)
    : cameras_(cameras), params_(adjusted(params)), tracker_(model, params.tracker) {
  if (static_cast<int>(cameras_.size()) < params_.tracker.min_cameras_for_start) {
    throw InputError("the tracker starts from at least " +
                     std::to_string(params_.tracker.min_cameras_for_start) +
                     " cameras that see the hand, but there are " +
                     std::to_string(cameras_.size()));
  }
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
  sets_since_recheck_ = 0;
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

bool TrackingPipeline::chooseRegionsAcrossViews(const FrameSet& set, bool tracking) {
  std::vector<std::vector<HandCandidate>> candidates(cameras_.size());
  for (const CameraImage& image : set.images) {
    candidates[image.camera] = segmenters_[image.camera].handCandidates(
        image.rgb, params_.multi_view.max_candidates_per_view);
  }
  const MultiViewChoice choice =
      chooseConsistentCandidates(cameras_, candidates, params_.multi_view);
  if (tracking) {
    const MultiViewChoice at_track =
        supportAt(cameras_, candidates, tracked_centre_, params_.multi_view);
    if (!replacesTrack(choice, at_track, params_.multi_view)) return false;
    tracker_.reset();
    tracked_regions_ = false;
  }
  for (const CameraImage& image : set.images) {
    const int c = image.camera;
    if (!choice.found) {
      // Nothing agrees across the views: no blob of any view is the hand.
      segmenters_[c].setRegionOfInterest(
          candidateRegion(nullptr, cameras_[c].width, cameras_[c].height, 0),
          RegionSource::kCandidates);
      continue;
    }
    const HandCandidate* chosen =
        choice.chosen[c] >= 0 ? &candidates[c][choice.chosen[c]] : nullptr;
    segmenters_[c].setRegionOfInterest(
        candidateRegion(chosen, cameras_[c].width, cameras_[c].height,
                        params_.multi_view.region_margin_cells),
        RegionSource::kCandidates);
  }
  return true;
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
  if (params_.segmentation.room.enabled && params_.multi_view.enabled) {
    if (!tracked_regions_) {
      chooseRegionsAcrossViews(set, false);
    } else if (params_.multi_view.recheck_interval > 0 &&
               ++sets_since_recheck_ >= params_.multi_view.recheck_interval) {
      sets_since_recheck_ = 0;
      chooseRegionsAcrossViews(set, true);
    }
  }
  std::vector<CameraObservation> observations;
  observations.reserve(set.images.size());
  for (const CameraImage& image : set.images) {
    CameraObservation observation;
    observation.camera = cameras_[image.camera];
    observation.sog = segmenters_[image.camera].segmentFrame(image.rgb);
    undistortImageSoG(observation.camera, &observation.sog);
    processed.image_gaussians += static_cast<int>(observation.sog.gaussians.size());
    observations.push_back(std::move(observation));
  }
  processed.segmentation_seconds = secondsSince(segmentation_start);

  const auto tracking_start = std::chrono::steady_clock::now();
  processed.result = tracker_.update(observations, set.stamp(), sets_seen_ - 1);
  processed.late = tracker_.takeLateResults();
  processed.tracking_seconds = secondsSince(tracking_start);

  if (params_.segmentation.room.enabled) {
    const FrameResult& result = processed.result;
    const bool tracked = result.has_pose && result.status != TrackStatus::kLost;
    // Posed once for every camera's region and the centre.
    const PosedHand hand = tracked ? forwardKinematics(tracker_.model(), result.pose) : PosedHand();
    for (size_t c = 0; c < segmenters_.size(); ++c) {
      segmenters_[c].setRegionOfInterest(tracked ? projectedHandMask(hand, cameras_[c])
                                                 : cv::Mat());
    }
    tracked_regions_ = tracked;
    if (tracked) {
      tracked_centre_.setZero();
      for (const WorldGaussian& g : hand.gaussians) tracked_centre_ += g.mean;
      tracked_centre_ /= static_cast<double>(std::max<size_t>(hand.gaussians.size(), 1));
    } else {
      sets_since_recheck_ = 0;
    }
  }
  if (observations_out) *observations_out = std::move(observations);
  return processed;
}

}  // namespace sag_hand_tracker
