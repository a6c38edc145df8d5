#include "sag_hand_tracker/tracking/colour_adaptation.h"

#include <algorithm>
#include <cmath>

#include "sag_hand_tracker/energy/hand_projection.h"
#include "sag_hand_tracker/model/kinematics.h"

namespace sag_hand_tracker {

namespace {
constexpr double kRadToDeg = 180.0 / M_PI;
}  // namespace

GaussianColourStatistics::GaussianColourStatistics(size_t gaussians)
    : weight_(gaussians, 0.0),
      hue_x_(gaussians, 0.0),
      hue_y_(gaussians, 0.0),
      saturation_(gaussians, 0.0),
      value_(gaussians, 0.0) {}

void GaussianColourStatistics::add(const HandModel& model, const Pose& pose,
                                   const std::vector<CameraObservation>& observations) {
  const size_t n = std::min(model.gaussians.size(), weight_.size());
  const PosedHand hand = forwardKinematics(model, pose);
  std::vector<Eigen::Matrix2d> inverse(n);
  for (const CameraObservation& observation : observations) {
    const std::vector<CameraGaussian> projected = projectModel(model, hand, observation.camera);
    for (size_t p = 0; p < n; ++p) {
      if (projected[p].projected.valid) inverse[p] = projected[p].projected.cov.inverse();
    }
    for (const ImageGaussian& q : observation.sog.gaussians) {
      if (!q.mean.allFinite()) continue;
      int nearest = -1;
      for (size_t p = 0; p < n; ++p) {
        if (!projected[p].projected.valid) continue;
        const Eigen::Vector2d d = q.mean - projected[p].projected.mean;
        if (d.dot(inverse[p] * d) > 1.0) continue;
        if (nearest < 0 || projected[p].depth < projected[nearest].depth) {
          nearest = static_cast<int>(p);
        }
      }
      if (nearest >= 0) addSample(static_cast<size_t>(nearest), q.hsv, q.sigma * q.sigma);
    }
  }
}

void GaussianColourStatistics::addSample(size_t p, const Hsv& colour, double weight) {
  if (p >= weight_.size() || !colour.allFinite() || !(weight > 0.0) || !std::isfinite(weight)) {
    return;
  }
  const double h = colour[0] / kRadToDeg;
  weight_[p] += weight;
  hue_x_[p] += weight * std::cos(h);
  hue_y_[p] += weight * std::sin(h);
  saturation_[p] += weight * colour[1];
  value_[p] += weight * colour[2];
}

void GaussianColourStatistics::scale(double factor) {
  for (std::vector<double>* sums : {&weight_, &hue_x_, &hue_y_, &saturation_, &value_}) {
    for (double& sum : *sums) sum *= factor;
  }
}

std::optional<Hsv> GaussianColourStatistics::mean(size_t p) const { return pooledMean({p}); }

std::optional<Hsv> GaussianColourStatistics::pooledMean(const std::vector<size_t>& members,
                                                        double* weight) const {
  double w = 0.0, x = 0.0, y = 0.0, s = 0.0, v = 0.0;
  for (size_t p : members) {
    if (p >= weight_.size()) continue;
    w += weight_[p];
    x += hue_x_[p];
    y += hue_y_[p];
    s += saturation_[p];
    v += value_[p];
  }
  if (weight) *weight = w;
  if (!(w > 0.0)) return std::nullopt;
  double hue = std::atan2(y, x) * kRadToDeg;
  if (hue < 0.0) hue += 360.0;
  return Hsv(hue, s / w, v / w);
}

bool GaussianColourStatistics::operator==(const GaussianColourStatistics& other) const {
  return weight_ == other.weight_ && hue_x_ == other.hue_x_ && hue_y_ == other.hue_y_ &&
         saturation_ == other.saturation_ && value_ == other.value_;
}

std::vector<Hsv> adaptedColours(const HandModel& model, const std::vector<Hsv>& start,
                                const GaussianColourStatistics& statistics,
                                double min_weight_share) {
  std::vector<Hsv> colours = start;
  const size_t n = std::min({model.gaussians.size(), start.size(), statistics.size()});
  if (n == 0) return colours;
  double total = 0.0;
  std::vector<size_t> fingers;
  for (size_t p = 0; p < n; ++p) {
    total += statistics.weight(p);
    if (model.gaussians[p].bone != 0) fingers.push_back(p);
  }
  const double min_weight = min_weight_share * total / n;
  for (size_t p = 0; p < n; ++p) {
    if (model.gaussians[p].bone != 0 || statistics.weight(p) < min_weight) continue;
    if (const std::optional<Hsv> colour = statistics.mean(p)) colours[p] = *colour;
  }
  double fingers_weight = 0.0;
  const std::optional<Hsv> finger_colour = statistics.pooledMean(fingers, &fingers_weight);
  if (finger_colour && fingers_weight >= min_weight * fingers.size()) {
    for (size_t p : fingers) colours[p] = *finger_colour;
  }
  return colours;
}

std::vector<Hsv> modelColours(const HandModel& model) {
  std::vector<Hsv> colours;
  for (const ModelGaussian& gaussian : model.gaussians) colours.push_back(gaussian.hsv);
  return colours;
}

}  // namespace sag_hand_tracker
