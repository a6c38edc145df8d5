// benchmark: the paper's evaluation (section 5) on the synthetic studio, SAG against SoG, in one
// run: renders the sequences with render_bag's code, tracks them with track_bag's code, prints
// the fingertip error per sequence, Table 1, the speed and (--camera-counts) Figure 6, and writes
// them as Markdown, CSV and PNG (see --help and benchmark.h).
//
//   rosrun sag_hand_tracker benchmark [--sequences a,b,..] [--camera-counts] [--frames N]
//       [--out-dir DIR] [--csv FILE] [--rig dexter5] [--iterations N] [--models sag,sog]
//       [--reuse|--rerender] [--fitted [--routine-frames N] [--fit-sequence NAME]]
//
// --fitted: per hand shape, the model fitted to the calibration routine on that hand
// (calibrate_hand's code; --fit-sequence: to the first --routine-frames of another motion) is
// tracked too, beside the default model (evaluation.h).
//
// Exit status: 0 done; 1 bad input (one-line message on stderr); 2 bad command line.
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "sag_hand_tracker/apps/evaluation.h"
#include "sag_hand_tracker/util/types.h"

int main(int argc, char** argv) {
  using namespace sag_hand_tracker;
  BenchmarkOptions options;
  try {
    options = parseBenchmarkArguments(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const UsageError& error) {
    std::cerr << "benchmark: " << error.what() << "\nRun 'benchmark --help' for the options.\n";
    return 2;
  }
  if (options.help) {
    std::cout << benchmarkUsage();
    return 0;
  }
  try {
    const BenchmarkResults results = runBenchmark(options, std::cerr);
    std::cout << results.markdown;
    char seconds[32];
    std::snprintf(seconds, sizeof(seconds), "%.1f", results.seconds);
    if (!options.rooms.empty()) {
      // The rooms write their own files (runRoomBenchmark), not the bags' tables.
      std::cout << "benchmark: the rooms in " << seconds << " s; results in " << options.out_dir
                << "/ (rooms.md, rooms.csv, rooms/" << (options.fitted ? ", models/" : "") << ")\n";
      return 0;
    }
    std::cout << "benchmark: " << results.runs.size() + results.camera_runs.size()
              << " tracking runs in " << seconds << " s; results in " << options.out_dir
              << "/ (results.md, " << (options.csv.empty() ? "results.csv" : options.csv)
              << (options.camera_counts ? ", camera_counts.csv, camera_combinations.csv" : "")
              << (options.fitted ? ", fitted.csv, models/" : "")
              << (options.plots ? ", error_per_frame.png, orientation_per_frame.png" : "")
              << (options.plots && results.shapes.size() > 1 ? ", shapes.png" : "")
              << (options.plots && options.camera_counts ? ", camera_counts.png" : "") << ")\n";
    return 0;
  } catch (const std::exception& error) {
    std::cerr << "benchmark: error: " << error.what() << "\n";
  }
  return 1;
}
