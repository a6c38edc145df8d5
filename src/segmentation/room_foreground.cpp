// The room cues (RoomCueParams in segmentation.h): learned skin colour, region of interest,
// connectivity, motion and plate adaptation on top of the plate and the skin gate.
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "sag_hand_tracker/segmentation/quadtree_segmentation.h"
#include "segmentation_internal.h"

namespace sag_hand_tracker {
namespace detail {
namespace {

// Chromaticity (r, g) of a cell mean; false for (near) black cells.
bool chromaticity(const float* c, double* r, double* g) {
  const double sum = static_cast<double>(c[0]) + c[1] + c[2];
  if (sum < 15.0) return false;
  *r = c[0] / sum;
  *g = c[1] / sum;
  return true;
}

// Connected components of the mask (8-neighbour cells): label per cell (-1: background) and the
// number of components.
int labelComponents(const std::vector<unsigned char>& mask, int cells_x, int cells_y,
                    std::vector<int>& labels) {
  labels.assign(mask.size(), -1);
  std::vector<int> stack;
  int count = 0;
  for (int start = 0; start < static_cast<int>(mask.size()); ++start) {
    if (!mask[start] || labels[start] >= 0) continue;
    labels[start] = count;
    stack.push_back(start);
    while (!stack.empty()) {
      const int cell = stack.back();
      stack.pop_back();
      const int cx = cell % cells_x, cy = cell / cells_x;
      for (int dy = -1; dy <= 1; ++dy) {
        const int ny = cy + dy;
        if (ny < 0 || ny >= cells_y) continue;
        for (int dx = -1; dx <= 1; ++dx) {
          const int nx = cx + dx;
          if (nx < 0 || nx >= cells_x) continue;
          const int n = ny * cells_x + nx;
          if (mask[n] && labels[n] < 0) {
            labels[n] = count;
            stack.push_back(n);
          }
        }
      }
    }
    ++count;
  }
  return count;
}

struct Component {
  int cells = 0;
  int moving = 0;
  int sleeve = 0;      // cells next to a dark, unsaturated cell (the sleeve)
  double score = 0.0;  // cells + motion_weight * moving + sleeve_weight * sleeve
  int x0 = 1 << 30, y0 = 1 << 30, x1 = -1, y1 = -1;  // cell box, inclusive
};

// The frame's overall brightness change against the previous frame's cell means (1 without
// them).
double frameGain(const std::vector<float>& means, const std::vector<float>& previous) {
  if (previous.size() != means.size()) return 1.0;
  double now = 0.0, before = 0.0;
  for (size_t i = 0; i < means.size(); ++i) {
    now += means[i];
    before += previous[i];
  }
  return before > 0.0 ? now / before : 1.0;
}

// This frame's motion per cell (RoomCueParams: decaying history, 1 = moved now) from the previous
// frame's cell means in `state`, with the frame's overall brightness change `gain` (frameGain)
// taken out (changing light is no motion). `state` is not changed.
std::vector<float> motionOf(const RoomCueParams& room, const std::vector<float>& means, double gain,
                            const RoomCueState& state, int cells) {
  if (state.previous_means.size() != means.size() ||
      state.motion.size() != static_cast<size_t>(cells)) {
    return std::vector<float>(cells, 0.0f);
  }
  std::vector<float> motion(cells, 0.0f);
  for (int i = 0; i < cells; ++i) {
    double change = 0.0;
    for (int k = 0; k < 3; ++k) {
      change =
          std::max(change, std::fabs(means[3 * i + k] - gain * state.previous_means[3 * i + k]));
    }
    const float decayed = static_cast<float>(room.motion_decay) * state.motion[i];
    motion[i] = change > room.motion_threshold ? 1.0f : decayed;
  }
  return motion;
}

// A surface of little colour: grey, white, black, a dark grey-green table (saturation below
// `max_saturation`, which is generous because the saturation of dark cells is noisy). On the
// cell's float means as they are: rgbToHsv's other rounding moved cells at the threshold, and
// with them single tracks.
bool isNeutral(const float* c, double max_saturation) {
  const double high = std::max({c[0], c[1], c[2]}), low = std::min({c[0], c[1], c[2]});
  return high <= 0.0 || (high - low) / high < max_saturation;
}

// Drops the cells farther than skin_max_distance from the learned skin colour (once learned).
// A cell on the hand's outline holds skin and what lies behind it: against a neutral surface (a
// grey table, a white wall, the black sleeve) its chromaticity lies between the skin's and grey
// (1/3, 1/3), the nearer grey the closer the skin's brightness is to the surface's: dark skin over
// a mid-grey table lost its fingertips to the plain test (doc/segmentation.md, "Session 32").
// With `keep_outline` (the skin gate alone, whose border cells are then decided pixel by pixel,
// while tracking) such a cell is kept when it is within skin_max_distance of the skin mixed with
// up to skin_border_neutral_share of grey and lies between a cell that passes the plain test and
// a neutral one that is no candidate (both 8-neighbours): the outline of the hand against a
// neutral surface, not skin beside wood. `outline_kept` marks those cells.
void removeUnlikeLearnedSkin(const SegmentationParams& params, const std::vector<float>& means,
                             int cells_x, int cells_y, const RoomCueState& state, bool keep_outline,
                             std::vector<unsigned char>& mask,
                             std::vector<unsigned char>* outline_kept = nullptr) {
  if (outline_kept) outline_kept->assign(mask.size(), 0);
  if (state.skin_frames <= 0) return;
  const RoomCueParams& room = params.room;
  const double floor = 0.012 * 0.012;  // chromaticity noise of a cell
  const double xx = state.skin_cov[0] + floor, xy = state.skin_cov[1],
               yy = state.skin_cov[2] + floor;
  const double det = xx * yy - xy * xy;
  const double limit = room.skin_max_distance * room.skin_max_distance;
  // Squared Mahalanobis length of (dr, dg) under the learned covariance.
  auto distance2 = [&](double dr, double dg) {
    return (yy * dr * dr - 2.0 * xy * dr * dg + xx * dg * dg) / det;
  };
  // The way from the skin towards grey, and its squared length.
  const double vr = 1.0 / 3.0 - state.skin_mean[0], vg = 1.0 / 3.0 - state.skin_mean[1];
  const double vv = distance2(vr, vg);
  const double share = room.skin_border_neutral_share;
  const bool outline = keep_outline && share > 0.0 && vv > 0.0;
  enum : unsigned char { kNone = 0, kUnlike = 1, kSkin = 2, kMixed = 3 };
  std::vector<unsigned char> kind(mask.size(), kNone);
  for (size_t i = 0; i < mask.size(); ++i) {
    if (!mask[i]) continue;
    kind[i] = kUnlike;
    double r, g;
    if (!chromaticity(&means[3 * i], &r, &g)) continue;
    const double dr = r - state.skin_mean[0], dg = g - state.skin_mean[1];
    if (distance2(dr, dg) <= limit) {
      kind[i] = kSkin;
      continue;
    }
    if (!outline) continue;
    // The nearest point of the segment skin -> skin mixed with the largest share of grey.
    const double along = ((yy * dr - xy * dg) * vr + (xx * dg - xy * dr) * vg) / det / vv;
    const double t = std::clamp(along, 0.0, share);
    if (distance2(dr - t * vr, dg - t * vg) <= limit) kind[i] = kMixed;
  }
  for (size_t i = 0; i < mask.size(); ++i) {
    if (kind[i] == kSkin) continue;
    bool next_to_skin = false, next_to_none = false;
    if (kind[i] == kMixed) {
      const int cx = static_cast<int>(i) % cells_x, cy = static_cast<int>(i) / cells_x;
      for (int y = cy - 1; y <= cy + 1; ++y) {
        for (int x = cx - 1; x <= cx + 1; ++x) {
          if (x < 0 || y < 0 || x >= cells_x || y >= cells_y) continue;
          const int j = y * cells_x + x;
          next_to_skin = next_to_skin || kind[j] == kSkin;
          next_to_none =
              next_to_none ||
              (kind[j] == kNone && isNeutral(&means[3 * j], room.skin_border_neutral_saturation));
        }
      }
    }
    if (!(next_to_skin && next_to_none)) {
      mask[i] = 0;
    } else if (outline_kept) {
      (*outline_kept)[i] = 1;
    }
  }
}

// Cue 6: the histogram bin of a cell's chromaticity; -1 for (near) black cells.
int colourBin(const float* c) {
  double r, g;
  if (!chromaticity(c, &r, &g)) return -1;
  constexpr int n = RoomCueState::kColourBins;
  const int br = std::min(n - 1, static_cast<int>(r * n));
  const int bg = std::min(n - 1, static_cast<int>(g * n));
  return br * n + bg;
}

// The histogram's mass in the 3 x 3 bins around `bin` (a cell's colour is noisy by about a bin).
double colourLikelihood(const std::vector<float>& histogram, int bin) {
  constexpr int n = RoomCueState::kColourBins;
  const int br = bin / n, bg = bin % n;
  double sum = 0.0;
  for (int r = std::max(0, br - 1); r <= std::min(n - 1, br + 1); ++r) {
    for (int g = std::max(0, bg - 1); g <= std::min(n - 1, bg + 1); ++g)
      sum += histogram[r * n + g];
  }
  return sum;
}

// Drops the cells whose colour is more than colour_ratio times as likely under the skin-coloured
// background's histogram as under the hand's (once both are learned).
void removeBackgroundColoured(const RoomCueParams& room, const std::vector<float>& means,
                              const RoomCueState& state, const std::vector<float>& cell_depth,
                              std::vector<unsigned char>& mask) {
  if (room.colour_ratio <= 0.0 || state.hand_colour.empty() || state.background_colour.empty()) {
    return;
  }
  for (size_t i = 0; i < mask.size(); ++i) {
    if (!mask[i]) continue;
    // Under the model the hand is kept whatever its colour (shading, mixed cells).
    if (!cell_depth.empty() && cell_depth[i] >= room.colour_core_depth) continue;
    const int bin = colourBin(&means[3 * i]);
    if (bin < 0) continue;
    const double background = colourLikelihood(state.background_colour, bin);
    if (background > room.colour_ratio * colourLikelihood(state.hand_colour, bin)) mask[i] = 0;
  }
}

// Blends the normalised histogram of the cells' colours into `histogram` at `rate` (all of it
// when the histogram is still empty); nothing when there are fewer than min_cells cells.
void learnColours(const std::vector<float>& means, const std::vector<int>& cells, int min_cells,
                  double rate, std::vector<float>& histogram) {
  std::vector<float> now(RoomCueState::kColourBins * RoomCueState::kColourBins, 0.0f);
  int count = 0;
  for (const int i : cells) {
    const int bin = colourBin(&means[3 * i]);
    if (bin < 0) continue;
    now[bin] += 1.0f;
    ++count;
  }
  if (count < min_cells) return;
  for (float& v : now) v /= static_cast<float>(count);
  if (histogram.empty()) {
    histogram = std::move(now);
    return;
  }
  const float a = static_cast<float>(rate);
  for (size_t b = 0; b < now.size(); ++b) histogram[b] += a * (now[b] - histogram[b]);
}

// The connected components of `mask` with their cues; `labels` receives the component per cell.
std::vector<Component> analyseComponents(const SegmentationParams& params,
                                         const std::vector<float>& means, int cells_x, int cells_y,
                                         const std::vector<unsigned char>& mask,
                                         const std::vector<float>& motion,
                                         std::vector<int>& labels) {
  const int count = labelComponents(mask, cells_x, cells_y, labels);
  std::vector<Component> components(count);
  for (int cy = 0; cy < cells_y; ++cy) {
    for (int cx = 0; cx < cells_x; ++cx) {
      const int i = cy * cells_x + cx;
      if (labels[i] < 0) continue;
      Component& c = components[labels[i]];
      ++c.cells;
      if (motion[i] > 0.5f) ++c.moving;
      c.x0 = std::min(c.x0, cx);
      c.x1 = std::max(c.x1, cx);
      c.y0 = std::min(c.y0, cy);
      c.y1 = std::max(c.y1, cy);
      bool next_to_sleeve = false;
      for (int dy = -1; dy <= 1 && !next_to_sleeve; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int nx = cx + dx, ny = cy + dy;
          if (nx < 0 || ny < 0 || nx >= cells_x || ny >= cells_y) continue;
          const float* m = &means[3 * (ny * cells_x + nx)];
          if (isDarkNonSkin(Eigen::Vector3d(m[0], m[1], m[2]), params.background)) {
            next_to_sleeve = true;
            break;
          }
        }
      }
      if (next_to_sleeve) ++c.sleeve;
    }
  }
  for (Component& c : components) {
    c.score = c.cells + params.room.motion_weight * c.moving + params.room.sleeve_weight * c.sleeve;
  }
  return components;
}

// Component `main` together with the components inside its box grown by a quarter of its size
// (the fingers that a gap cut off the palm): per component, whether it belongs to the group.
std::vector<unsigned char> groupAround(const std::vector<Component>& components, int main) {
  const Component& b = components[main];
  const int gx = std::max(1, (b.x1 - b.x0 + 1) / 4), gy = std::max(1, (b.y1 - b.y0 + 1) / 4);
  std::vector<unsigned char> group(components.size(), 0);
  for (size_t k = 0; k < components.size(); ++k) {
    const Component& c = components[k];
    group[k] = static_cast<int>(k) == main ||
               (c.x0 >= b.x0 - gx && c.x1 <= b.x1 + gx && c.y0 >= b.y0 - gy && c.y1 <= b.y1 + gy);
  }
  return group;
}

// A candidate of `cell_indices` (row after row): its moving cells (their number and which they
// are), centroid and box; score 0.
HandCandidate candidateOfCells(std::vector<int> cell_indices, const std::vector<float>& motion,
                               int cells_x, int cell_size, int width, int height) {
  HandCandidate candidate;
  candidate.cell_size = cell_size;
  candidate.cells_x = cells_x;
  candidate.cell_indices = std::move(cell_indices);
  if (candidate.cell_indices.empty()) return candidate;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  int x0 = cells_x, y0 = std::numeric_limits<int>::max(), x1 = -1, y1 = -1;
  for (const int i : candidate.cell_indices) {
    const int cx = i % cells_x, cy = i / cells_x;
    if (motion[i] > 0.5f) {
      ++candidate.moving;
      candidate.moving_cell_indices.push_back(i);
    }
    sum += candidate.cellCentre(i);
    x0 = std::min(x0, cx);
    y0 = std::min(y0, cy);
    x1 = std::max(x1, cx);
    y1 = std::max(y1, cy);
  }
  candidate.centroid = sum / static_cast<double>(candidate.cell_indices.size());
  candidate.box = cv::Rect(x0 * cell_size, y0 * cell_size, (x1 - x0 + 1) * cell_size,
                           (y1 - y0 + 1) * cell_size) &
                  cv::Rect(0, 0, width, height);
  return candidate;
}

// Breadth first over the 8-neighbour cell grid from `distance`'s cells at 0 (queued in `queue`):
// every cell that `admit` lets in gets its number of steps, up to `max_steps`; the others stay -1.
// Steps are the shortest path through admitted cells, whatever the order of the seeds.
template <typename Admit>
void growCells(std::vector<int>* queue, std::vector<int>* distance, int cells_x, int cells_y,
               int max_steps, const Admit& admit) {
  for (size_t head = 0; head < queue->size(); ++head) {
    const int cell = (*queue)[head];
    if ((*distance)[cell] >= max_steps) continue;
    const int cx = cell % cells_x, cy = cell / cells_x;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int nx = cx + dx, ny = cy + dy;
        if (nx < 0 || ny < 0 || nx >= cells_x || ny >= cells_y) continue;
        const int n = ny * cells_x + nx;
        if ((*distance)[n] >= 0 || !admit(n)) continue;
        (*distance)[n] = (*distance)[cell] + 1;
        queue->push_back(n);
      }
    }
  }
}

// Cue 9: the cells of `group` (a candidate's cells) within `margin` cells (8-neighbour steps inside
// the group) of one of its moving cells, as a candidate of its own; no cells when none moves.
HandCandidate movingPart(const SegmentationParams& params, const std::vector<int>& group,
                         const std::vector<float>& motion, int cells_x, int cells_y, int cell_size,
                         int width, int height, int margin) {
  const int cells = cells_x * cells_y;
  std::vector<int> distance(cells, -1);
  std::vector<unsigned char> in_group(cells, 0);
  std::vector<int> queue;
  for (const int i : group) {
    in_group[i] = 1;
    if (motion[i] > 0.5f) {
      distance[i] = 0;
      queue.push_back(i);
    }
  }
  growCells(&queue, &distance, cells_x, cells_y, margin, [&](int n) { return in_group[n] != 0; });
  std::vector<int> near_moving;
  for (const int i : group) {
    if (distance[i] >= 0) near_moving.push_back(i);
  }
  HandCandidate part =
      candidateOfCells(std::move(near_moving), motion, cells_x, cell_size, width, height);
  part.score = part.cell_indices.size() + params.room.motion_weight * part.moving;
  return part;
}

// Cue 8: whether a cell's colour `now` differs from `then` (the colour it had when it last
// changed, scaled by the light's change since): its chromaticity by more than
// unchanged_chromaticity, its brightness by more than the factor unchanged_brightness, or one of
// them is (near) black and the other not.
bool colourChanged(const RoomCueParams& room, const float* now, const double* then) {
  const double sum_now = static_cast<double>(now[0]) + now[1] + now[2];
  const double sum_then = then[0] + then[1] + then[2];
  constexpr double kBlack = 15.0;  // as chromaticity()
  if ((sum_now < kBlack) != (sum_then < kBlack)) return true;
  if (sum_now < kBlack) return false;
  const double ratio = sum_now / sum_then;
  if (ratio > room.unchanged_brightness || ratio < 1.0 / room.unchanged_brightness) return true;
  return std::fabs(now[0] / sum_now - then[0] / sum_then) > room.unchanged_chromaticity ||
         std::fabs(now[1] / sum_now - then[1] / sum_then) > room.unchanged_chromaticity;
}

// Cue 8: where the counts of frames stop (~500 days at 25 frames/s); a cell that never changed
// keeps the same count as the memory.
constexpr int kMaxUnchangedFrames = 1 << 30;

// Cue 8: counts, per cell, the frames since its colour last changed (state.unchanged_frames).
void updateUnchangedFrames(const RoomCueParams& room, const std::vector<float>& means, double gain,
                           RoomCueState& state) {
  const size_t cells = means.size() / 3;
  if (state.unchanged_frames.size() != cells) {
    state.unchanged_frames.assign(cells, 0);
    state.unchanged_colour = means;
    state.light = 1.0;
    state.memory_frames = 0;
  }
  if (state.memory_frames < kMaxUnchangedFrames) ++state.memory_frames;
  state.light *= gain;
  for (size_t i = 0; i < cells; ++i) {
    float* colour = &state.unchanged_colour[3 * i];
    const double then[3] = {state.light * colour[0], state.light * colour[1],
                            state.light * colour[2]};
    int& frames = state.unchanged_frames[i];
    if (colourChanged(room, &means[3 * i], then)) {
      frames = 0;
      for (int k = 0; k < 3; ++k) colour[k] = static_cast<float>(means[3 * i + k] / state.light);
    } else if (frames < kMaxUnchangedFrames) {
      ++frames;
    }
  }
}

// Cue 8: the older_quantile of the ages (unchanged frames) of the cells in `cells`; -1 when there
// are fewer than min_cells.
int ageQuantile(const RoomCueParams& room, const RoomCueState& state, const std::vector<int>& cells,
                int min_cells) {
  if (cells.empty() || static_cast<int>(cells.size()) < min_cells) return -1;
  std::vector<int> ages;
  ages.reserve(cells.size());
  for (const int i : cells) ages.push_back(state.unchanged_frames[i]);
  const size_t q =
      std::min(ages.size() - 1, static_cast<size_t>(room.older_quantile * ages.size()));
  std::nth_element(ages.begin(), ages.begin() + q, ages.end());
  return ages[q];
}

// Cue 8: whether at least first_frame_hand_share of `cells` have not changed since the camera's
// first frame (the hand was in view then: nothing is older than it).
bool heldSinceFirstFrame(const RoomCueParams& room, const RoomCueState& state,
                         const std::vector<int>& cells) {
  if (cells.empty()) return false;
  int unchanged = 0;
  for (const int i : cells) unchanged += state.unchanged_frames[i] >= state.memory_frames;
  return unchanged >= room.first_frame_hand_share * static_cast<double>(cells.size());
}

// Cue 8: drops the kept cells older than `limit`, but not those unchanged since the first frame
// when the hand was in view then; with reach_cells > 0, only those within reach_cells cells
// (8-neighbour steps) of a kept cell no older than `limit` (the hand's moving part).
void dropOlderThan(const RoomCueState& state, int limit, bool hand_from_first_frame,
                   int reach_cells, int cells_x, int cells_y, std::vector<unsigned char>& mask) {
  const int cells = cells_x * cells_y;
  std::vector<int> steps_from_young;  // empty: no reach limit
  if (hand_from_first_frame && reach_cells > 0) {
    steps_from_young.assign(cells, -1);
    std::vector<int> queue;
    for (int i = 0; i < cells; ++i) {
      if (mask[i] && state.unchanged_frames[i] <= limit) {
        steps_from_young[i] = 0;
        queue.push_back(i);
      }
    }
    growCells(&queue, &steps_from_young, cells_x, cells_y, reach_cells, [](int) { return true; });
  }
  for (int i = 0; i < cells; ++i) {
    const int age = state.unchanged_frames[i];
    if (age <= limit) continue;
    const bool as_old_as_the_hand = hand_from_first_frame && age >= state.memory_frames &&
                                    (steps_from_young.empty() || steps_from_young[i] >= 0);
    if (!as_old_as_the_hand) mask[i] = 0;
  }
}

}  // namespace

void applyRoomCues(const SegmentationParams& params, const std::vector<float>& means, int cells_x,
                   int cells_y, int cell_size, int width, int height, const cv::Rect& roi,
                   const cv::Mat& roi_mask, const cv::Mat& model_silhouette, bool learn_skin,
                   BackgroundPlate* plate, RoomCueState& state, std::vector<unsigned char>& mask) {
  const RoomCueParams& room = params.room;
  const int cells = cells_x * cells_y;
  const std::vector<unsigned char> candidate = mask;
  const double gain = frameGain(means, state.previous_means);
  const std::vector<float> motion = motionOf(room, means, gain, state, cells);
  state.motion = motion;
  state.previous_means = means;

  // The region of interest in cells.
  const cv::Rect image(0, 0, width, height);
  const cv::Rect box = roi & image;
  const bool has_roi = box.area() > 0;

  std::vector<unsigned char> outline_kept;
  removeUnlikeLearnedSkin(
      params, means, cells_x, cells_y, state,
      /*keep_outline=*/plate == nullptr && params.refine_border_pixels && has_roi, mask,
      &outline_kept);

  const int rx0 = has_roi ? box.x / cell_size : 0, ry0 = has_roi ? box.y / cell_size : 0;
  const int rx1 = has_roi ? (box.x + box.width - 1) / cell_size : cells_x - 1;
  const int ry1 = has_roi ? (box.y + box.height - 1) / cell_size : cells_y - 1;
  // With a mask, a cell is in the region when the mask is set at the cell's centre.
  const bool use_mask =
      has_roi && !roi_mask.empty() && roi_mask.cols == width && roi_mask.rows == height;
  // The pixel at a cell's centre, where the region's mask is read.
  auto cellCentre = [&](int cx, int cy) {
    return cv::Point(std::min(cx * cell_size + cell_size / 2, width - 1),
                     std::min(cy * cell_size + cell_size / 2, height - 1));
  };
  auto inRoi = [&](int cx, int cy) {
    if (!(cx >= rx0 && cx <= rx1 && cy >= ry0 && cy <= ry1)) return false;
    if (!use_mask) return true;
    return roi_mask.at<unsigned char>(cellCentre(cx, cy)) != 0;
  };
  // Cue 6: each cell's depth inside the region (pixels from its edge, at the cell's centre; 0
  // outside).
  std::vector<float> cell_depth;
  if (has_roi && use_mask && room.colour_ratio > 0.0) {
    cv::Mat depth;
    cv::distanceTransform(roi_mask, depth, cv::DIST_L2, 3);
    cell_depth.assign(cells, 0.0f);
    for (int cy = 0; cy < cells_y; ++cy) {
      for (int cx = 0; cx < cells_x; ++cx) {
        if (inRoi(cx, cy)) cell_depth[cy * cells_x + cx] = depth.at<float>(cellCentre(cx, cy));
      }
    }
  }
  if (has_roi) {
    for (int cy = 0; cy < cells_y; ++cy) {
      for (int cx = 0; cx < cells_x; ++cx) {
        if (!inRoi(cx, cy)) mask[cy * cells_x + cx] = 0;
      }
    }
    removeBackgroundColoured(room, means, state, cell_depth, mask);
  }

  // Cue 8 (without a plate): what lay there unchanged before the hand came. The hand arrived
  // moving: its cells changed then, so none is older than the track (or, at the start, than the
  // youngest of the region's cells) by more than the margin, however still it holds later. A hand
  // in view from the first frame changed only where it moved: there, what never changed is kept.
  const bool model_given = model_silhouette.size() == cv::Size(width, height);
  if (plate != nullptr || !room.drop_older_than_hand) {
    state.unchanged_frames.clear();
    state.unchanged_colour.clear();
    state.track_age_reference = -1;
    state.track_frames = 0;
  } else {
    updateUnchangedFrames(room, means, gain, state);
    if (has_roi && learn_skin) {
      if (state.track_age_reference < 0) {
        // The first frame of the track with enough of the hand in this view: the cells under the
        // model (all kept cells without its silhouette).
        std::vector<int> hand;
        for (int cy = 0; cy < cells_y; ++cy) {
          for (int cx = 0; cx < cells_x; ++cx) {
            const int i = cy * cells_x + cx;
            if (mask[i] &&
                (!model_given || model_silhouette.at<unsigned char>(cellCentre(cx, cy)) != 0)) {
              hand.push_back(i);
            }
          }
        }
        state.track_age_reference = ageQuantile(room, state, hand, room.skin_min_cells);
        state.hand_from_first_frame =
            state.track_age_reference >= 0 && heldSinceFirstFrame(room, state, hand);
        state.track_frames = 0;
      }
      if (state.track_age_reference >= 0) {
        const int limit = state.track_age_reference + state.track_frames + room.older_margin_frames;
        dropOlderThan(state, limit, state.hand_from_first_frame, 0, cells_x, cells_y, mask);
        ++state.track_frames;
      }
    } else {
      // No tracked hand: the next tracked region starts a new track.
      state.track_age_reference = -1;
      state.track_frames = 0;
      if (has_roi) {
        // A region of candidates (the start): against its own youngest cells.
        std::vector<int> kept;
        for (int i = 0; i < cells; ++i) {
          if (mask[i]) kept.push_back(i);
        }
        const int reference = ageQuantile(room, state, kept, room.skin_min_cells);
        if (reference >= 0) {
          dropOlderThan(state, reference + room.older_margin_frames,
                        heldSinceFirstFrame(room, state, kept), room.first_frame_hand_reach_cells,
                        cells_x, cells_y, mask);
        }
      }
    }
  }

  // Cue 7 (without a plate, which holds still objects already): a cell that stays still outside
  // the model. Under the model the count starts again, so that a still hand the model has not
  // yet covered is not lost for good once it is; motion starts it again too. A set without the
  // model (a restart, a re-check's switch) neither counts nor forgets: the ball that was still
  // beside the other arm is still beside the hand (doc/segmentation.md, "Session 20").
  const bool cue_on = plate == nullptr && room.still_object_frames > 0;
  const bool count_still =
      cue_on && has_roi && learn_skin && model_silhouette.size() == cv::Size(width, height);
  if (!cue_on) {
    state.still_outside.clear();
  } else if (count_still) {
    if (state.still_outside.size() != static_cast<size_t>(cells)) {
      state.still_outside.assign(cells, 0);
    }
    for (int cy = 0; cy < cells_y; ++cy) {
      for (int cx = 0; cx < cells_x; ++cx) {
        const int i = cy * cells_x + cx;
        unsigned short& frames = state.still_outside[i];
        const bool under_model = model_silhouette.at<unsigned char>(cellCentre(cx, cy)) != 0;
        if (under_model || motion[i] >= 1.0f) {
          frames = 0;
          continue;
        }
        if (frames < room.still_object_frames) ++frames;
        if (frames >= room.still_object_frames) mask[i] = 0;
      }
    }
  }

  // Connected components and their cues.
  std::vector<int> labels;
  const std::vector<Component> components =
      analyseComponents(params, means, cells_x, cells_y, mask, motion, labels);
  const int count = static_cast<int>(components.size());
  std::vector<unsigned char> keep(count, 0);
  if (count > 0) {
    if (has_roi) {
      int largest = 0;
      for (const Component& c : components) largest = std::max(largest, c.cells);
      for (int k = 0; k < count; ++k) {
        keep[k] =
            components[k].cells >= room.min_component_share * largest || components[k].moving > 0;
      }
    } else {
      int best = 0;
      for (int k = 1; k < count; ++k) {
        if (components[k].score > components[best].score) best = k;
      }
      keep = groupAround(components, best);
    }
  }
  for (int i = 0; i < cells; ++i) mask[i] = labels[i] >= 0 && keep[labels[i]] ? 1 : 0;

  // Learn the user's skin colour from the hand's foreground once the hand is tracked. Robustly:
  // the median chromaticity of the kept cells, then mean and covariance of the cells within
  // kSkinTrim of it, so that background that passed the gates inside the region (a photograph, a
  // wooden edge) does not widen the model.
  if (has_roi && learn_skin) {
    std::vector<double> rs, gs;
    for (int i = 0; i < cells; ++i) {
      double r, g;
      // Not the outline's cells that only the mix with grey let through: they would widen it.
      if (!mask[i] || outline_kept[i] || !chromaticity(&means[3 * i], &r, &g)) continue;
      // Only what has skin colour at all (in plate mode the region also holds changed
      // background).
      const float* m = &means[3 * i];
      if (!isSkinColour(Eigen::Vector3d(m[0], m[1], m[2]), params.skin)) continue;
      rs.push_back(r);
      gs.push_back(g);
    }
    if (static_cast<int>(rs.size()) >= room.skin_min_cells) {
      constexpr double kSkinTrim = 0.03;
      std::vector<double> sorted_r = rs, sorted_g = gs;
      std::nth_element(sorted_r.begin(), sorted_r.begin() + sorted_r.size() / 2, sorted_r.end());
      std::nth_element(sorted_g.begin(), sorted_g.begin() + sorted_g.size() / 2, sorted_g.end());
      const double median_r = sorted_r[sorted_r.size() / 2];
      const double median_g = sorted_g[sorted_g.size() / 2];
      double sum_r = 0.0, sum_g = 0.0, sum_rr = 0.0, sum_rg = 0.0, sum_gg = 0.0;
      int n = 0;
      for (size_t k = 0; k < rs.size(); ++k) {
        if (std::hypot(rs[k] - median_r, gs[k] - median_g) > kSkinTrim) continue;
        sum_r += rs[k];
        sum_g += gs[k];
        sum_rr += rs[k] * rs[k];
        sum_rg += rs[k] * gs[k];
        sum_gg += gs[k] * gs[k];
        ++n;
      }
      if (n >= room.skin_min_cells) {
        const double mr = sum_r / n, mg = sum_g / n;
        const double cov[3] = {sum_rr / n - mr * mr, sum_rg / n - mr * mg, sum_gg / n - mg * mg};
        const double rate = state.skin_frames == 0 ? 1.0 : room.skin_learning_rate;
        state.skin_mean[0] += rate * (mr - state.skin_mean[0]);
        state.skin_mean[1] += rate * (mg - state.skin_mean[1]);
        for (int k = 0; k < 3; ++k) state.skin_cov[k] += rate * (cov[k] - state.skin_cov[k]);
        ++state.skin_frames;
      }
    }
  }

  // Cue 6: the hand's colours against the skin-coloured background, in this camera. The hand is
  // sampled deep inside the tracked region (at least colour_core_depth pixels from its edge: under
  // the model, not a wooden edge or a photograph the region also holds), the background outside
  // the region and in its outer rim (less than colour_rim_depth from its edge: beyond the model's
  // silhouette, where what touches the hand lies).
  if (has_roi && learn_skin && !cell_depth.empty()) {
    std::vector<int> hand_cells, background_cells;
    for (int cy = 0; cy < cells_y; ++cy) {
      for (int cx = 0; cx < cells_x; ++cx) {
        const int i = cy * cells_x + cx;
        const float* m = &means[3 * i];
        if (!candidate[i] || !isSkinColour(Eigen::Vector3d(m[0], m[1], m[2]), params.skin)) {
          continue;
        }
        const float d = cell_depth[i];
        if (mask[i] && d >= room.colour_core_depth) {
          hand_cells.push_back(i);
        } else if (d < room.colour_rim_depth) {
          background_cells.push_back(i);
        }
      }
    }
    // The background needs only a few cells to count: one photograph corner is evidence.
    learnColours(means, hand_cells, room.skin_min_cells, room.colour_learning_rate,
                 state.hand_colour);
    if (!state.hand_colour.empty()) {
      learnColours(means, background_cells, 4, room.colour_learning_rate, state.background_colour);
    }
  }

  // The plate follows the scene where the hand is not (outside the region, not foreground).
  if (plate != nullptr && room.plate_adaptation_rate > 0.0 && plate->frameCount() > 0) {
    for (int cy = 0; cy < cells_y; ++cy) {
      for (int cx = 0; cx < cells_x; ++cx) {
        const int i = cy * cells_x + cx;
        // Before the hand is tracked, what might be hand (a candidate) is not learned either.
        const bool maybe_hand = has_roi ? inRoi(cx, cy) : candidate[i] != 0;
        if (mask[i] || maybe_hand || motion[i] > 0.5f) continue;
        plate->adaptCell(i, &means[3 * i], room.plate_adaptation_rate);
      }
    }
  }
}

std::vector<HandCandidate> roomCandidates(const SegmentationParams& params,
                                          const std::vector<float>& means, int cells_x, int cells_y,
                                          int cell_size, int width, int height,
                                          const RoomCueState& state,
                                          std::vector<unsigned char> mask, int max_candidates) {
  const int cells = cells_x * cells_y;
  const std::vector<float> motion =
      motionOf(params.room, means, frameGain(means, state.previous_means), state, cells);
  removeUnlikeLearnedSkin(params, means, cells_x, cells_y, state, /*keep_outline=*/false, mask);
  std::vector<int> labels;
  const std::vector<Component> components =
      analyseComponents(params, means, cells_x, cells_y, mask, motion, labels);
  std::vector<int> order(components.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return components[a].score > components[b].score; });
  std::vector<HandCandidate> candidates;
  std::vector<unsigned char> taken(components.size(), 0);  // already in a better group
  for (const int main : order) {
    if (static_cast<int>(candidates.size()) >= max_candidates) break;
    if (taken[main]) continue;
    const std::vector<unsigned char> group = groupAround(components, main);
    std::vector<int> group_cells;
    for (int i = 0; i < cells; ++i) {
      if (labels[i] >= 0 && group[labels[i]]) group_cells.push_back(i);
    }
    for (size_t k = 0; k < group.size(); ++k) taken[k] = taken[k] || group[k];
    if (group_cells.empty()) continue;
    HandCandidate candidate =
        candidateOfCells(std::move(group_cells), motion, cells_x, cell_size, width, height);
    candidate.score = components[main].score;
    // Cue 9: an oversized group that moves somewhere also offers its moving part.
    const bool split = params.room.split_candidate_share > 0.0 && candidate.moving > 0 &&
                       candidate.cell_indices.size() > params.room.split_candidate_share * cells;
    HandCandidate part;
    if (split) {
      part = movingPart(params, candidate.cell_indices, motion, cells_x, cells_y, cell_size, width,
                        height, params.room.split_margin_cells);
    }
    candidates.push_back(std::move(candidate));
    if (!part.cell_indices.empty() && static_cast<int>(candidates.size()) < max_candidates) {
      candidates.push_back(std::move(part));
    }
  }
  return candidates;
}

void sleeveNextToForeground(const SegmentationParams& params, const std::vector<float>& means,
                            int cells_x, int cells_y, int cell_size,
                            const std::vector<unsigned char>& mask, int* arm_cells,
                            Eigen::Vector2d* arm_centroid, std::vector<int>* band) {
  std::vector<unsigned char> sleeve(static_cast<size_t>(cells_x) * cells_y);
  for (size_t i = 0; i < sleeve.size(); ++i) {
    const float* m = &means[3 * i];
    sleeve[i] = isDarkNonSkin(Eigen::Vector3d(m[0], m[1], m[2]), params.background) ? 1 : 0;
  }
  sleeveNextToForeground(params, sleeve, cells_x, cells_y, cell_size, mask, arm_cells, arm_centroid,
                         band);
}

void sleeveNextToForeground(const SegmentationParams& params,
                            const std::vector<unsigned char>& sleeve, int cells_x, int cells_y,
                            int cell_size, const std::vector<unsigned char>& mask, int* arm_cells,
                            Eigen::Vector2d* arm_centroid, std::vector<int>* band) {
  *arm_cells = 0;
  *arm_centroid = Eigen::Vector2d::Zero();
  band->clear();
  const int cells = cells_x * cells_y;
  std::vector<int> distance(cells, -1);
  std::vector<int> queue;
  Eigen::Vector2d foreground_sum = Eigen::Vector2d::Zero();
  int foreground = 0, x0 = cells_x, x1 = -1, y0 = cells_y, y1 = -1;
  for (int i = 0; i < cells; ++i) {
    if (!mask[i]) continue;
    distance[i] = 0;
    queue.push_back(i);
    const int cx = i % cells_x, cy = i / cells_x;
    foreground_sum += Eigen::Vector2d(cx, cy);
    ++foreground;
    x0 = std::min(x0, cx);
    x1 = std::max(x1, cx);
    y0 = std::min(y0, cy);
    y1 = std::max(y1, cy);
  }
  if (foreground == 0) return;
  // Breadth first from the foreground through dark cells, up to the band's width: the cells
  // reached (queued after the foreground) are the sleeve.
  const size_t seeds = queue.size();
  growCells(&queue, &distance, cells_x, cells_y, params.room.sleeve_band_cells,
            [&](int n) { return sleeve[n] != 0; });
  Eigen::Vector2d sleeve_sum = Eigen::Vector2d::Zero();
  const int band_size = static_cast<int>(queue.size() - seeds);
  for (size_t k = seeds; k < queue.size(); ++k) {
    sleeve_sum += Eigen::Vector2d(queue[k] % cells_x, queue[k] / cells_x);
  }
  if (band_size == 0) return;
  const Eigen::Vector2d sleeve_centre = sleeve_sum / band_size;
  const Eigen::Vector2d foreground_centre = foreground_sum / foreground;
  const double diagonal = std::hypot(x1 - x0 + 1.0, y1 - y0 + 1.0);
  // Dark cells all around the hand (shadows, a dark table) say nothing about the wrist.
  if ((sleeve_centre - foreground_centre).norm() < params.room.sleeve_min_offset * diagonal) return;
  *arm_cells = band_size;
  *arm_centroid = (sleeve_centre + Eigen::Vector2d(0.5, 0.5)) * cell_size;
  band->assign(queue.begin() + static_cast<std::ptrdiff_t>(seeds), queue.end());
}

}  // namespace detail
}  // namespace sag_hand_tracker
