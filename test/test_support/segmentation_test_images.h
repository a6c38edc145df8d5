// Synthetic camera images for the segmentation tests and benchmarks: a textured desk scene (wall
// with a poster, grey desk with wood-like grain, a book, a mug, a keyboard), optionally with a
// skin-coloured hand (palm and five fingers, shaded), the black sleeve of the forearm, and the
// shadow that hand and arm cast on the desk; Gaussian camera noise that changes with the seed.
// The scene without noise is deterministic, so frames with different seeds are the same scene.
#pragma once

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace sag_test {

struct SceneOptions {
  int width = 320;
  int height = 240;
  bool hand = false;
  bool sleeve = false;
  bool shadow = false;
  double shadow_factor = 0.55;  // brightness of the shadowed desk / lit desk
  cv::Point2d shadow_offset{22.0, 14.0};
  double noise_std = 2.5;  // per channel, RGB units
  unsigned seed = 1;
};

// Everything is drawn in a 320 x 240 frame and scaled to the requested size.
inline double sx(const SceneOptions& o) { return o.width / 320.0; }
inline double sy(const SceneOptions& o) { return o.height / 240.0; }

// Hand (palm + fingers) as a CV_8UC1 mask (255 inside), shifted by offset (320x240 units).
inline cv::Mat handMask(const SceneOptions& o, cv::Point2d offset = {0.0, 0.0}) {
  cv::Mat mask = cv::Mat::zeros(o.height, o.width, CV_8UC1);
  auto p = [&](double x, double y) {
    return cv::Point(cvRound((x + offset.x) * sx(o)), cvRound((y + offset.y) * sy(o)));
  };
  const double s = std::min(sx(o), sy(o));
  cv::ellipse(mask, p(165, 150), cv::Size(cvRound(30 * s), cvRound(34 * s)), 10.0, 0, 360,
              cv::Scalar(255), cv::FILLED);
  // Fingers as thick lines (capsules) from the knuckles: index, middle, ring, pinky, thumb.
  const double base[5][2] = {{143, 122}, {160, 117}, {177, 119}, {192, 127}, {135, 160}};
  const double tip[5][2] = {{128, 68}, {158, 58}, {185, 64}, {210, 84}, {98, 138}};
  const double width[5] = {12, 13, 12, 10, 14};
  for (int f = 0; f < 5; ++f) {
    cv::line(mask, p(base[f][0], base[f][1]), p(tip[f][0], tip[f][1]), cv::Scalar(255),
             std::max(1, cvRound(width[f] * s)), cv::LINE_8);
  }
  return mask;
}

// Forearm from the wrist to the bottom border.
inline cv::Mat sleeveMask(const SceneOptions& o, cv::Point2d offset = {0.0, 0.0}) {
  cv::Mat mask = cv::Mat::zeros(o.height, o.width, CV_8UC1);
  auto p = [&](double x, double y) {
    return cv::Point(cvRound((x + offset.x) * sx(o)), cvRound((y + offset.y) * sy(o)));
  };
  const double s = std::min(sx(o), sy(o));
  cv::line(mask, p(170, 178), p(182, 260), cv::Scalar(255), std::max(1, cvRound(46 * s)));
  return mask;
}

// The scene without noise, float RGB.
inline cv::Mat sceneFloat(const SceneOptions& o) {
  cv::Mat img(o.height, o.width, CV_32FC3);
  const double horizon = 0.38 * o.height;
  for (int y = 0; y < o.height; ++y) {
    for (int x = 0; x < o.width; ++x) {
      const double u = x / sx(o), v = y / sy(o);  // 320 x 240 units
      cv::Vec3f c;
      if (y < horizon) {
        // Wall: light blue-grey, vertical lighting gradient.
        const double g = 1.0 - 0.15 * v / 91.0;
        c = cv::Vec3f(178 * g, 184 * g, 192 * g);
      } else {
        // Desk: grey with a wood-like grain (two sinusoids) and a slow lighting gradient.
        const double grain = 9.0 * std::sin(0.21 * u + 2.0 * std::sin(0.045 * v)) +
                             5.0 * std::sin(0.63 * u + 0.17 * v);
        const double g = 0.9 + 0.1 * (v - 91.0) / 149.0;
        c = cv::Vec3f((128 + grain) * g, (122 + grain) * g, (116 + 0.8 * grain) * g);
      }
      img.at<cv::Vec3f>(y, x) = c;
    }
  }
  auto rect = [&](double x0, double y0, double x1, double y1, cv::Scalar colour) {
    cv::rectangle(img, cv::Point(cvRound(x0 * sx(o)), cvRound(y0 * sy(o))),
                  cv::Point(cvRound(x1 * sx(o)) - 1, cvRound(y1 * sy(o)) - 1), colour, cv::FILLED);
  };
  // Poster on the wall with a yellow stripe.
  rect(22, 12, 92, 70, cv::Scalar(40, 62, 128));
  rect(22, 38, 92, 46, cv::Scalar(230, 210, 50));
  // Green book and red mug on the desk, dark keyboard with light keys.
  rect(236, 150, 306, 200, cv::Scalar(52, 118, 64));
  cv::ellipse(img, cv::Point(cvRound(40 * sx(o)), cvRound(170 * sy(o))),
              cv::Size(cvRound(14 * sx(o)), cvRound(18 * sy(o))), 0, 0, 360,
              cv::Scalar(196, 32, 40), cv::FILLED);
  rect(16, 204, 120, 236, cv::Scalar(46, 46, 50));
  for (int kx = 0; kx < 12; ++kx) {
    for (int ky = 0; ky < 3; ++ky) {
      rect(19 + 8.5 * kx, 207 + 9.5 * ky, 25 + 8.5 * kx, 214 + 9.5 * ky, cv::Scalar(150, 150, 156));
    }
  }
  if (o.shadow) {
    cv::Mat shadow = handMask(o, o.shadow_offset) | sleeveMask(o, o.shadow_offset);
    // Soft penumbra: blur the shadow's mask a little.
    cv::Mat soft;
    shadow.convertTo(soft, CV_32F, 1.0 / 255.0);
    cv::GaussianBlur(soft, soft, cv::Size(5, 5), 1.2);
    for (int y = 0; y < o.height; ++y) {
      for (int x = 0; x < o.width; ++x) {
        const float a = soft.at<float>(y, x);
        img.at<cv::Vec3f>(y, x) *= static_cast<float>(1.0 - a * (1.0 - o.shadow_factor));
      }
    }
  }
  if (o.sleeve) img.setTo(cv::Scalar(22, 22, 26), sleeveMask(o));
  if (o.hand) {
    const cv::Mat hand = handMask(o);
    for (int y = 0; y < o.height; ++y) {
      for (int x = 0; x < o.width; ++x) {
        if (!hand.at<unsigned char>(y, x)) continue;
        // Shading: lit from the upper left.
        const double u = x / sx(o), v = y / sy(o);
        const double shade =
            std::clamp(1.08 - 0.0022 * (u - 100.0) - 0.0012 * (v - 60.0), 0.7, 1.1);
        img.at<cv::Vec3f>(y, x) =
            cv::Vec3f(static_cast<float>(214 * shade), static_cast<float>(158 * shade),
                      static_cast<float>(128 * shade));
      }
    }
  }
  return img;
}

// The scene as a CV_8UC3 RGB camera image with noise.
inline cv::Mat scene(const SceneOptions& o) {
  cv::Mat img = sceneFloat(o);
  if (o.noise_std > 0.0) {
    cv::Mat noise(img.size(), CV_32FC3);
    cv::RNG rng(0x5eed0000u + o.seed);
    rng.fill(noise, cv::RNG::NORMAL, cv::Scalar::all(0.0), cv::Scalar::all(o.noise_std));
    img += noise;
  }
  cv::Mat out;
  img.convertTo(out, CV_8UC3);  // rounds and saturates
  return out;
}

inline cv::Mat backgroundFrame(unsigned seed, int width = 320, int height = 240) {
  SceneOptions o;
  o.width = width;
  o.height = height;
  o.seed = seed;
  return scene(o);
}

}  // namespace sag_test
