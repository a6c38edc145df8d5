#include "sag_hand_tracker/tracking/tracking_pipeline.h"

#include <chrono>

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
  return params;
}

}  // namespace

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
  for (ImageSegmenter& segmenter : segmenters_) segmenter.resetBackground();
  sets_seen_ = 0;
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
  std::vector<CameraObservation> observations;
  observations.reserve(set.images.size());
  for (const CameraImage& image : set.images) {
    CameraObservation observation;
    observation.camera = cameras_[image.camera];
    observation.sog = segmenters_[image.camera].segment(image.rgb);
    undistortImageSoG(observation.camera, &observation.sog);
    processed.image_gaussians += static_cast<int>(observation.sog.gaussians.size());
    observations.push_back(std::move(observation));
  }
  processed.segmentation_seconds = secondsSince(segmentation_start);

  const auto tracking_start = std::chrono::steady_clock::now();
  processed.result = tracker_.update(observations, set.stamp());
  processed.tracking_seconds = secondsSince(tracking_start);
  if (observations_out) *observations_out = std::move(observations);
  return processed;
}

}  // namespace sag_hand_tracker
