// Colour conversion and the colour similarity term d(c_p, c_q) of the energy (paper eq. 6).
#pragma once

#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

// RGB in [0, 255] to HSV (h degrees, s and v in [0, 1]).
Hsv rgbToHsv(double r, double g, double b);

// HSV (h degrees, s and v in [0, 1]) to RGB in [0, 1], for display.
Eigen::Vector3d hsvToRgb(const Hsv& hsv);

// Radii of the scaled HSV distance: colours further apart than 1 in this metric are dissimilar.
struct ColourSimilarityParams {
  double hue_radius_deg = 40.0;
  double saturation_radius = 0.5;
  double value_radius = 1.0;  // value varies with shading: weight it lightly
};

// Wendland function phi(r) = (1 - r)^4 (4 r + 1) for r < 1, else 0.
double wendland(double r);

// d(c_p, c_q) in [0, 1]: Wendland on the scaled HSV distance, hue circular.
double colourSimilarity(const Hsv& a, const Hsv& b, const ColourSimilarityParams& params);

}  // namespace sag_hand_tracker
