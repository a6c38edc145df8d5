// evaluateRoomSequence: see room_evaluation.h.
#include "sag_hand_tracker/apps/room_evaluation.h"

#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sag_hand_tracker/studio/renderer.h"
#include "sag_hand_tracker/studio/sequence.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace studio {
namespace {

void writePng(const std::string& path, const cv::Mat& rgb) {
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  if (!cv::imwrite(path, bgr)) throw InputError("cannot write " + path);
}

// The image darkened where the mask is 0, with the tracked hand's outline (labels) in green.
cv::Mat maskOverlay(const cv::Mat& rgb, const cv::Mat& mask, const cv::Mat& labels) {
  cv::Mat out = rgb.clone();
  for (int y = 0; y < out.rows; ++y) {
    for (int x = 0; x < out.cols; ++x) {
      cv::Vec3b& p = out.at<cv::Vec3b>(y, x);
      if (!mask.empty() && mask.at<unsigned char>(y, x) == 0) p = p * 0.25;
    }
  }
  cv::Mat hand(labels.size(), CV_8UC1);
  for (int i = 0; i < static_cast<int>(labels.total()); ++i) {
    hand.data[i] = isTrackedHandLabel(labels.data[i]) ? 255 : 0;
  }
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(hand, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  cv::drawContours(out, contours, -1, cv::Scalar(0, 255, 0), 1);
  return out;
}

}  // namespace

std::vector<RoomRunResult> evaluateRoomSequence(const HandModel& render_model,
                                                const std::vector<Camera>& cameras,
                                                const Motion& motion, const RoomParams* room,
                                                const std::string& config_dir,
                                                const std::vector<RoomRunConfig>& configs,
                                                const RoomSequenceOptions& options) {
  SequenceParams params;
  params.frames = options.frames;
  params.empty_frames = options.empty_frames;
  params.seed = options.seed;
  params.shape = options.hand.shape;
  params.surface.skin = options.hand.skin;
  const StudioSequence sequence(render_model, motion, params);
  std::unique_ptr<StudioRoom> studio_room;
  StudioSceneParams scene;
  if (room != nullptr) {
    studio_room = std::make_unique<StudioRoom>(*room, sequence.shapedModel(), config_dir);
    scene = studio_room->scene(scene);
  }
  const StudioRenderer renderer(cameras, scene);

  std::vector<TrackingPipeline> pipelines;
  std::vector<RoomRunResult> results(configs.size());
  for (size_t k = 0; k < configs.size(); ++k) {
    pipelines.emplace_back(configs[k].model, cameras, configs[k].pipeline);
    results[k].label = configs[k].label;
  }

  for (int index = 0; index < sequence.frameCount(); ++index) {
    const StudioFrame frame = sequence.frame(index);
    auto subframes = sequence.surfaces(index);
    double gain = 1.0;
    if (studio_room) {
      studio_room->addProps(&subframes, frame.time);
      gain = studio_room->lightGain(frame.time);
    }
    const std::vector<StudioImage> images =
        renderer.render(subframes, sequence.noiseSeed(index), gain);
    FrameSet set;
    set.stamp_ns = static_cast<std::int64_t>(1000000000LL + index * 40000000LL);
    for (size_t c = 0; c < images.size(); ++c)
      set.images.push_back({static_cast<int>(c), images[c].rgb});
    const bool dump = !options.dump_prefix.empty() && index == options.dump_frame;
    if (dump) writePng(options.dump_prefix + "_image.png", images[options.dump_camera].rgb);

    for (size_t k = 0; k < configs.size(); ++k) {
      const ProcessedFrame processed = pipelines[k].process(set);
      if (processed.background) continue;
      RoomRunResult& result = results[k];
      const bool posed = processed.result.has_pose && processed.result.status != TrackStatus::kLost;
      if (!frame.hand_present) {
        ++result.empty_frames;
        result.empty_frames_posed += posed;
        continue;
      }
      ++result.frames;
      if (posed) {
        ++result.frames_posed;
        result.errors_mm.push_back(
            1000.0 * meanFingertipError(processed.result.fingertips, frame.fingertips));
      }
      for (size_t c = 0; c < images.size(); ++c) {
        const cv::Mat mask = pipelines[k].foregroundMask(static_cast<int>(c));
        const cv::Mat& labels = images[c].labels;
        for (int i = 0; i < static_cast<int>(labels.total()); ++i) {
          const bool hand = isTrackedHandLabel(labels.data[i]);
          const bool kept = mask.data[i] != 0;
          result.hand += hand;
          result.kept += kept;
          result.kept_hand += hand && kept;
        }
      }
      if (dump) {
        const int c = options.dump_camera;
        writePng(options.dump_prefix + "_" + std::to_string(k) + ".png",
                 maskOverlay(images[c].rgb, pipelines[k].foregroundMask(c), images[c].labels));
      }
    }
  }
  for (RoomRunResult& result : results) result.errors = summariseErrors(result.errors_mm);
  return results;
}

}  // namespace studio
}  // namespace sag_hand_tracker
