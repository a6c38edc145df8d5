// The live graph's room cues adapter (ros/live_room_cues.h): the messages between the tracker and
// the segmentation nodelets, and the tracker side's multi-view check and re-check.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/energy/hand_projection.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/ros/live_room_cues.h"
#include "sag_hand_tracker/studio/motion.h"
#include "sag_hand_tracker/tracking/tracking_pipeline.h"

using namespace sag_hand_tracker;

namespace {

const std::string kConfigDir = std::string(SAG_SOURCE_DIR) + "/config";

const HandModel& sagModel() {
  static const HandModel model = loadHandModel(resolveModelPath("sag", kConfigDir));
  return model;
}

const std::vector<Camera>& dexter5() {
  static const std::vector<Camera> cameras =
      loadCameraRig(kConfigDir + "/rigs/dexter5/rig.yaml").cameras;
  return cameras;
}

// The hand of the pinch motion at 2 s, posed.
PosedHand studioHand(const Eigen::Vector3d& shift = Eigen::Vector3d::Zero()) {
  Pose pose =
      studio::loadMotion(studio::resolveMotionPath("pinch", kConfigDir), sagModel(), 1).poseAt(2.0);
  pose.translation += shift;
  return forwardKinematics(sagModel(), pose);
}

Eigen::Vector3d centre(const PosedHand& hand) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const WorldGaussian& g : hand.gaussians) sum += g.mean;
  return sum / static_cast<double>(hand.gaussians.size());
}

constexpr int kCell = 4;

// A candidate of (2 half + 1)^2 cells centred at a root-frame point's projection in `camera`,
// `moving` of them moving.
HandCandidate candidateAt(const Camera& camera, const Eigen::Vector3d& point, double score,
                          int moving, int half = 2) {
  Eigen::Vector2d pixel;
  EXPECT_TRUE(camera.project(point, &pixel));
  HandCandidate candidate;
  candidate.cell_size = kCell;
  candidate.cells_x = (camera.width + kCell - 1) / kCell;
  const int cx = static_cast<int>(pixel.x()) / kCell, cy = static_cast<int>(pixel.y()) / kCell;
  for (int y = cy - half; y <= cy + half; ++y) {
    for (int x = cx - half; x <= cx + half; ++x) {
      if (x >= 0 && y >= 0 && x < candidate.cells_x && y * kCell < camera.height) {
        candidate.cell_indices.push_back(y * candidate.cells_x + x);
      }
    }
  }
  candidate.centroid = pixel;
  candidate.score = score;
  candidate.moving = moving;
  // The first `moving` cells move (all of them near the point).
  candidate.moving_cell_indices.assign(
      candidate.cell_indices.begin(),
      candidate.cell_indices.begin() + std::min<size_t>(static_cast<size_t>(std::max(moving, 0)),
                                                        candidate.cell_indices.size()));
  candidate.box = cv::Rect((cx - half) * kCell, (cy - half) * kCell, (2 * half + 1) * kCell,
                           (2 * half + 1) * kCell);
  return candidate;
}

ImageGaussian gaussianAt(const Eigen::Vector2d& pixel) {
  ImageGaussian g;
  g.mean = pixel;
  g.sigma = 2.0;
  g.hsv = Hsv(20.0, 0.4, 0.7);
  return g;
}

// One view per dexter5 camera segmented with the candidates (region CANDIDATES): the hand at
// `hand` (moving) and a still head at `head` where the camera sees it, each a candidate with one
// image Gaussian at its centroid.
std::vector<LiveView> candidateViews(const Eigen::Vector3d& hand, const Eigen::Vector3d* head,
                                     int hand_moving = 20, int half = 2) {
  std::vector<LiveView> views;
  for (const Camera& camera : dexter5()) {
    LiveView view;
    view.camera = camera;
    view.region = sag_hand_tracker::SumOfGaussians::REGION_CANDIDATES;
    view.sog.width = camera.width;
    view.sog.height = camera.height;
    Eigen::Vector2d pixel;
    if (head != nullptr && camera.project(*head, &pixel) && pixel.x() > 10 && pixel.y() > 10 &&
        pixel.x() < camera.width - 10 && pixel.y() < camera.height - 10) {
      view.candidates.push_back(candidateAt(camera, *head, 400.0, 0, half));
      view.sog.gaussians.push_back(gaussianAt(pixel));
    }
    view.candidates.push_back(candidateAt(camera, hand, 100.0, hand_moving, half));
    view.sog.gaussians.push_back(gaussianAt(view.candidates.back().centroid));
    views.push_back(std::move(view));
  }
  return views;
}

}  // namespace

TEST(LiveRoomCues, CandidatesSurviveTheMessage) {
  const Camera& camera = dexter5()[0];
  const std::vector<HandCandidate> candidates = {
      candidateAt(camera, centre(studioHand()), 123.5, 7)};
  sag_hand_tracker::SumOfGaussians msg;
  msg.width = camera.width;
  msg.height = camera.height;
  msg.candidates = candidatesToMsg(candidates);
  const std::vector<HandCandidate> back = candidatesFromMsg(msg);
  ASSERT_EQ(back.size(), 1u);
  EXPECT_NEAR(back[0].score, 123.5, 1e-4);
  EXPECT_NEAR((back[0].centroid - candidates[0].centroid).norm(), 0.0, 1e-3);
  EXPECT_EQ(back[0].box, candidates[0].box);
  EXPECT_EQ(back[0].moving, 7);
  EXPECT_EQ(back[0].cell_indices, candidates[0].cell_indices);
  EXPECT_EQ(back[0].moving_cell_indices, candidates[0].moving_cell_indices);
  // The regions they give are the same.
  EXPECT_EQ(cv::countNonZero(candidateRegion(&back[0], camera.width, camera.height, 2) !=
                             candidateRegion(&candidates[0], camera.width, camera.height, 2)),
            0);
}

TEST(LiveRoomCues, BadCandidatesAreNamed) {
  const Camera& camera = dexter5()[0];
  sag_hand_tracker::SumOfGaussians msg;
  msg.width = camera.width;
  msg.height = camera.height;
  msg.candidates = candidatesToMsg({candidateAt(camera, centre(studioHand()), 1.0, 0)});
  auto expectError = [&msg](const std::string& words) {
    try {
      candidatesFromMsg(msg);
      ADD_FAILURE() << "no error; expected one with '" << words << "'";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("hand candidate 0"), std::string::npos) << e.what();
    }
  };
  const auto good = msg.candidates[0];
  msg.candidates[0].cell_indices.push_back(1000000);
  expectError("cell index 1000000");
  msg.candidates[0] = good;
  msg.candidates[0].moving = 1;
  msg.candidates[0].moving_cell_indices = {1000000};
  expectError("moving cell index 1000000");
  msg.candidates[0].moving_cell_indices = {good.cell_indices[0], good.cell_indices[1]};
  expectError("2 moving cells listed but moving is 1");
  msg.candidates[0].moving_cell_indices.clear();
  msg.candidates[0].moving = -3;
  expectError("moving -3 is negative");
  msg.candidates[0] = good;
  msg.candidates[0].cells_x += 1;
  expectError("cells_x");
  msg.candidates[0] = good;
  msg.candidates[0].cell_size = 0;
  expectError("cell_size 0");
  msg.candidates[0] = good;
  msg.candidates[0].score = std::numeric_limits<float>::quiet_NaN();
  expectError("not finite");
  msg.candidates.assign(kMaxHandCandidates + 1, good);
  EXPECT_THROW(candidatesFromMsg(msg), InputError);
}

TEST(LiveRoomCues, TheRegionProjectedByTheSegmenterIsThePipelines) {
  const PosedHand hand = studioHand();
  for (const Camera& camera : dexter5()) {
    const sag_hand_tracker::HandRegion msg = handRegionMsg(hand, camera);
    const cv::Mat live = trackedRegionMask(msg, camera);
    const cv::Mat offline = projectedHandMask(hand, camera);
    ASSERT_EQ(live.size(), offline.size());
    EXPECT_GT(cv::countNonZero(offline), 500) << camera.name;
    EXPECT_EQ(cv::countNonZero(live != offline), 0) << camera.name;
    // The model's own silhouette (cue 7) likewise.
    const cv::Mat live_silhouette = trackedModelSilhouette(msg, camera);
    const cv::Mat offline_silhouette = projectedModelSilhouette(hand, camera);
    ASSERT_EQ(live_silhouette.size(), offline_silhouette.size());
    EXPECT_GT(cv::countNonZero(offline_silhouette), 200) << camera.name;
    EXPECT_EQ(cv::countNonZero(live_silhouette != offline_silhouette), 0) << camera.name;
  }
}

TEST(LiveRoomCues, BadRegionsAreRefused) {
  const Camera& camera = dexter5()[0];
  sag_hand_tracker::HandRegion msg = handRegionMsg(studioHand(), camera);
  msg.gaussians[3].y = std::numeric_limits<double>::infinity();
  EXPECT_THROW(trackedRegionMask(msg, camera), InputError);
  msg = handRegionMsg(studioHand(), camera);
  msg.gaussians[2].cxx = -1.0;
  try {
    handFromRegionMsg(msg);
    ADD_FAILURE() << "a covariance that is not positive definite was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("Gaussian 2"), std::string::npos) << e.what();
  }
  msg.gaussians.resize(kMaxRegionGaussians + 1, msg.gaussians[0]);
  EXPECT_THROW(handFromRegionMsg(msg), InputError);
}

// The tracker's skin gate (cam<i>/skin_gate) reaches the segmentation as it was made, and a bad
// one is refused with what is wrong.
TEST(LiveRoomCues, TheSkinGateSurvivesTheMessageAndBadOnesAreNamed) {
  SkinParams gate;
  gate.hue_min_deg = -5.5;
  gate.hue_max_deg = 39.0;
  gate.saturation_min = 0.15;
  gate.saturation_max = 0.56;
  gate.value_min = 0.24;
  const SkinGate msg = skinGateMsg(gate, "/home/me/my_hand.yaml");
  EXPECT_EQ(msg.source, "/home/me/my_hand.yaml");
  const SkinParams back = skinGateFromMsg(msg);
  EXPECT_EQ(back.hue_min_deg, gate.hue_min_deg);
  EXPECT_EQ(back.hue_max_deg, gate.hue_max_deg);
  EXPECT_EQ(back.saturation_min, gate.saturation_min);
  EXPECT_EQ(back.saturation_max, gate.saturation_max);
  EXPECT_EQ(back.value_min, gate.value_min);
  auto refused = [&](const std::function<void(SkinGate&)>& spoil, const std::string& what) {
    SkinGate bad = msg;
    spoil(bad);
    try {
      skinGateFromMsg(bad);
      ADD_FAILURE() << "accepted: " << what;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  refused([](SkinGate& m) { m.value_min = NAN; }, "not finite");
  refused([](SkinGate& m) { m.hue_max_deg = m.hue_min_deg; }, "the end must lie above the start");
  refused([](SkinGate& m) { m.hue_max_deg = m.hue_min_deg + 400; }, "by at most 360");
  refused([](SkinGate& m) { m.saturation_max = 1.5; }, "outside [0, 1]");
  refused([](SkinGate& m) { m.saturation_min = 0.6; }, "the minimum is above the maximum");
}

TEST(LiveRoomCues, StaleRegionsAreIgnored) {
  EXPECT_TRUE(regionIsFresh(10.0, 10.04, 0.5));
  EXPECT_TRUE(regionIsFresh(10.0, 10.5, 0.5));
  EXPECT_FALSE(regionIsFresh(10.0, 10.6, 0.5));
  EXPECT_FALSE(regionIsFresh(10.0, 3.0, 0.5));  // a bag looping back
}

TEST(LiveRoomCues, KeepInsideRegionKeepsTheGaussiansInside) {
  ImageSoG sog;
  sog.width = 40;
  sog.height = 30;
  sog.arm_cells = 5;
  sog.gaussians = {gaussianAt({5.5, 5.5}), gaussianAt({30.0, 20.0}), gaussianAt({-3.0, 5.0})};
  cv::Mat region(30, 40, CV_8UC1, cv::Scalar(0));
  region(cv::Rect(0, 0, 10, 10)).setTo(255);
  const ImageSoG kept = keepInsideRegion(sog, region);
  ASSERT_EQ(kept.gaussians.size(), 1u);
  EXPECT_EQ(kept.gaussians[0].mean, Eigen::Vector2d(5.5, 5.5));
  EXPECT_EQ(kept.arm_cells, 5);
  EXPECT_THROW(keepInsideRegion(sog, cv::Mat(10, 10, CV_8UC1, cv::Scalar(0))), InputError);
}

TEST(LiveRoomCues, BeforeTheStartOnlyTheBlobsThatAgreeAcrossTheViewsAreKept) {
  const Eigen::Vector3d hand = centre(studioHand());
  // A still head 25 cm to the side of the hand (along camera 3's x axis): a larger, better scored
  // blob in the views that see it.
  const Eigen::Vector3d head =
      hand + 0.25 * dexter5()[3].world_to_camera.linear().row(0).transpose();
  LiveRoomCues cues;
  std::vector<LiveView> views = candidateViews(hand, &head);
  int heads_seen = 0;
  for (const LiveView& view : views) heads_seen += view.candidates.size() == 2;
  ASSERT_GE(heads_seen, 1) << "no view sees the head";
  EXPECT_FALSE(cues.beforeUpdate(&views));
  for (const LiveView& view : views) {
    // Only the hand's Gaussian is left, in every view.
    ASSERT_EQ(view.sog.gaussians.size(), 1u) << view.camera.name;
    EXPECT_LT((view.sog.gaussians[0].mean - view.candidates.back().centroid).norm(), 1e-9);
  }

  // A still hand (nothing moves) cannot start the track: nothing is kept anywhere.
  views = candidateViews(hand, &head, /*hand_moving=*/0);
  cues.beforeUpdate(&views);
  for (const LiveView& view : views) EXPECT_TRUE(view.sog.gaussians.empty()) << view.camera.name;

  // A view still segmented with an old track's region keeps nothing before the start.
  views = candidateViews(hand, nullptr);
  views[2].region = sag_hand_tracker::SumOfGaussians::REGION_TRACKED;
  cues.beforeUpdate(&views);
  EXPECT_TRUE(views[2].sog.gaussians.empty());
  EXPECT_EQ(views[0].sog.gaussians.size(), 1u);

  // Without the multi-view check each view keeps its best candidate (segmentFrame's choice):
  // the head where a view sees it.
  MultiViewParams alone;
  alone.enabled = false;
  LiveRoomCues single(alone);
  views = candidateViews(hand, &head);
  single.beforeUpdate(&views);
  for (const LiveView& view : views) {
    ASSERT_EQ(view.sog.gaussians.size(), 1u);
    EXPECT_LT((view.sog.gaussians[0].mean - view.candidates.front().centroid).norm(), 1e-9);
  }
}

TEST(LiveRoomCues, TheTrackAsksForCandidatesAndSwitchesToAHandThatMoreViewsAgreeOn) {
  const PosedHand other_arm = studioHand(Eigen::Vector3d(0.35, -0.1, -0.1));
  const Eigen::Vector3d hand = centre(studioHand());
  MultiViewParams every_five;  // the mechanism with sets between the re-checks (default: 1)
  every_five.recheck_interval = 5;
  LiveRoomCues cues(every_five);
  EXPECT_FALSE(cues.tracking());
  cues.afterUpdate(&other_arm);
  ASSERT_TRUE(cues.tracking());
  // Sets 1..4 after the start are plain; the regions published after set 4 ask for candidates.
  for (int set = 1; set <= 4; ++set) {
    EXPECT_FALSE(cues.candidatesWanted()) << set;
    std::vector<LiveView> views = candidateViews(hand, nullptr, 100);
    for (LiveView& view : views) {
      view.region = sag_hand_tracker::SumOfGaussians::REGION_TRACKED;
      view.candidates.clear();
    }
    EXPECT_FALSE(cues.beforeUpdate(&views));
    EXPECT_EQ(views[0].sog.gaussians.size(), 1u);  // segmented with the track's region: kept
    cues.afterUpdate(&other_arm);
  }
  EXPECT_TRUE(cues.candidatesWanted());
  // The re-check set: the hand has come into view in all five cameras, moving; the tracked arm has
  // no candidate. The choice replaces the track: nothing of this set is kept, the track is gone.
  std::vector<LiveView> views = candidateViews(hand, nullptr, 100);
  for (LiveView& view : views) view.region = sag_hand_tracker::SumOfGaussians::REGION_TRACKED;
  EXPECT_TRUE(cues.beforeUpdate(&views));
  for (const LiveView& view : views) EXPECT_TRUE(view.sog.gaussians.empty());
  EXPECT_FALSE(cues.tracking());
  EXPECT_EQ(cues.rechecks(), 1);
  EXPECT_EQ(cues.switches(), 1);
  cues.afterUpdate(nullptr);
  EXPECT_FALSE(cues.candidatesWanted());

  // A track on the hand itself is kept by the re-check.
  const PosedHand on_hand = studioHand();
  cues.afterUpdate(&on_hand);
  for (int set = 1; set <= 5; ++set) {
    views = candidateViews(hand, nullptr, 100);
    for (LiveView& view : views) view.region = sag_hand_tracker::SumOfGaussians::REGION_TRACKED;
    EXPECT_FALSE(cues.beforeUpdate(&views)) << set;
    cues.afterUpdate(&on_hand);
  }
  EXPECT_EQ(cues.rechecks(), 2);
  EXPECT_EQ(cues.switches(), 1);
  EXPECT_TRUE(cues.tracking());
}

TEST(LiveRoomCues, WhileTrackingAViewWithoutARegionKeepsTheCandidateAtTheHand) {
  const PosedHand tracked = studioHand();
  const Eigen::Vector3d hand = centre(tracked);
  const Eigen::Vector3d head =
      hand + 0.25 * dexter5()[3].world_to_camera.linear().row(0).transpose();
  LiveRoomCues cues;
  cues.afterUpdate(&tracked);
  std::vector<LiveView> views = candidateViews(hand, &head);
  EXPECT_FALSE(cues.beforeUpdate(&views));
  for (const LiveView& view : views) {
    ASSERT_EQ(view.sog.gaussians.size(), 1u) << view.camera.name;
    EXPECT_LT((view.sog.gaussians[0].mean - view.candidates.back().centroid).norm(), 1e-9);
  }
}

// A still scene (nothing moves: a hand held still from the first image): the views keep nothing,
// and each place where the still candidates of two or more views agree is a trial of its own
// (stillHypotheses), with per view only the Gaussians of that place's candidate, and the
// foreground that scores the starts.
TEST(LiveRoomCues, AStillSceneMakesATrialOfEachPlaceWhereTheViewsAgree) {
  const Eigen::Vector3d hand = centre(studioHand());
  const Eigen::Vector3d head =
      hand + 0.25 * dexter5()[3].world_to_camera.linear().row(0).transpose();
  constexpr int kHalf = 6;  // 13 x 13 cells of 4 pixels: a hand's size at the studio's depth
  LiveRoomCues cues;
  std::vector<LiveView> views = candidateViews(hand, &head, /*hand_moving=*/0, kHalf);
  int heads_seen = 0;
  for (const LiveView& view : views) heads_seen += view.candidates.size() == 2;
  ASSERT_GE(heads_seen, 2) << "fewer than two views see the head";
  const std::vector<LiveView> segmented = views;
  LiveStillTrials still;
  EXPECT_FALSE(cues.beforeUpdate(&views, &still));
  for (const LiveView& view : views) EXPECT_TRUE(view.sog.gaussians.empty()) << view.camera.name;
  // Two places: the hand (all five views) first, then the head.
  ASSERT_EQ(still.sogs.size(), 2u);
  ASSERT_EQ(still.places.size(), 2u);
  EXPECT_LT((still.places[0] - hand).norm(), 0.02);
  EXPECT_LT((still.places[1] - head).norm(), 0.02);
  ASSERT_EQ(still.foregrounds.size(), views.size());
  for (size_t h = 0; h < still.sogs.size(); ++h) {
    ASSERT_EQ(still.sogs[h].size(), views.size());
    for (size_t v = 0; v < views.size(); ++v) {
      const ImageSoG& sog = still.sogs[h][v];
      // The candidate of that place: the hand's is the view's last, the head's its first.
      const HandCandidate& candidate =
          h == 0 ? segmented[v].candidates.back() : segmented[v].candidates.front();
      if (h == 1 && segmented[v].candidates.size() < 2) {
        EXPECT_TRUE(sog.gaussians.empty()) << "head trial, view without the head " << v;
        continue;
      }
      ASSERT_EQ(sog.gaussians.size(), 1u) << h << " " << v;
      EXPECT_LT((sog.gaussians[0].mean - candidate.centroid).norm(), 1e-9) << h << " " << v;
    }
  }
  for (size_t v = 0; v < views.size(); ++v) {
    const cv::Mat& foreground = still.foregrounds[v];
    ASSERT_EQ(foreground.type(), CV_8UC1);
    ASSERT_EQ(foreground.size(), cv::Size(views[v].camera.width, views[v].camera.height));
    const Eigen::Vector2d c = segmented[v].candidates.back().centroid;
    EXPECT_EQ(foreground.at<uint8_t>(static_cast<int>(c.y()), static_cast<int>(c.x())), 255) << v;
    // The leaf of each Gaussian: about (sigma sqrt(2 pi))^2 pixels per Gaussian of the view.
    EXPECT_GT(cv::countNonZero(foreground), 0);
    EXPECT_LE(cv::countNonZero(foreground), 2 * 36) << v;
  }

  // Without still hypotheses, or with a hand that moves, there are no trials.
  MultiViewParams none;
  none.still_hypotheses = 0;
  LiveRoomCues without(none);
  views = segmented;
  LiveStillTrials empty;
  without.beforeUpdate(&views, &empty);
  EXPECT_TRUE(empty.sogs.empty());
  views = candidateViews(hand, &head, /*hand_moving=*/20, kHalf);
  cues.beforeUpdate(&views, &empty);
  EXPECT_TRUE(empty.sogs.empty());
  for (const LiveView& view : views) EXPECT_EQ(view.sog.gaussians.size(), 1u);
  // Too small a blob is no hand: the 5 x 5 cells of the other tests give no trial.
  views = candidateViews(hand, nullptr, /*hand_moving=*/0);
  cues.beforeUpdate(&views, &empty);
  EXPECT_TRUE(empty.sogs.empty());
}

// A track started on a still scene is provisional (MultiViewParams::still_confirm_distance): it
// asks for the candidates on every set, whatever recheck_interval, and yields to a moving hand
// elsewhere that as many views see (a tracked one needs more views and twice the motion,
// replacesTrack); once it has moved 5 cm it is a hand in use.
TEST(LiveRoomCues, AStillStartIsProvisionalUntilItMoves) {
  const Eigen::Vector3d hand = centre(studioHand());
  const Eigen::Vector3d shift(0.25, 0.0, 0.0);
  const PosedHand prop = studioHand(shift);  // the still start took something 25 cm away
  MultiViewParams rare;
  rare.recheck_interval = 50;
  LiveRoomCues cues(rare);
  cues.afterUpdate(&prop, /*still_start=*/true);
  EXPECT_TRUE(cues.provisional());
  EXPECT_TRUE(cues.candidatesWanted());
  // The prop is seen by all five views (a candidate each); the hand comes, moving, in all five.
  auto setWith = [&](const Eigen::Vector3d& moving_hand) {
    std::vector<LiveView> views = candidateViews(moving_hand, nullptr, 100);
    const std::vector<LiveView> at_prop = candidateViews(centre(prop), nullptr, 0);
    for (size_t v = 0; v < views.size(); ++v) {
      views[v].region = sag_hand_tracker::SumOfGaussians::REGION_TRACKED;
      views[v].candidates.push_back(at_prop[v].candidates.back());
    }
    return views;
  };
  std::vector<LiveView> views = setWith(hand);
  EXPECT_TRUE(cues.beforeUpdate(&views));
  EXPECT_FALSE(cues.tracking());
  EXPECT_FALSE(cues.provisional());
  EXPECT_EQ(cues.switches(), 1);

  // The same set against a confirmed track: as many views are not enough (replacesTrack).
  LiveRoomCues confirmed(rare);
  confirmed.afterUpdate(&prop);
  for (int set = 0; set < 50; ++set) {
    views = setWith(hand);
    EXPECT_FALSE(confirmed.beforeUpdate(&views)) << set;
    confirmed.afterUpdate(&prop);
  }
  EXPECT_EQ(confirmed.switches(), 0);

  // A still start on the hand itself: kept while it moves less than 5 cm, then confirmed.
  LiveRoomCues on_hand(rare);
  const PosedHand still_hand = studioHand();
  on_hand.afterUpdate(&still_hand, /*still_start=*/true);
  for (const double moved : {0.0, 0.02, 0.04}) {
    const PosedHand now = studioHand(Eigen::Vector3d(moved, 0.0, 0.0));
    views = setWith(centre(now));
    EXPECT_FALSE(on_hand.beforeUpdate(&views)) << moved;
    on_hand.afterUpdate(&now);
    EXPECT_TRUE(on_hand.provisional()) << moved;
  }
  const PosedHand moved = studioHand(Eigen::Vector3d(0.06, 0.0, 0.0));
  on_hand.afterUpdate(&moved);
  EXPECT_FALSE(on_hand.provisional());
  EXPECT_FALSE(on_hand.candidatesWanted());
  EXPECT_TRUE(on_hand.tracking());
}

// A still room (a face, a photograph) gives the same places set after set: once their starts found
// no hand, they are tried again only after still_retry_seconds, and a new place at once.
TEST(LiveRoomCues, StillPlacesThatHeldNoHandWaitBeforeTheyAreTriedAgain) {
  const Eigen::Vector3d hand = centre(studioHand());
  const Eigen::Vector3d head =
      hand + 0.25 * dexter5()[3].world_to_camera.linear().row(0).transpose();
  LiveRoomCues cues(MultiViewParams(), /*still_retry_seconds=*/2.0);
  std::vector<LiveView> views = candidateViews(hand, &head, /*hand_moving=*/0, 6);
  LiveStillTrials still;
  cues.beforeUpdate(&views, &still);
  ASSERT_EQ(still.places.size(), 2u);
  EXPECT_TRUE(cues.stillTrialsDue(still, 10.0));  // never tried
  cues.stillTrialsFailed(still, 10.0);
  EXPECT_FALSE(cues.stillTrialsDue(still, 10.04));
  EXPECT_FALSE(cues.stillTrialsDue(still, 11.9));
  EXPECT_TRUE(cues.stillTrialsDue(still, 12.0));  // the retry interval
  EXPECT_TRUE(cues.stillTrialsDue(still, 9.0));   // the stamps went back (a bag looping)
  // The same places moved by less than support_radius are the same; a place farther is new.
  LiveStillTrials moved = still;
  moved.places[1] += Eigen::Vector3d(0.0, 0.0, 0.5 * cues.params().support_radius);
  EXPECT_FALSE(cues.stillTrialsDue(moved, 10.5));
  moved.places.push_back(hand + Eigen::Vector3d(0.0, 0.3, 0.0));
  EXPECT_TRUE(cues.stillTrialsDue(moved, 10.5));
  cues.stillTrialsSucceeded();
  EXPECT_TRUE(cues.stillTrialsDue(still, 10.5));
  // The same through the sets: beforeUpdate makes no trials while they are not due, and a set whose
  // trials started no track (afterUpdate without a still start) makes them wait.
  LiveRoomCues live(MultiViewParams(), 2.0);
  auto trialsAt = [&](double stamp) {
    std::vector<LiveView> set = candidateViews(hand, &head, /*hand_moving=*/0, 6);
    LiveStillTrials made;
    live.beforeUpdate(&set, &made, stamp);
    live.afterUpdate(nullptr);
    return made.sogs.size();
  };
  EXPECT_EQ(trialsAt(10.0), 2u);
  EXPECT_EQ(trialsAt(10.04), 0u);
  EXPECT_EQ(trialsAt(11.9), 0u);
  EXPECT_EQ(trialsAt(12.0), 2u);
  EXPECT_THROW(LiveRoomCues(MultiViewParams(), -1.0), InputError);
  EXPECT_THROW(LiveRoomCues(MultiViewParams(), std::numeric_limits<double>::quiet_NaN()),
               InputError);
}
