// Multi-view consistency of the hand candidates before the start (issue 11): a skin blob that does
// not triangulate with blobs in the other views (a face at the edge of one view, a photograph on
// a wall) is not the hand. TrackingPipeline asks each camera's segmenter for its candidates
// (ImageSegmenter::handCandidates), chooses here the ones that agree on one point in front of every
// camera, and gives each segmenter its choice as this frame's region of interest
// (RegionSource::kCandidates), so that the start triangulates the hand and nothing else.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/segmentation/quadtree_segmentation.h"

namespace sag_hand_tracker {

struct MultiViewParams {
  bool enabled = true;
  int max_candidates_per_view = 4;
  // Two candidates' centroid rays (pixels undistorted) agree when they pass within this (m): the
  // centroids of a hand seen from different sides are different points of its surface.
  double max_ray_distance = 0.04;
  // A view supports a point when one of its candidates' centroids is within this (m, at the
  // point's depth) of the point's projection.
  double support_radius = 0.05;
  double min_depth = 0.05;  // m in front of every camera (TrackerParams::min_camera_depth)
  int min_views = 2;        // supporting views needed for a choice
  // ... and more than this share of the views that have candidates (viewsNeeded; 5 cameras: 3).
  // The user's hand is where the rig looks, in most views; the other hand reaching in at the edge
  // of two of five views is not (the kitchen: a fitted model's own gate started on it and stayed
  // 52 frames, 195 mm; doc/segmentation.md "Session 49"). 0: min_views alone.
  double min_view_share = 0.5;
  // The hand moves: only a pair of candidates of which at least this share of cells moves (in
  // both views) can propose a point; a still face, a photograph or a resting object cannot start
  // the track. 0: no motion needed.
  double min_moving_share = 0.1;
  int region_margin_cells = 2;  // the chosen candidate's cells grown by this for the region
  // The moving cells a choice counts (MultiViewChoice::moving, what the re-check compares) are
  // those of its candidates within this (m, at the point's depth) of the point's projection, a
  // hand's reach from its centre: a blob that merges the hand with a table or a wall photograph
  // supports a track beside it, but the fingers moving at its other end are not that track's
  // (the kitchen: a track on the other arm counted the user's fingers and kept the track 23 sets
  // longer, drawn4's fitted model 236 mm; doc/segmentation.md "Session 49"). 0: all of them.
  double moving_reach = 0.12;
  // While a hand is tracked, every this many sets the choice is made again on the whole images;
  // a choice at least `switch_distance` (m) from the tracked hand, with more supporting views and
  // more than twice the moving cells of the candidates at the tracked hand, replaces the track
  // (the start locked on a slower thing: the other arm drifting before the hand came into view).
  // Every set by default: with 5 the hand that comes into view waited up to 5 sets, 470 mm off,
  // for ~1 ms per set of segmentation (doc/segmentation.md, "Session 20"). 0: never.
  int recheck_interval = 1;
  double switch_distance = 0.15;
  // A still scene (a stereo pair of photographs replayed, a hand held still from the first frame
  // with nothing else moving): when no pair of moving candidates agrees, up to this many places
  // where still candidates agree (stillHypotheses) are each tried with a start of their own
  // (TrackingPipeline). The start with the highest score is kept when the score reaches
  // `still_min_score`. The score is two-sided: the similarity (the share of the foreground the
  // model explains) times the share of the model's core that lies on the foreground
  // (modelOnForeground). A hand fitted to a face or a photograph explains much of that blob
  // (similarity 0.57-0.68 in the studio's office) but lies half on the background (0.4-0.76);
  // on the hand both are high (0.76-0.78 and 0.89-0.93): scores <= 0.43 against >= 0.69
  // (doc/segmentation.md, "Session 14"). 0 hypotheses: a still scene never starts.
  int still_hypotheses = 3;
  double still_min_score = 0.5;
  // A track started on still hypotheses is provisional until its hand has moved this far (m): at
  // the first frame nothing can be seen to move, so the still start may take a prop or the other
  // arm before the hand comes into view; meanwhile it is re-checked every set, and a choice of
  // moving candidates at least switch_distance from it, supported by at least as many views as
  // the track, replaces it. (Any moving choice let the drifting other hand of the studio's
  // daylight room take a still hand's track: 352.6 mm.)
  double still_confirm_distance = 0.05;
  // A still hypothesis has a hand's size: its candidates' area at the point's depth (m^2, the mean
  // over its views, candidateArea) lies within these. An open hand seen flat is about 0.015 m^2, a
  // fist from its side 0.004, a bare forearm adds up to 0.03; a blob far smaller or larger (a
  // flower, a wall-sized photograph) is no hand however it triangulates, and would only take one
  // of the still_hypotheses trials from the hand.
  double still_min_area = 0.002;
  double still_max_area = 0.06;
};
// Throws InputError naming the first bad parameter.
void validate(const MultiViewParams& params);

struct MultiViewChoice {
  bool found = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  // root frame: the hand's centroid
  int supporting_views = 0;
  double score = 0.0;       // sum of the chosen candidates' scores
  int moving = 0;           // sum of the chosen candidates' moving cells near point (moving_reach)
  std::vector<int> chosen;  // per view: index into its candidates, -1 for none
};

// The supporting views a choice needs: min_views, and more than min_view_share of the views with
// at least one candidate (a camera without an image in the set, or that sees nothing, does not
// count).
int viewsNeeded(const std::vector<std::vector<HandCandidate>>& candidates,
                const MultiViewParams& params);

// `candidates[c]` are camera c's (best first). Every pair of moving candidates (min_moving_share)
// of two views is triangulated; a pair that agrees (max_ray_distance) on a point at least min_depth
// in front of every camera gathers the views whose candidates lie at the point's projection. The
// choice has the most supporting views, then the highest score; its point is re-triangulated from
// all of them. Not found when no point has viewsNeeded supporting views. Throws InputError when the
// sizes of `cameras` and `candidates` differ.
MultiViewChoice chooseConsistentCandidates(
    const std::vector<Camera>& cameras, const std::vector<std::vector<HandCandidate>>& candidates,
    const MultiViewParams& params);

// The places where candidates of two or more views agree, without asking for motion, best first
// (as chooseConsistentCandidates ranks them), one per place (the same candidates or a point within
// support_radius of a better one are left out), of a hand's size (still_min_area, still_max_area),
// at most still_hypotheses of them.
std::vector<MultiViewChoice> stillHypotheses(
    const std::vector<Camera>& cameras, const std::vector<std::vector<HandCandidate>>& candidates,
    const MultiViewParams& params);

// The mean over `choice`'s views of its candidate's area (cells x cell_size^2 pixels) at the depth
// of choice.point in that view, in m^2; 0 without views.
double candidateArea(const std::vector<Camera>& cameras,
                     const std::vector<std::vector<HandCandidate>>& candidates,
                     const MultiViewChoice& choice);

// The support of a root-frame point (e.g. the tracked hand's centre): per view the candidate whose
// centroid is nearest its projection within support_radius, else the first candidate whose cells
// reach its projection (a hand merged with a skin-coloured table into one blob whose centroid lies
// far away: the view still sees the hand there); `point` as given, `found` false.
MultiViewChoice supportAt(const std::vector<Camera>& cameras,
                          const std::vector<std::vector<HandCandidate>>& candidates,
                          const Eigen::Vector3d& point, const MultiViewParams& params);

// Whether `challenger` should replace a track whose support is `tracked` (recheck_interval).
bool replacesTrack(const MultiViewChoice& challenger, const MultiViewChoice& tracked,
                   const MultiViewParams& params);

// Whether `challenger` should replace a provisional track (started on a still scene and not yet
// moved still_confirm_distance) whose support is `tracked`: a choice at switch_distance or more
// that at least as many views support (the still start may have taken a prop before the hand came
// into view).
bool replacesProvisionalTrack(const MultiViewChoice& challenger, const MultiViewChoice& tracked,
                              const MultiViewParams& params);

// The region of interest (CV_8UC1, width x height) for a view: the chosen candidate's cells grown
// by margin_cells, or all zero when `candidate` is null (no candidate in this view agrees).
cv::Mat candidateRegion(const HandCandidate* candidate, int width, int height, int margin_cells);

// Keeps the Gaussians whose mean (raw pixels) lies inside `region` (CV_8UC1 at the SoG's size);
// the forearm evidence is kept. Throws InputError for a region of another size or type.
ImageSoG keepInsideRegion(const ImageSoG& sog, const cv::Mat& region);

}  // namespace sag_hand_tracker
