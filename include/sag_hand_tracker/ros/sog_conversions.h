// Message <-> core conversions for the image SoG and the hand candidates it carries (ROS layer;
// used by the nodelets and the graph tests). Camera, image and transform conversions are in
// conversions.h.
#pragma once

#include <vector>

#include "sag_hand_tracker/SumOfGaussians.h"
#include "sag_hand_tracker/segmentation/quadtree_segmentation.h"
#include "sag_hand_tracker/util/input_limits.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

// Core image SoG from the message (raw pixels). Throws InputError naming the first non-finite or
// negative value, or a size or Gaussian count over the limits (input_limits.h).
ImageSoG sogFromMsg(const sag_hand_tracker::SumOfGaussians& msg);

sag_hand_tracker::SumOfGaussians sogToMsg(const ImageSoG& sog);

// The hand candidates a segmentation attaches to its SoG (room cues, the live graph's multi-view
// check: live_room_cues.h).
std::vector<sag_hand_tracker::ImageCandidate> candidatesToMsg(
    const std::vector<HandCandidate>& candidates);
// The candidates of a SoG message. Throws InputError naming the candidate and the problem: a
// non-finite score or centroid, a cell size < 1, cells_x that does not cover the image's width, a
// cell or moving cell index outside the image, a negative `moving` or moving cells listed that are
// not `moving` of them, more candidates than kMaxHandCandidates.
std::vector<HandCandidate> candidatesFromMsg(const sag_hand_tracker::SumOfGaussians& msg);
constexpr int kMaxHandCandidates = 64;

}  // namespace sag_hand_tracker
