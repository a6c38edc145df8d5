// Background plate, shadow test, dark-sleeve rejection and skin-colour gate (doc/design.md
// section 3). See background_plate.h for the tests and their parameters.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

#include "sag_hand_tracker/energy/colour.h"
#include "sag_hand_tracker/segmentation/background_plate.h"
#include "sag_hand_tracker/util/number_text.h"
#include "segmentation_internal.h"

namespace sag_hand_tracker {

bool isSkinColour(const Eigen::Vector3d& rgb, const SkinParams& params) {
  const Hsv hsv = rgbToHsv(rgb[0], rgb[1], rgb[2]);
  if (hsv[2] < params.value_min) return false;
  if (hsv[1] < params.saturation_min || hsv[1] > params.saturation_max) return false;
  // Circular hue range: the offset from hue_min, in [0, 360), must not exceed the range's width.
  double offset = std::fmod(hsv[0] - params.hue_min_deg, 360.0);
  if (offset < 0.0) offset += 360.0;
  return offset <= params.hue_max_deg - params.hue_min_deg;
}

SkinParams personalSkinGate(const std::vector<Hsv>& colours, const PersonalSkinGateParams& params) {
  if (colours.empty())
    throw InputError("personal skin gate: no colours (a model without Gaussians?)");
  if (!(params.hue_margin_deg >= 0.0 && params.saturation_low_factor >= 0.0 &&
        params.saturation_high_factor >= params.saturation_low_factor &&
        params.value_factor >= 0.0)) {
    throw InputError(
        "personal skin gate: the margins must be >= 0 (and the high saturation factor "
        ">= the low one)");
  }
  // Hues relative to their circular mean, so that colours on both sides of 0/360 form one range.
  // Colours sampled from something else than skin (a fit that took the background) would make a
  // gate that keeps the wrong things: most of them must pass the generic gate they replace.
  const SkinParams generic;
  Eigen::Vector2d direction = Eigen::Vector2d::Zero();
  int skin_like = 0;
  for (size_t i = 0; i < colours.size(); ++i) {
    const Hsv& c = colours[i];
    if (!c.allFinite() || c[1] < 0.0 || c[1] > 1.0 || c[2] < 0.0 || c[2] > 1.0) {
      throw InputError("personal skin gate: colour " + std::to_string(i) + " (hsv " +
                       shortNumber(c[0]) + ", " + shortNumber(c[1]) + ", " + shortNumber(c[2]) +
                       ") is not a colour (saturation and value in [0, 1])");
    }
    const double hue = c[0] * M_PI / 180.0;
    direction += Eigen::Vector2d(std::cos(hue), std::sin(hue));
    skin_like += isSkinColour(hsvToRgb(c) * 255.0, generic) ? 1 : 0;
  }
  if (4 * skin_like < 3 * static_cast<int>(colours.size())) {
    throw InputError("personal skin gate: only " + std::to_string(skin_like) + " of " +
                     std::to_string(colours.size()) + " colours are skin-coloured (the generic " +
                     "gate's " + skinGateText(generic) +
                     "); were they sampled from the hand? Calibrate again in view of the cameras");
  }
  const double centre = std::atan2(direction.y(), direction.x()) * 180.0 / M_PI;
  double low = 180.0, high = -180.0;
  double saturation_min = 1.0, saturation_max = 0.0, value_min = 1.0;
  for (const Hsv& c : colours) {
    double offset = std::fmod(c[0] - centre, 360.0);
    if (offset > 180.0) offset -= 360.0;
    if (offset <= -180.0) offset += 360.0;
    low = std::min(low, offset);
    high = std::max(high, offset);
    saturation_min = std::min(saturation_min, c[1]);
    saturation_max = std::max(saturation_max, c[1]);
    value_min = std::min(value_min, c[2]);
  }
  SkinParams gate;
  gate.hue_min_deg = centre + low - params.hue_margin_deg;
  gate.hue_max_deg = centre + high + params.hue_margin_deg;
  if (gate.hue_max_deg - gate.hue_min_deg > 360.0) gate.hue_max_deg = gate.hue_min_deg + 360.0;
  gate.saturation_min = params.saturation_low_factor * saturation_min;
  gate.saturation_max = std::min(1.0, params.saturation_high_factor * saturation_max);
  gate.value_min = params.value_factor * value_min;
  return gate;
}

SkinParams personalSkinGate(const HandModel& model, const PersonalSkinGateParams& params) {
  std::vector<Hsv> colours;
  colours.reserve(model.gaussians.size());
  for (const ModelGaussian& g : model.gaussians) colours.push_back(g.hsv);
  return personalSkinGate(colours, params);
}

std::string skinGateText(const SkinParams& gate) {
  return "hue " + shortNumber(gate.hue_min_deg) + ".." + shortNumber(gate.hue_max_deg) +
         " deg, saturation " + shortNumber(gate.saturation_min) + ".." +
         shortNumber(gate.saturation_max) + ", value >= " + shortNumber(gate.value_min);
}

bool isDarkNonSkin(const Eigen::Vector3d& rgb, const BackgroundParams& params) {
  const double max = rgb.maxCoeff();
  const double min = rgb.minCoeff();
  const double value = max / 255.0;
  if (value < params.dark_max_value) return true;
  const double saturation = max > 0.0 ? (max - min) / max : 0.0;
  return value < params.sleeve_max_value && saturation < params.sleeve_max_saturation;
}

// ---- BackgroundPlate -------------------------------------------------------------------------

BackgroundPlate::BackgroundPlate(int cell_size) { reset(cell_size); }

void BackgroundPlate::reset(int cell_size) {
  if (cell_size < 1 || (cell_size & (cell_size - 1)) != 0) {
    throw InputError("BackgroundPlate: the cell size must be a power of two >= 1, got " +
                     std::to_string(cell_size));
  }
  cell_size_ = cell_size;
  width_ = height_ = cells_x_ = cells_y_ = frames_ = 0;
  sum_.clear();
  sum_sq_.clear();
  resizeCells(0);
}

void BackgroundPlate::resizeCells(std::size_t cells) {
  mean_.assign(3 * cells, 0.0f);
  spread_.assign(3 * cells, 0.0f);
  chroma_.assign(3 * cells, 0.0f);
  brightness_.assign(cells, 0.0f);
}

void BackgroundPlate::addFrame(int width, int height, const std::vector<float>& cell_means) {
  if (width <= 0 || height <= 0) throw InputError("BackgroundPlate: empty frame");
  if (frames_ > 0 && (width != width_ || height != height_)) {
    throw InputError("BackgroundPlate: the frame is " + std::to_string(width) + "x" +
                     std::to_string(height) + " but the plate is " + std::to_string(width_) + "x" +
                     std::to_string(height_));
  }
  const int cells_x = detail::cellCount(width, cell_size_);
  const int cells_y = detail::cellCount(height, cell_size_);
  const std::size_t values = static_cast<std::size_t>(cells_x) * cells_y * 3;
  if (cell_means.size() != values) {
    throw InputError("BackgroundPlate: expected " + std::to_string(values) +
                     " cell mean values for a " + std::to_string(width) + "x" +
                     std::to_string(height) + " frame, got " + std::to_string(cell_means.size()));
  }
  if (frames_ == 0) {
    width_ = width;
    height_ = height;
    cells_x_ = cells_x;
    cells_y_ = cells_y;
    sum_.assign(values, 0.0);
    sum_sq_.assign(values, 0.0);
    resizeCells(values / 3);
  }
  for (std::size_t i = 0; i < values; ++i) {
    const double m = cell_means[i];
    sum_[i] += m;
    sum_sq_[i] += m * m;
  }
  ++frames_;
  for (int cell = 0; cell < cells_x_ * cells_y_; ++cell) updateCell(cell);
}

void BackgroundPlate::updateCell(int cell) {
  const double n = frames_;
  double brightness = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double mean = sum_[3 * cell + k] / n;
    const double variance = std::max(0.0, sum_sq_[3 * cell + k] / n - mean * mean);
    mean_[3 * cell + k] = static_cast<float>(mean);
    spread_[3 * cell + k] = static_cast<float>(std::sqrt(variance));
    brightness += mean;
  }
  brightness_[cell] = static_cast<float>(brightness);
  for (int k = 0; k < 3; ++k) {
    chroma_[3 * cell + k] =
        brightness > 0.0 ? static_cast<float>(mean_[3 * cell + k] / brightness) : 1.0f / 3.0f;
  }
}

namespace {

// The colour distance of BackgroundParams in tolerances (k_sigma spreads, at least min_tolerance),
// squared; background within 1.
inline double plateDistanceSq(const float* rgb, const float* mean, const float* spread,
                              const BackgroundParams& params) {
  double distance_sq = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double tolerance = std::max(params.k_sigma * spread[k], params.min_tolerance);
    const double d = (rgb[k] - mean[k]) / tolerance;
    distance_sq += d * d;
  }
  return distance_sq;
}

}  // namespace

bool BackgroundPlate::isShadow(int cell, const float* rgb, const BackgroundParams& params) const {
  const float plate_brightness = brightness_[cell];
  if (plate_brightness < params.shadow_min_plate_brightness) return false;
  const double brightness = static_cast<double>(rgb[0]) + rgb[1] + rgb[2];
  const double ratio = brightness / plate_brightness;
  if (ratio < params.shadow_min_ratio || ratio > 1.0 || brightness <= 0.0) return false;
  for (int k = 0; k < 3; ++k) {
    if (std::fabs(rgb[k] / brightness - chroma_[3 * cell + k]) > params.shadow_chroma_tolerance) {
      return false;
    }
  }
  return true;
}

bool BackgroundPlate::isBackground(int cell, const float* rgb,
                                   const BackgroundParams& params) const {
  if (plateDistanceSq(rgb, &mean_[3 * cell], &spread_[3 * cell], params) <= 1.0) return true;
  return isShadow(cell, rgb, params);
}

void BackgroundPlate::differingCells(const std::vector<float>& cell_means,
                                     const BackgroundParams& params,
                                     std::vector<unsigned char>* differs) const {
  const int cells = cells_x_ * cells_y_;
  if (cell_means.size() != mean_.size()) {
    throw InputError("BackgroundPlate::differingCells: expected " + std::to_string(mean_.size()) +
                     " cell mean values, got " + std::to_string(cell_means.size()));
  }
  differs->resize(cells);
  const float* rgb = cell_means.data();
  const float* mean = mean_.data();
  const float* spread = spread_.data();
  unsigned char* out = differs->data();
  for (int i = 0; i < cells; ++i) {
    out[i] = plateDistanceSq(rgb + 3 * i, mean + 3 * i, spread + 3 * i, params) <= 1.0 ? 0 : 1;
  }
  for (int i = 0; i < cells; ++i) {
    if (out[i] && isShadow(i, rgb + 3 * i, params)) out[i] = 0;
  }
}

void BackgroundPlate::adaptCell(int cell, const float* rgb, double rate) {
  for (int k = 0; k < 3; ++k) {
    const double n = frames_;
    const double old_mean = sum_[3 * cell + k] / n;
    const double variance = std::max(0.0, sum_sq_[3 * cell + k] / n - old_mean * old_mean);
    const double mean = (1.0 - rate) * old_mean + rate * rgb[k];
    sum_[3 * cell + k] = n * mean;
    sum_sq_[3 * cell + k] = n * (variance + mean * mean);
  }
  updateCell(cell);
}

namespace {

// Per-cell values in the cell means' layout (R,G,B per cell, row after row) as a CV_32FC3 image
// of cells_y x cells_x: the same memory order, copied.
cv::Mat cellImage(int cells_y, int cells_x, const std::vector<float>& values) {
  cv::Mat out(cells_y, cells_x, CV_32FC3);
  if (!values.empty()) std::copy(values.begin(), values.end(), out.ptr<float>());
  return out;
}

}  // namespace

cv::Mat BackgroundPlate::mean() const { return cellImage(cells_y_, cells_x_, mean_); }

cv::Mat BackgroundPlate::spread() const { return cellImage(cells_y_, cells_x_, spread_); }

void BackgroundPlate::save(const std::string& path) const {
  if (frames_ == 0) throw InputError("BackgroundPlate::save: the plate is empty (no frames)");
  try {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    if (!fs.isOpened()) throw InputError("BackgroundPlate::save: cannot write " + path);
    fs << "sag_background_plate" << 1;
    fs << "width" << width_ << "height" << height_ << "cell_size" << cell_size_;
    fs << "frames" << frames_;
    fs << "mean" << mean() << "spread" << spread();
  } catch (const cv::Exception& e) {
    throw InputError("BackgroundPlate::save: cannot write " + path + ": " + e.what());
  }
}

void BackgroundPlate::load(const std::string& path) {
  auto fail = [&path](const std::string& why) {
    throw InputError("BackgroundPlate::load: " + path + ": " + why);
  };
  // Checked here so that OpenCV does not log its own error for a missing file.
  if (!std::ifstream(path).good()) fail("cannot open the file");
  int version = 0, width = 0, height = 0, cell_size = 0, frames = 0;
  cv::Mat mean, spread;
  try {
    cv::FileStorage fs(path, cv::FileStorage::READ);
    if (!fs.isOpened()) fail("cannot open the file");
    if (fs["sag_background_plate"].empty()) fail("not a background plate file");
    fs["sag_background_plate"] >> version;
    fs["width"] >> width;
    fs["height"] >> height;
    fs["cell_size"] >> cell_size;
    fs["frames"] >> frames;
    fs["mean"] >> mean;
    fs["spread"] >> spread;
  } catch (const cv::Exception& e) {
    fail(std::string("unreadable: ") + e.what());
  }
  if (version != 1) fail("unsupported version " + std::to_string(version));
  if (width <= 0 || height <= 0) fail("bad image size");
  if (cell_size < 1 || (cell_size & (cell_size - 1)) != 0) fail("bad cell size");
  if (frames < 1) fail("bad frame count");
  const int cells_x = detail::cellCount(width, cell_size);
  const int cells_y = detail::cellCount(height, cell_size);
  if (mean.type() != CV_32FC3 || spread.type() != CV_32FC3 || mean.rows != cells_y ||
      mean.cols != cells_x || spread.size() != mean.size()) {
    fail("mean/spread are not " + std::to_string(cells_y) + "x" + std::to_string(cells_x) +
         " CV_32FC3 matrices");
  }
  // Rebuild the running sums so that more frames can be added to a loaded plate.
  BackgroundPlate plate(cell_size);
  plate.width_ = width;
  plate.height_ = height;
  plate.cells_x_ = cells_x;
  plate.cells_y_ = cells_y;
  plate.frames_ = frames;
  const std::size_t cells = static_cast<std::size_t>(cells_x) * cells_y;
  plate.sum_.resize(3 * cells);
  plate.sum_sq_.resize(3 * cells);
  plate.resizeCells(cells);
  for (std::size_t cell = 0; cell < cells; ++cell) {
    const cv::Vec3f& m = mean.at<cv::Vec3f>(cell / cells_x, cell % cells_x);
    const cv::Vec3f& s = spread.at<cv::Vec3f>(cell / cells_x, cell % cells_x);
    for (int k = 0; k < 3; ++k) {
      plate.sum_[3 * cell + k] = frames * static_cast<double>(m[k]);
      plate.sum_sq_[3 * cell + k] =
          frames * (static_cast<double>(s[k]) * s[k] + static_cast<double>(m[k]) * m[k]);
    }
    plate.updateCell(static_cast<int>(cell));
  }
  *this = std::move(plate);
}

}  // namespace sag_hand_tracker
