// One energy + gradient evaluation: 17 model Gaussians (SAG) or 30 (SoG), 5 cameras, 500 image
// Gaussians per camera, all colour-compatible (the worst case), placed over the hand's
// projection as a foreground segmentation would.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <random>

#include "sag_hand_tracker/energy/hand_projection.h"
#include "sag_hand_tracker/energy/overlap.h"
#include "sag_hand_tracker/energy/silhouette.h"
#include "sag_hand_tracker/optimization/optimizer.h"
#include "sag_hand_tracker/tracking/tracker.h"
#include "test_support/synthetic_scene.h"

using namespace sag_hand_tracker;
using namespace sag_test;

namespace {

std::vector<CameraObservation> worstCaseObservations(const HandModel& model, const Pose& pose,
                                                     int per_camera) {
  std::vector<CameraObservation> observations;
  std::mt19937 rng(1);
  for (const Camera& camera : fiveCameraRig()) {
    // The bounding box of the projected hand.
    Eigen::Vector2d low(1e9, 1e9), high(-1e9, -1e9);
    for (const WorldGaussian& g : forwardKinematics(model, pose).gaussians) {
      Eigen::Vector2d pixel;
      if (camera.project(g.mean, &pixel)) {
        low = low.cwiseMin(pixel);
        high = high.cwiseMax(pixel);
      }
    }
    low -= Eigen::Vector2d(10, 10);
    high += Eigen::Vector2d(10, 10);
    std::uniform_real_distribution<double> x(low.x(), high.x()), y(low.y(), high.y()),
        sigma(1.0, 4.0);
    ImageSoG sog;
    sog.width = camera.width;
    sog.height = camera.height;
    for (int i = 0; i < per_camera; ++i) {
      sog.gaussians.push_back(
          {Eigen::Vector2d(x(rng), y(rng)), sigma(rng), model.gaussians[0].hsv});
    }
    observations.push_back({camera, sog});
  }
  return observations;
}

void energyBenchmark(benchmark::State& state, const std::string& model_name, bool with_gradient) {
  const HandModel model = loadHandModel(modelPath(model_name));
  const Pose pose = typicalPose(model);
  PoseEnergy energy(model, EnergyParams());
  energy.setFrame(worstCaseObservations(model, pose, static_cast<int>(state.range(0))));
  PoseVector gradient;
  for (auto _ : state) {
    benchmark::DoNotOptimize(energy.evaluate(pose, with_gradient ? &gradient : nullptr));
  }
  state.counters["image_gaussians_per_camera"] = static_cast<double>(state.range(0));
}

// The curled-hand refinement's evaluation (TrackerParams::curled_refine_*): a fist, scored with
// occlusion (the soft depth order over every pair of Gaussians that may hide each other) and the
// model's area.
void BM_EnergyGradientSagOccludedFist(benchmark::State& state) {
  const HandModel model = loadHandModel(modelPath("sag"));
  Pose pose = typicalPose(model);
  for (const LongFingerJoints& finger : longFingerJoints(model)) {
    pose.joints[finger.mcp_flex] = 1.3;
    pose.joints[finger.pip_flex] = 1.6;
  }
  const TrackerParams tracker;
  EnergyParams params;
  params.occlusion_depth_scale = tracker.curled_refine_occlusion_depth_scale;
  params.model_area_weight = tracker.curled_refine_model_area_weight;
  PoseEnergy energy(model, params);
  energy.setFrame(worstCaseObservations(model, pose, static_cast<int>(state.range(0))));
  PoseVector gradient;
  for (auto _ : state) benchmark::DoNotOptimize(energy.evaluate(pose, &gradient));
  state.counters["image_gaussians_per_camera"] = static_cast<double>(state.range(0));
}

// One model Gaussian's overlap row (overlapRow) over a column of image Gaussians that are all in
// its x range (overlapRange) but mostly beyond max_mahalanobis_sq in y: a finger across the
// image of a bare forearm. The far pairs must cost what the near ones do (overlapValue clamps
// the exponent; an exp that underflows takes glibc's scalar path lane by lane).
void BM_OverlapRowFarPairs(benchmark::State& state) {
  ProjectedGaussian finger;
  finger.mean = Eigen::Vector2d(160.0, 120.0);
  finger.cov << 16.0, 0.0, 0.0, 16.0;
  finger.valid = true;
  const OverlapTerm term = prepareOverlapTerm(finger);
  ImageGaussianArrays column;
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> x(150.0f, 170.0f), y(0.0f, 240.0f);
  const int count = static_cast<int>(state.range(0));
  for (int i = 0; i < count; ++i) {
    column.mean_x.push_back(x(rng));
    column.mean_y.push_back(y(rng));
    column.variance.push_back(4.0f);
    column.self_overlap.push_back(2.0 * M_PI * 4.0);
  }
  std::sort(column.mean_x.begin(), column.mean_x.end());
  column.max_variance = 4.0;
  const double max_mahalanobis_sq = EnergyParams().max_mahalanobis_sq;
  const OverlapRange range = overlapRange(term, column, max_mahalanobis_sq);
  const std::vector<float> weights(count, 1.0f);
  std::vector<float> row(count, 0.0f);
  for (auto _ : state) {
    overlapRow(term, column, range, weights.data(), max_mahalanobis_sq, row.data());
    benchmark::DoNotOptimize(row.data());
    benchmark::ClobberMemory();
  }
  state.counters["pairs_in_range"] = range.end - range.begin;
}

void BM_EnergyGradientSag(benchmark::State& state) { energyBenchmark(state, "sag", true); }
void BM_EnergyGradientSog(benchmark::State& state) { energyBenchmark(state, "sog", true); }
void BM_EnergyOnlySag(benchmark::State& state) { energyBenchmark(state, "sag", false); }

// One frame of tracking: setFrame (colour table) + N iterations (the paper's 10, the default 20),
// 5 cameras.
void BM_OptimizeFrameSag(benchmark::State& state) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const Pose pose = typicalPose(model);
  const auto observations = worstCaseObservations(model, pose, static_cast<int>(state.range(0)));
  PoseEnergy energy(model, EnergyParams());
  OptimizerParams params;
  params.iterations = static_cast<int>(state.range(1));
  for (auto _ : state) {
    energy.setFrame(observations);
    benchmark::DoNotOptimize(optimizePose(energy, pose, params).energy);
  }
}

// The finger toggles' silhouette score of one pose (TrackerParams::toggle_silhouette_sigmas):
// the model's ellipses filled in 5 cameras, then the Dice against each camera's foreground.
void BM_SilhouetteScore(benchmark::State& state) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const Pose pose = typicalPose(model);
  const auto observations = modelObservations(model, pose, fiveCameraRig(), 4.0);
  SilhouetteScorer scorer(observations, TrackerParams().toggle_silhouette_sigmas,
                          kSleeveChargedAsBackground);
  for (auto _ : state) benchmark::DoNotOptimize(scorer.score(model, pose));
}

// One ellipse of a finger (30 x 12 pixels) or of the palm (70 x 50) filled row by row
// (fillEllipse, arg 0) and by cv::ellipse's polygon (arg 1), which the silhouettes used before.
void BM_FillEllipse(benchmark::State& state) {
  const cv::RotatedRect box(
      cv::Point2f(160.3f, 120.6f),
      state.range(0) == 0 ? cv::Size2f(30.0f, 12.0f) : cv::Size2f(70.0f, 50.0f), 33.0f);
  cv::Mat mask(240, 320, CV_8UC1, cv::Scalar(0));
  for (auto _ : state) {
    if (state.range(1) == 0) {
      benchmark::DoNotOptimize(fillEllipse(box, &mask));
    } else {
      cv::ellipse(mask, box, cv::Scalar(255), cv::FILLED);
    }
    benchmark::ClobberMemory();
  }
}

}  // namespace

BENCHMARK(BM_SilhouetteScore)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_FillEllipse)
    ->ArgNames({"palm", "opencv"})
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({1, 0})
    ->Args({1, 1})
    ->Unit(benchmark::kNanosecond);
BENCHMARK(BM_EnergyGradientSag)->Arg(500)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EnergyGradientSog)->Arg(500)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EnergyOnlySag)->Arg(500)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EnergyGradientSagOccludedFist)->Arg(500)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_OverlapRowFarPairs)->Arg(512)->Unit(benchmark::kNanosecond);
BENCHMARK(BM_OptimizeFrameSag)
    ->ArgNames({"image_gaussians", "iterations"})
    ->Args({500, 10})
    ->Args({500, 20})
    ->Unit(benchmark::kMillisecond);
