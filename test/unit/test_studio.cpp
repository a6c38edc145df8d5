// Tests of the synthetic studio: primitives, hand surface, renderer, motions and sequences.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <iomanip>
#include <map>
#include <opencv2/core.hpp>
#include <random>
#include <sstream>

#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/energy/colour.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/segmentation/quadtree_segmentation.h"
#include "sag_hand_tracker/studio/hand_surface.h"
#include "sag_hand_tracker/studio/motion.h"
#include "sag_hand_tracker/studio/primitives.h"
#include "sag_hand_tracker/studio/renderer.h"
#include "sag_hand_tracker/studio/room.h"
#include "sag_hand_tracker/studio/sequence.h"

using namespace sag_hand_tracker;
using namespace sag_hand_tracker::studio;

namespace {

const std::string kSourceDir = SAG_SOURCE_DIR;
constexpr double kDeg = M_PI / 180.0;

const HandModel& handModel() {
  static const HandModel model = loadHandModel(resolveModelPath("sag", kSourceDir + "/config"));
  return model;
}

const std::vector<Camera>& dexter5() {
  static const std::vector<Camera> cameras =
      loadCameraRig(kSourceDir + "/config/rigs/dexter5/rig.yaml").cameras;
  return cameras;
}

const StudioRenderer& sharedRenderer() {
  static const StudioRenderer renderer(dexter5());
  return renderer;
}

Motion builtinMotion(const std::string& name, std::uint64_t seed) {
  return loadMotion(resolveMotionPath(name, kSourceDir + "/config"), handModel(), seed);
}

int jointIndex(const std::string& name) {
  const int j = handModel().jointIndex(name);
  if (j >= 0) return j;
  ADD_FAILURE() << "no joint " << name;
  return 0;
}

// Skin as a segmentation would see it: orange-red hue, moderate saturation, not dark.
bool isSkinPixel(const cv::Vec3b& rgb) {
  const Hsv hsv = rgbToHsv(rgb[0], rgb[1], rgb[2]);
  return hsv[2] > 0.3 && hsv[1] > 0.18 && hsv[1] < 0.75 && (hsv[0] < 50.0 || hsv[0] > 345.0);
}

int countSkin(const cv::Mat& rgb) {
  int count = 0;
  for (int v = 0; v < rgb.rows; ++v) {
    for (int u = 0; u < rgb.cols; ++u) count += isSkinPixel(rgb.at<cv::Vec3b>(v, u));
  }
  return count;
}

// First hit by sphere tracing an exact signed distance function; -1 for a miss.
double sphereTrace(const std::function<double(const Eigen::Vector3d&)>& sdf,
                   const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) {
  double t = 0.0;
  for (int i = 0; i < 100000 && t < 50.0; ++i) {
    const double d = sdf(origin + t * dir);
    if (d < 1e-10) return t;
    t += d;
  }
  return -1.0;
}

Eigen::Vector3d sdfGradient(const std::function<double(const Eigen::Vector3d&)>& sdf,
                            const Eigen::Vector3d& p) {
  const double h = 1e-6;
  Eigen::Vector3d g;
  for (int a = 0; a < 3; ++a) {
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d[a] = h;
    g[a] = (sdf(p + d) - sdf(p - d)) / (2 * h);
  }
  return g.normalized();
}

// Compares ray intersection with sphere tracing of the SDF for rays aimed near the primitive.
template <typename Primitive>
void checkAgainstSdf(const Primitive& primitive, std::mt19937_64* rng, int rays, int* hits) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const auto sdf = [&](const Eigen::Vector3d& p) { return signedDistance(primitive, p); };
  for (int r = 0; r < rays; ++r) {
    Eigen::Vector3d origin(unit(*rng), unit(*rng), unit(*rng));
    origin = 4.0 * origin.normalized();
    const Eigen::Vector3d target(0.6 * unit(*rng), 0.6 * unit(*rng), 0.6 * unit(*rng));
    const Eigen::Vector3d dir = (target - origin).normalized();
    RayHit hit;
    const bool found = intersect(primitive, origin, dir, &hit);
    const double traced = sphereTrace(sdf, origin, dir);
    if (found) {
      ++*hits;
      ASSERT_GE(traced, 0.0) << "intersection reports a hit the SDF does not have";
      EXPECT_NEAR(hit.t, traced, 1e-6);
      EXPECT_NEAR(sdf(origin + hit.t * dir), 0.0, 1e-9);
      EXPECT_GT(hit.normal.dot(sdfGradient(sdf, origin + hit.t * dir)), 1.0 - 1e-5);
    } else if (traced >= 0.0) {
      // A miss may only be a graze: the ray then passes within a hair of the surface.
      double closest = 1e9;
      for (double t = traced - 0.01; t < traced + 0.01; t += 1e-5) {
        closest = std::min(closest, sdf(origin + t * dir));
      }
      EXPECT_GT(closest, -1e-6) << "intersection misses a ray that enters the primitive";
    }
  }
}

}  // namespace

// ---- primitives -------------------------------------------------------------------------------

TEST(StudioPrimitives, RoundConeIntersectionMatchesSignedDistance) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), radius(0.05, 0.45);
  int hits = 0;
  for (int shape = 0; shape < 40; ++shape) {
    RoundCone cone{Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * 0.7,
                   Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * 0.7, radius(rng),
                   radius(rng)};
    if (shape == 0) cone.b = cone.a;    // a sphere
    if (shape == 1) cone.rb = cone.ra;  // a capsule
    if (shape == 2) cone.b = cone.a + Eigen::Vector3d(0.05, 0, 0), cone.rb = cone.ra + 0.2;
    checkAgainstSdf(cone, &rng, 100, &hits);
  }
  EXPECT_GT(hits, 1000);  // most rays are aimed at the primitive
}

TEST(StudioPrimitives, SweptPolygonIntersectionMatchesSignedDistance) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), radius(0.02, 0.3);
  int hits = 0;
  for (int shape = 0; shape < 30; ++shape) {
    std::vector<Eigen::Vector2d> points;
    for (int i = 0; i < 8; ++i) points.emplace_back(0.8 * unit(rng), 0.8 * unit(rng));
    SweptPolygon polygon;
    const Eigen::Matrix3d r =
        Eigen::Quaterniond(Eigen::Vector4d(unit(rng), unit(rng), unit(rng), unit(rng)).normalized())
            .toRotationMatrix();
    polygon.origin = 0.2 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    polygon.u = r.col(0);
    polygon.v = r.col(1);
    polygon.vertices = convexHull(points);
    polygon.radius = radius(rng);
    ASSERT_GE(polygon.vertices.size(), 3u);
    checkAgainstSdf(polygon, &rng, 100, &hits);
  }
  EXPECT_GT(hits, 800);
}

TEST(StudioPrimitives, ConvexHullIsCounterClockwiseWithoutInnerPoints) {
  const std::vector<Eigen::Vector2d> points{{0, 0},     {1, 0},   {1, 1},    {0, 1},
                                            {0.5, 0.5}, {0.5, 0}, {0.2, 0.7}};
  const auto hull = convexHull(points);
  ASSERT_EQ(hull.size(), 4u);
  double area = 0.0;
  for (size_t i = 0; i < hull.size(); ++i) {
    const auto& a = hull[i];
    const auto& b = hull[(i + 1) % hull.size()];
    area += a.x() * b.y() - a.y() * b.x();
  }
  EXPECT_NEAR(area / 2.0, 1.0, 1e-12);  // positive: counter-clockwise
}

// ---- hand surface ---------------------------------------------------------------------------

TEST(StudioHand, DistalCapsuleEndsExactlyAtTheFingertip) {
  const HandModel& model = handModel();
  Pose pose;
  pose.translation = Eigen::Vector3d(0.01, -0.05, 0.15);
  pose.rotation = motionOrientation(Eigen::Vector3d(30, -20, 10));
  for (int j = 0; j < kNumJointDof; ++j) {
    pose.joints[j] = model.joints[j].min + 0.3 * (model.joints[j].max - model.joints[j].min);
  }
  for (const double scale : {1.0, 0.85, 1.15}) {
    HandShape shape;
    shape.scale = scale;
    shape.finger_length = {1.0, 1.05, 0.95, 1.0, 1.1};
    const HandModel shaped = shapeHandModel(model, shape);
    const PosedHand posed = forwardKinematics(shaped, pose);
    const auto tips = boneFingertips(shaped, posed.bone_frames);
    const auto parts = buildHandSurface(shaped, posed.bone_frames, HandSurfaceParams(), shape);
    const auto chains = fingerChains(shaped);
    for (int f = 0; f < kNumFingers; ++f) {
      const SurfacePart* distal = nullptr;
      for (const auto& part : parts) {
        if (part.label == fingerBoneLabel(f, 2)) distal = &part;
      }
      ASSERT_NE(distal, nullptr);
      const Eigen::Vector3d x = posed.bone_frames[chains[f][2]].linear().col(0);
      // The tip lies on the capsule surface, and it is its extremity along the bone.
      EXPECT_NEAR(signedDistance(distal->cone, tips[f]), 0.0, 1e-12) << fingerNames()[f];
      EXPECT_GT(signedDistance(distal->cone, tips[f] + 1e-5 * x), 0.0);
      EXPECT_LT(signedDistance(distal->cone, tips[f] - 1e-5 * x), 0.0);
      const Eigen::Vector3d side = x.unitOrthogonal();
      EXPECT_GT(signedDistance(distal->cone, tips[f] + 1e-4 * side), 0.0);
      // Ground truth = the distal bone's end of the shaped skeleton.
      const Eigen::Isometry3d& frame = posed.bone_frames[chains[f][2]];
      EXPECT_LT((tips[f] - (frame.translation() + shaped.bones[chains[f][2]].length * x)).norm(),
                1e-12);
    }
  }
}

TEST(StudioHand, ShapeScalesTheSkeleton) {
  const HandModel& model = handModel();
  Pose pose;  // root at the origin, all joints 0 clamped
  for (int j = 0; j < kNumJointDof; ++j) {
    pose.joints[j] = std::clamp(0.0, model.joints[j].min, model.joints[j].max);
  }
  const auto base = boneFingertips(model, forwardKinematics(model, pose).bone_frames);
  HandShape shape;
  shape.scale = 1.2;
  const HandModel big = shapeHandModel(model, shape);
  const auto scaled = boneFingertips(big, forwardKinematics(big, pose).bone_frames);
  for (int f = 0; f < kNumFingers; ++f) {
    EXPECT_NEAR((scaled[f] - 1.2 * base[f]).norm(), 0.0, 1e-12) << fingerNames()[f];
  }
  shape.scale = 1.0;
  shape.finger_length[2] = 1.1;  // longer middle finger only
  const HandModel longer = shapeHandModel(model, shape);
  const auto tips = boneFingertips(longer, forwardKinematics(longer, pose).bone_frames);
  EXPECT_NEAR((tips[1] - base[1]).norm(), 0.0, 1e-12);
  EXPECT_GT((tips[2] - base[2]).norm(), 0.005);
  shape.scale = -1.0;
  EXPECT_THROW(shapeHandModel(model, shape), InputError);
}

// ---- renderer --------------------------------------------------------------------------------

TEST(StudioRender, GroundTruthFingertipsProjectOntoRenderedFingertips) {
  const HandModel& model = handModel();
  const StudioRenderer& renderer = sharedRenderer();
  // An open hand with spread fingers, tilted so that every camera sees it from a different side.
  Pose pose;
  pose.translation = Eigen::Vector3d(0.0, -0.06, 0.15);
  pose.rotation = motionOrientation(Eigen::Vector3d(15, -10, 0));
  const std::map<std::string, double> joints{
      {"thumb_cmc_abd", 30},   {"thumb_mcp_flex", 5},  {"index_mcp_abd", 15},
      {"ring_mcp_abd", -10},   {"pinky_mcp_abd", -18}, {"index_pip_flex", 10},
      {"middle_pip_flex", 10}, {"ring_pip_flex", 10},  {"pinky_pip_flex", 10}};
  for (const auto& [name, degrees] : joints) pose.joints[jointIndex(name)] = degrees * kDeg;
  HandShape shape;
  const PosedHand posed = forwardKinematics(model, pose);
  const auto tips = boneFingertips(model, posed.bone_frames);
  const auto chains = fingerChains(model);
  const auto parts = buildHandSurface(model, posed.bone_frames, HandSurfaceParams(), shape);
  const auto images = renderer.render({parts}, 11);
  ASSERT_EQ(images.size(), 5u);

  int checked = 0;
  for (size_t c = 0; c < images.size(); ++c) {
    const Camera& camera = renderer.cameras()[c];
    const StudioImage& image = images[c];
    int visible_in_camera = 0;
    for (int f = 0; f < kNumFingers; ++f) {
      SCOPED_TRACE(camera.name + " " + fingerNames()[f]);
      const Eigen::Vector3d tip_c = camera.world_to_camera * tips[f];
      const Eigen::Vector3d base_c =
          camera.world_to_camera * posed.bone_frames[chains[f][2]].translation();
      const Eigen::Vector2d tip_px = (camera.K * tip_c).hnormalized();
      const Eigen::Vector2d base_px = (camera.K * base_c).hnormalized();
      ASSERT_TRUE(tip_px.x() > 4 && tip_px.y() > 4 && tip_px.x() < camera.width - 5 &&
                  tip_px.y() < camera.height - 5)
          << "tip outside the image at " << tip_px.transpose();
      const std::uint8_t label = fingerBoneLabel(f, 2);
      // The distal phalanx's pixels and the skin-coloured pixels around the projected tip.
      bool near_tip = false;
      int skin_near = 0;
      double reach = -1e9;  // furthest distal pixel along the projected bone direction
      const Eigen::Vector2d axis = tip_px - base_px;
      const bool foreshortened = axis.norm() < 4.0;
      const Eigen::Vector2d e = foreshortened ? Eigen::Vector2d::Zero() : axis.normalized();
      double farthest = 0.0;  // any direction, for foreshortened fingers
      for (int v = 0; v < camera.height; ++v) {
        for (int u = 0; u < camera.width; ++u) {
          const Eigen::Vector2d d = Eigen::Vector2d(u, v) - tip_px;
          if (d.norm() <= 3.0 && isSkinPixel(image.rgb.at<cv::Vec3b>(v, u))) ++skin_near;
          if (image.labels.at<std::uint8_t>(v, u) != label) continue;
          if (d.norm() <= 2.0) near_tip = true;
          reach = std::max(reach, d.dot(e));
          farthest = std::max(farthest, d.norm());
        }
      }
      const int pu = static_cast<int>(std::lround(tip_px.x()));
      const int pv = static_cast<int>(std::lround(tip_px.y()));
      if (!near_tip) {
        // Only acceptable when something else is in front of the tip.
        EXPECT_LT(image.depth.at<float>(pv, pu), tip_c.z() - 0.003)
            << "no pixel of the distal phalanx near the projected fingertip";
        continue;
      }
      ++visible_in_camera;
      ++checked;
      EXPECT_GE(skin_near, 3) << "no skin colour around the projected fingertip";
      const double radius_px = camera.K(0, 0) * HandSurfaceParams().finger_radii[f][3] / tip_c.z();
      if (foreshortened) {
        EXPECT_LE(farthest, 2.0 * radius_px + 2.0);
      } else {
        EXPECT_GE(reach, -1.5) << "the rendered finger stops short of the fingertip";
        EXPECT_LE(reach, radius_px + 1.5) << "the rendered finger extends beyond the fingertip";
      }
    }
    EXPECT_GE(visible_in_camera, 3) << camera.name;
  }
  EXPECT_GE(checked, 21);
}

TEST(StudioRender, EmptyFramesShowNoSkinThenTheHandAppears) {
  SequenceParams params;
  const StudioSequence sequence(handModel(), builtinMotion("fingercount", 1), params);
  ASSERT_EQ(params.empty_frames, 10);
  for (const int index : {0, 5, 9, 10}) {
    SCOPED_TRACE("frame " + std::to_string(index));
    const StudioFrame frame = sequence.frame(index);
    const auto surfaces = sequence.surfaces(index);
    EXPECT_EQ(frame.hand_present, index >= 10);
    EXPECT_EQ(surfaces.empty(), index < 10);
    const auto images = sharedRenderer().render(surfaces, sequence.noiseSeed(index));
    int skin = 0, labelled = 0;
    for (const StudioImage& image : images) {
      skin += countSkin(image.rgb);
      labelled += cv::countNonZero(image.labels);
    }
    if (index < 10) {
      EXPECT_EQ(skin, 0);
      EXPECT_EQ(labelled, 0);
    } else {
      EXPECT_GT(skin, 5 * 300);  // a hand in each of the 5 views
      EXPECT_GT(labelled, 5 * 400);
    }
  }
}

TEST(StudioRender, DeterministicFromTheSeed) {
  auto renderFrame = [](std::uint64_t seed, int index, StudioFrame* frame) {
    SequenceParams params;
    params.seed = seed;
    const StudioSequence sequence(handModel(), builtinMotion("random", seed), params);
    *frame = sequence.frame(index);
    return sharedRenderer().render(sequence.surfaces(index), sequence.noiseSeed(index));
  };
  StudioFrame a, b, c;
  const auto first = renderFrame(7, 60, &a);
  const auto again = renderFrame(7, 60, &b);
  const auto other = renderFrame(8, 60, &c);
  EXPECT_EQ((a.pose.toVector() - b.pose.toVector()).norm(), 0.0);
  EXPECT_GT((a.pose.toVector() - c.pose.toVector()).norm(), 0.05);  // random keyframes differ
  for (size_t k = 0; k < first.size(); ++k) {
    ASSERT_EQ(first[k].rgb.total(), again[k].rgb.total());
    EXPECT_EQ(std::memcmp(first[k].rgb.data, again[k].rgb.data, first[k].rgb.total() * 3), 0);
    EXPECT_GT(cv::norm(first[k].rgb, other[k].rgb, cv::NORM_L1), 0.0);
  }
  // The sensor noise alone follows the seed too: same surfaces, different noise seeds.
  SequenceParams params;
  const StudioSequence sequence(handModel(), builtinMotion("pinch", 1), params);
  const auto surfaces = sequence.surfaces(30);
  const StudioImage x = sharedRenderer().renderCamera(0, surfaces, 100);
  const StudioImage y = sharedRenderer().renderCamera(0, surfaces, 100);
  const StudioImage z = sharedRenderer().renderCamera(0, surfaces, 101);
  EXPECT_EQ(cv::norm(x.rgb, y.rgb, cv::NORM_L1), 0.0);
  const double mean_difference = cv::norm(x.rgb, z.rgb, cv::NORM_L1) / (x.rgb.total() * 3.0);
  EXPECT_GT(mean_difference, 0.5);  // noise sigma 2 levels: mean |difference| about 2.2
  EXPECT_LT(mean_difference, 4.0);
  EXPECT_EQ(cv::norm(x.labels, z.labels, cv::NORM_L1), 0.0);
}

// The views of a set rendered on kept threads (StudioRenderer::setRenderThreads, the live
// studio's render_threads) are the one-thread images, byte for byte: each view has its own noise
// seed and its own buffers. Several frames, so that the threads reuse their buffers.
TEST(StudioRender, RenderThreadsGiveTheSameImages) {
  SequenceParams params;
  const StudioSequence sequence(handModel(), builtinMotion("random", 3), params);
  StudioRenderer threaded = sharedRenderer();
  threaded.setRenderThreads(3);
  for (int index : {20, 40, 60}) {
    const auto one = sharedRenderer().render(sequence.surfaces(index), sequence.noiseSeed(index));
    const auto three = threaded.render(sequence.surfaces(index), sequence.noiseSeed(index));
    ASSERT_EQ(one.size(), three.size());
    for (size_t k = 0; k < one.size(); ++k) {
      ASSERT_EQ(one[k].rgb.total(), three[k].rgb.total());
      EXPECT_EQ(std::memcmp(one[k].rgb.data, three[k].rgb.data, one[k].rgb.total() * 3), 0)
          << "frame " << index << ", view " << k;
      EXPECT_EQ(cv::norm(one[k].labels, three[k].labels, cv::NORM_L1), 0.0);
      EXPECT_EQ(cv::norm(one[k].depth, three[k].depth, cv::NORM_L1), 0.0);
    }
  }
}

TEST(StudioRender, HandCastsAShadowOnTheTable) {
  const HandModel& model = handModel();
  Pose pose;
  pose.translation = Eigen::Vector3d(0.0, -0.06, 0.12);
  pose.rotation = motionOrientation(Eigen::Vector3d::Zero());
  const auto parts =
      buildHandSurface(model, forwardKinematics(model, pose).bone_frames, HandSurfaceParams());
  StudioSceneParams lit;
  lit.background_supersampling = 1;
  StudioSceneParams unshadowed = lit;
  unshadowed.shadows = false;
  SensorParams clean;
  clean.noise_sigma = 0.0;
  clean.blur_sigma = 0.0;
  const std::vector<Camera> top{dexter5()[4]};  // the camera above the table
  const StudioImage with = StudioRenderer(top, lit, clean).renderCamera(0, {parts}, 1);
  const StudioImage without = StudioRenderer(top, unshadowed, clean).renderCamera(0, {parts}, 1);
  int darker = 0, brighter = 0;
  for (int v = 0; v < with.rgb.rows; ++v) {
    for (int u = 0; u < with.rgb.cols; ++u) {
      const cv::Vec3b a = with.rgb.at<cv::Vec3b>(v, u), b = without.rgb.at<cv::Vec3b>(v, u);
      const int diff = (a[0] + a[1] + a[2]) - (b[0] + b[1] + b[2]);
      if (diff < -15) {
        ++darker;
        EXPECT_EQ(with.labels.at<std::uint8_t>(v, u), kLabelBackground);
      }
      if (diff > 0) ++brighter;
    }
  }
  EXPECT_GT(darker, 300);  // the hand's and arm's shadow
  EXPECT_EQ(brighter, 0);
}

TEST(StudioRender, MotionBlurAveragesSubFrames) {
  SequenceParams sharp, blurred;
  blurred.motion_blur_samples = 5;
  blurred.exposure = 0.03;
  const StudioSequence a(handModel(), builtinMotion("random", 3), sharp);
  const StudioSequence b(handModel(), builtinMotion("random", 3), blurred);
  const int index = 100;
  ASSERT_EQ(b.surfaces(index).size(), 5u);
  const StudioImage x = sharedRenderer().renderCamera(4, a.surfaces(index), 5);
  const StudioImage y = sharedRenderer().renderCamera(4, b.surfaces(index), 5);
  // Labels and depth come from the middle sub-frame, i.e. the frame time.
  EXPECT_EQ(cv::norm(x.labels, y.labels, cv::NORM_L1), 0.0);
  EXPECT_GT(cv::norm(x.rgb, y.rgb, cv::NORM_L1), 1000.0);
  // Frame ground truth is at the frame time, whatever the blur.
  EXPECT_EQ((a.frame(index).pose.toVector() - b.frame(index).pose.toVector()).norm(), 0.0);
}

TEST(StudioRender, PlateSegmentationSeparatesTheRenderedHand) {
  // The studio's images are what the tracker consumes: a background plate learned from the empty
  // frames must find the hand (skin) and reject the table, the shadows and the black sleeve.
  const StudioSequence sequence(handModel(), builtinMotion("tigergrasp", 1), SequenceParams());
  std::vector<ImageSegmenter> segmenters(dexter5().size());
  for (int k = 0; k < 10; ++k) {
    const auto images = sharedRenderer().render(sequence.surfaces(k), sequence.noiseSeed(k));
    for (size_t c = 0; c < images.size(); ++c) segmenters[c].addBackgroundFrame(images[c].rgb);
  }
  double hand_found = 0, hand_total = 0, false_fg = 0, fg_total = 0, sleeve_fg = 0;
  for (const int k : {20, 80, 150, 230}) {
    const auto images = sharedRenderer().render(sequence.surfaces(k), sequence.noiseSeed(k));
    for (size_t c = 0; c < images.size(); ++c) {
      ASSERT_TRUE(segmenters[c].backgroundReady());
      const cv::Mat mask = segmenters[c].foregroundMask(images[c].rgb);
      for (int v = 0; v < mask.rows; ++v) {
        for (int u = 0; u < mask.cols; ++u) {
          const std::uint8_t label = images[c].labels.at<std::uint8_t>(v, u);
          const bool fg = mask.at<std::uint8_t>(v, u) > 0;
          // Ignore pixels within 4 px of the silhouette (cells are 4 px).
          bool boundary = false;
          for (int dv = -4; dv <= 4 && !boundary; dv += 4) {
            for (int du = -4; du <= 4 && !boundary; du += 4) {
              const int vv = std::clamp(v + dv, 0, mask.rows - 1);
              const int uu = std::clamp(u + du, 0, mask.cols - 1);
              boundary =
                  isSkinLabel(images[c].labels.at<std::uint8_t>(vv, uu)) != isSkinLabel(label);
            }
          }
          if (boundary) continue;
          if (isSkinLabel(label)) {
            ++hand_total;
            hand_found += fg;
          }
          if (fg) {
            ++fg_total;
            false_fg += !isSkinLabel(label);
            sleeve_fg += label == kLabelSleeve;
          }
        }
      }
    }
  }
  EXPECT_GT(hand_found / hand_total, 0.95);
  EXPECT_LT(false_fg / fg_total, 0.05);
  EXPECT_LT(sleeve_fg / fg_total, 0.01);
}

namespace {

// The daylight room (photographs, props, the second arm) with the pinch hand at frame 40,
// `subframes` sub-frames of motion blur, lit by `light_gain`: everything the renderer draws.
struct RoomFrameRenderer {
  StudioRoom room{builtinRoom("daylight"), handModel(), kSourceDir + "/config"};
  StudioRenderer renderer;
  RoomFrameRenderer() : renderer(dexter5(), sceneOf(room)) {}
  static StudioSceneParams sceneOf(const StudioRoom& room) {
    StudioSceneParams base;
    base.background_supersampling = 1;  // the background cache is the same code, set-up faster
    return room.scene(base);
  }
  std::vector<std::vector<SurfacePart>> subframes(int count) const {
    SequenceParams params;
    params.motion_blur_samples = count;
    const StudioSequence sequence(handModel(), builtinMotion("pinch", 1), params);
    auto parts = sequence.surfaces(40);
    room.addProps(&parts, sequence.frameTime(40));
    return parts;
  }
};

const RoomFrameRenderer& roomFrameRenderer() {
  static const RoomFrameRenderer renderer;
  return renderer;
}

// A summary of one image that survives rounding: the sum of each colour channel, the pixels of
// each kind of label, the summed depth.
struct ImageFingerprint {
  std::array<double, 3> channel_sum{};
  int background = 0, prop = 0, hand = 0, sleeve = 0;
  double depth_sum = 0.0;
};

ImageFingerprint fingerprint(const StudioImage& image) {
  ImageFingerprint f;
  const cv::Scalar sum = cv::sum(image.rgb);
  for (int c = 0; c < 3; ++c) f.channel_sum[c] = sum[c];
  for (size_t i = 0; i < image.labels.total(); ++i) {
    const std::uint8_t label = image.labels.data[i];
    if (label == kLabelBackground)
      ++f.background;
    else if (label == kLabelProp)
      ++f.prop;
    else if (label == kLabelSleeve)
      ++f.sleeve;
    else if (isTrackedHandLabel(label))
      ++f.hand;
  }
  f.depth_sum = cv::sum(image.depth)[0];
  return f;
}

std::string describe(const ImageFingerprint& f) {
  std::ostringstream out;
  out << std::setprecision(12) << "{{" << f.channel_sum[0] << ", " << f.channel_sum[1] << ", "
      << f.channel_sum[2] << "}, " << f.background << ", " << f.prop << ", " << f.hand << ", "
      << f.sleeve << ", " << f.depth_sum << "}";
  return out.str();
}

}  // namespace

bool sameImage(const StudioImage& a, const StudioImage& b) {
  return cv::norm(a.rgb, b.rgb, cv::NORM_INF) == 0.0 &&
         cv::norm(a.labels, b.labels, cv::NORM_INF) == 0.0 &&
         cv::norm(a.depth, b.depth, cv::NORM_INF) == 0.0;
}

// The fast path (only the pixels the parts and their shadows can change are shaded, over the
// cached background, in reused buffers) gives exactly the image of shading every pixel: one and
// several sub-frames, the empty studio, after other frames were rendered in the same buffers.
TEST(StudioRender, ChangedRegionRenderingEqualsShadingEveryPixel) {
  const RoomFrameRenderer& room = roomFrameRenderer();
  for (const int count : {1, 3, 4}) {
    const auto subframes = room.subframes(count);
    for (int c = 0; c < static_cast<int>(dexter5().size()); ++c) {
      const StudioImage fast = room.renderer.renderCamera(c, subframes, 5 + count, 0.8);
      const StudioImage full = room.renderer.renderCameraFullFrame(c, subframes, 5 + count, 0.8);
      EXPECT_TRUE(sameImage(fast, full)) << count << " sub-frames, camera " << c;
      EXPECT_GT(cv::countNonZero(fast.labels != kLabelBackground), 1000) << c;
    }
  }
  const StudioImage empty = room.renderer.renderCamera(2, {}, 9, 0.5);
  EXPECT_TRUE(sameImage(empty, room.renderer.renderCameraFullFrame(2, {}, 9, 0.5)));
  EXPECT_EQ(cv::countNonZero(empty.labels != kLabelBackground), 0);
  // The same frame again, after others: nothing of them is left in the buffers.
  const auto subframes = room.subframes(1);
  const StudioImage again = room.renderer.renderCamera(0, subframes, 6, 0.8);
  EXPECT_TRUE(sameImage(again, room.renderer.renderCameraFullFrame(0, subframes, 6, 0.8)));
}

// The images as the renderer made them before the changed-region fast path (commit 00d8c5c, on
// this machine; equal there bit for bit but for rounding in the motion blur's sum): the daylight
// room, shadows, noise, dimmed light, 3 sub-frames of motion blur.
TEST(StudioRender, RoomFrameMatchesTheImagesOfTheEarlierRenderer) {
  const ImageFingerprint before[5] = {
      {{4669798, 5552663, 5297980}, 68319, 1497, 2648, 4336, 110005.760582},
      {{4892034, 6007915, 5698817}, 69539, 2115, 2698, 2448, 97176.9149728},
      {{4828086, 5775507, 5442393}, 67024, 4334, 2065, 3377, 102163.902562},
      {{4926739, 5694430, 5426085}, 66671, 2667, 1515, 5947, 129590.061371},
      {{5389503, 6640941, 6064699}, 63413, 7225, 2958, 3204, 62977.4524893},
  };
  const RoomFrameRenderer& room = roomFrameRenderer();
  const auto images = room.renderer.render(room.subframes(3), 77, 0.7);
  ASSERT_EQ(images.size(), 5u);
  for (size_t c = 0; c < images.size(); ++c) {
    const ImageFingerprint now = fingerprint(images[c]);
    SCOPED_TRACE("camera " + std::to_string(c) + ": " + describe(now));
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(now.channel_sum[k], before[c].channel_sum[k], 20.0);
    EXPECT_NEAR(now.background, before[c].background, 2);
    EXPECT_NEAR(now.prop, before[c].prop, 2);
    EXPECT_NEAR(now.hand, before[c].hand, 2);
    EXPECT_NEAR(now.sleeve, before[c].sleeve, 2);
    EXPECT_NEAR(now.depth_sum, before[c].depth_sum, 1e-6 * before[c].depth_sum);
  }
}

TEST(StudioRender, RejectsUnusableCameras) {
  Camera bad = dexter5()[0];
  bad.K(0, 0) = 0.0;
  EXPECT_THROW(StudioRenderer({bad}), InputError);
  bad = dexter5()[0];
  bad.width = 0;
  EXPECT_THROW(StudioRenderer({bad}), InputError);
  bad = dexter5()[0];
  bad.distortion = {0.1, 0.0, 0.0, 0.0, 0.0};
  EXPECT_THROW(StudioRenderer({bad}), InputError);
  bad.distortion = {0.0, 0.0, 0.0, 0.0, 0.0};  // zeros are a pinhole
  EXPECT_NO_THROW(StudioRenderer({bad}));
}

TEST(StudioRender, ContactSheetShowsEveryViewAndTheLabels) {
  const StudioSequence sequence(handModel(), builtinMotion("pinch", 1), SequenceParams());
  const auto images = sharedRenderer().render(sequence.surfaces(50), sequence.noiseSeed(50));
  const StudioFrame frame = sequence.frame(50);
  const cv::Mat sheet = contactSheet(images, dexter5(), &frame.fingertips, "pinch 50");
  ASSERT_EQ(sheet.type(), CV_8UC3);
  EXPECT_EQ(sheet.cols, 3 * 320);
  EXPECT_EQ(sheet.rows, 2 * 240);
  // The second view sits in the top middle tile, unchanged apart from its name in the corner.
  const cv::Rect tile(320, 30, 320, 200);
  EXPECT_EQ(cv::norm(sheet(tile), images[1].rgb(cv::Rect(0, 30, 320, 200)), cv::NORM_L1), 0.0);
  EXPECT_THROW(contactSheet(images, {dexter5()[0]}), InputError);
}

TEST(StudioRig, ResolvesNamesDirectoriesAndFiles) {
  const std::string config = kSourceDir + "/config";
  const std::string rig = config + "/rigs/dexter5/rig.yaml";
  EXPECT_EQ(resolveRigPath("dexter5", config), rig);
  EXPECT_EQ(resolveRigPath(config + "/rigs/dexter5", config), rig);
  EXPECT_EQ(resolveRigPath(rig, config), rig);
  try {
    resolveRigPath("nosuchrig", config);
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no camera rig 'nosuchrig'"), std::string::npos);
  }
}

TEST(StudioRig, Dexter5LooksAtTheWorkspaceFromAboveTheTable) {
  const std::vector<Camera>& cameras = dexter5();
  ASSERT_EQ(cameras.size(), 5u);
  const Eigen::Vector3d centre(0.0, 0.0, 0.15);
  for (size_t c = 0; c < cameras.size(); ++c) {
    SCOPED_TRACE(cameras[c].name);
    EXPECT_EQ(cameras[c].name, "cam" + std::to_string(c));
    EXPECT_EQ(cameras[c].width, 320);
    EXPECT_EQ(cameras[c].height, 240);
    const Eigen::Isometry3d pose = cameras[c].world_to_camera.inverse();
    const double distance = (pose.translation() - centre).norm();
    EXPECT_GT(distance, 0.6);
    EXPECT_LT(distance, 0.9);
    EXPECT_GT(pose.translation().z(), centre.z());  // none looks from below
    // The workspace centre projects near the image centre.
    const Eigen::Vector2d px = (cameras[c].K * (cameras[c].world_to_camera * centre)).hnormalized();
    EXPECT_NEAR(px.x(), 160.0, 25.0);
    EXPECT_NEAR(px.y(), 120.0, 25.0);
  }
}

// ---- motions -----------------------------------------------------------------------------------

TEST(StudioMotion, BuiltinSequencesParseStayInLimitsAndInView) {
  const HandModel& model = handModel();
  ASSERT_EQ(builtinMotionNames().size(), 7u);
  std::map<std::string, double> mean_speed;
  for (const std::string& name : builtinMotionNames()) {
    SCOPED_TRACE(name);
    const Motion motion = builtinMotion(name, 1);
    EXPECT_EQ(motion.name, name);
    SequenceParams params;
    const StudioSequence sequence(model, motion, params);
    EXPECT_GE(sequence.frameCount(), 300);
    std::vector<double> speeds;  // fingertip speed (m/s, mean over the five) per frame
    std::array<Eigen::Vector3d, kNumFingers> previous =
        sequence.frame(params.empty_frames).fingertips;
    for (int k = params.empty_frames; k < sequence.frameCount(); ++k) {
      const StudioFrame frame = sequence.frame(k);
      for (int j = 0; j < kNumJointDof; ++j) {
        ASSERT_GE(frame.pose.joints[j], model.joints[j].min) << "frame " << k << " joint " << j;
        ASSERT_LE(frame.pose.joints[j], model.joints[j].max) << "frame " << k << " joint " << j;
      }
      for (int f = 0; f < kNumFingers; ++f) {
        ASSERT_GT(frame.fingertips[f].z(), 0.01) << "frame " << k << ": fingertip in the table";
      }
      // Every fingertip inside the image of at least 4 of the 5 cameras.
      for (int f = 0; f < kNumFingers; ++f) {
        int in_view = 0;
        for (const Camera& camera : dexter5()) {
          const Eigen::Vector3d p = camera.world_to_camera * frame.fingertips[f];
          const Eigen::Vector2d px = (camera.K * p).hnormalized();
          in_view += p.z() > 0 && px.x() >= 0 && px.y() >= 0 && px.x() < camera.width &&
                     px.y() < camera.height;
        }
        ASSERT_GE(in_view, 4) << "frame " << k << " " << fingerNames()[f];
      }
      if (k > params.empty_frames) {
        double speed = 0.0;
        for (int f = 0; f < kNumFingers; ++f) {
          speed += (frame.fingertips[f] - previous[f]).norm() * params.fps / kNumFingers;
        }
        speeds.push_back(speed);
      }
      previous = frame.fingertips;
    }
    // Slow and fast parts: the mean speed over one-second windows.
    const int window = static_cast<int>(params.fps);
    double fastest = 0.0, slowest = 1e9;
    for (size_t k = 0; k + window <= speeds.size(); ++k) {
      double mean = 0.0;
      for (int i = 0; i < window; ++i) mean += speeds[k + i] / window;
      fastest = std::max(fastest, mean);
      slowest = std::min(slowest, mean);
    }
    EXPECT_GT(fastest, 0.2);            // a fast part
    EXPECT_GT(fastest, 3.0 * slowest);  // and a distinctly slower one
    double mean = 0.0;
    for (const double speed : speeds) mean += speed / speeds.size();
    mean_speed[name] = mean;
  }
  // `random` is the hard one: the fastest on average.
  for (const auto& [name, speed] : mean_speed) {
    if (name != "random") {
      EXPECT_GT(mean_speed["random"], speed) << name;
    }
  }
}

TEST(StudioMotion, SixtyFramesPerSecondSamplesTheSameMotion) {
  SequenceParams at25, at60;
  at60.fps = 60.0;
  const StudioSequence a(handModel(), builtinMotion("fingerwave", 1), at25);
  const StudioSequence b(handModel(), builtinMotion("fingerwave", 1), at60);
  EXPECT_EQ(a.frameCount(), 300);
  EXPECT_EQ(b.frameCount(), 720);
  EXPECT_DOUBLE_EQ(b.frame(60).time, 1.0);
  EXPECT_EQ((a.frame(25).pose.toVector() - b.frame(60).pose.toVector()).norm(), 0.0);
  EXPECT_FALSE(b.frame(9).hand_present);  // the empty frames are frames, not seconds
  EXPECT_TRUE(b.frame(10).hand_present);
  SequenceParams bad;
  bad.fps = 0.0;
  EXPECT_THROW(StudioSequence(handModel(), builtinMotion("fingerwave", 1), bad), InputError);
  bad = SequenceParams();
  bad.motion_blur_samples = 0;
  EXPECT_THROW(StudioSequence(handModel(), builtinMotion("fingerwave", 1), bad), InputError);
}

TEST(StudioMotion, InterpolationPassesThroughKeyframesAndHolds) {
  const Motion motion = parseMotion(
      "duration: 4\n"
      "keyframes:\n"
      "  - {time: 0, position: [0, 0, 0.1], orientation: [0, 0, 0], joints: {index_pip_flex: 10}}\n"
      "  - {time: 1, joints: {index_pip_flex: 10}}\n"
      "  - {time: 2, position: [0.1, 0, 0.1], orientation: [30, 0, 0],"
      " joints: {index_pip_flex: 90}}\n"
      "  - {time: 3, joints: {index_pip_flex: 40}}\n",
      "inline", handModel(), 1);
  const int pip = jointIndex("index_pip_flex");
  EXPECT_NEAR(motion.poseAt(0.0).joints[pip], 10 * kDeg, 1e-12);
  EXPECT_NEAR(motion.poseAt(0.5).joints[pip], 10 * kDeg, 1e-12);  // a hold stays a hold
  EXPECT_NEAR(motion.poseAt(2.0).joints[pip], 90 * kDeg, 1e-12);
  EXPECT_NEAR(motion.poseAt(3.0).joints[pip], 40 * kDeg, 1e-12);
  EXPECT_NEAR(motion.poseAt(3.7).joints[pip], 40 * kDeg, 1e-12);  // held after the last key
  EXPECT_NEAR(motion.poseAt(2.0).translation.x(), 0.1, 1e-12);
  // No overshoot: values between keyframes stay between their neighbours.
  for (double t = 1.0; t <= 3.0; t += 0.01) {
    const double q = motion.poseAt(t).joints[pip];
    EXPECT_GE(q, 10 * kDeg - 1e-12);
    EXPECT_LE(q, 90 * kDeg + 1e-12);
  }
  // Orientation follows roll/pitch/yaw: at zero the fingers point along +y, the back up.
  const Eigen::Matrix3d r0 = motion.poseAt(0.0).rotation;
  EXPECT_NEAR((r0.col(0) - Eigen::Vector3d::UnitY()).norm(), 0.0, 1e-12);
  EXPECT_NEAR((r0.col(2) - Eigen::Vector3d::UnitZ()).norm(), 0.0, 1e-12);
  const Eigen::Matrix3d r2 = motion.poseAt(2.0).rotation;
  EXPECT_NEAR(r2.col(0).dot(Eigen::Vector3d::UnitY()), 1.0, 1e-12);  // roll keeps the long axis
  EXPECT_NEAR(std::acos(r2.col(2).dot(Eigen::Vector3d::UnitZ())), 30 * kDeg, 1e-9);
}

TEST(StudioMotion, RandomPartsFollowTheSeed) {
  const Motion a = builtinMotion("random", 5), b = builtinMotion("random", 5);
  const Motion c = builtinMotion("random", 6);
  ASSERT_EQ(a.keyframes.size(), b.keyframes.size());
  int random_keys = 0;
  for (const auto& key : a.keyframes) random_keys += key.random;
  EXPECT_GE(random_keys, 15);
  double differs = 0.0;
  for (double t = 1.0; t < 12.0; t += 0.1) {
    EXPECT_EQ((a.poseAt(t).toVector() - b.poseAt(t).toVector()).norm(), 0.0);
    differs = std::max(differs, (a.poseAt(t).toVector() - c.poseAt(t).toVector()).norm());
  }
  EXPECT_GT(differs, 0.5);
}

namespace {

// Parses `yaml` and returns the InputError message ("" if it parsed).
std::string motionError(const std::string& yaml) {
  try {
    parseMotion(yaml, "bad.yaml", handModel(), 1);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(StudioMotion, BadFilesAreRejectedNamingTheProblem) {
  const std::string key0 = "keyframes:\n  - {time: 0, position: [0, 0, 0.15]";
  struct Case {
    std::string yaml;
    std::vector<std::string> expected;
  };
  const std::vector<Case> cases{
      {"keyframes: [\n", {"motion bad.yaml:", "malformed YAML"}},
      {"duration: 3\n", {"key 'keyframes': missing"}},
      {key0 + ", joints: {index_pip_flexion: 10}}\n",
       {"bad.yaml:2: key 'keyframes[0].joints.index_pip_flexion'",
        "unknown joint 'index_pip_flexion'", "index_pip_flex"}},
      {key0 + ", joints: {index_pip_flex: 150}}\n",
       {"keyframe 1", "index_pip_flex = 150 deg", "outside its limits [-5, 110]"}},
      {key0 + "}\n  - {time: 0, position: [0, 0, 0.1]}\n",
       {"key 'keyframes[1].time'", "times must increase strictly"}},
      {key0 + ", orientation: [1, 2]}\n",
       {"key 'keyframes[0].orientation': must be a list of 3 numbers"}},
      {key0 + ", shape: fist}\n", {"unknown shape 'fist'"}},
      {key0 + ", speed: 3}\n", {"key 'keyframes[0].speed': unknown key"}},
      {key0 + "}\nduration: -1\n", {"key 'duration': must be positive"}},
      // A duration before the last keyframe: the keyframes after it were silently never shown.
      {key0 + "}\n  - {time: 3, position: [0, 0, 0.1]}\nduration: 2.5\n",
       {"motion bad.yaml:4: key 'duration': 2.5 s ends before the last keyframe's time 3 s "
        "(keyframes[1], line 3); the duration must be at least the last keyframe's time"}},
      {key0 + "}\ninterpolation: spline\n", {"key 'interpolation': must be 'cubic' or 'linear'"}},
      {"keyframes:\n  - {time: 0}\n", {"key 'keyframes[0].position': missing"}},
      {key0 + "}\nduration: 2\nrandom: {keyframes: {from: 1, to: 2, interval: 0, joints: 0.5}}\n",
       {"key 'random.keyframes.interval': must be positive"}},
      // Random keyframes after the end were silently never shown.
      {key0 + "}\nduration: 2\nrandom: {keyframes: {from: 1, to: 5, interval: 0.5}}\n",
       {"key 'random.keyframes.to': 5 s is after the motion's end at 2 s (its duration, or its "
        "last keyframe's time)"}},
      {key0 + "}\nduration: 2\nrandom: {jitter: {joints: abc}}\n",
       {"key 'random.jitter.joints': must be a number"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.yaml);
    const std::string message = motionError(c.yaml);
    ASSERT_FALSE(message.empty()) << "accepted";
    for (const std::string& part : c.expected) {
      EXPECT_NE(message.find(part), std::string::npos) << "message: " << message;
    }
  }
  EXPECT_THROW(loadMotion("/nonexistent/motion.yaml", handModel(), 1), InputError);
  EXPECT_EQ(resolveMotionPath("pinch", "/cfg"), "/cfg/motions/pinch.yaml");
  EXPECT_EQ(resolveMotionPath("my/own.yaml", "/cfg"), "my/own.yaml");
}
