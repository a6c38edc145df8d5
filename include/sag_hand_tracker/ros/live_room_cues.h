// The room cues in the live graph (issue 11; doc/segmentation.md, "The live graph"). The
// segmentation nodelets run per camera and the tracker nodelet sees every camera, so the work of
// TrackingPipeline's room cues is split between them, with the same core functions:
//   - the tracker publishes the tracked hand per camera (cam<i>/hand_region, HandRegion: the posed
//     model's Gaussians in that camera's optical frame, stamped with the set); each segmentation
//     nodelet projects it with its own camera_info (projectedHandMask) into its region of
//     interest (RegionSource::kTrack) and ignores a region older than its timeout;
//   - without a tracked hand a segmentation nodelet segments inside the union of its image's hand
//     candidates (handCandidates, each grown by region_margin_cells) and attaches the candidates
//     to its SumOfGaussians (region CANDIDATES); the tracker runs the multi-view check
//     (chooseConsistentCandidates) on the set and keeps, per camera, only the image Gaussians
//     inside the chosen candidate's region (candidateRegion), or none;
//   - a still scene (nothing moves: a hand held still from the first image; MultiViewParams::
//     still_hypotheses): when no moving candidates agree, each place where still ones do is a
//     trial (LiveStillTrials: per view, the Gaussians inside that place's candidate), which the
//     tracker nodelet starts with startOnStillScene, as TrackingPipeline does offline; the track
//     of the best start is provisional until it has moved still_confirm_distance, and every set
//     until then asks for the candidates and yields to a moving choice (replacesProvisionalTrack);
//   - the re-check (MultiViewParams::recheck_interval): the tracker asks (candidates_wanted) for
//     the whole image's candidates on the next set and resets the track when the choice replaces
//     it (replacesTrack); the segmenters then get no region and the next set starts again.
// Differences from TrackingPipeline, by construction: a region reaches a camera's next image only
// when the tracker has finished the set (one set later, or more when the tracker lags), and after
// a re-check switch the new start comes one set later (the switching set's images were segmented
// with the old region). A still scene's trials keep the sleeve evidence each segmentation found
// beside all its candidates (offline: beside the trial's blob only), and their foreground is the
// SoGs' leaves (foregroundOfSoG) rather than the segmenter's pixel mask; a provisional track that
// yields does not make the segmentations forget the colours they learnt from it.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "sag_hand_tracker/HandRegion.h"
#include "sag_hand_tracker/SkinGate.h"
#include "sag_hand_tracker/SumOfGaussians.h"
#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/ros/sog_conversions.h"
#include "sag_hand_tracker/segmentation/background_plate.h"
#include "sag_hand_tracker/segmentation/multi_view_consistency.h"
#include "sag_hand_tracker/segmentation/quadtree_segmentation.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

// ---- messages ----
// The candidates' conversions (candidatesToMsg, candidatesFromMsg): sog_conversions.h.

// The tracked hand for one camera: `hand`'s Gaussians in `camera`'s optical frame.
sag_hand_tracker::HandRegion handRegionMsg(const PosedHand& hand, const Camera& camera);
// The hand of a HandRegion (Gaussians in the camera's frame). Throws InputError for a non-finite
// value, a covariance that is not positive definite, or more than kMaxRegionGaussians Gaussians.
constexpr int kMaxRegionGaussians = 1024;
PosedHand handFromRegionMsg(const sag_hand_tracker::HandRegion& msg);

// The user's skin gate (personalSkinGate) from the tracker to the segmentations (~skin_gate).
sag_hand_tracker::SkinGate skinGateMsg(const SkinParams& gate, const std::string& source);
// Throws InputError naming the problem: a value that is not finite, hue_max_deg not above
// hue_min_deg or more than 360 degrees above it, saturation_min above saturation_max, or a
// saturation or value outside [0, 1].
SkinParams skinGateFromMsg(const sag_hand_tracker::SkinGate& msg);

// ---- segmentation nodelet ----
// The region of interest of a HandRegion in its camera (projectedHandMask with the camera at the
// origin: the Gaussians are in its frame). Same errors as handFromRegionMsg.
cv::Mat trackedRegionMask(const sag_hand_tracker::HandRegion& msg, const Camera& camera);
// The tracked model's own silhouette of a HandRegion in its camera (projectedModelSilhouette;
// RoomCueParams cue 7). Same errors as handFromRegionMsg.
cv::Mat trackedModelSilhouette(const sag_hand_tracker::HandRegion& msg, const Camera& camera);
// The union of the candidates' regions (candidateRegion, each grown by margin_cells); all zero
// without candidates (nothing kept: no blob of this view can be the hand).
cv::Mat candidatesRegionMask(const std::vector<HandCandidate>& candidates, int width, int height,
                             int margin_cells);
// Whether a region stamped `region_stamp` may be used for an image stamped `image_stamp`
// (seconds): not older than `timeout`, and not from the future by more than it (a replayed bag
// looping back).
bool regionIsFresh(double region_stamp, double image_stamp, double timeout);

// ---- tracker nodelet ----

// One camera's input of a set, as the tracker nodelet has it before undistortion.
struct LiveView {
  Camera camera;
  ImageSoG sog;    // raw pixels
  int region = 0;  // SumOfGaussians::REGION_*
  std::vector<HandCandidate> candidates;
};

// A still scene's trials (see the file comment), made by LiveRoomCues::beforeUpdate.
struct LiveStillTrials {
  // Per still hypothesis (stillHypotheses, best first), per view: the view's SoG (raw pixels)
  // inside that hypothesis' candidate region there (no Gaussians where it has none).
  std::vector<std::vector<ImageSoG>> sogs;
  // Per view: the foreground that scores the starts (startOnStillScene): the SoG's leaves inside
  // the union of the hypotheses' regions.
  std::vector<cv::Mat> foregrounds;
  // Per hypothesis: where its candidates triangulate (root frame).
  std::vector<Eigen::Vector3d> places;
};

// The tracker side of the live room cues: the multi-view check and the re-check on the set's
// views, and the regions it publishes. Not thread-safe (the tracker nodelet holds its mutex).
class LiveRoomCues {
 public:
  // `still_retry_seconds`: see stillTrialsDue.
  explicit LiveRoomCues(const MultiViewParams& params = MultiViewParams(),
                        double still_retry_seconds = 2.0);
  const MultiViewParams& params() const { return params_; }
  double stillRetrySeconds() const { return still_retry_seconds_; }

  // Before the tracker's update of a set: narrows each view's SoG down to the hand (see the file
  // comment). Without a tracked hand: views segmented with the candidates keep the multi-view
  // choice (with multi_view off: their best candidate), views still segmented with an old
  // track's region keep nothing. With a tracked hand: views without a region keep the candidate
  // at the tracked hand; on a re-check set, a choice that replaces the track clears every view
  // and returns true: the caller resets the tracker. With `still`: when nothing moving agrees,
  // the still scene's trials of the set stamped `stamp` (seconds) go there when they are due
  // (stillTrialsDue; otherwise it is left empty) while the views keep nothing.
  bool beforeUpdate(std::vector<LiveView>* views, LiveStillTrials* still = nullptr,
                    double stamp = 0.0);
  // After the update: the tracked hand (nullptr: none, lost, or no pose); `still_start`: it is a
  // still scene's start (the track is provisional). When the set had still trials, their outcome
  // (stillTrialsSucceeded, stillTrialsFailed).
  void afterUpdate(const PosedHand* hand, bool still_start = false);
  // Forgets the track (the tracker was reset).
  void reset();

  // Whether a still scene's trials (made for the set stamped `stamp`, seconds) should be started:
  // a still room (a face, a photograph) gives the same places set after set, and their starts
  // cost the frame path about 25 ms each. Due unless the last trials found no hand, every place
  // lies within support_radius of one of theirs, and they are less than still_retry_seconds older
  // (or the stamps went back).
  bool stillTrialsDue(const LiveStillTrials& trials, double stamp) const;
  // The trials of the set stamped `stamp` were started and none was a hand.
  void stillTrialsFailed(const LiveStillTrials& trials, double stamp);
  // A start on the still trials became the track: the next still scene is tried at once.
  void stillTrialsSucceeded() { failed_stamp_.reset(); }
  bool tracking() const { return tracking_; }
  // The track was started on a still scene and has not yet moved still_confirm_distance.
  bool provisional() const { return provisional_; }
  // The regions published after the last set should ask for the candidates (re-check next set).
  bool candidatesWanted() const;
  int rechecks() const { return rechecks_; }
  int switches() const { return switches_; }

 private:
  // The still scene's trials of the set stamped `stamp` whose views (seen by `cameras`) have the
  // candidates `candidates` (only those segmented with them), when they are due: the places are
  // found first, the trials made only then.
  void makeStillTrials(const std::vector<LiveView>& views, const std::vector<Camera>& cameras,
                       const std::vector<std::vector<HandCandidate>>& candidates, double stamp,
                       LiveStillTrials* still);

  MultiViewParams params_;
  double still_retry_seconds_;
  std::optional<double> failed_stamp_;  // of the last still trials that found no hand
  std::vector<Eigen::Vector3d> failed_places_;
  std::optional<LiveStillTrials> pending_trials_;  // made by this set's beforeUpdate (places only)
  double pending_stamp_ = 0.0;
  bool tracking_ = false;
  Eigen::Vector3d tracked_centre_ = Eigen::Vector3d::Zero();
  int sets_since_recheck_ = 0;
  int rechecks_ = 0, switches_ = 0;
  bool provisional_ = false;
  Eigen::Vector3d provisional_origin_ = Eigen::Vector3d::Zero();
};

}  // namespace sag_hand_tracker
