// What cannot be hand, per cell of the image: the background plate learned from frames without
// the hand (with its shadow and dark-sleeve tests) and the skin-colour gate. ImageSegmenter
// (quadtree_segmentation.h) applies them before the quad-tree. Core library: OpenCV + Eigen only.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

// Background plate: the mean colour of every cell (cell_size x cell_size pixels) over frames
// without the hand, and its spread over those frames. A cell of a new frame is background when
//   1. its mean colour c is within the plate's tolerance: sum_k ((c_k - p_k) / tol_k)^2 <= 1 with
//      tol_k = max(k_sigma * spread_k, min_tolerance) (RGB units), or
//   2. it is a shadow on the plate: darker (brightness ratio (r+g+b)/(r_p+g_p+b_p) in
//      [shadow_min_ratio, 1]) with the same chromaticity: max_k |c_k/sum(c) - p_k/sum(p)| <=
//      shadow_chroma_tolerance. A cast shadow scales all channels alike (also after the camera's
//      gamma), so it keeps the normalised rgb of the surface; a hand does not.
// A cell that differs from the plate is then still rejected when it is too dark to be skin
// (value < dark_max_value) or dark and unsaturated (value < sleeve_max_value and saturation <
// sleeve_max_saturation): the black sleeve the paper asks the user to wear, and deep shadows.
// Limitation: a surface whose chromaticity equals the skin's (e.g. beige wood) cannot tell a darker
// hand from a shadow; a plate_and_skin mode does not help there either. Prefer neutral tables.
struct BackgroundParams {
  int frames = 10;  // frames needed before the plate is ready (more are averaged in as well)
  double k_sigma = 3.0;
  double min_tolerance = 12.0;  // RGB units (the cell mean's noise floor, small flicker)
  double shadow_min_ratio = 0.25;
  double shadow_chroma_tolerance = 0.04;
  double shadow_min_plate_brightness = 30.0;  // r+g+b of the plate; darker plate: no shadow test
  double dark_max_value = 0.12;
  double sleeve_max_value = 0.35;
  double sleeve_max_saturation = 0.3;
};

// Skin-colour gate on the cell's mean colour in HSV: hue in the circular range
// [hue_min_deg, hue_max_deg] (red to orange-yellow; skin of every tone has R > G > B, i.e. hue in
// about [0, 50] degrees, slightly below 0 under pinkish light), saturation in [saturation_min,
// saturation_max] (rejects grey, white, black and vivid red/orange objects), value >= value_min
// (rejects black). Rejects blue, green, purple and neutral colours. Beige/wood/cardboard objects
// pass, and so do the cells where a saturated red object blends with a grey surface (its outline):
// use a plate (or plate_and_skin) when such things are in view.
struct SkinParams {
  double hue_min_deg = -25.0;  // = 335 degrees
  double hue_max_deg = 50.0;
  double saturation_min = 0.12;
  double saturation_max = 0.8;
  double value_min = 0.2;
};

// The user's own skin gate (issue 11): the generic gate above keeps every beige, wooden or orange
// thing; a hand model whose colours were sampled from the user's hand (calibrate_hand, the
// tracker's ~calibrate: HandModel::colours_fitted) gives a gate around those colours instead. The
// margins allow for other light than at the calibration: the hue range of the colours widened by
// hue_margin_deg on each side, the saturation range by the factors below, and value down to
// value_factor of the darkest colour (shading, a dimmer room). In the studio's kitchen the generic
// gate keeps the wooden table joined with the hand and the track never starts; this one drops the
// table (doc/segmentation.md, "Session 22").
struct PersonalSkinGateParams {
  double hue_margin_deg = 12.0;
  double saturation_low_factor = 0.6;
  double saturation_high_factor = 1.6;
  double value_factor = 0.4;
};

// The skin gate around `colours` (HSV: hue degrees, saturation and value in [0, 1]; hues may lie
// on both sides of 0/360). Throws InputError when there is no colour, one is not finite or out of
// range, fewer than 3 in 4 pass the generic gate (SkinParams(): colours sampled from something
// else than skin), or for negative margins.
SkinParams personalSkinGate(const std::vector<Hsv>& colours,
                            const PersonalSkinGateParams& params = PersonalSkinGateParams());

// personalSkinGate of the model's Gaussians' colours: the user's gate when the colours are the
// user's (HandModel::colours_fitted; TrackingPipeline and the segmentation nodelet's skin_model
// use it only then).
SkinParams personalSkinGate(const HandModel& model,
                            const PersonalSkinGateParams& params = PersonalSkinGateParams());

// The gate's ranges for messages and logs: "hue A..B deg, saturation C..D, value >= E".
std::string skinGateText(const SkinParams& gate);

// Skin-colour gate on one colour (RGB in [0, 255]).
bool isSkinColour(const Eigen::Vector3d& rgb, const SkinParams& params);
// The dark/sleeve rejection of BackgroundParams on one colour: true when too dark to be skin or
// dark and unsaturated.
bool isDarkNonSkin(const Eigen::Vector3d& rgb, const BackgroundParams& params);

// The background plate of one camera on a grid of cells (see BackgroundParams for the test).
// Frames are given as cell means; ImageSegmenter computes those from the image.
class BackgroundPlate {
 public:
  explicit BackgroundPlate(int cell_size = 4);
  // Forgets everything; the next frame fixes the size again.
  void reset(int cell_size);

  int cellSize() const { return cell_size_; }
  int width() const { return width_; }  // image size the plate was learned at (0 before)
  int height() const { return height_; }
  int cellsX() const { return cells_x_; }
  int cellsY() const { return cells_y_; }
  int frameCount() const { return frames_; }

  // Adds one frame of width x height pixels given as its cell means: cellsY x cellsX cells (for
  // this size and the cell size, the last row/column clipped by the border), row after row, R,G,B
  // per cell. Throws InputError when the size differs from the first frame's.
  void addFrame(int width, int height, const std::vector<float>& cell_means);

  // Whether a cell (index row * cellsX() + col) with mean colour rgb is background or a shadow
  // on it. Requires frameCount() > 0.
  bool isBackground(int cell, const float* rgb, const BackgroundParams& params) const;
  // The same test for a whole frame given as its cell means (addFrame's layout): differs[cell] is
  // 1 where the cell is not background (nor a shadow on it), else 0. The colour distance runs
  // over all cells in one vectorised loop, the shadow test only on the cells that failed it.
  void differingCells(const std::vector<float>& cell_means, const BackgroundParams& params,
                      std::vector<unsigned char>* differs) const;

  // Blends a cell's mean toward rgb: mean <- (1 - rate) mean + rate rgb (the spread is kept).
  // For a plate that follows slow changes of the scene where the hand is not.
  void adaptCell(int cell, const float* rgb, double rate);

  // Per cell mean colour and spread (standard deviation over the frames), CV_32FC3, RGB.
  cv::Mat mean() const;
  cv::Mat spread() const;

  // cv::FileStorage file (.yml, .yml.gz, .xml, .json): image size, cell size, frame count, mean
  // and spread per cell. load throws InputError for a missing/unreadable/inconsistent file; it
  // adopts the file's cell size.
  void save(const std::string& path) const;
  void load(const std::string& path);

 private:
  void updateCell(int cell);
  void resizeCells(std::size_t cells);
  // The shadow test of a cell that failed the colour distance: darker, the same chromaticity.
  bool isShadow(int cell, const float* rgb, const BackgroundParams& params) const;

  int cell_size_ = 4;
  int width_ = 0;
  int height_ = 0;
  int cells_x_ = 0;
  int cells_y_ = 0;
  int frames_ = 0;
  std::vector<double> sum_;     // per cell and channel: sum over frames of the cell mean
  std::vector<double> sum_sq_;  // same, squares
  // Per cell, in the cell means' layout (R,G,B per cell, row after row) so that the frame's test
  // runs over all cells with vector loads: the mean and spread, the chromaticity (normalised rgb)
  // of the mean, and its brightness (r + g + b, one per cell).
  std::vector<float> mean_;
  std::vector<float> spread_;
  std::vector<float> chroma_;
  std::vector<float> brightness_;
};

}  // namespace sag_hand_tracker
