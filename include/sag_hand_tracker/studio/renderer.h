// The synthetic studio's renderer: a room with a textured tabletop and walls, lit by a directional
// key light and ambient light, the hand surface (hand_surface.h) ray-cast per pixel inside each
// primitive's projected bounding box with a depth buffer, its cast shadow on the table, optional
// motion blur (average of sub-frame renders), a small optical blur and seeded Gaussian sensor
// noise. Cameras are exact pinholes (distortion, if any, is ignored). No ROS.
//
// Speed: the lit background (room, table, textures) is computed once per camera at construction;
// a frame shades only the pixels a sub-frame can change (the parts' projected bounding boxes and
// their shadow's footprint on the table) over that cached image, in per-thread buffers reused
// from frame to frame. The light gain scales the finished sum, so the cache does not depend on
// it. renderCameraFullFrame shades every pixel instead: the same image, for the tests.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/studio/hand_surface.h"
#include "sag_hand_tracker/util/thread_pool.h"

namespace sag_hand_tracker {
namespace studio {

// The static scene, in the rig's root frame (z up, table top at z = 0).
struct StudioSceneParams {
  // Table top: a rectangle at z = 0.
  Eigen::Vector2d table_min{-0.65, -0.5};
  Eigen::Vector2d table_max{0.65, 0.55};
  // The room: an axis-aligned box around everything (floor, walls, ceiling).
  Eigen::Vector3d room_min{-1.8, -1.6, -0.75};
  Eigen::Vector3d room_max{1.8, 1.6, 2.2};
  // Direction towards the key light (normalised internally), its intensity and the ambient light.
  Eigen::Vector3d light_direction{-0.35, -0.5, 1.0};
  double light_intensity = 0.62;
  double ambient = 0.36;
  // Cast shadows of the hand and arm on the table, sampled on a grid of this spacing (metres).
  bool shadows = true;
  double shadow_texel = 0.002;
  // Samples per pixel and axis when the static background is precomputed (anti-aliasing).
  int background_supersampling = 3;
  // Seed of the procedural textures (the background is static; it is not the per-frame seed).
  std::uint64_t texture_seed = 20140101;
  // Photographs (CV_8UC3, R G B, sRGB-encoded) instead of the procedural textures; empty: none.
  // The table photo is stretched over the whole table top; the wall photo is tiled over the
  // walls in squares of wall_photo_size metres (floor and ceiling stay procedural).
  cv::Mat table_photo;
  cv::Mat wall_photo;
  double wall_photo_size = 0.9;
};

// The camera sensor.
struct SensorParams {
  double noise_sigma = 2.0;  // Gaussian noise per channel, 8-bit levels
  double blur_sigma = 0.6;   // optical blur (pixels), 0 for none
};

// One camera's image.
struct StudioImage {
  cv::Mat rgb;     // CV_8UC3, R G B order
  cv::Mat labels;  // CV_8UC1, SurfaceLabel per pixel (sharp, no blur, no noise)
  cv::Mat depth;   // CV_32FC1, distance along the optical axis (z, metres) of the visible surface
};

class StudioRenderer {
 public:
  // Throws InputError for an unusable camera (non-positive size or focal length, distortion).
  StudioRenderer(std::vector<Camera> cameras, const StudioSceneParams& scene = StudioSceneParams(),
                 const SensorParams& sensor = SensorParams());

  // Renders every camera. `subframes` holds the hand surface at each sub-frame time of the
  // exposure; the colours are averaged over them (motion blur), labels and depth come from the
  // middle one. No sub-frame (or only empty ones) renders the empty studio. `noise_seed` seeds
  // the sensor noise (e.g. from the sequence seed and the frame number).
  // `light_gain` scales all light (key and ambient) for this frame: daylight that changes.
  std::vector<StudioImage> render(const std::vector<std::vector<SurfacePart>>& subframes,
                                  std::uint64_t noise_seed, double light_gain = 1.0) const;
  // One camera only.
  StudioImage renderCamera(int camera, const std::vector<std::vector<SurfacePart>>& subframes,
                           std::uint64_t noise_seed, double light_gain = 1.0) const;
  // The same image with every pixel of every sub-frame shaded (no changed-region bookkeeping):
  // slower, the reference the tests hold renderCamera to.
  StudioImage renderCameraFullFrame(int camera,
                                    const std::vector<std::vector<SurfacePart>>& subframes,
                                    std::uint64_t noise_seed, double light_gain = 1.0) const;

  // render() shades the views on this many threads, kept from frame to frame (the images are the
  // same for any number: each view has its own noise seed). 1, the default: the calling thread.
  void setRenderThreads(int threads);

  const std::vector<Camera>& cameras() const { return cameras_; }
  const StudioSceneParams& scene() const { return scene_; }
  const SensorParams& sensor() const { return sensor_; }

 private:
  struct CameraData {
    std::vector<Eigen::Vector3f> rays;      // per pixel, unit direction in the camera frame
    cv::Mat bg_linear;                      // CV_32FC3, lit background colour (linear RGB)
    std::vector<float> bg_t;                // per pixel, ray distance to the background
    std::vector<float> bg_direct;           // per pixel, the key light's share of bg_linear
    std::vector<Eigen::Vector2f> table_uv;  // per pixel, table point (x, y), NaN if not table
    cv::Mat bg_depth;                       // CV_32FC1, bg_t along the optical axis
  };
  // Per sub-frame: which table points are in the hand's shadow (fraction 0..1 of key light).
  struct ShadowMap {
    Eigen::Vector2d origin;
    double texel = 1.0;
    int width = 0;
    int height = 0;
    std::vector<float> occlusion;
    float sample(float x, float y) const;
  };
  ShadowMap computeShadow(const std::vector<SurfacePart>& parts) const;
  std::vector<ShadowMap> computeShadows(
      const std::vector<std::vector<SurfacePart>>& subframes) const;
  StudioImage renderCamera(int camera, const std::vector<std::vector<SurfacePart>>& subframes,
                           const std::vector<ShadowMap>& shadows, std::uint64_t noise_seed,
                           double light_gain, bool full_frame) const;

  std::vector<Camera> cameras_;
  StudioSceneParams scene_;
  SensorParams sensor_;
  Eigen::Vector3d light_;  // unit, towards the light, root frame
  std::vector<CameraData> data_;
  std::shared_ptr<ThreadPool> pool_;  // setRenderThreads; shared by copies (its runs take turns)
};

// The background colour of a root-frame point on the table, walls, floor or ceiling (linear RGB
// albedo), from procedural textures seeded by `seed`. Exposed for tests and tools.
Eigen::Vector3f studioAlbedo(const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                             bool on_table, std::uint64_t seed);

// A contact sheet (RGB, CV_8UC3): every camera's image in a grid of 3 columns, named, and a last
// tile with camera 0's label image and, if given, the ground-truth fingertips (+) projected into
// it. `caption` is written at the bottom left.
cv::Mat contactSheet(const std::vector<StudioImage>& images, const std::vector<Camera>& cameras,
                     const Fingertips* fingertips = nullptr, const std::string& caption = "");

// Linear <-> sRGB-encoded values in [0, 1].
float linearToSrgb(float linear);
float srgbToLinear(float srgb);

// A fixed-point 64-bit mix of two values (splitmix64), for deriving seeds.
std::uint64_t mixSeed(std::uint64_t a, std::uint64_t b);

}  // namespace studio
}  // namespace sag_hand_tracker
