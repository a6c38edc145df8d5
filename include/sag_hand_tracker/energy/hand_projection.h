// The posed hand's Gaussians seen by one camera: each one's projected ellipse (paper eq. 5) and
// the depth of its mean, for the work outside the energy that needs to know which model Gaussian
// an image region belongs to (colour sampling, the shape fit's score, overlays).
#pragma once

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

// One per model Gaussian of `hand`, in its order; with the model's projection.
std::vector<CameraGaussian> projectModel(const HandModel& model, const PosedHand& hand,
                                         const Camera& camera);

}  // namespace sag_hand_tracker
