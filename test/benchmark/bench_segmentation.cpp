// Speed of the image-to-SoG segmentation (issue 3 target: <= 0.5 ms per 320x240 image, one core).
// One realistic 320x240 frame: textured desk scene, skin-coloured hand, black sleeve, and the
// shadow of hand and arm; the plate is learned from 10 frames without the hand.
#include <benchmark/benchmark.h>

#include "sag_hand_tracker/segmentation/quadtree_segmentation.h"
#include "test_support/segmentation_test_images.h"

namespace {

using namespace sag_hand_tracker;

const cv::Mat& benchmarkFrame() {
  static const cv::Mat frame = [] {
    sag_test::SceneOptions o;
    o.hand = o.sleeve = o.shadow = true;
    o.seed = 1234;
    return sag_test::scene(o);
  }();
  return frame;
}

ImageSegmenter makeSegmenter(SegmentationMode mode, bool refine_border_pixels) {
  SegmentationParams p;
  p.mode = mode;
  p.refine_border_pixels = refine_border_pixels;
  ImageSegmenter segmenter(p);
  if (mode == SegmentationMode::kPlate || mode == SegmentationMode::kPlateAndSkin) {
    for (unsigned seed = 0; seed < 10; ++seed) {
      segmenter.addBackgroundFrame(sag_test::backgroundFrame(seed));
    }
  }
  return segmenter;
}

void run(benchmark::State& state, SegmentationMode mode, bool refine_border_pixels = true) {
  const ImageSegmenter segmenter = makeSegmenter(mode, refine_border_pixels);
  const cv::Mat& frame = benchmarkFrame();
  std::size_t gaussians = 0;
  for (auto _ : state) {
    ImageSoG sog = segmenter.segment(frame);
    gaussians = sog.gaussians.size();
    benchmark::DoNotOptimize(sog);
  }
  state.counters["gaussians"] = static_cast<double>(gaussians);
}

// The whole image (no background removal): the paper's image SoG.
void SegmentQuadtreeNoBackgroundRemoval(benchmark::State& state) {
  run(state, SegmentationMode::kNone);
}
BENCHMARK(SegmentQuadtreeNoBackgroundRemoval)->Unit(benchmark::kMicrosecond);

void SegmentWithBackgroundPlate(benchmark::State& state) { run(state, SegmentationMode::kPlate); }
BENCHMARK(SegmentWithBackgroundPlate)->Unit(benchmark::kMicrosecond);

void SegmentWithPlateAndSkinGate(benchmark::State& state) {
  run(state, SegmentationMode::kPlateAndSkin);
}
BENCHMARK(SegmentWithPlateAndSkinGate)->Unit(benchmark::kMicrosecond);

void SegmentWithSkinGateOnly(benchmark::State& state) { run(state, SegmentationMode::kSkin); }
BENCHMARK(SegmentWithSkinGateOnly)->Unit(benchmark::kMicrosecond);

// The same with whole border cells (refine_border_pixels off): what the pixel test costs.
void SegmentWithSkinGateOnlyWholeCells(benchmark::State& state) {
  run(state, SegmentationMode::kSkin, false);
}
BENCHMARK(SegmentWithSkinGateOnlyWholeCells)->Unit(benchmark::kMicrosecond);

// Learning: the cost of one addBackgroundFrame.
void SegmentAddBackgroundFrame(benchmark::State& state) {
  ImageSegmenter segmenter;
  const cv::Mat frame = sag_test::backgroundFrame(0);
  for (auto _ : state) segmenter.addBackgroundFrame(frame);
}
BENCHMARK(SegmentAddBackgroundFrame)->Unit(benchmark::kMicrosecond);

}  // namespace
