// The offline tracking pipeline of one recording: per set of camera images, either learn the
// background plates (the first sets, without the hand) or segment every camera into its image SoG
// (undistorted) and update the tracker. track_bag and the benchmark call it, so they measure the
// same code. No ROS.
#pragma once

#include <vector>

#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/segmentation/quadtree_segmentation.h"
#include "sag_hand_tracker/tracking/frame_set.h"
#include "sag_hand_tracker/tracking/tracker.h"

namespace sag_hand_tracker {

// The outcome of one set: either it went into the background plates (the first frames of a
// recording, without the hand), or it was segmented and tracked.
struct ProcessedFrame {
  bool background = false;  // true: learned as background, `result` holds no pose
  FrameResult result;
  int image_gaussians = 0;  // foreground image Gaussians over all cameras of the set
  double segmentation_seconds = 0.0;
  double tracking_seconds = 0.0;  // HandTracker::update (start or optimisation)
};

struct PipelineParams {
  SegmentationParams segmentation;
  TrackerParams tracker;
  // The first sets go into the background plates and are not tracked. With 0 there is no plate:
  // the segmentation then uses the skin-colour gate (ImageSegmenter::effectiveMode). When > 0 it
  // also sets segmentation.background.frames, so that the plates are ready after these sets.
  int background_frames = 10;
};

class TrackingPipeline {
 public:
  // One segmenter per camera. Throws InputError for fewer cameras than the automatic start needs
  // (TrackerParams::min_cameras_for_start), a camera that fails validateCamera, or bad
  // segmentation or model parameters.
  TrackingPipeline(const HandModel& model, const std::vector<Camera>& cameras,
                   const PipelineParams& params);

  // Processes one set; CameraImage::camera indexes the cameras given to the constructor. Throws
  // InputError for an unknown camera index or an image whose size is not its camera's. With
  // `observations`, a tracked set's cameras and image SoGs (what the tracker saw) are copied there
  // (cleared for a background set).
  ProcessedFrame process(const FrameSet& set,
                         std::vector<CameraObservation>* observations = nullptr);

  // Forgets the track and the background plates: the next sets are background again.
  void reset();

  const std::vector<Camera>& cameras() const { return cameras_; }
  const PipelineParams& params() const { return params_; }
  const HandTracker& tracker() const { return tracker_; }
  const ImageSegmenter& segmenter(int camera) const { return segmenters_.at(camera); }
  // Sets processed so far (background ones included).
  int setsSeen() const { return sets_seen_; }

 private:
  void checkImage(const CameraImage& image) const;

  std::vector<Camera> cameras_;
  PipelineParams params_;
  std::vector<ImageSegmenter> segmenters_;
  HandTracker tracker_;
  int sets_seen_ = 0;
};

}  // namespace sag_hand_tracker
