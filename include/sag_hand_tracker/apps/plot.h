// Small PNG line plots (OpenCV drawing) for the benchmark's figures.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace sag_hand_tracker {

struct PlotSeries {
  std::string label;
  std::vector<double> x;
  std::vector<double> y;
  std::vector<double> error_bars;  // optional, same size as y
  cv::Scalar colour;               // BGR
};

// A line plot with axes, ticks, labels and a legend.
cv::Mat linePlot(const std::vector<PlotSeries>& series, const std::string& title,
                 const std::string& x_label, const std::string& y_label, int width = 900,
                 int height = 420);

// Writes the image (BGR) complete or not at all; throws InputError if the file cannot be written.
// With `overwrite` (the benchmark's own figures, replaced each run) it replaces a file at `path`;
// without, nothing there is replaced (AtomicOutputFile).
void writePng(const std::string& path, const cv::Mat& image, bool overwrite = true);

// Stacks plots vertically (same width).
cv::Mat stackVertically(const std::vector<cv::Mat>& images);

}  // namespace sag_hand_tracker
