// Internals of the segmentation shared by quadtree_segmentation.cpp and background_plate.cpp.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "sag_hand_tracker/segmentation/quadtree_segmentation.h"

namespace sag_hand_tracker {
namespace detail {

// Integral image of an RGB8 image, sampled on the grid lines that segmentation queries. With grid
// step g (a power of two), entry (j, i) holds the sums over the pixels with row < min(j g, height)
// and column < min(i g, width) of R, G, B, R^2, G^2, B^2 (lanes 0-5; lanes 6-7 are zero padding so
// that one entry is one 256-bit vector). Every quad-tree node and every plate cell starts at a
// multiple of g and ends at a multiple of g or at the image border, so this subsampled integral
// image gives the exact sums over each of them in O(1) while storing g^2 times fewer entries than a
// full one (which made it 5x faster to build).
// The sums are uint32 and wrap modulo 2^32: the sum over a rectangle, a difference of four
// entries, is still exact whenever its true value is below 2^32, i.e. for every rectangle of up to
// 2^32 / 255^2 = 66051 pixels, whatever the image size. The quad-tree's largest node (128 x 128)
// and the plate cells (<= 64 x 64) are far below that.
struct ColourIntegral {
  static constexpr int kLanes = 8;
  int width = 0;   // pixels
  int height = 0;  // pixels
  int step = 1;    // g
  int shift = 0;   // log2(g): index() divides by a shift, not an integer division per corner
  int cols = 0;    // entries per row: ceil(width / g) + 1
  int rows = 0;    // ceil(height / g) + 1
  std::vector<std::uint32_t> data;
  std::vector<std::uint16_t> column_sum;     // scratch: per row element, sum over a band of rows
  std::vector<std::uint32_t> column_sum_sq;  // same, squares

  // step: power of two in [1, 256] (a band of 256 rows of 255 still fits the 16-bit column sums).
  void compute(const cv::Mat& rgb, int step);

  // Entry index of a pixel coordinate that is a multiple of step or the image border.
  int index(int pixel) const { return (pixel + step - 1) >> shift; }
  const std::uint32_t* entry(int j, int i) const {
    return data.data() + (static_cast<std::size_t>(j) * cols + i) * kLanes;
  }
  // Sums over columns [x0, x1) and rows [y0, y1) (multiples of step or the border):
  // out[0..2] = sums of R, G, B, out[3..5] = sums of their squares.
  void region(int x0, int y0, int x1, int y1, std::uint32_t out[6]) const {
    const int i0 = index(x0), i1 = index(x1), j0 = index(y0), j1 = index(y1);
    const std::uint32_t* a = entry(j0, i0);
    const std::uint32_t* b = entry(j0, i1);
    const std::uint32_t* c = entry(j1, i0);
    const std::uint32_t* d = entry(j1, i1);
    for (int k = 0; k < 6; ++k) out[k] = d[k] - b[k] - c[k] + a[k];
  }
};

// Mean colour of every cell_size x cell_size cell (the last row/column clipped by the border):
// ceil(height / cell_size) x ceil(width / cell_size) cells, row after row, R,G,B per cell.
void cellMeans(const ColourIntegral& integral, int cell_size, std::vector<float>& means);

inline int cellCount(int pixels, int cell_size) { return (pixels + cell_size - 1) / cell_size; }

// The room cues of RoomCueParams on a frame's candidate cell mask (plate / skin gate done, isolated
// cells removed): narrows `mask` down to the hand and updates `state` (motion, learned skin
// colour) and, when given, the plate (adaptation where the hand is not). `means`: the frame's
// cell means; `roi`: pixels, empty for none; `roi_mask`: optional (empty or image size, CV_8UC1),
// narrows the region to its non-zero pixels; `learn_skin`: the region comes from the tracked hand,
// so the user's skin colour may be learned from what it keeps.
void applyRoomCues(const SegmentationParams& params, const std::vector<float>& means, int cells_x,
                   int cells_y, int cell_size, int width, int height, const cv::Rect& roi,
                   const cv::Mat& roi_mask, const cv::Mat& model_silhouette, bool learn_skin,
                   BackgroundPlate* plate, RoomCueState& state, std::vector<unsigned char>& mask);

// Without a plate (the skin gate), the forearm evidence of ImageSoG::arm_cells: the dark,
// unsaturated cells (the sleeve) reached from the kept foreground `mask` through such cells within
// RoomCueParams::sleeve_band_cells; counted and averaged (pixels) when their centroid lies at
// least sleeve_min_offset of the foreground's box diagonal from the foreground's centroid (to one
// side, as a sleeve at the wrist does), else 0 cells. `band` gets those cells' indices (empty with
// 0 cells).
void sleeveNextToForeground(const SegmentationParams& params, const std::vector<float>& means,
                            int cells_x, int cells_y, int cell_size,
                            const std::vector<unsigned char>& mask, int* arm_cells,
                            Eigen::Vector2d* arm_centroid, std::vector<int>* band);
// The same with the sleeve's cells given (`sleeve`: 1 where a cell may be sleeve; with the plate,
// the cells that differ from it and are too dark to be skin).
void sleeveNextToForeground(const SegmentationParams& params,
                            const std::vector<unsigned char>& sleeve, int cells_x, int cells_y,
                            int cell_size, const std::vector<unsigned char>& mask, int* arm_cells,
                            Eigen::Vector2d* arm_centroid, std::vector<int>* band);

// The groups that applyRoomCues would choose from without a region of interest (cue 3), best
// score first, at most max_candidates; `state` is only read (motion and learned skin colour).
std::vector<HandCandidate> roomCandidates(const SegmentationParams& params,
                                          const std::vector<float>& means, int cells_x, int cells_y,
                                          int cell_size, int width, int height,
                                          const RoomCueState& state,
                                          std::vector<unsigned char> mask, int max_candidates);

}  // namespace detail
}  // namespace sag_hand_tracker
