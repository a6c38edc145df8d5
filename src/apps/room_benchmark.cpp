// runRoomBenchmark: see room_benchmark.h.
#include "sag_hand_tracker/apps/room_benchmark.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>

#include "sag_hand_tracker/apps/render_runner.h"
#include "sag_hand_tracker/apps/room_evaluation.h"
#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/ros/package_config.h"
#include "sag_hand_tracker/studio/sequence.h"
#include "sag_hand_tracker/util/number_text.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace {

namespace fs = std::filesystem;

// The mean error, or NaN (printed "-") when the tracker had no pose in any frame.
double meanError(const studio::RoomRunResult& r) {
  return r.errors_mm.empty() ? NAN : r.errors.mean_mm;
}

std::string modelLabel(const std::string& model) {
  if (model == "sag") return "SAG";
  if (model == "sog") return "SoG";
  return fs::path(model).stem().string();
}

struct Row {
  std::string sequence;
  std::string hand;
  std::string room;
  std::string segmentation;  // skin / plate
  bool cues = false;
  std::string model;
  studio::RoomRunResult result;
};

struct TrackedModel {
  std::string label;
  HandModel model;
  bool skin_gate_from_model = true;
};

// The rows of one hand, model, run and room pooled over the sequences: precision and recall over
// all their pixels, the error over all their posed frames.
struct Pooled {
  studio::RoomRunResult result;
  double error_sum_mm = 0.0;
  double meanError() const {
    return result.frames_posed > 0 ? error_sum_mm / result.frames_posed : NAN;
  }
  void add(const studio::RoomRunResult& r) {
    result.frames += r.frames;
    result.frames_posed += r.frames_posed;
    result.kept += r.kept;
    result.kept_hand += r.kept_hand;
    result.hand += r.hand;
    for (const double e : r.errors_mm) error_sum_mm += e;
  }
};

std::string runLabel(const Row& row) {
  return row.model + ", " + row.segmentation + (row.cues ? " + cues" : "");
}

// With more than one hand: per hand, run and room, pooled over the sequences, against the same
// hand and run in the clean studio.
void writePerHandTable(const std::vector<Row>& rows, const std::vector<std::string>& rooms,
                       std::ostream& md) {
  std::vector<std::string> hands, runs;
  std::map<std::string, Pooled> pooled;  // hand|run|room
  for (const Row& row : rows) {
    if (std::find(hands.begin(), hands.end(), row.hand) == hands.end()) hands.push_back(row.hand);
    if (std::find(runs.begin(), runs.end(), runLabel(row)) == runs.end())
      runs.push_back(runLabel(row));
    pooled[row.hand + "|" + runLabel(row) + "|" + row.room].add(row.result);
  }
  if (hands.size() < 2) return;
  md << "\n## Per hand, pooled over the sequences\n\n"
     << "Precision % / fingertip error mm (× the same hand and run in the clean studio); `-`: no "
        "pose, or the run does not apply to the room (the plate needs hand-free frames).\n\n"
     << "| hand | run |";
  for (const std::string& room : rooms) md << " " << room << " |";
  md << "\n|---|---|";
  for (size_t i = 0; i < rooms.size(); ++i) md << "---:|";
  md << "\n";
  for (const std::string& hand : hands) {
    for (const std::string& run : runs) {
      const auto clean = pooled.find(hand + "|" + run + "|clean");
      const double clean_error = clean != pooled.end() ? clean->second.meanError() : NAN;
      md << "| " << hand << " | " << run << " |";
      for (const std::string& room : rooms) {
        const auto cell = pooled.find(hand + "|" + run + "|" + room);
        if (cell == pooled.end() || cell->second.result.frames_posed == 0) {
          md << " - |";
          continue;
        }
        const double error = cell->second.meanError();
        md << " " << fixedNumber(100.0 * cell->second.result.precision(), 1) << " / "
           << fixedNumber(error, 1);
        if (room != "clean" && std::isfinite(clean_error) && clean_error > 0.0)
          md << " (" << fixedNumber(error / clean_error, 2) << "×)";
        md << " |";
      }
      md << "\n";
    }
  }
}

}  // namespace

std::string runRoomBenchmark(const BenchmarkOptions& options, const std::vector<RoomHand>& hands,
                             std::ostream& log) {
  const std::string config = packageConfigDir(options.config_dir);
  const CameraRig rig = loadCameraRig(studio::resolveRigPath(options.rig, config));
  const HandModel render_model = loadHandModel(resolveModelPath("sag", config));
  std::vector<TrackedModel> base_models;
  for (const std::string& model : options.models) {
    base_models.push_back({modelLabel(model), loadHandModel(resolveModelPath(model, config))});
  }
  std::vector<std::vector<TrackedModel>> models_of_hand;
  for (const RoomHand& hand : hands) {
    models_of_hand.push_back(base_models);
    if (hand.fitted_model.empty()) continue;
    const HandModel fitted = loadHandModel(hand.fitted_model);
    models_of_hand.back().push_back({"SAG fitted", fitted, true});
    models_of_hand.back().push_back({"SAG fitted (generic gate)", fitted, false});
  }
  std::vector<std::string> rooms{""};  // "" = the clean studio
  for (const std::string& room : options.rooms) {
    if (room == "all") {
      for (const std::string& name : studio::builtinRoomNames()) rooms.push_back(name);
    } else {
      studio::builtinRoom(room);  // throws for an unknown name
      rooms.push_back(room);
    }
  }
  const fs::path dir(options.out_dir);
  fs::create_directories(dir / "rooms");

  std::vector<Row> rows;
  for (const std::string& sequence_name : options.sequences) {
    const std::string sequence_stem = fs::path(sequence_name).stem().string();
    const studio::Motion motion =
        studio::loadMotion(studio::resolveMotionPath(sequence_name, config), render_model, 1);
    for (size_t h = 0; h < hands.size(); ++h) {
      const studio::StudioHand& hand = hands[h].hand;
      // The default hand's runs keep their names of before --shapes.
      const std::string run_stem =
          sequence_stem + (hand.name == "default" ? std::string() : "_" + hand.name);
      for (const std::string& room_name : rooms) {
        const auto start = std::chrono::steady_clock::now();
        const std::string room_label = room_name.empty() ? "clean" : room_name;
        studio::RoomParams room;
        if (!room_name.empty()) room = studio::builtinRoom(room_name);
        const bool hand_free = room_name.empty() || room.hand_free_frames;
        std::vector<studio::RoomRunConfig> configs;
        std::vector<Row> pending;
        for (const TrackedModel& tracked : models_of_hand[h]) {
          for (const std::string segmentation : {"skin", "plate"}) {
            if (segmentation == std::string("plate") && !hand_free) continue;
            for (const bool cues : {false, true}) {
              const std::string run_name = segmentation + (cues ? "+cues" : "");
              if (std::find(options.room_configs.begin(), options.room_configs.end(), run_name) ==
                  options.room_configs.end()) {
                continue;
              }
              studio::RoomRunConfig run;
              run.model = tracked.model;
              run.pipeline.skin_gate_from_model = tracked.skin_gate_from_model;
              run.pipeline.tracker.optimizer.iterations = options.iterations;
              run.pipeline.segmentation.room.enabled = cues;
              if (segmentation == std::string("skin")) {
                run.pipeline.segmentation.mode = SegmentationMode::kSkin;
                run.pipeline.background_frames = 0;
              } else {
                run.pipeline.segmentation.mode = SegmentationMode::kPlate;
                run.pipeline.background_frames = 10;
              }
              run.label = tracked.label + " " + segmentation + (cues ? " + room cues" : "");
              configs.push_back(run);
              pending.push_back(
                  {sequence_stem, hand.name, room_label, segmentation, cues, tracked.label, {}});
            }
          }
        }
        studio::RoomSequenceOptions run_options;
        run_options.frames = options.frames;
        run_options.empty_frames = hand_free ? 10 : 0;
        run_options.hand = hand;
        run_options.dump_prefix = (dir / "rooms" / (run_stem + "_" + room_label)).string();
        run_options.dump_frame = run_options.empty_frames + 40;
        run_options.dump_camera = 0;
        const auto results = studio::evaluateRoomSequence(render_model, rig.cameras, motion,
                                                          room_name.empty() ? nullptr : &room,
                                                          config, configs, run_options);
        for (size_t k = 0; k < results.size(); ++k) {
          pending[k].result = results[k];
          rows.push_back(pending[k]);
          const studio::RoomRunResult& r = results[k];
          log << "benchmark --rooms: " << sequence_stem << " " << hand.name << " " << room_label
              << " [" << k << "] " << r.label << ": precision "
              << fixedNumber(100.0 * r.precision(), 1) << " %, recall "
              << fixedNumber(100.0 * r.recall(), 1) << " %, error " << fixedNumber(meanError(r), 1)
              << " mm over " << r.frames_posed << "/" << r.frames << " frames\n"
              << std::flush;
        }
        log << "benchmark --rooms: " << sequence_stem << " " << hand.name << " " << room_label
            << " took "
            << fixedNumber(
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                   1)
            << " s\n"
            << std::flush;
      }
    }
  }

  // The clean studio's error of the same sequence, hand, model and segmentation (with cues as the
  // run).
  std::map<std::string, double> clean_error;
  auto key = [](const Row& row) {
    return row.sequence + "|" + row.hand + "|" + row.model + "|" + row.segmentation + "|" +
           (row.cues ? "1" : "0");
  };
  for (const Row& row : rows) {
    if (row.room == "clean") clean_error[key(row)] = meanError(row.result);
  }
  std::ostringstream md;
  md << "# Studio rooms: foreground and tracking (benchmark --rooms)\n\n"
     << "Precision: kept foreground pixels that belong to the tracked hand (palm, fingers, bare "
        "wrist); recall: hand pixels kept; over all cameras and frames with the hand. Error: mean "
        "fingertip error over the frames with a pose; `posed` counts them; `vs clean`: the error "
        "relative to the same sequence, hand, model and segmentation in the clean studio. Hands: "
     <<
      [&] {
        std::string names;
        for (const RoomHand& hand : hands) {
          names += (names.empty() ? "" : "; ") + hand.hand.name;
          if (!hand.hand.description.empty()) names += " (" + hand.hand.description + ")";
        }
        return names;
      }()
     << ".\n\n"
     << "| sequence | hand | room | model | segmentation | room cues | precision % | recall % | "
        "posed | error mm | sd mm | vs clean |\n"
     << "|---|---|---|---|---|---|---:|---:|---:|---:|---:|---:|\n";
  std::ostringstream csv;
  csv << "sequence,hand,room,model,segmentation,room_cues,precision,recall,frames,frames_posed,"
         "error_mean_mm,error_sd_mm\n";
  for (const Row& row : rows) {
    const studio::RoomRunResult& r = row.result;
    const auto clean = clean_error.find(key(row));
    const double ratio =
        clean != clean_error.end() && row.room != "clean" ? meanError(r) / clean->second : NAN;
    md << "| " << row.sequence << " | " << row.hand << " | " << row.room << " | " << row.model
       << " | " << row.segmentation << " | " << (row.cues ? "yes" : "no") << " | "
       << fixedNumber(100.0 * r.precision(), 1) << " | " << fixedNumber(100.0 * r.recall(), 1)
       << " | " << r.frames_posed << "/" << r.frames << " | " << fixedNumber(meanError(r), 1)
       << " | " << fixedNumber(r.errors_mm.empty() ? NAN : r.errors.sd_mm, 1) << " | "
       << (std::isfinite(ratio) ? fixedNumber(ratio, 2) : "-") << " |\n";
    csv << row.sequence << "," << row.hand << "," << row.room << "," << row.model << ","
        << row.segmentation << "," << (row.cues ? 1 : 0) << "," << fixedNumber(r.precision(), 4)
        << "," << fixedNumber(r.recall(), 4) << "," << r.frames << "," << r.frames_posed << ","
        << fixedNumber(meanError(r), 2) << ","
        << fixedNumber(r.errors_mm.empty() ? NAN : r.errors.sd_mm, 2) << "\n";
  }
  std::vector<std::string> room_labels;
  for (const std::string& room : rooms) room_labels.push_back(room.empty() ? "clean" : room);
  writePerHandTable(rows, room_labels, md);
  writeOutputFile((dir / "rooms.csv").string(), csv.str());
  writeOutputFile((dir / "rooms.md").string(), md.str());
  return md.str();
}

}  // namespace sag_hand_tracker
