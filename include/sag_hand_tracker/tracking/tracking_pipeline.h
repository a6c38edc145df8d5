// The offline tracking pipeline of one recording: per set of camera images, either learn the
// background plates (the first sets, without the hand) or segment every camera into its image SoG
// (undistorted) and update the tracker. track_bag and the benchmark call it, so they measure the
// same code. No ROS.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/segmentation/multi_view_consistency.h"
#include "sag_hand_tracker/segmentation/quadtree_segmentation.h"
#include "sag_hand_tracker/tracking/frame_set.h"
#include "sag_hand_tracker/tracking/tracker.h"

namespace sag_hand_tracker {

// The outcome of one set: either it went into the background plates (the first frames of a
// recording, without the hand), or it was segmented and tracked.
struct ProcessedFrame {
  bool background = false;  // true: learned as background, `result` holds no pose
  FrameResult result;       // frame_id: the set's index (setsSeen() - 1)
  // Earlier sets' late results (HandTracker::takeLateResults; only with
  // TrackerParams::asynchronous_search, which the offline tools keep off).
  std::vector<FrameResult> late;
  int image_gaussians = 0;  // foreground image Gaussians over all cameras of the set
  double segmentation_seconds = 0.0;
  double tracking_seconds = 0.0;  // HandTracker::update (start or optimisation)
};

struct PipelineParams {
  SegmentationParams segmentation;
  TrackerParams tracker;
  // With segmentation.room.enabled, the pose tracked in a set gives each camera's segmenter its
  // region of interest for the next set (projectedHandMask); a lost track clears them. Without a
  // tracked region (before the start, after a loss), with multi_view.enabled the candidates of
  // every camera that triangulate to one point (chooseConsistentCandidates) are this set's regions.
  MultiViewParams multi_view;
  // The first sets go into the background plates and are not tracked. With 0 there is no plate:
  // the segmentation then uses the skin-colour gate (ImageSegmenter::effectiveMode). When > 0 it
  // also sets segmentation.background.frames, so that the plates are ready after these sets.
  int background_frames = 10;
  // Without a plate (background_frames 0) the generic skin gate's foreground holds more than the
  // hand (a wooden table, a photograph, the other arm), and the tracker's starts are scored with
  // model area charged at least this much (TrackerParams::start_model_area_weight). With a plate,
  // or with the user's own gate (skin_gate_from_model, which drops those things), the tracker's
  // own setting stays. 0.3: over 11 hands in the studio's rooms (doc/segmentation.md, "Session
  // 33") the kitchen's error fell 83.7 -> 57.1 mm with the clean studio's 6.55 -> 6.09; 1 gave
  // 48.0 mm in the kitchen but 6.83 in the clean studio (the dark hand 12.8 -> 19.2 mm).
  double skin_gate_start_area_weight = 0.3;
  // With a model whose colours are the user's (HandModel::colours_fitted: calibrate_hand, the
  // tracker's ~calibrate), the skin gate is the one around them (personalSkinGate) instead of
  // segmentation.skin: the generic gate keeps wood, cardboard and coffee (doc/segmentation.md,
  // "Session 22"). false: segmentation.skin whatever the model.
  bool skin_gate_from_model = true;
  PersonalSkinGateParams personal_skin_gate;
  // The curled hand's refinement (TrackerParams::curled_refine_*) without a plate (the skin gate,
  // the rooms): off unless true. It was measured on the plate's foreground only; in the kitchen
  // with the generic gate it refined 8 frames of a track that had curled an open hand, and that
  // track went 27.6 -> 49.1 mm (StudioRooms.AHandUnlikeTheModelStartsOnItselfInTheKitchen).
  bool curled_refine_without_plate = false;
  // The open finger toggles (TrackerParams::toggle_curled_flexion) without a plate: off unless
  // true. The silhouette judges an opened finger by the foreground it lands on, and without a
  // plate that holds skin-coloured wood beside the hand: in the kitchen a track on the other arm
  // opened a finger onto the table and held the user's hand off until frame 51 instead of 33
  // (StudioRooms.TheTrackStartsInTheKitchenAndStaysOnTheUsersHand). A curl toggle removes model
  // and needs no such trust.
  bool open_toggles_without_plate = false;
  // The model's size adaptation (TrackerParams::size_step) without a plate: off unless true. It
  // reads the hand's size off the foreground, which without a plate holds skin-coloured wood and
  // the other arm beside the hand, as for the open toggles above.
  bool size_adaptation_without_plate = false;
  // With the generic skin gate, no plate and the room cues, the tracker searches again
  // (HandTracker::requestRedetection) on the first set segmented in the region of a hand it
  // started (or restarted, or took from a re-detection: that set's search checks the new pose in
  // turn). Such a start is fitted to the candidates' blobs (MultiViewParams), which hold the
  // wooden table with the hand; the next set is segmented in the started hand's region. In the
  // studio's kitchen, the hand in view from the first frame, the default model's start on
  // `adbadd` was 34-47 mm off and stayed so until the periodic re-detection 25 sets later; the
  // search in the region finds the hand. Not with the user's own gate (skin_gate_from_model),
  // which drops the table: there the start is off only when it took the other arm's hand, and
  // the search made two such tracks stick (the re-check took the track to the user's hand 24 sets
  // later or never; doc/segmentation.md "Session 52").
  bool redetect_in_started_region = true;
};

// The box around a posed hand in one camera's image (pixels, clipped to the image; empty when the
// hand is not in front of the camera or outside the image): every model Gaussian's sphere of radius
// 2.5 sqrt(trace Sigma) (>= 2.5 sigma along any axis) projected, the union grown by `margin` of its
// size on each side plus `margin_pixels`.
cv::Rect projectedHandBox(const HandModel& model, const Pose& pose, const Camera& camera,
                          double margin = 0.3, int margin_pixels = 8);

// The posed hand's silhouette in one camera, grown by a margin (CV_8UC1 at image size, 255 inside):
// every model Gaussian whose centre is in front of the camera drawn as a disc of radius
// radius_scale sqrt(trace Sigma) projected (1.5: about 2.6 sigma for a round Gaussian), plus
// margin_pixels (one frame's motion). All zero when the hand is at or behind the camera.
// (2.5 sqrt(trace Sigma) held much background between and around the fingers in the rooms:
// doc/segmentation.md.)
cv::Mat projectedHandMask(const PosedHand& hand, const Camera& camera, int margin_pixels = 10,
                          double radius_scale = 1.5);

// The radius (in sqrt(trace Sigma)) of the discs that draw the model's core in modelOnForeground.
constexpr double kModelCoreRadius = 0.5;

// The share of the posed model's core (its Gaussians as discs of kModelCoreRadius sqrt(trace
// Sigma), projectedHandMask without margin) that lies on the foreground, pixels summed over the
// cameras with a mask (`foregrounds[c]`: CV_8UC1 at camera c's size, 255 = foreground; empty: the
// camera is left out). 0 when the model projects into none. Throws InputError for masks that do
// not match the cameras.
double modelOnForeground(const PosedHand& hand, const std::vector<Camera>& cameras,
                         const std::vector<cv::Mat>& foregrounds);

// The starts' model-area weight (TrackerParams::start_model_area_weight) the tracker runs with:
// with the generic skin gate and no plate (`generic_skin_gate_without_plate`) at least
// params.skin_gate_start_area_weight, else params.tracker's own. TrackingPipeline and the live
// tracker nodelet decide it here.
double startModelAreaWeight(const PipelineParams& params, bool generic_skin_gate_without_plate);

// The curled hand's refinement iterations (TrackerParams::curled_refine_iterations) the tracker
// runs with: params.tracker's own with a plate, 0 without one (`without_plate`) unless
// params.curled_refine_without_plate. TrackingPipeline and the live tracker nodelet decide it here.
int curledRefineIterations(const PipelineParams& params, bool without_plate);

// The open toggles' flexion threshold (TrackerParams::toggle_curled_flexion) the tracker runs
// with: params.tracker's own with a plate, infinity (none) without one (`without_plate`) unless
// params.open_toggles_without_plate. TrackingPipeline and the live tracker nodelet decide it here.
double toggleCurledFlexion(const PipelineParams& params, bool without_plate);

// The size adaptation's step (TrackerParams::size_step) the tracker runs with: params.tracker's own
// with a plate, 0 (off) without one (`without_plate`) unless params.size_adaptation_without_plate.
// TrackingPipeline and the live tracker nodelet decide it here.
double sizeStep(const PipelineParams& params, bool without_plate);

// Whether the tracker searches again in a started hand's region (PipelineParams::
// redetect_in_started_region): with the generic skin gate and no plate
// (`generic_skin_gate_without_plate`) and the room cues on (`room_cues`, which segment in the
// tracked hand's region). TrackingPipeline and the live tracker nodelet decide it here.
bool redetectsInStartedRegion(const PipelineParams& params, bool generic_skin_gate_without_plate,
                              bool room_cues);

// The start of a still scene (MultiViewParams::still_hypotheses) that won: which trial, its
// result and score, and the tracker that holds its track.
struct StillStart {
  int hypothesis = -1;  // index into the trials
  FrameResult result;
  double score = 0.0;  // similarity x modelOnForeground
  std::optional<HandTracker> tracker;
};

// A still scene's starts, for TrackingPipeline and the live tracker nodelet: each trial (one per
// still hypothesis; per camera of `cameras`, the observation of that hypothesis' blob, undistorted)
// is started by a tracker of its own (`model`, `params`, its search run synchronously), and a start
// that holds (a pose, not lost) scores its similarity times modelOnForeground on `foregrounds`
// (per camera, the set's foreground; empty: left out). The best start scoring at least `min_score`
// (MultiViewParams::still_min_score), or none. Throws InputError as modelOnForeground.
std::optional<StillStart> startOnStillScene(
    const HandModel& model, const TrackerParams& params,
    const std::vector<std::vector<CameraObservation>>& trials, const std::vector<Camera>& cameras,
    const std::vector<cv::Mat>& foregrounds, double min_score, double stamp, std::int64_t frame_id);

class TrackingPipeline {
 public:
  // One segmenter per camera. Throws InputError for fewer cameras than the automatic start needs
  // (TrackerParams::min_cameras_for_start), a camera that fails validateCamera, or bad
  // segmentation or model parameters.
  TrackingPipeline(const HandModel& model, const std::vector<Camera>& cameras,
                   const PipelineParams& params);

  // Processes one set; CameraImage::camera indexes the cameras given to the constructor. Throws
  // InputError for an unknown camera index or an image whose size is not its camera's. With
  // `observations`, a tracked set's cameras and image SoGs (what the tracker saw) are copied there
  // (cleared for a background set).
  ProcessedFrame process(const FrameSet& set,
                         std::vector<CameraObservation>* observations = nullptr);

  // Forgets the track, the background plates and the room cues' memory: the next sets are
  // background again.
  void reset();

  const std::vector<Camera>& cameras() const { return cameras_; }
  const PipelineParams& params() const { return params_; }
  // Whether params().segmentation.skin is the model's own gate (PipelineParams::
  // skin_gate_from_model), and why not when the model's colours could not give one (empty: they
  // were not asked for, or gave it).
  bool skinGateFromModel() const { return skin_gate_from_model_; }
  const std::string& skinGateProblem() const { return skin_gate_problem_; }
  const HandTracker& tracker() const { return tracker_; }
  const ImageSegmenter& segmenter(int camera) const { return segmenters_.at(camera); }
  // The foreground of each camera's last segmented image (ImageSegmenter::lastForegroundMask), or
  // after still hypotheses (MultiViewParams::still_hypotheses) what the chosen one kept of it.
  cv::Mat foregroundMask(int camera) const;
  // Sets processed so far (background ones included).
  int setsSeen() const { return sets_seen_; }

 private:
  void checkImage(const CameraImage& image) const;
  // Per still hypothesis (MultiViewParams::still_hypotheses), per camera: the region of its
  // candidate there (an all-zero mask where it has none; empty for cameras without an image).
  using StillRegions = std::vector<std::vector<cv::Mat>>;
  // Before the start: gives each camera's segmenter its multi-view candidate region for `set`;
  // when no moving candidates agree but still ones do, the union of the still hypotheses'
  // regions, which go to `still_regions` (for startOnStillHypotheses). While tracking
  // (MultiViewParams::recheck_interval): only when the choice replaces the track, which is then
  // reset; returns whether the regions were set.
  bool chooseRegionsAcrossViews(const FrameSet& set, bool tracking,
                                StillRegions* still_regions = nullptr);
  // A still scene: each hypothesis keeps, of this set's segmented (raw-pixel) SoGs, the Gaussians
  // inside its regions and is started by a tracker of its own; the start with the highest score
  // (MultiViewParams::still_min_score), at least still_min_score, becomes the track (its tracker
  // replaces tracker_, its observations `observations`) and its result is returned. None: nothing
  // is kept of the set (`observations` are emptied of Gaussians) and the tracker waits.
  std::optional<FrameResult> startOnStillHypotheses(const FrameSet& set,
                                                    const StillRegions& still_regions,
                                                    std::vector<CameraObservation>* observations);

  std::vector<Camera> cameras_;
  PipelineParams params_;
  bool skin_gate_from_model_ = false;
  std::string skin_gate_problem_;
  std::vector<ImageSegmenter> segmenters_;
  HandTracker tracker_;
  int sets_seen_ = 0;
  bool tracked_regions_ = false;             // the segmenters hold regions from a tracked pose
  bool redetect_in_started_region_ = false;  // redetectsInStartedRegion, decided once
  bool redetect_next_set_ = false;  // the segmenters hold the region of a start: search again
  Eigen::Vector3d tracked_centre_ = Eigen::Vector3d::Zero();  // mean of the tracked model's means
  int sets_since_recheck_ = 0;
  // Per camera, what the last set kept when it tried still hypotheses (empty: the segmenter's
  // mask).
  std::vector<cv::Mat> still_kept_;
  // A track started on still hypotheses, until it has moved still_confirm_distance from where it
  // started: re-checked every set, and a moving choice at switch_distance that as many views
  // support replaces it (MultiViewParams::still_confirm_distance).
  bool provisional_track_ = false;
  Eigen::Vector3d provisional_origin_ = Eigen::Vector3d::Zero();
};

}  // namespace sag_hand_tracker
