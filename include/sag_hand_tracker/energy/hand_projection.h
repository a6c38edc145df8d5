// The posed hand's Gaussians seen by one camera: each one's projected ellipse (paper eq. 5) and
// the depth of its mean, for the work outside the energy that needs to know which model Gaussian
// an image region belongs to (colour sampling, the shape fit's score, overlays), and the model's
// silhouette drawn from them.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

struct CameraGaussian {
  ProjectedGaussian projected;
  double depth = 0.0;  // of the mean, along the camera's optical axis
};

// One per Gaussian of `hand`, in its order, with the projection `mode`.
std::vector<CameraGaussian> projectHand(const PosedHand& hand, const Camera& camera,
                                        ProjectionMode mode = ProjectionMode::kPerspective);
// The same with the model's projection.
std::vector<CameraGaussian> projectModel(const HandModel& model, const PosedHand& hand,
                                         const Camera& camera);

// Whether every Gaussian centre of `hand` lies at least 2 cm in front of `camera`: the regions and
// silhouettes drawn from a hand are all zero otherwise (a hand at or behind the camera).
bool handInFrontOf(const PosedHand& hand, const Camera& camera);

// The ellipse of a projected Gaussian at `sigmas` standard deviations, grown by margin_pixels, as
// cv::ellipse draws it (full axes, degrees). False for an invalid projection or a non-finite
// result.
bool ellipseBox(const ProjectedGaussian& g, double sigmas, double margin_pixels,
                cv::RotatedRect* box);

// Sets to 255 the pixels of `mask` (CV_8UC1) whose centres (integer coordinates, as cv::ellipse)
// lie inside the ellipse `box` (full axes, degrees, as ellipseBox gives it): each row's span
// solved from the ellipse's equation. Exact, where cv::ellipse fills a polygon of up to 72 edges
// (4 under 3 pixels) and draws its outline too; 6 to 14 times faster than it on a hand's
// ellipses (BM_FillEllipse). Returns the rectangle of the pixels set (empty: none, e.g. an
// ellipse between pixel centres); throws InputError for a mask of another type.
cv::Rect fillEllipse(const cv::RotatedRect& box, cv::Mat* mask);

// The posed model's own silhouette in one camera (CV_8UC1 at image size, 255 inside): every model
// Gaussian's exact projected ellipse (projectPerspective) at `sigmas` standard deviations, grown
// by margin_pixels and 0.4 pixel (the outline cv::ellipse added, hand_projection.cpp), filled by
// fillEllipse; an ellipse the projection leaves undefined is left out.
// All zero unless handInFrontOf, as projectedHandMask (tracking_pipeline.h). Used for what the
// model does not explain (the room cues' still things, RoomCueParams) and for the shape fit's
// silhouette score (hand_fit.h).
cv::Mat projectedModelSilhouette(const PosedHand& hand, const Camera& camera, double sigmas = 1.0,
                                 int margin_pixels = 3);
// The same drawn (255) on `mask` (CV_8UC1 of the camera's size), which it does not clear; returns
// a rectangle that holds every pixel drawn (empty: none), for work counted within it only
// (SilhouetteScorer).
cv::Rect drawModelSilhouette(const PosedHand& hand, const Camera& camera, double sigmas,
                             int margin_pixels, cv::Mat* mask);

// Draws each projected Gaussian's 1-sigma ellipse (1 px, anti-aliased) in `colour` on `image`
// (the overlays of the live graph and of calibrate_hand's contact sheet).
void drawProjectedEllipses(const std::vector<CameraGaussian>& projected, const cv::Scalar& colour,
                           cv::Mat* image);

}  // namespace sag_hand_tracker
