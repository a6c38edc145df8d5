// Multi-view consistency of the hand candidates (multi_view_consistency.h).
#include "sag_hand_tracker/segmentation/multi_view_consistency.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <opencv2/imgproc.hpp>
#include <string>

#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace {

// The midpoint of the shortest segment between two rays and its length; false for parallel rays.
bool closestApproach(const Ray& a, const Ray& b, Eigen::Vector3d* midpoint, double* distance) {
  const Eigen::Vector3d w = a.origin - b.origin;
  const double ab = a.direction.dot(b.direction);
  const double denominator = 1.0 - ab * ab;
  if (denominator < 1e-9) return false;
  const double da = a.direction.dot(w), db = b.direction.dot(w);
  const double s = (ab * db - da) / denominator;
  const double t = (db - ab * da) / denominator;
  const Eigen::Vector3d pa = a.origin + s * a.direction, pb = b.origin + t * b.direction;
  *midpoint = 0.5 * (pa + pb);
  *distance = (pa - pb).norm();
  return midpoint->allFinite();
}

// A length of `metres` at `depth` (m) in front of `camera`, in pixels.
double pixelsAtDepth(const Camera& camera, double metres, double depth) {
  return camera.K(0, 0) * metres / depth;
}

// Per view, the candidate whose centroid is nearest the point's projection, within the support
// radius; -1 for none.
std::vector<int> support(const std::vector<Camera>& cameras,
                         const std::vector<std::vector<Eigen::Vector2d>>& centroids,
                         const Eigen::Vector3d& point, const MultiViewParams& params) {
  std::vector<int> chosen(cameras.size(), -1);
  for (size_t c = 0; c < cameras.size(); ++c) {
    const double depth = (cameras[c].world_to_camera * point).z();
    Eigen::Vector2d pixel;
    if (!cameras[c].project(point, &pixel)) continue;
    const double radius = pixelsAtDepth(cameras[c], params.support_radius, depth);
    double best = radius;
    for (size_t j = 0; j < centroids[c].size(); ++j) {
      const double d = (centroids[c][j] - pixel).norm();
      if (d <= best) {
        best = d;
        chosen[c] = static_cast<int>(j);
      }
    }
  }
  return chosen;
}

// Whether one of the candidate's cells, or a cell next to one, holds `pixel` (distorted pixels).
bool candidateCoversPixel(const HandCandidate& candidate, const Eigen::Vector2d& pixel) {
  if (candidate.cells_x <= 0 || candidate.cell_size <= 0) return false;
  const int cx = static_cast<int>(std::floor(pixel.x() / candidate.cell_size));
  const int cy = static_cast<int>(std::floor(pixel.y() / candidate.cell_size));
  for (const int i : candidate.cell_indices) {
    if (std::abs(i % candidate.cells_x - cx) <= 1 && std::abs(i / candidate.cells_x - cy) <= 1) {
      return true;
    }
  }
  return false;
}

// Per view, the undistorted centroids of its first max_candidates_per_view candidates. Throws
// InputError (naming `caller`) when the sizes of `cameras` and `candidates` differ.
std::vector<std::vector<Eigen::Vector2d>> undistortedCentroids(
    const std::vector<Camera>& cameras, const std::vector<std::vector<HandCandidate>>& candidates,
    const MultiViewParams& params, const char* caller) {
  if (cameras.size() != candidates.size()) {
    throw InputError(std::string(caller) + ": " + std::to_string(cameras.size()) +
                     " cameras but candidates of " + std::to_string(candidates.size()) + " views");
  }
  std::vector<std::vector<Eigen::Vector2d>> centroids(cameras.size());
  for (size_t c = 0; c < cameras.size(); ++c) {
    const size_t n =
        std::min(candidates[c].size(), static_cast<size_t>(params.max_candidates_per_view));
    for (size_t j = 0; j < n; ++j) {
      centroids[c].push_back(cameras[c].undistortPixel(candidates[c][j].centroid));
    }
  }
  return centroids;
}

// The candidate's moving cells whose centres lie within `reach` (m, at the point's depth) of
// `point`'s projection in `camera`; all of them for reach 0, a point not in front of the camera,
// or a candidate without its moving cells' places.
int movingNear(const Camera& camera, const HandCandidate& candidate, const Eigen::Vector3d& point,
               double reach) {
  const bool placed = candidate.cells_x > 0 && candidate.cell_size > 0 &&
                      candidate.moving_cell_indices.size() == static_cast<size_t>(candidate.moving);
  const double depth = (camera.world_to_camera * point).z();
  Eigen::Vector2d pixel;
  if (!(reach > 0.0) || !placed || !(depth > 0.0) || !camera.projectDistorted(point, &pixel)) {
    return candidate.moving;
  }
  const double radius = pixelsAtDepth(camera, reach, depth);
  int near = 0;
  for (const int i : candidate.moving_cell_indices) {
    near += (candidate.cellCentre(i) - pixel).norm() <= radius;
  }
  return near;
}

// `chosen` (per view, a candidate or -1) at `point`, with its views and score; its moving cells
// are counted only for a choice that is returned (countMoving), not for every proposal.
MultiViewChoice tally(const std::vector<std::vector<HandCandidate>>& candidates,
                      const Eigen::Vector3d& point, std::vector<int> chosen) {
  MultiViewChoice choice;
  choice.point = point;
  choice.chosen = std::move(chosen);
  for (size_t c = 0; c < choice.chosen.size(); ++c) {
    if (choice.chosen[c] < 0) continue;
    ++choice.supporting_views;
    choice.score += candidates[c][choice.chosen[c]].score;
  }
  return choice;
}

// Sets `choice`'s moving cells: those of its candidates near its point (moving_reach).
void countMoving(const std::vector<Camera>& cameras,
                 const std::vector<std::vector<HandCandidate>>& candidates,
                 const MultiViewParams& params, MultiViewChoice* choice) {
  choice->moving = 0;
  for (size_t c = 0; c < choice->chosen.size(); ++c) {
    if (choice->chosen[c] < 0) continue;
    choice->moving += movingNear(cameras[c], candidates[c][choice->chosen[c]], choice->point,
                                 params.moving_reach);
  }
}

}  // namespace

void validate(const MultiViewParams& params) {
  auto fail = [](const std::string& what) { throw InputError("multi-view consistency: " + what); };
  if (params.max_candidates_per_view < 1) fail("max_candidates_per_view must be >= 1");
  if (!(params.max_ray_distance > 0.0)) fail("max_ray_distance must be > 0");
  if (!(params.support_radius > 0.0)) fail("support_radius must be > 0");
  if (!(params.min_depth > 0.0)) fail("min_depth must be > 0");
  if (params.min_views < 2) fail("min_views must be >= 2");
  if (!(params.min_view_share >= 0.0 && params.min_view_share < 1.0)) {
    fail("min_view_share must be in [0, 1)");
  }
  if (!(params.min_moving_share >= 0.0 && params.min_moving_share <= 1.0)) {
    fail("min_moving_share must be in [0, 1]");
  }
  if (params.region_margin_cells < 0) fail("region_margin_cells must be >= 0");
  if (!(params.moving_reach >= 0.0)) fail("moving_reach must be >= 0");
  if (params.recheck_interval < 0) fail("recheck_interval must be >= 0");
  if (!(params.switch_distance > 0.0)) fail("switch_distance must be > 0");
  if (params.still_hypotheses < 0) fail("still_hypotheses must be >= 0");
  if (!(params.still_min_score >= 0.0 && params.still_min_score <= 1.0)) {
    fail("still_min_score must be in [0, 1]");
  }
  if (!(params.still_confirm_distance >= 0.0)) fail("still_confirm_distance must be >= 0");
  if (!(params.still_min_area >= 0.0 && params.still_max_area > params.still_min_area)) {
    fail("still_min_area must be >= 0 and still_max_area above it");
  }
}

int viewsNeeded(const std::vector<std::vector<HandCandidate>>& candidates,
                const MultiViewParams& params) {
  int views = 0;
  for (const std::vector<HandCandidate>& view : candidates) views += !view.empty();
  const int majority = static_cast<int>(std::floor(params.min_view_share * views)) + 1;
  return std::max(params.min_views, majority);
}

namespace {

// Every point proposed by a pair of candidates of two views (moving ones only when
// `require_motion`), with its supporting views; points with fewer than viewsNeeded are left out.
std::vector<MultiViewChoice> proposedChoices(
    const std::vector<Camera>& cameras, const std::vector<std::vector<HandCandidate>>& candidates,
    const MultiViewParams& params, bool require_motion, const char* caller) {
  const std::vector<std::vector<Eigen::Vector2d>> centroids =
      undistortedCentroids(cameras, candidates, params, caller);
  const size_t views = cameras.size();
  const int min_views = viewsNeeded(candidates, params);
  std::vector<std::vector<Ray>> rays(views);
  std::vector<std::vector<bool>> moves(views);
  for (size_t c = 0; c < views; ++c) {
    for (size_t j = 0; j < centroids[c].size(); ++j) {
      rays[c].push_back(pixelRay(cameras[c], centroids[c][j]));
      const HandCandidate& candidate = candidates[c][j];
      const double cells = static_cast<double>(candidate.cell_indices.size());
      moves[c].push_back(
          !require_motion || params.min_moving_share <= 0.0 ||
          (candidate.moving > 0 && candidate.moving >= params.min_moving_share * cells));
    }
  }

  std::vector<MultiViewChoice> choices;
  for (size_t a = 0; a < views; ++a) {
    for (size_t b = a + 1; b < views; ++b) {
      for (size_t i = 0; i < rays[a].size(); ++i) {
        if (!moves[a][i]) continue;
        for (size_t j = 0; j < rays[b].size(); ++j) {
          if (!moves[b][j]) continue;
          Eigen::Vector3d point;
          double distance;
          if (!closestApproach(rays[a][i], rays[b][j], &point, &distance)) continue;
          if (distance > params.max_ray_distance) continue;
          if (!isInFrontOfCameras(point, cameras, params.min_depth)) continue;
          std::vector<int> chosen = support(cameras, centroids, point, params);
          // Re-triangulated from every supporting view, when that stays in front of the cameras.
          std::vector<Ray> supporting;
          for (size_t c = 0; c < views; ++c) {
            if (chosen[c] >= 0) supporting.push_back(rays[c][chosen[c]]);
          }
          Eigen::Vector3d refined;
          if (triangulate(supporting, &refined) &&
              isInFrontOfCameras(refined, cameras, params.min_depth)) {
            const std::vector<int> refined_chosen = support(cameras, centroids, refined, params);
            int before = 0, after = 0;
            for (size_t c = 0; c < views; ++c) {
              before += chosen[c] >= 0;
              after += refined_chosen[c] >= 0;
            }
            if (after >= before) {
              point = refined;
              chosen = refined_chosen;
            }
          }
          MultiViewChoice choice = tally(candidates, point, std::move(chosen));
          choice.found = true;
          if (choice.supporting_views >= min_views) choices.push_back(std::move(choice));
        }
      }
    }
  }
  // Most supporting views first, then the highest score; stable, so ties keep the pair order.
  std::stable_sort(
      choices.begin(), choices.end(), [](const MultiViewChoice& x, const MultiViewChoice& y) {
        return x.supporting_views != y.supporting_views ? x.supporting_views > y.supporting_views
                                                        : x.score > y.score;
      });
  return choices;
}

}  // namespace

MultiViewChoice chooseConsistentCandidates(
    const std::vector<Camera>& cameras, const std::vector<std::vector<HandCandidate>>& candidates,
    const MultiViewParams& params) {
  std::vector<MultiViewChoice> choices =
      proposedChoices(cameras, candidates, params, true, "chooseConsistentCandidates");
  if (!choices.empty()) {
    countMoving(cameras, candidates, params, &choices.front());
    return std::move(choices.front());
  }
  MultiViewChoice none;
  none.chosen.assign(cameras.size(), -1);
  return none;
}

double candidateArea(const std::vector<Camera>& cameras,
                     const std::vector<std::vector<HandCandidate>>& candidates,
                     const MultiViewChoice& choice) {
  double sum = 0.0;
  int views = 0;
  for (size_t c = 0; c < cameras.size() && c < choice.chosen.size(); ++c) {
    if (choice.chosen[c] < 0) continue;
    const double depth = (cameras[c].world_to_camera * choice.point).z();
    if (!(depth > 0.0)) continue;
    const HandCandidate& candidate = candidates[c][choice.chosen[c]];
    const double pixels = static_cast<double>(candidate.cell_indices.size()) * candidate.cell_size *
                          candidate.cell_size;
    sum += pixels * (depth / cameras[c].K(0, 0)) * (depth / cameras[c].K(1, 1));
    ++views;
  }
  return views > 0 ? sum / views : 0.0;
}

std::vector<MultiViewChoice> stillHypotheses(
    const std::vector<Camera>& cameras, const std::vector<std::vector<HandCandidate>>& candidates,
    const MultiViewParams& params) {
  std::vector<MultiViewChoice> kept;
  for (MultiViewChoice& choice :
       proposedChoices(cameras, candidates, params, false, "stillHypotheses")) {
    if (static_cast<int>(kept.size()) >= params.still_hypotheses) break;
    const double area = candidateArea(cameras, candidates, choice);
    if (!(area >= params.still_min_area && area <= params.still_max_area)) continue;
    // One hypothesis per place: the same candidates proposed by another pair of views, or a
    // neighbouring blob, would only repeat a trial start.
    bool repeats = false;
    for (const MultiViewChoice& k : kept) {
      repeats = repeats || k.chosen == choice.chosen ||
                (k.point - choice.point).norm() < params.support_radius;
    }
    if (repeats) continue;
    countMoving(cameras, candidates, params, &choice);
    kept.push_back(std::move(choice));
  }
  return kept;
}

MultiViewChoice supportAt(const std::vector<Camera>& cameras,
                          const std::vector<std::vector<HandCandidate>>& candidates,
                          const Eigen::Vector3d& point, const MultiViewParams& params) {
  const std::vector<std::vector<Eigen::Vector2d>> centroids =
      undistortedCentroids(cameras, candidates, params, "supportAt");
  std::vector<int> chosen = support(cameras, centroids, point, params);
  for (size_t c = 0; c < cameras.size(); ++c) {
    if (chosen[c] >= 0) continue;
    Eigen::Vector2d pixel;
    if (!cameras[c].projectDistorted(point, &pixel)) continue;
    const size_t n =
        std::min(candidates[c].size(), static_cast<size_t>(params.max_candidates_per_view));
    for (size_t j = 0; j < n && chosen[c] < 0; ++j) {
      if (candidateCoversPixel(candidates[c][j], pixel)) chosen[c] = static_cast<int>(j);
    }
  }
  MultiViewChoice choice = tally(candidates, point, std::move(chosen));
  countMoving(cameras, candidates, params, &choice);
  return choice;
}

bool replacesTrack(const MultiViewChoice& challenger, const MultiViewChoice& tracked,
                   const MultiViewParams& params) {
  return challenger.found && (challenger.point - tracked.point).norm() >= params.switch_distance &&
         challenger.supporting_views > tracked.supporting_views &&
         challenger.moving > 2 * tracked.moving;
}

bool replacesProvisionalTrack(const MultiViewChoice& challenger, const MultiViewChoice& tracked,
                              const MultiViewParams& params) {
  return challenger.found && (challenger.point - tracked.point).norm() >= params.switch_distance &&
         challenger.supporting_views >= tracked.supporting_views;
}

cv::Mat candidateRegion(const HandCandidate* candidate, int width, int height, int margin_cells) {
  cv::Mat region(height, width, CV_8UC1, cv::Scalar(0));
  if (candidate == nullptr || candidate->cells_x <= 0) return region;
  const int s = candidate->cell_size;
  for (const int i : candidate->cell_indices) {
    const int x = (i % candidate->cells_x) * s, y = (i / candidate->cells_x) * s;
    const cv::Rect cell = cv::Rect(x - margin_cells * s, y - margin_cells * s,
                                   (2 * margin_cells + 1) * s, (2 * margin_cells + 1) * s) &
                          cv::Rect(0, 0, width, height);
    region(cell).setTo(255);
  }
  return region;
}

ImageSoG keepInsideRegion(const ImageSoG& sog, const cv::Mat& region) {
  if (region.type() != CV_8UC1 || region.cols != sog.width || region.rows != sog.height) {
    throw InputError("keepInsideRegion: the region is not a CV_8UC1 mask of the SoG's size " +
                     std::to_string(sog.width) + "x" + std::to_string(sog.height));
  }
  ImageSoG kept = sog;
  kept.gaussians.clear();
  for (const ImageGaussian& g : sog.gaussians) {
    const int x = static_cast<int>(std::floor(g.mean.x()));
    const int y = static_cast<int>(std::floor(g.mean.y()));
    if (x >= 0 && y >= 0 && x < region.cols && y < region.rows && region.at<uint8_t>(y, x) != 0) {
      kept.gaussians.push_back(g);
    }
  }
  return kept;
}

}  // namespace sag_hand_tracker
