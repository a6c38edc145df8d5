// What the tracker shows a person: rviz markers of the posed model (one ellipsoid per Gaussian at
// 1 sigma, the skeleton as lines) and overlays of the projected model on the camera images.
#pragma once

#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>
#include <opencv2/core.hpp>

#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/kinematics.h"

namespace sag_hand_tracker {

// Namespace "gaussians" (ids = Gaussian indices, coloured with the model's HSV) and "skeleton"
// (id 0, parent -> bone origin and bone origin -> bone end), in header.frame_id.
visualization_msgs::MarkerArray makeHandMarkers(const HandModel& model, const PosedHand& hand,
                                                const std_msgs::Header& header);

// Draws the 1-sigma ellipse of every model Gaussian that projects validly into `camera` onto the
// 8-bit BGR image, in cyan (the model's skin colour would vanish on the hand). Ideal pinhole
// pixels: with strong lens distortion the ellipses are slightly off near the image border.
void drawHandOverlay(const Camera& camera, const PosedHand& hand, cv::Mat* bgr);

}  // namespace sag_hand_tracker
