// Plain data types shared by every part of the core library (no ROS).
#pragma once

#include <Eigen/Core>
#include <array>
#include <stdexcept>
#include <string>
#include <vector>

namespace sag_hand_tracker {

// HSV colour: h in degrees [0, 360), s and v in [0, 1].
using Hsv = Eigen::Vector3d;

// One isotropic Gaussian of an image SoG (paper section 4.1, "2D RGB Image Modeling").
struct ImageGaussian {
  Eigen::Vector2d mean;  // pixels, undistorted pinhole coordinates once attached to a camera
  double sigma = 1.0;    // pixels
  Hsv hsv = Hsv::Zero();
};

// The 2D Sum of Gaussians of one camera image.
struct ImageSoG {
  int width = 0;
  int height = 0;
  std::vector<ImageGaussian> gaussians;
  // Where the forearm joins the hand: the sleeve's cells (too dark to be skin; with a plate, also
  // differing from it) next to the foreground (RoomCueParams::sleeve_band_cells), counted and
  // averaged (pixels). The forearm joins the hand at the wrist, so this tells the tracker which
  // end of the hand is the wrist, and about where the wrist is (EnergyParams::wrist_weight).
  // 0 cells: no such evidence.
  int arm_cells = 0;
  Eigen::Vector2d arm_centroid = Eigen::Vector2d::Zero();
  // Those cells themselves, one square Gaussian each (the leaves of a sleeve, hue 0): where the
  // sleeve may hide the heel of the hand, a silhouette score may charge the model's pixels less
  // than on the background (foregroundsOf, silhouetteScore's sleeve_charge). Empty when arm_cells
  // is 0.
  std::vector<ImageGaussian> arm_gaussians;
};

// A projected model Gaussian in one camera image (pixels).
struct ProjectedGaussian {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  Eigen::Matrix2d cov = Eigen::Matrix2d::Identity();
  bool valid = false;  // false when the projection is undefined (camera inside, behind, ...)
};

// ASCII control characters (0x00-0x1f, 0x7f): never part of a name, never echoed raw.
inline bool isControlCharacter(char c) {
  const unsigned char u = static_cast<unsigned char>(c);
  return u < 0x20 || u == 0x7f;
}

// Thrown for bad input (model files, cameras, ...): the message names the problem.
// Control characters of the input it quotes (a frame_id, an encoding, an option's value) are
// written as \xNN: raw, an escape sequence reached the user's terminal and a NUL cut the message.
// Line breaks and tabs stay: some messages list their points on lines of their own.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& what) : std::runtime_error(printable(what)) {}
  explicit InputError(const char* what) : InputError(std::string(what)) {}

 private:
  static std::string printable(const std::string& text) {
    std::string out;
    out.reserve(text.size());
    static const char kHex[] = "0123456789abcdef";
    for (const char c : text) {
      if (isControlCharacter(c) && c != '\n' && c != '\t') {
        const unsigned char u = static_cast<unsigned char>(c);
        out += "\\x";
        out += kHex[u >> 4];
        out += kHex[u & 15];
      } else {
        out += c;
      }
    }
    return out;
  }
};

constexpr int kNumFingers = 5;  // thumb, index, middle, ring, pinky
inline const std::array<const char*, kNumFingers>& fingerNames() {
  static const std::array<const char*, kNumFingers> names{"thumb", "index", "middle", "ring",
                                                          "pinky"};
  return names;
}

}  // namespace sag_hand_tracker
