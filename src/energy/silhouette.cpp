#include "sag_hand_tracker/energy/silhouette.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

#include "sag_hand_tracker/energy/hand_projection.h"
#include "sag_hand_tracker/model/kinematics.h"

namespace sag_hand_tracker {

namespace {

// Each Gaussian's square leaf (side sigma sqrt(2 pi)) set to `value` on `mask`, where it is below.
void drawLeaves(const std::vector<ImageGaussian>& gaussians, unsigned char value, cv::Mat* mask) {
  const double side_per_sigma = std::sqrt(2.0 * M_PI);
  for (const ImageGaussian& g : gaussians) {
    if (!g.mean.allFinite() || !(g.sigma > 0.0) || !std::isfinite(g.sigma)) continue;
    const double half = 0.5 * side_per_sigma * g.sigma;
    const cv::Rect leaf(cv::Point(static_cast<int>(std::lround(g.mean.x() - half)),
                                  static_cast<int>(std::lround(g.mean.y() - half))),
                        cv::Point(static_cast<int>(std::lround(g.mean.x() + half)),
                                  static_cast<int>(std::lround(g.mean.y() + half))));
    const cv::Rect inside = leaf & cv::Rect(0, 0, mask->cols, mask->rows);
    for (int y = inside.y; y < inside.y + inside.height; ++y) {  // cv::Mat::setTo costs more
      std::uint8_t* row = mask->ptr<std::uint8_t>(y) + inside.x;
      if (value == 255) {
        std::memset(row, 255, static_cast<std::size_t>(inside.width));
      } else {
        for (int x = 0; x < inside.width; ++x) row[x] = std::max(row[x], value);
      }
    }
  }
}

}  // namespace

cv::Mat foregroundOfSoG(const ImageSoG& sog, int width, int height) {
  cv::Mat mask(height, width, CV_8UC1, cv::Scalar(0));
  drawLeaves(sog.gaussians, 255, &mask);
  return mask;
}

namespace {

// foregroundsOf, with each mask's |F| (its 255 pixels; 0 for an empty mask) counted before the
// sleeve's leaves are drawn (`mark_sleeve`; without, the sleeve scores as the background).
std::vector<cv::Mat> foregroundsAndSizes(const std::vector<CameraObservation>& observations,
                                         bool mark_sleeve, std::vector<int>* sizes) {
  std::vector<cv::Mat> foregrounds;
  foregrounds.reserve(observations.size());
  for (const CameraObservation& observation : observations) {
    if (observation.sog.gaussians.empty()) {
      foregrounds.emplace_back();
      if (sizes) sizes->push_back(0);
      continue;
    }
    foregrounds.push_back(
        foregroundOfSoG(observation.sog, observation.camera.width, observation.camera.height));
    if (sizes) sizes->push_back(cv::countNonZero(foregrounds.back()));
    if (mark_sleeve) {
      drawLeaves(observation.sog.arm_gaussians, kSilhouetteOccluded, &foregrounds.back());
    }
  }
  return foregrounds;
}

}  // namespace

std::vector<cv::Mat> foregroundsOf(const std::vector<CameraObservation>& observations) {
  return foregroundsAndSizes(observations, true, nullptr);
}

namespace {

// Camera c's Dice coefficient 2 |F and M| / (|F| + |M|) of `foreground` (255; |F| =
// foreground_size) and the model's silhouette M (drawModelSilhouette at `sigmas`, no margin; its
// pixels on the sleeve, kSilhouetteOccluded, count `sleeve_charge` each) on `canvas` (a zero mask
// of the camera's size, zero again on return), counted within the drawn rectangle only. False when
// both are empty.
bool cameraDice(const PosedHand& hand, const Camera& camera, const cv::Mat& foreground,
                int foreground_size, double sigmas, double sleeve_charge, cv::Mat* canvas,
                double* dice) {
  if (canvas->rows != camera.height || canvas->cols != camera.width) {
    *canvas = cv::Mat(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  }
  const cv::Rect drawn = drawModelSilhouette(hand, camera, sigmas, 0, canvas);
  // Both counts and the clearing in one pass over the drawn rows.
  int model_size = 0, both = 0, model_occluded = 0;
  for (int y = drawn.y; y < drawn.y + drawn.height; ++y) {
    std::uint8_t* model = canvas->ptr<std::uint8_t>(y) + drawn.x;
    const std::uint8_t* seen = foreground.ptr<std::uint8_t>(y) + drawn.x;
    for (int x = 0; x < drawn.width; ++x) {
      const int drawn_here = model[x] != 0;
      const int occluded = seen[x] == kSilhouetteOccluded;
      model_size += drawn_here & (1 - occluded);
      model_occluded += drawn_here & occluded;
      both += drawn_here & static_cast<int>(seen[x] == 255);
    }
    std::memset(model, 0, static_cast<std::size_t>(drawn.width));
  }
  const double sizes = foreground_size + model_size + sleeve_charge * model_occluded;
  if (sizes <= 0) return false;
  *dice = 2.0 * both / sizes;
  return true;
}

// |F|: the foreground's pixels (255), not the sleeve's.
int foregroundSize(const cv::Mat& foreground) {
  int size = 0;
  for (int y = 0; y < foreground.rows; ++y) {
    const std::uint8_t* row = foreground.ptr<std::uint8_t>(y);
    for (int x = 0; x < foreground.cols; ++x) size += row[x] == 255;
  }
  return size;
}

// The mean over the cameras with a foreground of cameraDice; `foreground_sizes` (|F| per camera)
// counted here when null.
double meanDice(const HandModel& model, const Pose& pose,
                const std::vector<CameraObservation>& observations,
                const std::vector<cv::Mat>& foregrounds, const std::vector<int>* foreground_sizes,
                double sigmas, double sleeve_charge, cv::Mat* canvas) {
  const PosedHand hand = forwardKinematics(model, pose);
  double score = 0.0;
  int cameras = 0;
  for (size_t c = 0; c < observations.size(); ++c) {
    const cv::Mat& foreground = foregrounds[c];
    if (foreground.empty()) continue;
    const Camera& camera = observations[c].camera;
    if (foreground.rows != camera.height || foreground.cols != camera.width) {
      throw InputError("silhouetteScore: camera '" + camera.name +
                       "': the foreground is not of the camera's size");
    }
    const int size = foreground_sizes ? (*foreground_sizes)[c] : foregroundSize(foreground);
    double dice = 0.0;
    if (!cameraDice(hand, camera, foreground, size, sigmas, sleeve_charge, canvas, &dice)) continue;
    score += dice;
    ++cameras;
  }
  return cameras > 0 ? score / cameras : 0.0;
}

}  // namespace

double silhouetteScore(const HandModel& model, const std::vector<CameraObservation>& observations,
                       const std::vector<cv::Mat>& foregrounds, const Pose& pose, double sigmas,
                       double sleeve_charge) {
  if (foregrounds.size() != observations.size()) {
    throw InputError("silhouetteScore: " + std::to_string(observations.size()) +
                     " observations but " + std::to_string(foregrounds.size()) + " foregrounds");
  }
  cv::Mat canvas;
  return meanDice(model, pose, observations, foregrounds, nullptr, sigmas, sleeve_charge, &canvas);
}

SilhouetteScorer::SilhouetteScorer(const std::vector<CameraObservation>& observations,
                                   double sigmas, double sleeve_charge)
    : observations_(&observations), sigmas_(sigmas), sleeve_charge_(sleeve_charge) {
  // Charged as the background, the sleeve's pixels need no mark (the tracker, every frame).
  foregrounds_ = foregroundsAndSizes(observations, sleeve_charge != kSleeveChargedAsBackground,
                                     &foreground_sizes_);
}

double SilhouetteScorer::score(const HandModel& model, const Pose& pose) {
  return score(model, pose, sigmas_);
}

double SilhouetteScorer::score(const HandModel& model, const Pose& pose, double sigmas) {
  return meanDice(model, pose, *observations_, foregrounds_, &foreground_sizes_, sigmas,
                  sleeve_charge_, &canvas_);
}

}  // namespace sag_hand_tracker
