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

// Room cues (issue 11): in a real room the plate and the skin gate keep faces, arms, wood and
// skin-coloured things. ImageSegmenter::segmentFrame (stateful, one call per frame of one camera)
// narrows their foreground down to the hand:
//   1. learned skin colour: once the hand has been found (the first frame with a region of
//      interest from the tracked hand, RegionSource::kTrack), the chromaticity (r, g) = (R, G) / (R
//      + G + B) of the foreground cells inside it is learned (mean and covariance of the cells
//      within 0.03 of their median, then updated slowly); a cell farther than skin_max_distance
//      (Mahalanobis) from it is not hand. Chromaticity does not change with the light's brightness.
//      While tracking with the skin gate, a cell on the hand's outline against a neutral surface
//      may be farther: its colour is the skin's mixed with grey (skin_border_neutral_share).
//   2. region of interest: the tracked hand projected into this view (setRegionOfInterest, fed by
//      TrackingPipeline with the model's silhouette grown by a margin); cells outside it are
//      background, and inside it only connected
//      components (8-neighbour cells) of at least min_component_share of the largest, or that
//      move, are kept.
//   3. without a region of interest (before the start, after a loss): the one connected component
//      with the best score = cells + motion_weight * moving cells + sleeve_weight * cells next to
//      a dark (sleeve) cell, together with the components inside its box (fingers cut off by a
//      gap). The hand moves and joins the sleeve; a face, a photograph or a resting object do
//      not. With several cameras TrackingPipeline chooses instead among these candidates
//      (handCandidates) the ones that triangulate across the views (multi_view_consistency.h).
//      (Requiring motion before anything counts as hand was tried: it kept the start off still
//      props, but delayed and spoiled the start with the plate; see doc/segmentation.md.)
//   4. motion: a cell moves when its colour differs from the previous frame's (scaled by the
//      frame's overall brightness change, so that changing light is not motion) by more than
//      motion_threshold; it stays "moving" for a while (motion_decay per frame).
//   5. plate adaptation: cells that are background and outside the region of interest are
//      blended into the plate at plate_adaptation_rate per frame, so that a plate learned minutes
//      ago follows the light.
struct RoomCueParams {
  bool enabled = false;
  double skin_max_distance = 3.5;
  // A cell on the hand's outline against a neutral surface (skin gate, while tracking): kept
  // within skin_max_distance of the skin mixed with up to skin_border_neutral_share of grey when
  // it lies between a cell of the learned skin and one that is no candidate and has a saturation
  // below skin_border_neutral_saturation (0 share: off).
  double skin_border_neutral_share = 0.6;
  double skin_border_neutral_saturation = 0.25;
  double skin_learning_rate = 0.02;  // per frame, after the first frame with the hand
  int skin_min_cells = 12;           // foreground cells in the region needed to learn from
  double min_component_share = 0.1;
  double motion_threshold = 15.0;  // RGB units (cell means)
  double motion_decay = 0.9;
  double motion_weight = 4.0;
  double sleeve_weight = 2.0;
  // The forearm evidence (ImageSoG::arm_cells), with or without a plate (this applies whether or
  // not the room cues are enabled): the sleeve's cells (dark and unsaturated; with the plate, also
  // differing from it) within this many cells of the kept foreground, i.e. where the sleeve meets
  // the hand, when they lie to one side of it (centroid at least sleeve_min_offset of its box
  // diagonal from its centroid). 0 cells: no evidence.
  int sleeve_band_cells = 4;
  double sleeve_min_offset = 0.25;
  double plate_adaptation_rate = 0.05;
  // 6. two-class colour (the user's skin against this camera's skin-coloured background): once the
  //    hand is tracked (a region mask of RegionSource::kTrack), a chromaticity histogram of the
  //    kept skin cells deep inside the region (at least colour_core_depth pixels from its edge:
  //    under the model) and one of the skin-gate cells outside the region or in its rim (less than
  //    colour_rim_depth from its edge: where a wooden edge or a photograph touches the hand) are
  //    learned (colour_learning_rate per frame). A cell inside the region but not in its core is
  //    dropped when its colour is more than colour_ratio times as likely under the background's
  //    histogram as under the hand's (3 x 3 bins around it). 0 turns the cue off.
  double colour_ratio = 1.0;
  double colour_learning_rate = 0.05;
  double colour_core_depth = 16.0;  // pixels inside the region's edge: the hand is sampled there
  double colour_rim_depth = 5.0;    // pixels: the region's rim, sampled as background
  // 7. still objects beside the hand (without a plate): a cell that has stayed outside the tracked
  //    model's own silhouette (setRegionOfInterest's model_silhouette) with an unchanged colour
  //    (cue 4's motion test) for still_object_frames frames in a row is not hand, even inside
  //    the region: a skin-coloured ball at the fingertips, a wooden spoon, the other hand at rest.
  //    It counts again once it moves or the model covers it. 0 turns the cue off.
  int still_object_frames = 25;
  // 8. what was there before the hand (without a plate): per cell, the frames since its colour
  //    last changed against the colour it had then (chromaticity by more than
  //    unchanged_chromaticity, or brightness by more than the factor unchanged_brightness, after
  //    the frame's overall light change, so that dimming light and a passing shadow are no
  //    change; a slow edge that creeps across the cell adds up). A region of candidates (the
  //    start) drops its cells older than the older_quantile of its kept cells' ages plus
  //    older_margin_frames; a tracked region takes that quantile once, from the cells under the
  //    model in its first frame with enough of them, and then drops the cells older than it
  //    plus the frames tracked since plus the margin: a skin-coloured ball or a wooden spoon
  //    that lay unchanged beside the hand before the hand came into view, even once the model
  //    covers it. A hand that arrived moving is younger than that however still it holds; a hand
  //    held still from the first frame sets the quantile itself and is kept. Off when false.
  //    A hand in view from the camera's first frame (no frame without it: the kitchen, a graph
  //    started with the hand in view) is as old as the room: when at least
  //    first_frame_hand_share of the cells the quantile is taken from have not changed since
  //    that frame, cells unchanged since then are not dropped (only the moving fingers would
  //    set the quantile, and the still palm would go; doc/segmentation.md "Session 50"); at the
  //    start only those within first_frame_hand_reach_cells of the region's younger cells (the
  //    candidate blob can hold a table or a photograph joined with the hand; 0: all).
  //    first_frame_hand_share above 1 turns this off.
  bool drop_older_than_hand = true;
  int older_margin_frames = 3;
  double older_quantile = 0.25;
  double first_frame_hand_share = 0.5;
  int first_frame_hand_reach_cells = 4;
  double unchanged_chromaticity = 0.03;
  double unchanged_brightness = 3.0;
  // 9. a candidate larger than split_candidate_share of the image's cells (cue 3's group: a
  //    wooden table or a wall photograph joined with the hand) that has moving cells also gives a
  //    candidate of its own of its cells within split_margin_cells of a moving one: the hand that
  //    moves inside it. In the kitchen no candidate agreed across the views before (no start in
  //    110 frames with the generic gate). 0 turns the cue off.
  double split_candidate_share = 0.15;
  int split_margin_cells = 6;
};

struct SegmentationParams {
  SegmentationMode mode = SegmentationMode::kPlate;
  // Foreground decisions (plate, skin) are made per cell_size x cell_size cell on the cell's mean
  // colour: power of two >= 1 (1 = per pixel). The silhouette is accurate to a cell.
  int cell_size = 4;
  // A foreground cell none of whose 8 neighbours is foreground is dropped (noise, specular spots).
  bool remove_isolated_cells = true;
  // With the skin gate alone (no plate), the foreground cells on the silhouette's border (a
  // 4-neighbour is background) are decided again pixel by pixel with the gate: each becomes one
  // image Gaussian at its skin pixels' centroid, of their area and colour, and the foreground mask
  // keeps only those pixels. A whole border cell otherwise adds its background pixels to the hand
  // (doc/segmentation.md, "Session 19").
  bool refine_border_pixels = true;
  QuadtreeParams quadtree;
  BackgroundParams background;
  SkinParams skin;
  RoomCueParams room;
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

// One camera's memory of the room cues (ImageSegmenter::segmentFrame).
struct RoomCueState {
  std::vector<float> previous_means;  // cell means of the previous frame
  std::vector<float> motion;          // per cell, decaying 0..1
  std::vector<unsigned char> mask;    // the last foreground, per cell
  int cells_x = 0, cells_y = 0, cell_size = 1, width = 0, height = 0;
  int skin_frames = 0;                   // frames the skin colour was learned from
  double skin_mean[2] = {0.0, 0.0};      // chromaticity (r, g)
  double skin_cov[3] = {0.0, 0.0, 0.0};  // xx, xy, yy
  // Cue 6: chromaticity histograms (kColourBins^2, sum 1) of the hand and of the skin-coloured
  // background; empty until learned.
  static constexpr int kColourBins = 64;
  std::vector<float> hand_colour, background_colour;
  // Cue 7: per cell, the frames in a row it stayed still outside the model's silhouette.
  std::vector<unsigned short> still_outside;
  // Cue 8: per cell, the frames since its colour last changed, and that colour (RGB divided by
  // `light`, the product of the frames' overall brightness changes since the first frame).
  std::vector<int> unchanged_frames;
  std::vector<float> unchanged_colour;
  double light = 1.0;
  int memory_frames = 0;  // frames since unchanged_frames began: a cell at it never changed
  // Cue 8: the tracked hand was in view from the first frame (first_frame_hand_share).
  bool hand_from_first_frame = false;
  // Cue 8: the age quantile of the tracked hand's cells in the track's first frame with enough of
  // them (-1: not yet taken), and the frames tracked since.
  int track_age_reference = -1;
  int track_frames = 0;
  // The last foreground at pixel level when its border cells were refined (refine_border_pixels),
  // else empty (the cells are the foreground).
  cv::Mat pixel_mask;
};

// One hand candidate of a frame without a region of interest (RoomCueParams, cue 3): a connected
// component of candidate cells (after the learned skin colour) together with the components
// inside its box grown by a quarter. The multi-view check (multi_view_consistency.h) picks, across
// the cameras, the candidates that triangulate to one point in front of every camera.
struct HandCandidate {
  double score =
      0.0;  // of its main component: cells + motion_weight * moving + sleeve_weight * sleeve
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();  // pixels, of the image as given (distorted)
  cv::Rect box;                                        // pixels
  int moving = 0;                                      // its cells that move (cue 4)
  std::vector<int> cell_indices;                       // its cells, row after row
  // The moving ones among them, row after row (the multi-view check counts those near a point:
  // MultiViewParams::moving_reach); empty when it has none or was made without them.
  std::vector<int> moving_cell_indices;
  int cell_size = 1;
  int cells_x = 0;  // cells per row

  // The centre (pixels, as `centroid`) of cell `index` of the image's cell grid.
  Eigen::Vector2d cellCentre(int index) const {
    return Eigen::Vector2d((index % cells_x + 0.5) * cell_size - 0.5,
                           (index / cells_x + 0.5) * cell_size - 0.5);
  }
};

// Where a region of interest comes from (ImageSegmenter::setRegionOfInterest).
enum class RegionSource {
  kTrack,      // the tracked hand projected: the user's skin colour is learned from what it keeps
  kCandidates  // this frame's multi-view choice before the start: nothing is learned from it, and
               // an all-zero mask keeps no foreground at all (no candidate in this view agrees)
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

  // ---- stateful use, one call per frame of this camera (RoomCueParams) ----
  // The tracked hand's box in this view for the next segmentFrame calls (pixels; clipped to the
  // image). An empty rectangle clears it.
  void setRegionOfInterest(const cv::Rect& roi);
  // The same with the region as a mask (CV_8UC1 at image size, non-zero = region), e.g. the
  // tracked model's projected silhouette grown by a margin: tighter than its box, which in a room
  // holds much background. An empty mask clears the region. Throws InputError for another type.
  // model_silhouette (optional, kTrack only; CV_8UC1 at the mask's size): the tracked model's own
  // silhouette (projectedModelSilhouette), for cue 7.
  void setRegionOfInterest(const cv::Mat& roi_mask, RegionSource source = RegionSource::kTrack,
                           const cv::Mat& model_silhouette = cv::Mat());
  // Whether cue 7 or 8 runs, so that a tracked region should come with the model's silhouette:
  // room cues on, still_object_frames > 0 or drop_older_than_hand, and no plate in use (a plate
  // holds still things already).
  bool usesModelSilhouette() const;
  // The hand candidates of `rgb` as segmentFrame would choose among them when no region of
  // interest is set (best first, at most max_candidates), without changing any memory. Empty
  // when params().room.enabled is false or the mode is none. Same errors as segment.
  std::vector<HandCandidate> handCandidates(const cv::Mat& rgb, int max_candidates) const;
  const cv::Rect& regionOfInterest() const { return roi_; }
  // As segment(), then, when params().room.enabled, the room cues narrow the foreground down to
  // the hand, and update the motion history, the learned skin colour and the plate.
  ImageSoG segmentFrame(const cv::Mat& rgb, std::vector<QuadtreeLeaf>* leaves = nullptr);
  // The foreground of the last segmentFrame call (CV_8UC1, 255 = foreground; empty before).
  cv::Mat lastForegroundMask() const;
  // Without a plate (the skin gate, room cues on), in the image last given to segmentFrame: the
  // forearm evidence of `kept` (CV_8UC1 at the image's size; a cell counts when its centre pixel
  // is set), i.e. the sleeve beside that part of the foreground (RoomCueParams::
  // sleeve_band_cells), written to sog->arm_cells and arm_centroid; segmentFrame gives it for
  // everything it kept. With a plate `sog` is left as it is (the plate's evidence). Changes no
  // memory. Throws InputError before any segmentFrame or for a mask of another size.
  void sleeveEvidence(const cv::Mat& kept, ImageSoG* sog) const;
  bool skinColourLearned() const { return room_.skin_frames > 0; }
  // Forgets the motion history, the learned skin colour and the region of interest.
  void resetRoomState();
  // Forgets what was learned from a tracked hand (cue 1's skin colour, cue 6's histograms) and
  // keeps the scene's history (motion, cue 8's ages): for a track that turned out to be something
  // else and is replaced (TrackingPipeline's re-check), whose colours are not the hand's.
  void forgetTrackedHand();

 private:
  SegmentationParams params_;
  BackgroundPlate plate_;
  cv::Rect roi_;
  cv::Mat roi_mask_;
  cv::Mat model_silhouette_;
  RegionSource roi_source_ = RegionSource::kTrack;
  RoomCueState room_;
};

// The quad-tree alone on the whole image (mode none), for tools and tests.
ImageSoG quadtreeSegment(const cv::Mat& rgb, const QuadtreeParams& params,
                         std::vector<QuadtreeLeaf>* leaves = nullptr);

// Throws InputError unless rgb is a non-empty CV_8UC3 image; what names the caller in the message.
void checkRgbImage(const cv::Mat& rgb, const char* what);

}  // namespace sag_hand_tracker
