// Quad-tree clustering of an RGB image into an image SoG (paper section 4.1) and the
// ImageSegmenter entry point. See segmentation.h for the method and its parameters.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <string>

#include "sag_hand_tracker/energy/colour.h"
#include "sag_hand_tracker/segmentation/quadtree_segmentation.h"
#include "segmentation_internal.h"

namespace sag_hand_tracker {

namespace detail {

void ColourIntegral::compute(const cv::Mat& rgb, int grid_step) {
  width = rgb.cols;
  height = rgb.rows;
  step = grid_step;
  shift = 0;
  while ((1 << shift) < step) ++shift;
  cols = (width + step - 1) / step + 1;
  rows = (height + step - 1) / step + 1;
  const std::size_t row_entries = static_cast<std::size_t>(cols) * kLanes;
  data.resize(static_cast<std::size_t>(rows) * row_entries);
  std::fill(data.begin(), data.begin() + row_entries, 0u);
  const int elements = 3 * width;
  column_sum.resize(elements);
  column_sum_sq.resize(elements);
  std::uint16_t* sum = column_sum.data();
  std::uint32_t* sum_sq = column_sum_sq.data();
  for (int j = 1; j < rows; ++j) {
    // Vertical pass over the band of rows [(j - 1) step, min(j step, height)): element-wise on the
    // interleaved R,G,B bytes, which the compiler vectorises. 256 rows of 255 fit in 16 bits.
    const int y0 = (j - 1) * step, y1 = std::min(j * step, height);
    {
      const std::uint8_t* src = rgb.ptr<std::uint8_t>(y0);
      for (int e = 0; e < elements; ++e) {
        const std::uint32_t v = src[e];
        sum[e] = static_cast<std::uint16_t>(v);
        sum_sq[e] = v * v;
      }
    }
    for (int y = y0 + 1; y < y1; ++y) {
      const std::uint8_t* src = rgb.ptr<std::uint8_t>(y);
      for (int e = 0; e < elements; ++e) {
        const std::uint32_t v = src[e];
        sum[e] = static_cast<std::uint16_t>(sum[e] + v);
        sum_sq[e] += v * v;
      }
    }
    // Horizontal pass: block sums, running along the row, plus the entry above.
    const std::uint32_t* above = data.data() + (j - 1) * row_entries;
    std::uint32_t* out = data.data() + j * row_entries;
    std::uint32_t acc[kLanes] = {0, 0, 0, 0, 0, 0, 0, 0};
    for (int k = 0; k < kLanes; ++k) out[k] = 0;
    // Adds the column sums of pixels [x0, x1) to to[0..5].
    auto add_columns = [&](int x0, int x1, std::uint32_t* to) {
      for (int x = x0; x < x1; ++x) {
        for (int c = 0; c < 3; ++c) {
          to[c] += sum[3 * x + c];
          to[3 + c] += sum_sq[3 * x + c];
        }
      }
    };
    // Steps up to 16: the sums of the whole blocks by doubling, element-wise (vectorised): after
    // the passes at offsets 3, 6, ..., 3 step / 2, element 3x + c holds the sum over pixels
    // x .. x + step - 1 of channel c (a block of 16 x 16 pixels of 255 still fits 16 bits). The
    // last block, cut by the border, is summed first, from the column sums as they were. Larger
    // steps add the columns block by block.
    const bool doubling = step <= 16;
    const int whole_blocks = doubling ? width / step : 0;
    std::uint32_t cut[6] = {0, 0, 0, 0, 0, 0};
    if (doubling) {
      add_columns(whole_blocks * step, width, cut);
      for (int offset = 3; offset < 3 * step; offset *= 2) {
        for (int e = 0; e + offset < elements; ++e) {
          sum[e] = static_cast<std::uint16_t>(sum[e] + sum[e + offset]);
          sum_sq[e] += sum_sq[e + offset];
        }
      }
    }
    for (int i = 1; i < cols; ++i) {
      const int x0 = (i - 1) * step;
      if (i <= whole_blocks) {
        add_columns(x0, x0 + 1, acc);  // the block's sums, at its first column
      } else if (doubling) {
        for (int k = 0; k < 6; ++k) acc[k] += cut[k];
      } else {
        add_columns(x0, std::min(i * step, width), acc);
      }
      const std::uint32_t* up = above + i * kLanes;
      std::uint32_t* o = out + i * kLanes;
      for (int k = 0; k < kLanes; ++k) o[k] = up[k] + acc[k];
    }
  }
}

void cellMeans(const ColourIntegral& integral, int cell_size, std::vector<float>& means) {
  const int cells_x = cellCount(integral.width, cell_size);
  const int cells_y = cellCount(integral.height, cell_size);
  means.resize(static_cast<std::size_t>(cells_x) * cells_y * 3);
  float* m = means.data();
  // Cells start on the integral's grid (the cell size is a multiple of its step): a whole cell
  // spans `span` entries of a row, and only the last column can be cut by the border. Reading the
  // entries directly, with one 1/n per row, made this twice as fast as region() per cell.
  const std::size_t span =
      static_cast<std::size_t>(cell_size >> integral.shift) * ColourIntegral::kLanes;
  const int whole_x = integral.width / cell_size;
  std::uint32_t s[6];
  for (int cy = 0; cy < cells_y; ++cy) {
    const int y0 = cy * cell_size, y1 = std::min(y0 + cell_size, integral.height);
    const std::uint32_t* top = integral.entry(integral.index(y0), 0);
    const std::uint32_t* bottom = integral.entry(integral.index(y1), 0);
    const float inv_whole = 1.0f / static_cast<float>(cell_size * (y1 - y0));
    for (int cx = 0; cx < whole_x; ++cx) {
      const std::size_t i0 = cx * span, i1 = i0 + span;
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t sum = bottom[i1 + k] - top[i1 + k] - bottom[i0 + k] + top[i0 + k];
        *m++ = static_cast<float>(sum) * inv_whole;
      }
    }
    for (int cx = whole_x; cx < cells_x; ++cx) {
      const int x0 = cx * cell_size, x1 = std::min(x0 + cell_size, integral.width);
      integral.region(x0, y0, x1, y1, s);
      const float inv_n = 1.0f / static_cast<float>((x1 - x0) * (y1 - y0));
      *m++ = static_cast<float>(s[0]) * inv_n;
      *m++ = static_cast<float>(s[1]) * inv_n;
      *m++ = static_cast<float>(s[2]) * inv_n;
    }
  }
}

}  // namespace detail

namespace {

using detail::ColourIntegral;

bool isPowerOfTwo(int v) { return v > 0 && (v & (v - 1)) == 0; }

// Scratch buffers of segment(), one set per thread: large buffers are reused instead of being
// allocated (and page-faulted in) for every image.
struct Workspace {
  ColourIntegral integral;
  std::vector<float> cell_means;
  std::vector<unsigned char> differs;  // with the plate: the cells that differ from it
  std::vector<unsigned char> mask;
  std::vector<unsigned char> mask_tmp;
  std::vector<int> mask_integral;
  std::vector<unsigned char> border;  // refine_border_pixels: the border cells of `mask`
  std::vector<int> border_integral;
  // With the plate: the cells that differ from it but are too dark for skin (the sleeve).
  std::vector<unsigned char> sleeve;
  int arm_cells = 0;  // the forearm evidence of the last image (see ImageSoG::arm_cells)
  Eigen::Vector2d arm_sum = Eigen::Vector2d::Zero();
  std::vector<int> arm_band;  // its cells
};

Workspace& workspace() {
  thread_local Workspace ws;
  return ws;
}

// The foreground cells seen by the quad-tree (absent: everything is foreground).
struct CellMask {
  const unsigned char* cells = nullptr;
  const int* integral = nullptr;  // (cells_y + 1) x (cells_x + 1)
  int cells_x = 0;
  int cells_y = 0;
  int cell_size = 1;
  // With refine_border_pixels: the border cells (and their integral image), and the foreground
  // at pixel level with the image, from which the leaves inside border cells are made.
  const unsigned char* border = nullptr;
  const int* border_integral = nullptr;
  const cv::Mat* pixels = nullptr;  // CV_8UC1, 255 on the foreground
  const cv::Mat* rgb = nullptr;

  // Foreground cells and all cells touched by the node at (x, y) of side s (clipped to the image).
  void count(int x, int y, int s, int& foreground, int& total) const {
    foreground = sum(cells, integral, x, y, s, &total);
  }
  // Border cells touched by the node.
  int borders(int x, int y, int s) const {
    int total = 0;
    return border == nullptr ? 0 : sum(border, border_integral, x, y, s, &total);
  }

 private:
  int sum(const unsigned char* values, const int* values_integral, int x, int y, int s,
          int* total) const {
    if (s <= cell_size) {  // nodes and cells are aligned powers of two: inside one cell
      *total = 1;
      return values[(y / cell_size) * cells_x + x / cell_size];
    }
    const int cx0 = x / cell_size, cy0 = y / cell_size;
    const int cx1 = std::min(cx0 + s / cell_size, cells_x);
    const int cy1 = std::min(cy0 + s / cell_size, cells_y);
    const int stride = cells_x + 1;
    *total = (cx1 - cx0) * (cy1 - cy0);
    return values_integral[cy1 * stride + cx1] - values_integral[cy0 * stride + cx1] -
           values_integral[cy1 * stride + cx0] + values_integral[cy0 * stride + cx0];
  }
};

class Quadtree {
 public:
  Quadtree(const ColourIntegral& integral, const QuadtreeParams& params, const CellMask* mask,
           ImageSoG& sog, std::vector<QuadtreeLeaf>* leaves)
      : integral_(integral),
        params_(params),
        mask_(mask),
        sog_(sog),
        leaves_(leaves),
        max_variance_(params.max_colour_std * params.max_colour_std) {}

  void run() {
    const int root = params_.max_leaf_size;
    for (int y = 0; y < integral_.height; y += root) {
      for (int x = 0; x < integral_.width; x += root) visit(x, y, root);
    }
  }

 private:
  void visit(int x, int y, int s) {
    if (x >= integral_.width || y >= integral_.height) return;
    const int x1 = std::min(x + s, integral_.width);
    const int y1 = std::min(y + s, integral_.height);
    const bool can_split = s > params_.min_leaf_size;
    bool split = can_split && (x1 - x < s || y1 - y < s);  // clipped by the border
    if (mask_ != nullptr) {
      int foreground = 0, total = 0;
      mask_->count(x, y, s, foreground, total);
      if (foreground == 0) return;
      if (foreground < total) {
        if (can_split) {
          split = true;
        } else if (2 * foreground < total) {
          return;  // a smallest leaf that is mostly background
        }
      }
    }
    if (!split && mask_ != nullptr && mask_->borders(x, y, s) > 0) {
      // On the silhouette's border: down to the smallest leaves, each made of its foreground
      // pixels only.
      if (!can_split) {
        emitForegroundPixels(x, y, x1, y1);
        return;
      }
      split = true;
    }
    std::uint32_t sums[6];
    integral_.region(x, y, x1, y1, sums);
    const int n = (x1 - x) * (y1 - y);
    const double inv_n = 1.0 / n;
    double mean[3];
    for (int k = 0; k < 3; ++k) mean[k] = sums[k] * inv_n;
    if (!split && can_split) {
      for (int k = 0; k < 3; ++k) {
        if (sums[3 + k] * inv_n - mean[k] * mean[k] > max_variance_) {
          split = true;
          break;
        }
      }
    }
    if (split) {
      const int h = s / 2;
      visit(x, y, h);
      visit(x + h, y, h);
      visit(x, y + h, h);
      visit(x + h, y + h, h);
      return;
    }
    emit(x, y, x1 - x, y1 - y, mean);
  }

  // A leaf of the foreground pixels in [x0, x1) x [y0, y1): at their centroid, with their area
  // (sigma = sigma_per_leaf_size * sqrt(count), as a square leaf of that area) and mean colour.
  void emitForegroundPixels(int x0, int y0, int x1, int y1) {
    int count = 0;
    double sx = 0.0, sy = 0.0, colour[3] = {0.0, 0.0, 0.0};
    for (int y = y0; y < y1; ++y) {
      const unsigned char* keep = mask_->pixels->ptr<unsigned char>(y);
      const unsigned char* px = mask_->rgb->ptr<unsigned char>(y);
      for (int x = x0; x < x1; ++x) {
        if (!keep[x]) continue;
        ++count;
        sx += x;
        sy += y;
        for (int k = 0; k < 3; ++k) colour[k] += px[3 * x + k];
      }
    }
    if (count == 0) return;
    for (double& c : colour) c /= count;
    emit(x0, y0, x1 - x0, y1 - y0, colour, Eigen::Vector2d(sx / count, sy / count),
         params_.sigma_per_leaf_size * std::sqrt(static_cast<double>(count)));
  }

  void emit(int x, int y, int w, int h, const double mean[3]) {
    emit(x, y, w, h, mean, Eigen::Vector2d(x + 0.5 * (w - 1), y + 0.5 * (h - 1)),
         params_.sigma_per_leaf_size * (w == h ? w : std::sqrt(static_cast<double>(w) * h)));
  }

  void emit(int x, int y, int w, int h, const double mean[3], const Eigen::Vector2d& centre,
            double sigma) {
    ImageGaussian g;
    g.mean = centre;
    g.sigma = sigma;
    g.hsv = rgbToHsv(mean[0], mean[1], mean[2]);
    sog_.gaussians.push_back(g);
    if (leaves_ != nullptr) {
      QuadtreeLeaf leaf;
      leaf.x = x;
      leaf.y = y;
      leaf.width = w;
      leaf.height = h;
      leaf.rgb = Eigen::Vector3d(mean[0], mean[1], mean[2]);
      leaves_->push_back(leaf);
    }
  }

  const ColourIntegral& integral_;
  const QuadtreeParams& params_;
  const CellMask* mask_;
  ImageSoG& sog_;
  std::vector<QuadtreeLeaf>* leaves_;
  double max_variance_;
};

ImageSoG runQuadtree(const ColourIntegral& integral, const QuadtreeParams& params,
                     const CellMask* mask, std::vector<QuadtreeLeaf>* leaves) {
  ImageSoG sog;
  sog.width = integral.width;
  sog.height = integral.height;
  sog.gaussians.reserve(1024);
  if (leaves != nullptr) leaves->clear();
  Quadtree(integral, params, mask, sog, leaves).run();
  return sog;
}

// Drops foreground cells without a foreground 8-neighbour. tmp: scratch of the same size.
void removeIsolatedCells(std::vector<unsigned char>& mask, std::vector<unsigned char>& tmp,
                         int cells_x, int cells_y) {
  tmp = mask;
  // Raw pointers, as in prepare(): through the vectors every cell reloaded their data pointers.
  const unsigned char* before = tmp.data();
  unsigned char* after = mask.data();
  for (int cy = 0; cy < cells_y; ++cy) {
    for (int cx = 0; cx < cells_x; ++cx) {
      if (!before[cy * cells_x + cx]) continue;
      bool neighbour = false;
      for (int dy = -1; dy <= 1 && !neighbour; ++dy) {
        const int ny = cy + dy;
        if (ny < 0 || ny >= cells_y) continue;
        for (int dx = -1; dx <= 1; ++dx) {
          const int nx = cx + dx;
          if ((dx == 0 && dy == 0) || nx < 0 || nx >= cells_x) continue;
          if (before[ny * cells_x + nx]) {
            neighbour = true;
            break;
          }
        }
      }
      if (!neighbour) after[cy * cells_x + cx] = 0;
    }
  }
}

}  // namespace

const char* toString(SegmentationMode mode) {
  switch (mode) {
    case SegmentationMode::kNone:
      return "none";
    case SegmentationMode::kPlate:
      return "plate";
    case SegmentationMode::kSkin:
      return "skin";
    case SegmentationMode::kPlateAndSkin:
      return "plate_and_skin";
  }
  return "unknown";
}

SegmentationMode parseSegmentationMode(const std::string& name) {
  for (SegmentationMode mode : {SegmentationMode::kNone, SegmentationMode::kPlate,
                                SegmentationMode::kSkin, SegmentationMode::kPlateAndSkin}) {
    if (name == toString(mode)) return mode;
  }
  throw InputError("unknown segmentation mode '" + name +
                   "' (expected none, plate, skin or plate_and_skin)");
}

void checkRgbImage(const cv::Mat& rgb, const char* what) {
  if (rgb.empty()) throw InputError(std::string(what) + ": the image is empty");
  if (rgb.type() != CV_8UC3) {
    throw InputError(std::string(what) + ": expected an 8-bit 3-channel RGB image (CV_8UC3), got " +
                     cv::typeToString(rgb.type()));
  }
  if (rgb.dims != 2) throw InputError(std::string(what) + ": expected a 2-dimensional image");
}

void validate(const SegmentationParams& params) {
  auto fail = [](const std::string& message) {
    throw InputError("bad segmentation parameter: " + message);
  };
  const QuadtreeParams& q = params.quadtree;
  if (!isPowerOfTwo(q.min_leaf_size)) fail("quadtree.min_leaf_size must be a power of two >= 1");
  if (!isPowerOfTwo(q.max_leaf_size) || q.max_leaf_size < q.min_leaf_size ||
      q.max_leaf_size > 128) {
    fail("quadtree.max_leaf_size must be a power of two in [min_leaf_size, 128]");
  }
  if (!(q.max_colour_std >= 0.0)) fail("quadtree.max_colour_std must be >= 0");
  if (!(q.sigma_per_leaf_size > 0.0)) fail("quadtree.sigma_per_leaf_size must be > 0");
  if (!isPowerOfTwo(params.cell_size) || params.cell_size > 64) {
    fail("cell_size must be a power of two in [1, 64]");
  }
  const BackgroundParams& b = params.background;
  if (b.frames < 1) fail("background.frames must be >= 1");
  if (!(b.k_sigma >= 0.0)) fail("background.k_sigma must be >= 0");
  if (!(b.min_tolerance > 0.0)) fail("background.min_tolerance must be > 0");
  if (!(b.shadow_min_ratio >= 0.0 && b.shadow_min_ratio <= 1.0)) {
    fail("background.shadow_min_ratio must be in [0, 1]");
  }
  if (!(b.shadow_chroma_tolerance >= 0.0)) fail("background.shadow_chroma_tolerance must be >= 0");
  if (!(b.shadow_min_plate_brightness >= 0.0)) {
    fail("background.shadow_min_plate_brightness must be >= 0");
  }
  const SkinParams& s = params.skin;
  if (!(s.hue_max_deg > s.hue_min_deg && s.hue_max_deg - s.hue_min_deg <= 360.0)) {
    fail("skin.hue_min_deg < skin.hue_max_deg <= skin.hue_min_deg + 360 is required");
  }
  if (!(s.saturation_min <= s.saturation_max)) fail("skin.saturation_min > skin.saturation_max");
  const RoomCueParams& r = params.room;
  if (!(r.skin_max_distance > 0.0)) fail("room.skin_max_distance must be > 0");
  if (!(r.skin_learning_rate >= 0.0 && r.skin_learning_rate <= 1.0)) {
    fail("room.skin_learning_rate must be in [0, 1]");
  }
  if (r.skin_min_cells < 1) fail("room.skin_min_cells must be >= 1");
  if (!(r.skin_border_neutral_share >= 0.0 && r.skin_border_neutral_share <= 1.0)) {
    fail("room.skin_border_neutral_share must be in [0, 1]");
  }
  if (!(r.skin_border_neutral_saturation >= 0.0 && r.skin_border_neutral_saturation <= 1.0)) {
    fail("room.skin_border_neutral_saturation must be in [0, 1]");
  }
  if (!(r.split_candidate_share >= 0.0 && r.split_candidate_share <= 1.0)) {
    fail("room.split_candidate_share must be in [0, 1]");
  }
  if (r.split_margin_cells < 0) fail("room.split_margin_cells must be >= 0");
  if (!(r.min_component_share >= 0.0 && r.min_component_share <= 1.0)) {
    fail("room.min_component_share must be in [0, 1]");
  }
  if (!(r.motion_threshold > 0.0)) fail("room.motion_threshold must be > 0");
  if (!(r.motion_decay >= 0.0 && r.motion_decay < 1.0)) fail("room.motion_decay must be in [0, 1)");
  if (!(r.motion_weight >= 0.0) || !(r.sleeve_weight >= 0.0)) {
    fail("room.motion_weight and room.sleeve_weight must be >= 0");
  }
  if (r.sleeve_band_cells < 0 || !(r.sleeve_min_offset >= 0.0)) {
    fail("room.sleeve_band_cells and room.sleeve_min_offset must be >= 0");
  }
  if (!(r.plate_adaptation_rate >= 0.0 && r.plate_adaptation_rate <= 1.0)) {
    fail("room.plate_adaptation_rate must be in [0, 1]");
  }
  if (!(r.colour_ratio >= 0.0)) fail("room.colour_ratio must be >= 0 (0: off)");
  if (r.still_object_frames < 0 || r.still_object_frames > 65535) {
    fail("room.still_object_frames must be in [0, 65535] (0: off)");
  }
  if (!(r.colour_learning_rate > 0.0 && r.colour_learning_rate <= 1.0)) {
    fail("room.colour_learning_rate must be in (0, 1]");
  }
  if (!(r.colour_core_depth > r.colour_rim_depth && r.colour_rim_depth >= 0.0)) {
    fail("room.colour_core_depth > room.colour_rim_depth >= 0 is required");
  }
  if (r.older_margin_frames < 0 || r.older_margin_frames > 65535) {
    fail("room.older_margin_frames must be in [0, 65535]");
  }
  if (!(r.older_quantile >= 0.0 && r.older_quantile <= 1.0)) {
    fail("room.older_quantile must be in [0, 1]");
  }
  if (!(r.first_frame_hand_share >= 0.0 && std::isfinite(r.first_frame_hand_share))) {
    fail("room.first_frame_hand_share must be >= 0 (above 1: off)");
  }
  if (r.first_frame_hand_reach_cells < 0 || r.first_frame_hand_reach_cells > 1000) {
    fail("room.first_frame_hand_reach_cells must be in [0, 1000] (0: no limit)");
  }
  if (!(r.unchanged_chromaticity > 0.0 && r.unchanged_chromaticity < 1.0)) {
    fail("room.unchanged_chromaticity must be in (0, 1)");
  }
  if (!(r.unchanged_brightness > 1.0 && std::isfinite(r.unchanged_brightness))) {
    fail("room.unchanged_brightness must be a finite factor > 1");
  }
}

ImageSoG quadtreeSegment(const cv::Mat& rgb, const QuadtreeParams& params,
                         std::vector<QuadtreeLeaf>* leaves) {
  checkRgbImage(rgb, "quadtreeSegment");
  SegmentationParams all;
  all.quadtree = params;
  validate(all);
  Workspace& ws = workspace();
  ws.integral.compute(rgb, params.min_leaf_size);
  return runQuadtree(ws.integral, params, nullptr, leaves);
}

// ---- ImageSegmenter ---------------------------------------------------------------------------

ImageSegmenter::ImageSegmenter(const SegmentationParams& params) : params_(params) {
  validate(params_);
  plate_.reset(params_.cell_size);
}

void ImageSegmenter::setParams(const SegmentationParams& params) {
  validate(params);
  if (params.cell_size != plate_.cellSize()) plate_.reset(params.cell_size);
  params_ = params;
}

void ImageSegmenter::addBackgroundFrame(const cv::Mat& rgb) {
  checkRgbImage(rgb, "addBackgroundFrame");
  if (plate_.frameCount() > 0 && (rgb.cols != plate_.width() || rgb.rows != plate_.height())) {
    throw InputError("addBackgroundFrame: the image is " + std::to_string(rgb.cols) + "x" +
                     std::to_string(rgb.rows) + " but the background plate is " +
                     std::to_string(plate_.width()) + "x" + std::to_string(plate_.height()));
  }
  Workspace& ws = workspace();
  ws.integral.compute(rgb, params_.cell_size);
  detail::cellMeans(ws.integral, params_.cell_size, ws.cell_means);
  plate_.addFrame(rgb.cols, rgb.rows, ws.cell_means);
  if (params_.room.enabled) {
    // The room cues' motion history starts here, so that the hand coming into view after the
    // plate's frames counts as motion on its first frame.
    room_.previous_means = ws.cell_means;
    room_.motion.assign(ws.cell_means.size() / 3, 0.0f);
  }
}

bool ImageSegmenter::backgroundReady() const {
  return plate_.frameCount() >= params_.background.frames;
}

void ImageSegmenter::resetBackground() { plate_.reset(params_.cell_size); }

void ImageSegmenter::saveBackground(const std::string& path) const { plate_.save(path); }

void ImageSegmenter::loadBackground(const std::string& path) {
  BackgroundPlate loaded;
  loaded.load(path);
  if (loaded.cellSize() != params_.cell_size) {
    throw InputError("loadBackground: " + path + " has cell size " +
                     std::to_string(loaded.cellSize()) + " but the segmenter uses cell_size " +
                     std::to_string(params_.cell_size));
  }
  plate_ = loaded;
}

SegmentationMode ImageSegmenter::effectiveMode() const {
  const SegmentationMode mode = params_.mode;
  if ((mode == SegmentationMode::kPlate || mode == SegmentationMode::kPlateAndSkin) &&
      !backgroundReady()) {
    return SegmentationMode::kSkin;
  }
  return mode;
}

namespace {

void finishMask(Workspace& ws, int cells_x, int cells_y, int cell_size, CellMask& mask);

// Computes the integral image and, unless the mode is none, the cell mask; returns whether a
// mask applies.
bool prepare(const cv::Mat& rgb, const SegmentationParams& params, SegmentationMode mode,
             const BackgroundPlate& plate, const char* what, Workspace& ws, CellMask& mask) {
  checkRgbImage(rgb, what);
  const bool use_plate =
      mode == SegmentationMode::kPlate || mode == SegmentationMode::kPlateAndSkin;
  const bool use_skin = mode == SegmentationMode::kSkin || mode == SegmentationMode::kPlateAndSkin;
  if (use_plate && (rgb.cols != plate.width() || rgb.rows != plate.height())) {
    throw InputError(std::string(what) + ": the image is " + std::to_string(rgb.cols) + "x" +
                     std::to_string(rgb.rows) + " but the background plate was learned at " +
                     std::to_string(plate.width()) + "x" + std::to_string(plate.height()));
  }
  ws.integral.compute(rgb, std::min(params.quadtree.min_leaf_size, params.cell_size));
  if (mode == SegmentationMode::kNone) return false;

  const int cell_size = params.cell_size;
  const int cells_x = detail::cellCount(rgb.cols, cell_size);
  const int cells_y = detail::cellCount(rgb.rows, cell_size);
  const int cells = cells_x * cells_y;
  detail::cellMeans(ws.integral, cell_size, ws.cell_means);
  ws.mask.resize(cells);
  ws.arm_cells = 0;
  ws.arm_sum.setZero();
  ws.arm_band.clear();
  ws.sleeve.resize(use_plate ? cells : 0);  // every cell is written below
  if (use_plate) plate.differingCells(ws.cell_means, params.background, &ws.differs);
  // Raw pointers: a store through unsigned char may alias anything, and through the vectors the
  // compiler reloaded their data pointers for every cell.
  const float* means = ws.cell_means.data();
  const unsigned char* differs = ws.differs.data();
  unsigned char* sleeve = ws.sleeve.data();
  unsigned char* foreground_cells = ws.mask.data();
  for (int i = 0; i < cells; ++i) {
    const float* c = means + 3 * i;
    bool foreground = true;
    if (use_plate) {
      const bool dark =
          differs[i] && isDarkNonSkin(Eigen::Vector3d(c[0], c[1], c[2]), params.background);
      foreground = differs[i] && !dark;
      sleeve[i] = dark ? 1 : 0;  // the forearm's evidence (addArmEvidence)
    }
    if (foreground && use_skin) {
      foreground = isSkinColour(Eigen::Vector3d(c[0], c[1], c[2]), params.skin);
    }
    foreground_cells[i] = foreground ? 1 : 0;
  }
  if (params.remove_isolated_cells) removeIsolatedCells(ws.mask, ws.mask_tmp, cells_x, cells_y);
  finishMask(ws, cells_x, cells_y, cell_size, mask);
  return true;
}

// The integral image of per-cell 0/1 values, (cells_y + 1) x (cells_x + 1).
void cellIntegral(const std::vector<unsigned char>& values, int cells_x, int cells_y,
                  std::vector<int>& integral) {
  const int stride = cells_x + 1;
  integral.assign(static_cast<std::size_t>(stride) * (cells_y + 1), 0);
  for (int cy = 0; cy < cells_y; ++cy) {
    int row = 0;
    for (int cx = 0; cx < cells_x; ++cx) {
      row += values[cy * cells_x + cx];
      integral[(cy + 1) * stride + cx + 1] = integral[cy * stride + cx + 1] + row;
    }
  }
}

// The mask's integral image and the view of it that the quad-tree reads.
void finishMask(Workspace& ws, int cells_x, int cells_y, int cell_size, CellMask& mask) {
  cellIntegral(ws.mask, cells_x, cells_y, ws.mask_integral);
  mask.cells = ws.mask.data();
  mask.integral = ws.mask_integral.data();
  mask.cells_x = cells_x;
  mask.cells_y = cells_y;
  mask.cell_size = cell_size;
}

// The sleeve's cells `band` as ImageSoG::arm_gaussians: one square leaf per cell (a Gaussian of
// sigma cell_size / sqrt(2 pi), as the quad-tree's leaves), hue 0.
std::vector<ImageGaussian> armGaussians(const std::vector<int>& band, int cells_x, int cell_size) {
  std::vector<ImageGaussian> gaussians;
  gaussians.reserve(band.size());
  const double sigma = cell_size / std::sqrt(2.0 * M_PI);
  for (const int i : band) {
    gaussians.push_back(
        {Eigen::Vector2d((i % cells_x + 0.5) * cell_size, (i / cells_x + 0.5) * cell_size), sigma,
         Hsv::Zero()});
  }
  return gaussians;
}

// The forearm evidence of the image SoG (ImageSoG::arm_cells): with the plate, the sleeve cells
// prepare() marked that lie next to the kept foreground (RoomCueParams::sleeve_band_cells), i.e.
// where the sleeve meets the hand; without it, what the room cues found (segmentFrame).
void addArmEvidence(const SegmentationParams& params, Workspace& ws, const CellMask& mask,
                    bool masked, ImageSoG* sog) {
  if (masked && !ws.sleeve.empty()) {
    ws.arm_cells = 0;
    ws.arm_band.clear();
    if (params.room.sleeve_band_cells > 0) {
      Eigen::Vector2d centroid;
      detail::sleeveNextToForeground(params, ws.sleeve, mask.cells_x, mask.cells_y, mask.cell_size,
                                     ws.mask, &ws.arm_cells, &centroid, &ws.arm_band);
      ws.arm_sum = centroid * ws.arm_cells;
    }
  }
  if (!masked || ws.arm_cells <= 0) return;
  sog->arm_cells = ws.arm_cells;
  sog->arm_centroid = ws.arm_sum / ws.arm_cells;
  sog->arm_gaussians = armGaussians(ws.arm_band, mask.cells_x, mask.cell_size);
}

// The cell mask at image size: 255 where a cell is foreground.
cv::Mat maskImage(const unsigned char* cells, int cells_x, int cell_size, int width, int height) {
  cv::Mat out(height, width, CV_8UC1, cv::Scalar(0));
  const int c = cell_size;
  for (int y = 0; y < height; ++y) {
    const unsigned char* row_cells = cells + (y / c) * cells_x;
    unsigned char* row = out.ptr<unsigned char>(y);
    for (int cx = 0; cx < cells_x; ++cx) {
      if (!row_cells[cx]) continue;
      const int x0 = cx * c;
      std::fill(row + x0, row + std::min(x0 + c, width), static_cast<unsigned char>(255));
    }
  }
  return out;
}

// refine_border_pixels: the foreground at pixel level, i.e. the cells less the pixels that fail the
// skin gate in the cells with a background 4-neighbour; the cells that lost a pixel are marked in
// mask.border (a border cell of skin pixels only stays a whole cell, and its leaf may stay large).
cv::Mat refineBorderPixels(const cv::Mat& rgb, const SkinParams& skin, Workspace& ws,
                           CellMask& mask) {
  const int cells_x = mask.cells_x, cells_y = mask.cells_y, c = mask.cell_size;
  ws.border.assign(ws.mask.size(), 0);
  cv::Mat pixels = maskImage(ws.mask.data(), cells_x, c, rgb.cols, rgb.rows);
  for (int cy = 0; cy < cells_y; ++cy) {
    for (int cx = 0; cx < cells_x; ++cx) {
      const int i = cy * cells_x + cx;
      if (!ws.mask[i]) continue;
      const bool border = (cx > 0 && !ws.mask[i - 1]) || (cx + 1 < cells_x && !ws.mask[i + 1]) ||
                          (cy > 0 && !ws.mask[i - cells_x]) ||
                          (cy + 1 < cells_y && !ws.mask[i + cells_x]);
      if (!border) continue;
      for (int y = cy * c; y < std::min((cy + 1) * c, rgb.rows); ++y) {
        const unsigned char* px = rgb.ptr<unsigned char>(y);
        unsigned char* keep = pixels.ptr<unsigned char>(y);
        for (int x = cx * c; x < std::min((cx + 1) * c, rgb.cols); ++x) {
          if (!isSkinColour(Eigen::Vector3d(px[3 * x], px[3 * x + 1], px[3 * x + 2]), skin)) {
            keep[x] = 0;
            ws.border[i] = 1;
          }
        }
      }
    }
  }
  cellIntegral(ws.border, cells_x, cells_y, ws.border_integral);
  mask.border = ws.border.data();
  mask.border_integral = ws.border_integral.data();
  return pixels;
}

// Applies refine_border_pixels where it applies (the skin gate alone, a mask): returns the
// foreground at pixel level and points the quad-tree's mask at it, or returns an empty matrix.
cv::Mat refineBorderPixelsIfSkinOnly(const cv::Mat& rgb, const SegmentationParams& params,
                                     SegmentationMode mode, bool masked, Workspace& ws,
                                     CellMask& mask) {
  if (!masked || mode != SegmentationMode::kSkin || !params.refine_border_pixels) return cv::Mat();
  return refineBorderPixels(rgb, params.skin, ws, mask);
}

}  // namespace

ImageSoG ImageSegmenter::segment(const cv::Mat& rgb, std::vector<QuadtreeLeaf>* leaves) const {
  Workspace& ws = workspace();
  CellMask mask;
  ws.arm_cells = 0;
  ws.arm_band.clear();
  const SegmentationMode mode = effectiveMode();
  const bool masked = prepare(rgb, params_, mode, plate_, "segment", ws, mask);
  const cv::Mat pixels = refineBorderPixelsIfSkinOnly(rgb, params_, mode, masked, ws, mask);
  if (!pixels.empty()) {
    mask.pixels = &pixels;
    mask.rgb = &rgb;
  }
  ImageSoG sog = runQuadtree(ws.integral, params_.quadtree, masked ? &mask : nullptr, leaves);
  addArmEvidence(params_, ws, mask, masked, &sog);
  return sog;
}

cv::Mat ImageSegmenter::foregroundMask(const cv::Mat& rgb) const {
  Workspace& ws = workspace();
  CellMask mask;
  const SegmentationMode mode = effectiveMode();
  const bool masked = prepare(rgb, params_, mode, plate_, "foregroundMask", ws, mask);
  if (!masked) return cv::Mat(rgb.rows, rgb.cols, CV_8UC1, cv::Scalar(255));
  cv::Mat pixels = refineBorderPixelsIfSkinOnly(rgb, params_, mode, masked, ws, mask);
  if (!pixels.empty()) return pixels;
  return maskImage(mask.cells, mask.cells_x, mask.cell_size, rgb.cols, rgb.rows);
}

void ImageSegmenter::setRegionOfInterest(const cv::Rect& roi) {
  roi_ = roi;
  roi_mask_ = cv::Mat();
  model_silhouette_ = cv::Mat();
  roi_source_ = RegionSource::kTrack;
}

void ImageSegmenter::setRegionOfInterest(const cv::Mat& roi_mask, RegionSource source,
                                         const cv::Mat& model_silhouette) {
  if (roi_mask.empty()) {
    setRegionOfInterest(cv::Rect());
    return;
  }
  if (roi_mask.type() != CV_8UC1) {
    throw InputError("setRegionOfInterest: the region mask must be CV_8UC1, got " +
                     cv::typeToString(roi_mask.type()));
  }
  if (!model_silhouette.empty() &&
      (model_silhouette.type() != CV_8UC1 || model_silhouette.size() != roi_mask.size())) {
    throw InputError(
        "setRegionOfInterest: the model's silhouette must be a CV_8UC1 mask of the "
        "region's size");
  }
  roi_source_ = source;
  roi_mask_ = roi_mask;
  model_silhouette_ = source == RegionSource::kTrack ? model_silhouette : cv::Mat();
  roi_ = cv::boundingRect(roi_mask);
  // A multi-view choice that found nothing in this view: a region that holds no cell.
  if (roi_.area() == 0 && source == RegionSource::kCandidates) {
    roi_ = cv::Rect(0, 0, roi_mask.cols, roi_mask.rows);
  }
}

bool ImageSegmenter::usesModelSilhouette() const {
  return params_.room.enabled &&
         (params_.room.still_object_frames > 0 || params_.room.drop_older_than_hand) &&
         effectiveMode() == SegmentationMode::kSkin;
}

std::vector<HandCandidate> ImageSegmenter::handCandidates(const cv::Mat& rgb,
                                                          int max_candidates) const {
  Workspace& ws = workspace();
  CellMask mask;
  const bool masked = prepare(rgb, params_, effectiveMode(), plate_, "handCandidates", ws, mask);
  if (!masked || !params_.room.enabled) return {};
  return detail::roomCandidates(params_, ws.cell_means, mask.cells_x, mask.cells_y, mask.cell_size,
                                rgb.cols, rgb.rows, room_, ws.mask, max_candidates);
}

void ImageSegmenter::resetRoomState() {
  room_ = RoomCueState();
  roi_source_ = RegionSource::kTrack;
  roi_ = cv::Rect();
  roi_mask_ = cv::Mat();
  model_silhouette_ = cv::Mat();
}

void ImageSegmenter::forgetTrackedHand() {
  room_.skin_frames = 0;
  room_.skin_mean[0] = room_.skin_mean[1] = 0.0;
  room_.skin_cov[0] = room_.skin_cov[1] = room_.skin_cov[2] = 0.0;
  room_.hand_colour.clear();
  room_.background_colour.clear();
}

cv::Mat ImageSegmenter::lastForegroundMask() const {
  if (!room_.pixel_mask.empty()) return room_.pixel_mask.clone();
  if (room_.mask.empty()) return cv::Mat();
  return maskImage(room_.mask.data(), room_.cells_x, room_.cell_size, room_.width, room_.height);
}

void ImageSegmenter::sleeveEvidence(const cv::Mat& kept, ImageSoG* sog) const {
  const SegmentationMode mode = effectiveMode();
  if (mode != SegmentationMode::kSkin) return;  // the plate's evidence, or no foreground at all
  if (!params_.room.enabled || params_.room.sleeve_band_cells <= 0) return;
  if (room_.mask.empty() || room_.previous_means.size() != 3 * room_.mask.size()) {
    throw InputError("sleeveEvidence: no image segmented yet");
  }
  if (kept.type() != CV_8UC1 || kept.cols != room_.width || kept.rows != room_.height) {
    throw InputError("sleeveEvidence: the kept mask is not CV_8UC1 at the image's size " +
                     std::to_string(room_.width) + "x" + std::to_string(room_.height));
  }
  // The last segmented image's cell means are the room cues' previous means by now.
  const int s = room_.cell_size;
  std::vector<unsigned char> cells(room_.mask.size(), 0);
  for (int i = 0; i < static_cast<int>(cells.size()); ++i) {
    const int x = std::min((i % room_.cells_x) * s + s / 2, room_.width - 1);
    const int y = std::min((i / room_.cells_x) * s + s / 2, room_.height - 1);
    cells[i] = kept.at<unsigned char>(y, x) != 0;
  }
  std::vector<int> band;
  detail::sleeveNextToForeground(params_, room_.previous_means, room_.cells_x, room_.cells_y, s,
                                 cells, &sog->arm_cells, &sog->arm_centroid, &band);
  sog->arm_gaussians = armGaussians(band, room_.cells_x, s);
}

ImageSoG ImageSegmenter::segmentFrame(const cv::Mat& rgb, std::vector<QuadtreeLeaf>* leaves) {
  Workspace& ws = workspace();
  CellMask mask;
  const SegmentationMode mode = effectiveMode();
  const bool masked = prepare(rgb, params_, mode, plate_, "segmentFrame", ws, mask);
  if (!masked) {
    room_.mask.assign(static_cast<size_t>(detail::cellCount(rgb.cols, params_.cell_size)) *
                          detail::cellCount(rgb.rows, params_.cell_size),
                      1);
  } else if (params_.room.enabled) {
    const bool use_plate =
        (mode == SegmentationMode::kPlate || mode == SegmentationMode::kPlateAndSkin);
    detail::applyRoomCues(params_, ws.cell_means, mask.cells_x, mask.cells_y, mask.cell_size,
                          rgb.cols, rgb.rows, roi_, roi_mask_, model_silhouette_,
                          roi_source_ == RegionSource::kTrack, use_plate ? &plate_ : nullptr, room_,
                          ws.mask);
    finishMask(ws, mask.cells_x, mask.cells_y, mask.cell_size, mask);
    if (!use_plate && params_.room.sleeve_band_cells > 0) {
      Eigen::Vector2d centroid;
      detail::sleeveNextToForeground(params_, ws.cell_means, mask.cells_x, mask.cells_y,
                                     mask.cell_size, ws.mask, &ws.arm_cells, &centroid,
                                     &ws.arm_band);
      ws.arm_sum = centroid * ws.arm_cells;
    }
    room_.mask = ws.mask;
  } else {
    room_.mask = ws.mask;
  }
  room_.cells_x = detail::cellCount(rgb.cols, params_.cell_size);
  room_.cells_y = detail::cellCount(rgb.rows, params_.cell_size);
  room_.cell_size = params_.cell_size;
  room_.width = rgb.cols;
  room_.height = rgb.rows;
  room_.pixel_mask = refineBorderPixelsIfSkinOnly(rgb, params_, mode, masked, ws, mask);
  if (!room_.pixel_mask.empty()) {
    mask.pixels = &room_.pixel_mask;
    mask.rgb = &rgb;
  }
  ImageSoG sog = runQuadtree(ws.integral, params_.quadtree, masked ? &mask : nullptr, leaves);
  addArmEvidence(params_, ws, mask, masked, &sog);
  return sog;
}

}  // namespace sag_hand_tracker
