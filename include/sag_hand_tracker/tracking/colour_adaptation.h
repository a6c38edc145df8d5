// The model's colours learnt from the images (issue 9). The model's colours are an average skin's
// under average light; a user's skin, the camera's white balance and the room are not, and eq. 8
// weighs every overlap by d(c_p, c_q) (eq. 6). The paper takes the colours from the images when it
// builds the user's model (section 4); the tracker does the same while it tracks: the frames it
// tracks well teach each model Gaussian the colour of the image regions it covers.
#pragma once

#include <optional>
#include <vector>

#include "sag_hand_tracker/energy/energy.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/pose.h"

namespace sag_hand_tracker {

// TrackerParams::colour_adaptation. A tracked frame is sampled when the track has gone on for
// `min_tracked_frames` frames without a start, a flip or a carried flip hypothesis, and its
// similarity is at least `min_similarity_ratio` times the running average (a frame the model fits
// as well as usual). Every `update_interval` sampled frames the model takes the colours sampled so
// far; older samples fade (each sampled frame multiplies the earlier ones by 1 - 1 / `memory`). A
// Gaussian that covered less than `min_weight_share` of the mean Gaussian's image area keeps its
// start colour (a Gaussian that is always hidden has nothing to learn from).
struct ColourAdaptationParams {
  bool enabled = true;
  int min_tracked_frames = 5;
  double min_similarity_ratio = 0.95;
  int update_interval = 10;
  double memory = 100.0;
  double min_weight_share = 0.1;
};

// Per model Gaussian, area-weighted sums of the colours (hue on the circle) of the image Gaussians
// whose centres fall inside its projected 1-sigma ellipse where it is the nearest model Gaussian
// to the camera.
class GaussianColourStatistics {
 public:
  explicit GaussianColourStatistics(size_t gaussians = 0);

  size_t size() const { return weight_.size(); }
  // Adds one frame: `model` at `pose`, seen by the cameras of `observations`.
  void add(const HandModel& model, const Pose& pose,
           const std::vector<CameraObservation>& observations);
  // Adds one image region of `colour` and area `weight` (px^2) to Gaussian p.
  void addSample(size_t p, const Hsv& colour, double weight);
  // Multiplies every sum by `factor` (forgetting).
  void scale(double factor);
  // The image area (sum of sigma^2, px^2) that Gaussian p has collected.
  double weight(size_t p) const { return weight_[p]; }
  // Its mean colour; empty while it has collected no area.
  std::optional<Hsv> mean(size_t p) const;
  // The mean colour of the Gaussians `members` together, and their area; empty: no area.
  std::optional<Hsv> pooledMean(const std::vector<size_t>& members, double* weight = nullptr) const;

  bool operator==(const GaussianColourStatistics& other) const;

 private:
  std::vector<double> weight_, hue_x_, hue_y_, saturation_, value_;
};

// The colours `model` learns from `statistics`: each palm Gaussian (bone 0) its own mean colour;
// the fingers' Gaussians (every other bone) one colour together, the mean over all of them. A
// finger shows its back, side, pad or nail by turns, so a colour per finger Gaussian learnt in one
// pose misleads in the next: on the benchmark it cost the curled and raised sequences
// (doc/history.md, session 8). A palm Gaussian, or the fingers together, that collected less than
// `min_weight_share` of the mean Gaussian's area keeps the colours of `start` (one per Gaussian).
std::vector<Hsv> adaptedColours(const HandModel& model, const std::vector<Hsv>& start,
                                const GaussianColourStatistics& statistics,
                                double min_weight_share);

// The colours of the model's Gaussians, in order.
std::vector<Hsv> modelColours(const HandModel& model);

}  // namespace sag_hand_tracker
