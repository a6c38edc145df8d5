// Colour conversion and the colour similarity term d(c_p, c_q) of the energy (paper eq. 6).
#pragma once

#include <vector>

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

// Weighted mean of colours: hue as the circular mean weighted by weight x saturation (hue means
// little for grey), saturation and value as weighted arithmetic means. Zero if all weights are 0.
Hsv meanColour(const std::vector<Hsv>& colours, const std::vector<double>& weights);

// A frame's colour cast against the model (issue 9): the user's skin is never the model's, and a
// mismatch of a uniform shift is not uniform in d(c_p, c_q): it favours whichever image region
// happens to be nearer the model colour (with a pale or a dark hand, the fingers curled onto the
// palm). Mapping the foreground's mean colour onto the model's removes the skin tone, the camera's
// white balance and exposure, and keeps every colour difference inside the hand.
struct ColourCast {
  double hue_shift_deg = 0.0;
  double saturation_gain = 1.0;
  double value_gain = 1.0;
  Hsv apply(const Hsv& image_colour) const;
};

// The cast that maps `image_mean` onto `model_mean`; gains are limited to [1 / max_gain,
// max_gain] (a grey or black foreground has no colour to correct).
ColourCast colourCast(const Hsv& model_mean, const Hsv& image_mean, double max_gain);

}  // namespace sag_hand_tracker
