// The silhouettes of the fit: the foreground an image SoG stands for, and the Dice coefficient of
// a posed model's silhouette against it. The shape fit's score (hand_fit.h) and the tracker's
// finger toggles (tracker.h) use them. No ROS.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "sag_hand_tracker/energy/energy.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/pose.h"

namespace sag_hand_tracker {

// The foreground an image SoG stands for (CV_8UC1, width x height, 255 inside): each image
// Gaussian's square leaf (side sigma sqrt(2 pi), QuadtreeParams::sigma_per_leaf_size).
cv::Mat foregroundOfSoG(const ImageSoG& sog, int width, int height);

// The value of a silhouette mask (foregroundsOf) where the sleeve meets the hand
// (ImageSoG::arm_gaussians) and no foreground is: the sleeve may hide the hand there (a cuff
// covers the heel of the hand), so a model pixel there is charged only in part (`sleeve_charge`).
constexpr unsigned char kSilhouetteOccluded = 128;

// The charge of a model pixel on the sleeve that counts it as one on the background: the tracker's
// finger toggles and size trial score so (with 0 there too, the default hand's default-model
// tracks went 8.13 -> 8.90 mm; doc/calibration.md "Session 44").
constexpr double kSleeveChargedAsBackground = 1.0;

// foregroundOfSoG of each observation's SoG, at its camera's size, with the sleeve's cells next to
// it kSilhouetteOccluded; an empty mask for a camera without foreground (silhouetteScore leaves it
// out).
std::vector<cv::Mat> foregroundsOf(const std::vector<CameraObservation>& observations);

// The silhouette score of a model at a pose in a frame: per camera with a foreground, the Dice
// coefficient 2 |F and M| / (|F| + |M|) of the foreground F (`foregrounds[c]`, the 255 pixels of
// foregroundsOf observation c; empty: the camera is left out) and the model's silhouette M
// (projectedModelSilhouette at `sigmas`, no margin), where a pixel of M on the sleeve
// (kSilhouetteOccluded) counts `sleeve_charge` in |M| (0: neither for nor against the model, 1: as
// on the background); averaged over those cameras. Overlapping Gaussians count once, and the
// model's mass over the background costs what it covers.
double silhouetteScore(const HandModel& model, const std::vector<CameraObservation>& observations,
                       const std::vector<cv::Mat>& foregrounds, const Pose& pose, double sigmas,
                       double sleeve_charge);

// silhouetteScore for many poses in one frame (the tracker's finger toggles): the foregrounds
// (foregroundsOf) and their sizes made once, and each pose's silhouette drawn and counted only
// within its bounding box. The same value as silhouetteScore. `observations` must outlive it.
class SilhouetteScorer {
 public:
  SilhouetteScorer(const std::vector<CameraObservation>& observations, double sigmas,
                   double sleeve_charge);
  double score(const HandModel& model, const Pose& pose);
  // At other sigmas than the constructor's: one scorer (the foregrounds made once) serves a
  // frame's finger toggles and its size trial.
  double score(const HandModel& model, const Pose& pose, double sigmas);

 private:
  const std::vector<CameraObservation>* observations_;
  double sigmas_;
  double sleeve_charge_;
  std::vector<cv::Mat> foregrounds_;
  std::vector<int> foreground_sizes_;
  cv::Mat canvas_;  // all zero between calls
};

}  // namespace sag_hand_tracker
