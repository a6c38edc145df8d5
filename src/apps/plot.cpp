#include "sag_hand_tracker/apps/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sag_hand_tracker/util/atomic_output.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace {

// A "nice" tick step (1, 2 or 5 times a power of ten) giving about `count` ticks over `range`.
double tickStep(double range, int count) {
  const double raw = range / count;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  for (double factor : {1.0, 2.0, 5.0, 10.0}) {
    if (raw <= factor * power) return factor * power;
  }
  return 10.0 * power;
}

std::string formatTick(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", std::fabs(value) < 1e-12 ? 0.0 : value);
  return text;
}

}  // namespace

cv::Mat linePlot(const std::vector<PlotSeries>& series, const std::string& title,
                 const std::string& x_label, const std::string& y_label, int width, int height) {
  cv::Mat image(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  const int left = 70, right = 20, top = 40, bottom = 55;
  double x_min = 1e300, x_max = -1e300, y_min = 0.0, y_max = -1e300;
  for (const PlotSeries& s : series) {
    for (size_t i = 0; i < s.x.size(); ++i) {
      x_min = std::min(x_min, s.x[i]);
      x_max = std::max(x_max, s.x[i]);
      const double bar = i < s.error_bars.size() ? s.error_bars[i] : 0.0;
      if (std::isfinite(s.y[i])) y_max = std::max(y_max, s.y[i] + bar);
    }
  }
  if (!(x_max > x_min)) {
    x_min -= 1.0;
    x_max += 1.0;
  }
  if (!(y_max > y_min)) y_max = y_min + 1.0;
  y_max *= 1.05;
  const double plot_w = width - left - right, plot_h = height - top - bottom;
  // Headroom for the legend box in the upper right, so that it does not hide the lines.
  int labelled = 0;
  for (const PlotSeries& s : series) labelled += s.label.empty() ? 0 : 1;
  const double legend_px = labelled > 0 ? 12.0 + 20.0 * labelled : 0.0;
  if (legend_px < 0.6 * plot_h) y_max = y_min + (y_max - y_min) * plot_h / (plot_h - legend_px);
  auto to_pixel = [&](double x, double y) {
    return cv::Point(static_cast<int>(left + (x - x_min) / (x_max - x_min) * plot_w),
                     static_cast<int>(top + plot_h - (y - y_min) / (y_max - y_min) * plot_h));
  };
  const cv::Scalar grey(200, 200, 200), black(0, 0, 0);
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  const double y_step = tickStep(y_max - y_min, 6), x_step = tickStep(x_max - x_min, 8);
  for (double y = y_min; y <= y_max + 1e-9; y += y_step) {
    cv::line(image, to_pixel(x_min, y), to_pixel(x_max, y), grey, 1);
    cv::putText(image, formatTick(y), to_pixel(x_min, y) + cv::Point(-60, 5), font, 0.45, black, 1,
                cv::LINE_AA);
  }
  for (double x = std::ceil(x_min / x_step) * x_step; x <= x_max + 1e-9; x += x_step) {
    cv::line(image, to_pixel(x, y_min), to_pixel(x, y_min) + cv::Point(0, 5), black, 1);
    cv::putText(image, formatTick(x), to_pixel(x, y_min) + cv::Point(-10, 22), font, 0.45, black, 1,
                cv::LINE_AA);
  }
  cv::rectangle(image, cv::Point(left, top), cv::Point(width - right, top + plot_h), black, 1);
  // A title wider than the image (e.g. many hand shapes named) is set smaller, not cut off.
  int baseline = 0;
  const int title_width = cv::getTextSize(title, font, 0.6, 1, &baseline).width;
  const double title_scale =
      std::max(0.3, std::min(0.6, 0.6 * (width - left - 10) / std::max(1, title_width)));
  cv::putText(image, title, cv::Point(left, 20), font, title_scale, black, 1, cv::LINE_AA);
  cv::putText(image, x_label, cv::Point(left + plot_w / 2 - 40, height - 12), font, 0.5, black, 1,
              cv::LINE_AA);
  // Above the y axis, below the title, so that the two do not overlap.
  cv::putText(image, y_label, cv::Point(5, top - 6), font, 0.45, black, 1, cv::LINE_AA);

  for (const PlotSeries& s : series) {
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.y[i])) continue;
      const cv::Point p = to_pixel(s.x[i], s.y[i]);
      if (i + 1 < s.x.size() && std::isfinite(s.y[i + 1])) {
        cv::line(image, p, to_pixel(s.x[i + 1], s.y[i + 1]), s.colour, 2, cv::LINE_AA);
      }
      if (i < s.error_bars.size()) {
        cv::line(image, to_pixel(s.x[i], s.y[i] - s.error_bars[i]),
                 to_pixel(s.x[i], s.y[i] + s.error_bars[i]), s.colour, 1, cv::LINE_AA);
        cv::circle(image, p, 4, s.colour, cv::FILLED, cv::LINE_AA);
      }
    }
  }
  // The legend on a white box over the lines; series without a label are left out of it. The box
  // is as wide as the longest label needs (at least the 178 px of short labels).
  int text_w = 0;
  for (const PlotSeries& s : series) {
    int baseline = 0;
    if (!s.label.empty()) {
      text_w = std::max(text_w, cv::getTextSize(s.label, font, 0.5, 1, &baseline).width);
    }
  }
  const int box_w = std::min(std::max(178, text_w + 52), width - right - 3);
  if (labelled > 0) {
    const int box_left = width - right - box_w;
    cv::rectangle(image, cv::Point(box_left, top + 3),
                  cv::Point(width - right - 3, top + 8 + 20 * labelled), cv::Scalar(255, 255, 255),
                  cv::FILLED);
    cv::rectangle(image, cv::Point(box_left, top + 3),
                  cv::Point(width - right - 3, top + 8 + 20 * labelled), grey, 1);
  }
  int legend_y = top + 20;
  for (const PlotSeries& s : series) {
    if (s.label.empty()) continue;
    cv::line(image, cv::Point(width - right - box_w + 8, legend_y - 5),
             cv::Point(width - right - box_w + 38, legend_y - 5), s.colour, 3);
    cv::putText(image, s.label, cv::Point(width - right - box_w + 46, legend_y), font, 0.5, black,
                1, cv::LINE_AA);
    legend_y += 20;
  }
  return image;
}

void writePng(const std::string& path, const cv::Mat& image, bool overwrite) {
  // Keeps the extension, which imwrite goes by.
  AtomicOutputFile file(path, overwrite);
  bool ok = false;
  try {
    ok = cv::imwrite(file.tempPath(), image);
  } catch (const cv::Exception&) {
    ok = false;
  }
  if (!ok) throw InputError("cannot write the image '" + path + "'");
  file.commit();
}

cv::Mat stackVertically(const std::vector<cv::Mat>& images) {
  cv::Mat stacked;
  if (!images.empty()) cv::vconcat(images, stacked);
  return stacked;
}

}  // namespace sag_hand_tracker
