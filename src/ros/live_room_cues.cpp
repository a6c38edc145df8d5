// The room cues in the live graph: see live_room_cues.h.
#include "sag_hand_tracker/ros/live_room_cues.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <string>

#include "sag_hand_tracker/energy/hand_projection.h"
#include "sag_hand_tracker/energy/silhouette.h"
#include "sag_hand_tracker/tracking/tracking_pipeline.h"
#include "sag_hand_tracker/util/number_text.h"

namespace sag_hand_tracker {

sag_hand_tracker::HandRegion handRegionMsg(const PosedHand& hand, const Camera& camera) {
  sag_hand_tracker::HandRegion msg;
  msg.tracked = true;
  msg.gaussians.reserve(hand.gaussians.size());
  const Eigen::Matrix3d rotation = camera.world_to_camera.linear();
  for (const WorldGaussian& g : hand.gaussians) {
    const Eigen::Vector3d mean = camera.world_to_camera * g.mean;
    const Eigen::Matrix3d cov = rotation * g.cov * rotation.transpose();
    sag_hand_tracker::Gaussian3D m;
    m.x = mean.x();
    m.y = mean.y();
    m.z = mean.z();
    m.cxx = cov(0, 0);
    m.cxy = cov(0, 1);
    m.cxz = cov(0, 2);
    m.cyy = cov(1, 1);
    m.cyz = cov(1, 2);
    m.czz = cov(2, 2);
    msg.gaussians.push_back(m);
  }
  return msg;
}

sag_hand_tracker::SkinGate skinGateMsg(const SkinParams& gate, const std::string& source) {
  sag_hand_tracker::SkinGate msg;
  msg.source = source;
  msg.hue_min_deg = gate.hue_min_deg;
  msg.hue_max_deg = gate.hue_max_deg;
  msg.saturation_min = gate.saturation_min;
  msg.saturation_max = gate.saturation_max;
  msg.value_min = gate.value_min;
  return msg;
}

SkinParams skinGateFromMsg(const sag_hand_tracker::SkinGate& msg) {
  const double values[] = {msg.hue_min_deg, msg.hue_max_deg, msg.saturation_min, msg.saturation_max,
                           msg.value_min};
  for (const double v : values) {
    if (!std::isfinite(v)) throw InputError("skin gate with a value that is not finite");
  }
  if (!(msg.hue_max_deg > msg.hue_min_deg && msg.hue_max_deg - msg.hue_min_deg <= 360.0)) {
    throw InputError("skin gate hue " + shortNumber(msg.hue_min_deg) + ".." +
                     shortNumber(msg.hue_max_deg) +
                     " deg: the end must lie above the start, by at most 360");
  }
  for (const double v : {msg.saturation_min, msg.saturation_max, msg.value_min}) {
    if (v < 0.0 || v > 1.0) {
      throw InputError("skin gate saturation or value " + shortNumber(v) + " outside [0, 1]");
    }
  }
  if (msg.saturation_min > msg.saturation_max) {
    throw InputError("skin gate saturation " + shortNumber(msg.saturation_min) + ".." +
                     shortNumber(msg.saturation_max) + ": the minimum is above the maximum");
  }
  SkinParams gate;
  gate.hue_min_deg = msg.hue_min_deg;
  gate.hue_max_deg = msg.hue_max_deg;
  gate.saturation_min = msg.saturation_min;
  gate.saturation_max = msg.saturation_max;
  gate.value_min = msg.value_min;
  return gate;
}

PosedHand handFromRegionMsg(const sag_hand_tracker::HandRegion& msg) {
  if (msg.gaussians.size() > static_cast<size_t>(kMaxRegionGaussians)) {
    throw InputError("hand region with " + std::to_string(msg.gaussians.size()) +
                     " Gaussians, more than the limit of " + std::to_string(kMaxRegionGaussians));
  }
  PosedHand hand;
  hand.gaussians.reserve(msg.gaussians.size());
  for (size_t i = 0; i < msg.gaussians.size(); ++i) {
    const sag_hand_tracker::Gaussian3D& m = msg.gaussians[i];
    WorldGaussian g;
    g.mean = Eigen::Vector3d(m.x, m.y, m.z);
    g.cov << m.cxx, m.cxy, m.cxz, m.cxy, m.cyy, m.cyz, m.cxz, m.cyz, m.czz;
    if (!g.mean.allFinite() || !g.cov.allFinite()) {
      throw InputError("hand region Gaussian " + std::to_string(i) + " is not finite");
    }
    if (Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(g.cov, Eigen::EigenvaluesOnly)
            .eigenvalues()
            .minCoeff() <= 0.0) {
      throw InputError("hand region Gaussian " + std::to_string(i) +
                       ": covariance not positive definite");
    }
    hand.gaussians.push_back(g);
  }
  return hand;
}

namespace {
Camera atOrigin(const Camera& camera) {
  Camera at_origin = camera;
  at_origin.world_to_camera = Eigen::Isometry3d::Identity();  // the Gaussians are in its frame
  return at_origin;
}
}  // namespace

cv::Mat trackedRegionMask(const sag_hand_tracker::HandRegion& msg, const Camera& camera) {
  return projectedHandMask(handFromRegionMsg(msg), atOrigin(camera));
}

cv::Mat trackedModelSilhouette(const sag_hand_tracker::HandRegion& msg, const Camera& camera) {
  return projectedModelSilhouette(handFromRegionMsg(msg), atOrigin(camera));
}

cv::Mat candidatesRegionMask(const std::vector<HandCandidate>& candidates, int width, int height,
                             int margin_cells) {
  cv::Mat region(height, width, CV_8UC1, cv::Scalar(0));
  for (const HandCandidate& candidate : candidates) {
    region |= candidateRegion(&candidate, width, height, margin_cells);
  }
  return region;
}

bool regionIsFresh(double region_stamp, double image_stamp, double timeout) {
  return std::fabs(image_stamp - region_stamp) <= timeout;
}

LiveRoomCues::LiveRoomCues(const MultiViewParams& params, double still_retry_seconds)
    : params_(params), still_retry_seconds_(still_retry_seconds) {
  validate(params_);
  if (!(still_retry_seconds_ >= 0.0) || !std::isfinite(still_retry_seconds_)) {
    throw InputError("still_retry_seconds must be a finite number >= 0, got " +
                     std::to_string(still_retry_seconds_));
  }
}

bool LiveRoomCues::stillTrialsDue(const LiveStillTrials& trials, double stamp) const {
  if (!failed_stamp_ || stamp < *failed_stamp_ || stamp - *failed_stamp_ >= still_retry_seconds_) {
    return true;
  }
  for (const Eigen::Vector3d& place : trials.places) {
    const bool known = std::any_of(failed_places_.begin(), failed_places_.end(),
                                   [&](const Eigen::Vector3d& failed) {
                                     return (failed - place).norm() <= params_.support_radius;
                                   });
    if (!known) return true;  // something new agrees across the views
  }
  return false;
}

void LiveRoomCues::stillTrialsFailed(const LiveStillTrials& trials, double stamp) {
  failed_stamp_ = stamp;
  failed_places_ = trials.places;
}

void LiveRoomCues::reset() {
  tracking_ = false;
  sets_since_recheck_ = 0;
  provisional_ = false;
}

bool LiveRoomCues::candidatesWanted() const {
  return tracking_ && params_.enabled &&
         (provisional_ ||
          (params_.recheck_interval > 0 && sets_since_recheck_ + 1 >= params_.recheck_interval));
}

bool LiveRoomCues::beforeUpdate(std::vector<LiveView>* views_in, LiveStillTrials* still,
                                double stamp) {
  pending_trials_.reset();
  std::vector<LiveView>& views = *views_in;
  using Msg = sag_hand_tracker::SumOfGaussians;
  auto keepCandidate = [this](LiveView* view, int index) {
    const HandCandidate* chosen = index >= 0 ? &view->candidates.at(index) : nullptr;
    view->sog = keepInsideRegion(
        view->sog,
        candidateRegion(chosen, view->sog.width, view->sog.height, params_.region_margin_cells));
  };
  std::vector<Camera> cameras;
  for (const LiveView& view : views) cameras.push_back(view.camera);

  if (!tracking_) {
    if (!params_.enabled) {
      // As ImageSegmenter::segmentFrame without a region: each view's best candidate.
      for (LiveView& view : views) {
        if (view.region == Msg::REGION_TRACKED) {
          view.sog.gaussians.clear();
        } else if (view.region == Msg::REGION_CANDIDATES) {
          keepCandidate(&view, view.candidates.empty() ? -1 : 0);
        }
      }
      return false;
    }
    std::vector<std::vector<HandCandidate>> candidates(views.size());
    for (size_t v = 0; v < views.size(); ++v) {
      if (views[v].region == Msg::REGION_CANDIDATES) candidates[v] = views[v].candidates;
    }
    const MultiViewChoice choice = chooseConsistentCandidates(cameras, candidates, params_);
    if (!choice.found && still != nullptr && params_.still_hypotheses > 0) {
      makeStillTrials(views, cameras, candidates, stamp, still);
    }
    for (size_t v = 0; v < views.size(); ++v) {
      // A view still segmented with an old track's region (its hand_region had not yet said
      // "lost") keeps nothing: that region may hold anything.
      if (views[v].region == Msg::REGION_TRACKED) views[v].sog.gaussians.clear();
      if (views[v].region != Msg::REGION_CANDIDATES) continue;
      keepCandidate(&views[v], choice.found ? choice.chosen[v] : -1);
    }
    return false;
  }

  // Tracking: a view without a region (its hand_region late or missing) keeps the candidate at
  // the tracked hand.
  std::vector<std::vector<HandCandidate>> candidates(views.size());
  for (size_t v = 0; v < views.size(); ++v) candidates[v] = views[v].candidates;
  const MultiViewChoice at_track = supportAt(cameras, candidates, tracked_centre_, params_);
  bool recheck = false;
  if (params_.enabled && (provisional_ || (params_.recheck_interval > 0 &&
                                           ++sets_since_recheck_ >= params_.recheck_interval))) {
    sets_since_recheck_ = 0;
    int views_with_candidates = 0;
    for (const auto& c : candidates) views_with_candidates += !c.empty();
    recheck = views_with_candidates >= params_.min_views;
  }
  if (recheck) {
    ++rechecks_;
    const MultiViewChoice choice = chooseConsistentCandidates(cameras, candidates, params_);
    // A still start yields to a hand that moves elsewhere and that as many views see.
    if (provisional_ ? replacesProvisionalTrack(choice, at_track, params_)
                     : replacesTrack(choice, at_track, params_)) {
      // The set's images were segmented with the old track's region: nothing of them is kept;
      // the segmenters get no region and the next set starts at the new choice.
      ++switches_;
      for (LiveView& view : views) view.sog.gaussians.clear();
      reset();
      return true;
    }
  }
  for (size_t v = 0; v < views.size(); ++v) {
    if (views[v].region == Msg::REGION_CANDIDATES) keepCandidate(&views[v], at_track.chosen[v]);
  }
  return false;
}

void LiveRoomCues::afterUpdate(const PosedHand* hand, bool still_start) {
  if (pending_trials_) {
    if (still_start) {
      stillTrialsSucceeded();
    } else {
      stillTrialsFailed(*pending_trials_, pending_stamp_);
    }
    pending_trials_.reset();
  }
  if (hand == nullptr || hand->gaussians.empty()) {
    reset();
    return;
  }
  if (!tracking_) sets_since_recheck_ = 0;
  tracking_ = true;
  tracked_centre_.setZero();
  for (const WorldGaussian& g : hand->gaussians) tracked_centre_ += g.mean;
  tracked_centre_ /= static_cast<double>(hand->gaussians.size());
  if (still_start) {
    provisional_ = true;
    provisional_origin_ = tracked_centre_;
  } else if (provisional_ &&
             (tracked_centre_ - provisional_origin_).norm() >= params_.still_confirm_distance) {
    provisional_ = false;  // it moved: a hand in use
  }
}

void LiveRoomCues::makeStillTrials(const std::vector<LiveView>& views,
                                   const std::vector<Camera>& cameras,
                                   const std::vector<std::vector<HandCandidate>>& candidates,
                                   double stamp, LiveStillTrials* still) {
  const std::vector<MultiViewChoice> hypotheses = stillHypotheses(cameras, candidates, params_);
  if (hypotheses.empty()) return;
  LiveStillTrials places;
  for (const MultiViewChoice& hypothesis : hypotheses) places.places.push_back(hypothesis.point);
  // The places that held no hand a moment ago: no masks, no trials (a still room, set after set).
  if (!stillTrialsDue(places, stamp)) return;
  pending_trials_ = places;
  pending_stamp_ = stamp;
  std::vector<cv::Mat> regions_union(views.size());
  for (size_t v = 0; v < views.size(); ++v) {
    regions_union[v] = cv::Mat(views[v].sog.height, views[v].sog.width, CV_8UC1, cv::Scalar(0));
  }
  still->places = std::move(places.places);
  for (const MultiViewChoice& hypothesis : hypotheses) {
    std::vector<ImageSoG>& sogs = still->sogs.emplace_back(views.size());
    for (size_t v = 0; v < views.size(); ++v) {
      const int chosen = hypothesis.chosen[v];
      const cv::Mat region =
          candidateRegion(chosen >= 0 ? &candidates[v][chosen] : nullptr, views[v].sog.width,
                          views[v].sog.height, params_.region_margin_cells);
      sogs[v] = keepInsideRegion(views[v].sog, region);
      regions_union[v] |= region;
    }
  }
  for (size_t v = 0; v < views.size(); ++v) {
    still->foregrounds.push_back(
        foregroundOfSoG(views[v].sog, views[v].sog.width, views[v].sog.height) & regions_union[v]);
  }
}

}  // namespace sag_hand_tracker
