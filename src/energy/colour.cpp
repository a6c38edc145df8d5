#include "sag_hand_tracker/energy/colour.h"

#include <algorithm>
#include <cmath>

namespace sag_hand_tracker {

Hsv rgbToHsv(double r, double g, double b) {
  r /= 255.0;
  g /= 255.0;
  b /= 255.0;
  const double max = std::max({r, g, b});
  const double min = std::min({r, g, b});
  const double chroma = max - min;
  double hue = 0.0;
  if (chroma > 1e-12) {
    if (max == r) {
      hue = 60.0 * std::fmod((g - b) / chroma, 6.0);
    } else if (max == g) {
      hue = 60.0 * ((b - r) / chroma + 2.0);
    } else {
      hue = 60.0 * ((r - g) / chroma + 4.0);
    }
    if (hue < 0.0) hue += 360.0;
  }
  const double saturation = max > 1e-12 ? chroma / max : 0.0;
  return Hsv(hue, saturation, max);
}

Eigen::Vector3d hsvToRgb(const Hsv& hsv) {
  const double h = std::fmod(std::fmod(hsv[0], 360.0) + 360.0, 360.0) / 60.0;
  const double s = std::clamp(hsv[1], 0.0, 1.0), v = std::clamp(hsv[2], 0.0, 1.0);
  const double c = v * s, x = c * (1.0 - std::fabs(std::fmod(h, 2.0) - 1.0)), m = v - c;
  Eigen::Vector3d rgb;
  switch (static_cast<int>(h)) {
    case 0:
      rgb << c, x, 0;
      break;
    case 1:
      rgb << x, c, 0;
      break;
    case 2:
      rgb << 0, c, x;
      break;
    case 3:
      rgb << 0, x, c;
      break;
    case 4:
      rgb << x, 0, c;
      break;
    default:
      rgb << c, 0, x;
      break;
  }
  return rgb + Eigen::Vector3d::Constant(m);
}

double wendland(double r) {
  if (r >= 1.0) return 0.0;
  const double one_minus = 1.0 - r;
  const double sq = one_minus * one_minus;
  return sq * sq * (4.0 * r + 1.0);
}

double colourSimilarity(const Hsv& a, const Hsv& b, const ColourSimilarityParams& params) {
  double hue_difference = std::fabs(a[0] - b[0]);
  hue_difference = std::min(hue_difference, 360.0 - hue_difference);  // hue is circular
  // Hue is meaningless for grey colours: scale its weight by the smaller saturation.
  const double hue_weight = std::min(a[1], b[1]);
  const double dh = hue_weight * hue_difference / params.hue_radius_deg;
  const double ds = (a[1] - b[1]) / params.saturation_radius;
  const double dv = (a[2] - b[2]) / params.value_radius;
  return wendland(std::sqrt(dh * dh + ds * ds + dv * dv));
}

Hsv meanColour(const std::vector<Hsv>& colours, const std::vector<double>& weights) {
  double weight_sum = 0.0, cos_sum = 0.0, sin_sum = 0.0, saturation = 0.0, value = 0.0;
  for (size_t i = 0; i < colours.size() && i < weights.size(); ++i) {
    const double w = weights[i];
    const double hue = colours[i][0] * M_PI / 180.0;
    weight_sum += w;
    cos_sum += w * colours[i][1] * std::cos(hue);
    sin_sum += w * colours[i][1] * std::sin(hue);
    saturation += w * colours[i][1];
    value += w * colours[i][2];
  }
  if (!(weight_sum > 0.0)) return Hsv::Zero();
  double hue = std::atan2(sin_sum, cos_sum) * 180.0 / M_PI;
  if (hue < 0.0) hue += 360.0;
  return Hsv(hue, saturation / weight_sum, value / weight_sum);
}

Hsv ColourCast::apply(const Hsv& image_colour) const {
  double hue = std::fmod(image_colour[0] + hue_shift_deg, 360.0);
  if (hue < 0.0) hue += 360.0;
  return Hsv(hue, std::clamp(image_colour[1] * saturation_gain, 0.0, 1.0),
             std::clamp(image_colour[2] * value_gain, 0.0, 1.0));
}

ColourCast colourCast(const Hsv& model_mean, const Hsv& image_mean, double max_gain) {
  ColourCast cast;
  const auto gain = [max_gain](double model, double image) {
    if (!(image > 1e-6) || !(model > 1e-6)) return 1.0;
    return std::clamp(model / image, 1.0 / max_gain, max_gain);
  };
  cast.saturation_gain = gain(model_mean[1], image_mean[1]);
  cast.value_gain = gain(model_mean[2], image_mean[2]);
  double shift = model_mean[0] - image_mean[0];
  shift = std::remainder(shift, 360.0);  // the shorter way round, in (-180, 180]
  // A hue is only as reliable as its saturation: no shift from grey colours.
  cast.hue_shift_deg = std::min(model_mean[1], image_mean[1]) > 0.05 ? shift : 0.0;
  return cast;
}

}  // namespace sag_hand_tracker
