// From a camera image to its 2D Sum of Gaussians (paper section 4.1, "2D RGB Image Modeling";
// doc/design.md section 3): quad-tree clustering into regions of near-uniform colour, one isotropic
// Gaussian per leaf, and the removal of what cannot be hand (background plate, skin-colour gate).
// Core library: OpenCV + Eigen only, no ROS. The tracker, the offline tools and the segmentation
// nodelet all call ImageSegmenter::segment, so the live graph and the benchmarks measure the same
// code.
//
// Conventions: images are CV_8UC3 in R,G,B order (convert bgr8 before calling); pixel centres are
// at integer coordinates, so the pixel (col, row) covers [col - 0.5, col + 0.5] x [row - 0.5,
// row + 0.5]; RGB values are in [0, 255]; HSV as in colour.h (h degrees, s and v in [0, 1]).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "sag_hand_tracker/segmentation/background_plate.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

// Which pixels may become image Gaussians.
enum class SegmentationMode {
  kNone,         // the whole image, background included
  kPlate,        // what differs from the learned background plate, minus shadows and dark sleeves
  kSkin,         // what has skin colour (no plate needed)
  kPlateAndSkin  // both tests must pass
};
const char* toString(SegmentationMode mode);
// "none", "plate", "skin", "plate_and_skin"; anything else throws InputError.
SegmentationMode parseSegmentationMode(const std::string& name);

// Quad-tree clustering. The image is covered by a grid of root squares of max_leaf_size pixels
// (the last row/column is clipped by the image border when the size is not a multiple); a square
// is split into four while it is larger than min_leaf_size and either its colour is not uniform
// enough, it is clipped by the border, or (with a foreground mask) it is partly foreground.
struct QuadtreeParams {
  // pixels; power of two >= 1. Colour edges are resolved down to this size, and they produce most
  // leaves: 2 gives about twice as many Gaussians as 4.
  int min_leaf_size = 4;
  int max_leaf_size = 32;  // pixels; power of two, min_leaf_size <= max_leaf_size <= 128
  // A square is a leaf when the standard deviation of every RGB channel over its pixels is at most
  // this (RGB units). Camera noise (std 2-5) stays below it; colour edges and texture do not.
  double max_colour_std = 12.0;
  // sigma = sigma_per_leaf_size * side. Default 1/sqrt(2 pi) = 0.399: the (unnormalised) Gaussian's
  // integral 2 pi sigma^2 then equals the area side^2 of the square it stands for, so the image SoG
  // carries the same mass as the pixels it replaces and E_qq = pi sigma^2 = side^2 / 2. (Matching
  // the second moment of the square instead would give 1/sqrt(12) = 0.289.) A leaf clipped to a
  // w x h rectangle by the image border uses sqrt(w h) as its side.
  double sigma_per_leaf_size = 0.3989422804014327;
};

struct SegmentationParams {
  SegmentationMode mode = SegmentationMode::kPlate;
  // Foreground decisions (plate, skin) are made per cell_size x cell_size cell on the cell's mean
  // colour: power of two >= 1 (1 = per pixel). The silhouette is accurate to a cell.
  int cell_size = 4;
  // A foreground cell none of whose 8 neighbours is foreground is dropped (noise, specular spots).
  bool remove_isolated_cells = true;
  QuadtreeParams quadtree;
  BackgroundParams background;
  SkinParams skin;
};
// Throws InputError naming the first bad parameter.
void validate(const SegmentationParams& params);

// One quad-tree leaf in pixels: columns [x, x + width), rows [y, y + height); mean RGB colour.
struct QuadtreeLeaf {
  int x = 0;
  int y = 0;
  int width = 0;
  int height = 0;
  Eigen::Vector3d rgb = Eigen::Vector3d::Zero();
};

// The single entry point: learn a plate (optional), then turn images into image SoGs.
// segment() and foregroundMask() are const and thread-safe (scratch buffers are per thread).
class ImageSegmenter {
 public:
  explicit ImageSegmenter(const SegmentationParams& params = SegmentationParams());

  const SegmentationParams& params() const { return params_; }
  // Validates; keeps the learned plate unless the cell size changes (then the plate is reset).
  void setParams(const SegmentationParams& params);

  // Learning the plate from frames without the hand. The first frame fixes the image size.
  void addBackgroundFrame(const cv::Mat& rgb);
  // The plate holds at least params().background.frames frames (a loaded plate counts with the
  // frame count stored in its file; more frames can still be added to it).
  bool backgroundReady() const;
  int backgroundFrameCount() const { return plate_.frameCount(); }
  void resetBackground();
  const BackgroundPlate& backgroundPlate() const { return plate_; }
  void saveBackground(const std::string& path) const;
  // Throws InputError as BackgroundPlate::load, and when the file's cell size differs from
  // params().cell_size (the segmenter is left unchanged then).
  void loadBackground(const std::string& path);

  // The mode actually applied: plate and plate_and_skin fall back to skin while the plate is not
  // ready, so that the tracker never sees the unmodelled background.
  SegmentationMode effectiveMode() const;

  // The image SoG (width, height and one Gaussian per leaf); with a foreground test active only
  // foreground leaves. leaves (optional) receives the leaf rectangles, in the same order.
  // Throws InputError for an empty image, a type other than CV_8UC3, or a size different from the
  // plate's (when the plate is used).
  ImageSoG segment(const cv::Mat& rgb, std::vector<QuadtreeLeaf>* leaves = nullptr) const;

  // The foreground decision at image size: CV_8UC1, 255 where leaves may be, 0 elsewhere (all 255
  // in mode none). For debugging overlays and the automatic start. Same errors as segment.
  cv::Mat foregroundMask(const cv::Mat& rgb) const;

 private:
  SegmentationParams params_;
  BackgroundPlate plate_;
};

// The quad-tree alone on the whole image (mode none), for tools and tests.
ImageSoG quadtreeSegment(const cv::Mat& rgb, const QuadtreeParams& params,
                         std::vector<QuadtreeLeaf>* leaves = nullptr);

// Throws InputError unless rgb is a non-empty CV_8UC3 image; what names the caller in the message.
void checkRgbImage(const cv::Mat& rgb, const char* what);

}  // namespace sag_hand_tracker
