// runBenchmark: see benchmark.h.
#include "sag_hand_tracker/ros/benchmark.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "sag_hand_tracker/atomic_output.h"
#include "sag_hand_tracker/csv.h"
#include "sag_hand_tracker/metrics.h"
#include "sag_hand_tracker/plot.h"
#include "sag_hand_tracker/ros/bag_input.h"
#include "sag_hand_tracker/ros/render_studio_bag.h"
#include "sag_hand_tracker/types.h"

namespace sag_hand_tracker {
namespace {

// A whole text output, written next to `path` and renamed there (atomic_output.h).
void writeOutputFile(const std::string& path, const std::string& text) {
  AtomicOutputFile file(path);
  {
    std::ofstream out(file.tempPath(), std::ios::binary | std::ios::trunc);
    out << text;
    out.close();
    if (!out) throw InputError("cannot write '" + path + "'");
  }
  file.commit();
}

namespace fs = std::filesystem;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string fixed(double value, int decimals) {
  if (std::isnan(value)) return "-";
  if (std::isinf(value)) return "inf";
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

std::string trackerLabel(const std::string& model) {
  if (model == "sag" || model == "sog") return model;
  return fs::path(model).stem().string();
}

std::string displayName(const std::string& tracker) {
  if (tracker == "sag") return "SAG";
  if (tracker == "sog") return "SoG";
  return tracker;
}

std::string cameraList(const std::vector<int>& cameras) {
  std::string text;
  for (int c : cameras) text += (text.empty() ? "" : ",") + std::to_string(c);
  return text.empty() ? "all" : text;
}

// ---- bags ---------------------------------------------------------------------------------------

struct SequenceBag {
  std::string name;
  std::string bag;
  std::string gt_csv;
};

// What a bag was rendered with; a bag is reused only when this matches.
std::string renderStamp(const RenderBagOptions& render) {
  std::ostringstream out;
  out << "sequence " << render.sequence << "\nrig " << render.rig << "\nframes " << render.frames
      << "\nseed " << render.seed << "\nfps " << render.fps << "\n";
  return out.str();
}

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

SequenceBag prepareBag(const BenchmarkOptions& options, const std::string& sequence,
                       std::ostream& log) {
  const fs::path dir = fs::path(options.out_dir) / "bags";
  fs::create_directories(dir);
  const std::string stem = fs::path(sequence).stem().string();
  SequenceBag bag{stem, (dir / (stem + ".bag")).string(), (dir / (stem + "_gt.csv")).string()};
  const std::string stamp_path = (dir / (stem + ".render.txt")).string();

  RenderBagOptions render;
  render.sequence = sequence;
  render.rig = options.rig;
  render.out = bag.bag;
  render.gt_csv = bag.gt_csv;
  render.config_dir = options.config_dir;
  render.frames = options.frames;
  render.quiet = true;
  const std::string stamp = renderStamp(render);
  if (!options.rerender && fs::exists(bag.bag) && fs::exists(bag.gt_csv) &&
      fs::exists(stamp_path) && readFile(stamp_path) == stamp) {
    log << "benchmark: reusing " << bag.bag << "\n" << std::flush;
    return bag;
  }
  fs::remove(stamp_path);
  const RenderBagSummary summary = renderStudioBag(render, nullptr);
  writeOutputFile(stamp_path, stamp);
  log << "benchmark: rendered " << summary.sequence << ": " << summary.frames << " frames x "
      << summary.cameras << " cameras in " << fixed(summary.total_seconds, 1) << " s -> " << bag.bag
      << "\n"
      << std::flush;
  return bag;
}

// ---- one run ------------------------------------------------------------------------------------

BenchmarkRun trackRun(const BenchmarkOptions& options, const SequenceBag& bag,
                      const std::string& model, const std::vector<int>& cameras,
                      const std::string& out_csv) {
  TrackBagOptions track;
  track.bag = bag.bag;
  track.out = out_csv;
  track.model = model;
  track.iterations = options.iterations;
  track.cameras = cameras;
  track.config_dir = options.config_dir;
  track.quiet = true;
  const TrackBagSummary summary = trackBag(track, nullptr, nullptr);

  BenchmarkRun run;
  run.sequence = bag.name;
  run.tracker = trackerLabel(model);
  run.cameras = cameras;
  // No CSV when nothing was tracked (and an old one at out_csv is not this run's).
  run.errors = matchToGroundTruth(bag.gt_csv, summary.csv_written ? out_csv : "");
  run.stats = errorStats(run.errors.errors_mm);
  run.fps = summary.pipelineFps();
  run.pipeline_frames = summary.frames - summary.background_frames;
  run.pipeline_seconds = summary.pipeline_seconds;
  run.segmentation_seconds = summary.segmentation_seconds;
  run.tracking_seconds = summary.tracking_seconds;
  return run;
}

std::string runLine(const BenchmarkRun& run) {
  std::ostringstream out;
  out << run.sequence << " " << run.tracker << " (cameras " << cameraList(run.cameras)
      << "): " << fixed(run.stats.mean_mm, 1) << " mm mean, " << run.stats.failed << "/"
      << run.stats.frames << " failed, " << fixed(run.fps, 0) << " fps";
  return out.str();
}

// ---- aggregation --------------------------------------------------------------------------------

struct Pooled {
  ErrorStats stats;
  double fps = 0.0;
  double segmentation_ms = 0.0;
  double tracking_ms = 0.0;
  int runs = 0;
};

Pooled pool(const std::vector<const BenchmarkRun*>& runs) {
  Pooled pooled;
  std::vector<double> errors;
  int frames = 0;
  double seconds = 0.0, segmentation = 0.0, tracking = 0.0;
  for (const BenchmarkRun* run : runs) {
    errors.insert(errors.end(), run->errors.errors_mm.begin(), run->errors.errors_mm.end());
    frames += run->pipeline_frames;
    seconds += run->pipeline_seconds;
    segmentation += run->segmentation_seconds;
    tracking += run->tracking_seconds;
  }
  pooled.stats = errorStats(errors);
  pooled.fps = seconds > 0.0 ? frames / seconds : 0.0;
  pooled.segmentation_ms = frames > 0 ? 1e3 * segmentation / frames : 0.0;
  pooled.tracking_ms = frames > 0 ? 1e3 * tracking / frames : 0.0;
  pooled.runs = static_cast<int>(runs.size());
  return pooled;
}

template <typename Predicate>
std::vector<const BenchmarkRun*> select(const std::vector<BenchmarkRun>& runs,
                                        Predicate predicate) {
  std::vector<const BenchmarkRun*> selected;
  for (const BenchmarkRun& run : runs) {
    if (predicate(run)) selected.push_back(&run);
  }
  return selected;
}

// Every combination of `k` of `n` cameras, in lexicographic order.
std::vector<std::vector<int>> combinations(int n, int k) {
  std::vector<std::vector<int>> result;
  std::vector<int> current;
  std::function<void(int)> recurse = [&](int first) {
    if (static_cast<int>(current.size()) == k) {
      result.push_back(current);
      return;
    }
    for (int c = first; c < n; ++c) {
      current.push_back(c);
      recurse(c + 1);
      current.pop_back();
    }
  };
  recurse(0);
  return result;
}

// ---- report -------------------------------------------------------------------------------------

std::string markdownRow(const std::vector<std::string>& cells) {
  std::string row = "|";
  for (const std::string& cell : cells) row += " " + cell + " |";
  return row + "\n";
}

std::string markdownRule(size_t columns) {
  std::string row = "|";
  for (size_t i = 0; i < columns; ++i) row += (i == 0 ? "---|" : "---:|");
  return row + "\n";
}

std::string report(const BenchmarkOptions& options, const BenchmarkResults& results,
                   const std::map<int, int>& combinations_per_count) {
  std::ostringstream md;
  const auto& trackers = results.trackers;
  md << "# Benchmark: SAG against SoG on the synthetic studio\n\n";
  md << "Rig `" << options.rig << "` (" << results.rig_cameras << " cameras), "
     << options.iterations << " optimiser iterations per frame, "
     << (options.frames > 0 ? std::to_string(options.frames) + " frames per sequence"
                            : std::string("full-length sequences"))
     << ". Error: mean over the 5 fingertips per frame (mm), against the rendered ground truth. "
        "A frame without a pose (before the start, or lost) is a failed frame: left out of the "
        "mean and sd, counted against every bound of Table 1.\n\n";

  // Error table.
  md << "## Fingertip error per sequence (mm)\n\n";
  std::vector<std::string> header{"sequence", "frames"};
  for (const std::string& t : trackers) {
    header.push_back(displayName(t) + " mean");
    header.push_back(displayName(t) + " sd");
    header.push_back(displayName(t) + " failed");
  }
  md << markdownRow(header) << markdownRule(header.size());
  auto errorCells = [&](const std::string& label, const std::vector<std::string>& sequences) {
    std::vector<std::string> cells{label, ""};
    for (const std::string& t : trackers) {
      const Pooled p = pool(select(results.runs, [&](const BenchmarkRun& r) {
        return r.tracker == t &&
               std::find(sequences.begin(), sequences.end(), r.sequence) != sequences.end();
      }));
      cells[1] = std::to_string(p.stats.frames);
      cells.push_back(fixed(p.stats.mean_mm, 1));
      cells.push_back(fixed(p.stats.sd_mm, 1));
      cells.push_back(std::to_string(p.stats.failed));
    }
    return cells;
  };
  for (const std::string& s : results.sequences) md << markdownRow(errorCells(s, {s}));
  md << markdownRow(errorCells("**all**", results.sequences));
  md << "\n(**all**: over every frame of every sequence.)\n\n";

  // Table 1: rows = bounds, columns = sequence x tracker (SoG beside SAG as in the paper).
  std::vector<std::string> ordered = trackers;
  std::stable_sort(ordered.begin(), ordered.end(), [](const std::string& a, const std::string& b) {
    return (a == "sog" ? 0 : a == "sag" ? 1 : 2) < (b == "sog" ? 0 : b == "sag" ? 1 : 2);
  });
  md << "## Table 1: % of frames with an error below x mm\n\n";
  std::vector<std::string> t1{"x (mm)"};
  for (const std::string& s : results.sequences) {
    for (const std::string& t : ordered) t1.push_back(s + " " + displayName(t));
  }
  md << markdownRow(t1) << markdownRule(t1.size());
  for (size_t b = 0; b < errorBoundsMm().size(); ++b) {
    std::vector<std::string> cells{fixed(errorBoundsMm()[b], 0)};
    for (const std::string& s : results.sequences) {
      for (const std::string& t : ordered) {
        const Pooled p = pool(select(results.runs, [&](const BenchmarkRun& r) {
          return r.tracker == t && r.sequence == s;
        }));
        cells.push_back(fixed(p.stats.percent_below[b], 1));
      }
    }
    md << markdownRow(cells);
  }
  md << "\n";

  // Speed.
  md << "## Speed (frames per second, single thread; segmentation + optimisation, decode "
        "excluded)\n\n";
  std::vector<std::string> sh{"sequence"};
  for (const std::string& t : trackers) sh.push_back(displayName(t) + " fps");
  md << markdownRow(sh) << markdownRule(sh.size());
  for (const std::string& s : results.sequences) {
    std::vector<std::string> cells{s};
    for (const std::string& t : trackers) {
      cells.push_back(fixed(
          pool(select(results.runs,
                      [&](const BenchmarkRun& r) { return r.tracker == t && r.sequence == s; }))
              .fps,
          0));
    }
    md << markdownRow(cells);
  }
  std::vector<std::string> all_cells{"**all**"};
  std::ostringstream per_frame;
  for (const std::string& t : trackers) {
    const Pooled p =
        pool(select(results.runs, [&](const BenchmarkRun& r) { return r.tracker == t; }));
    all_cells.push_back(fixed(p.fps, 0));
    per_frame << (per_frame.tellp() > 0 ? "; " : "") << displayName(t) << ": segmentation "
              << fixed(p.segmentation_ms, 2) << " ms + optimisation " << fixed(p.tracking_ms, 2)
              << " ms per frame";
  }
  md << markdownRow(all_cells) << "\n" << per_frame.str() << ".\n\n";

  // Figure 6.
  if (!results.camera_runs.empty()) {
    std::set<std::string> seqs;
    for (const BenchmarkRun& r : results.camera_runs) seqs.insert(r.sequence);
    std::string seq_list;
    for (const std::string& s : results.sequences) {
      if (seqs.count(s)) seq_list += (seq_list.empty() ? "" : ", ") + s;
    }
    md << "## Figure 6: error against the number of cameras\n\n";
    md << "Every combination of the cameras, on " << seq_list
       << "; mean and sd over every frame of every combination and sequence.\n\n";
    std::vector<std::string> ch{"cameras", "combinations"};
    for (const std::string& t : trackers) {
      ch.push_back(displayName(t) + " mean");
      ch.push_back(displayName(t) + " sd");
      ch.push_back(displayName(t) + " failed %");
    }
    md << markdownRow(ch) << markdownRule(ch.size());
    for (const auto& [count, combos] : combinations_per_count) {
      std::vector<std::string> cells{std::to_string(count), std::to_string(combos)};
      for (const std::string& t : trackers) {
        const Pooled p = pool(select(results.camera_runs, [&](const BenchmarkRun& r) {
          return r.tracker == t && static_cast<int>(r.cameras.size()) == count;
        }));
        cells.push_back(fixed(p.stats.mean_mm, 1));
        cells.push_back(fixed(p.stats.sd_mm, 1));
        cells.push_back(
            fixed(p.stats.frames > 0 ? 100.0 * p.stats.failed / p.stats.frames : kNaN, 1));
      }
      md << markdownRow(cells);
    }
    md << "\n";
  }
  return md.str();
}

void writeResultsCsv(const std::string& path, const BenchmarkResults& results) {
  std::ostringstream out;
  out << "sequence,tracker,frames,mean_mm,sd_mm,pct15,pct20,pct25,pct30,pct45,fps,failed\n";
  for (const BenchmarkRun& run : results.runs) {
    out << run.sequence << "," << run.tracker << "," << run.stats.frames << ","
        << fixed(run.stats.mean_mm, 3) << "," << fixed(run.stats.sd_mm, 3);
    for (double p : run.stats.percent_below) out << "," << fixed(p, 2);
    out << "," << fixed(run.fps, 1) << "," << run.stats.failed << "\n";
  }
  writeOutputFile(path, out.str());
}

void writeCameraCsvs(const std::string& dir, const BenchmarkResults& results,
                     const std::map<int, int>& combinations_per_count) {
  const std::string counts_path = dir + "/camera_counts.csv";
  std::ostringstream counts;
  counts << "tracker,cameras,combinations,runs,frames,failed,mean_mm,sd_mm\n";
  for (const std::string& t : results.trackers) {
    for (const auto& [count, combos] : combinations_per_count) {
      const Pooled p = pool(select(results.camera_runs, [&](const BenchmarkRun& r) {
        return r.tracker == t && static_cast<int>(r.cameras.size()) == count;
      }));
      counts << t << "," << count << "," << combos << "," << p.runs << "," << p.stats.frames << ","
             << p.stats.failed << "," << fixed(p.stats.mean_mm, 3) << "," << fixed(p.stats.sd_mm, 3)
             << "\n";
    }
  }
  const std::string runs_path = dir + "/camera_combinations.csv";
  writeOutputFile(counts_path, counts.str());
  std::ostringstream runs;
  runs << "sequence,tracker,cameras,frames,failed,mean_mm,sd_mm,fps\n";
  for (const BenchmarkRun& r : results.camera_runs) {
    std::string cams = cameraList(r.cameras);
    std::replace(cams.begin(), cams.end(), ',', ' ');
    runs << r.sequence << "," << r.tracker << "," << cams << "," << r.stats.frames << ","
         << r.stats.failed << "," << fixed(r.stats.mean_mm, 3) << "," << fixed(r.stats.sd_mm, 3)
         << "," << fixed(r.fps, 1) << "\n";
  }
  writeOutputFile(runs_path, runs.str());
}

cv::Scalar trackerColour(const std::string& tracker, size_t index) {
  if (tracker == "sag") return cv::Scalar(40, 40, 220);   // red (BGR)
  if (tracker == "sog") return cv::Scalar(200, 120, 30);  // blue
  static const cv::Scalar others[] = {cv::Scalar(40, 160, 40), cv::Scalar(150, 40, 150)};
  return others[index % 2];
}

void writePlots(const std::string& dir, const BenchmarkResults& results,
                const std::map<int, int>& combinations_per_count) {
  std::vector<cv::Mat> panels;
  for (const std::string& s : results.sequences) {
    std::vector<PlotSeries> series;
    for (size_t i = 0; i < results.trackers.size(); ++i) {
      const std::string& t = results.trackers[i];
      for (const BenchmarkRun& run : results.runs) {
        if (run.sequence != s || run.tracker != t) continue;
        PlotSeries line;
        line.label = displayName(t) + " (" + fixed(run.stats.mean_mm, 1) + " mm)";
        line.colour = trackerColour(t, i);
        for (size_t k = 0; k < run.errors.errors_mm.size(); ++k) {
          line.x.push_back(static_cast<double>(k));
          const double e = run.errors.errors_mm[k];
          line.y.push_back(std::isfinite(e) ? e : kNaN);  // failed frames: a gap
        }
        series.push_back(line);
      }
    }
    panels.push_back(linePlot(series, s + ": fingertip error per frame (gaps: no pose)",
                              "frame (with the hand)", "error (mm)", 900, 260));
  }
  if (!panels.empty()) writePng(dir + "/error_per_frame.png", stackVertically(panels));

  if (!results.camera_runs.empty()) {
    std::vector<PlotSeries> series;
    for (size_t i = 0; i < results.trackers.size(); ++i) {
      const std::string& t = results.trackers[i];
      PlotSeries line;
      line.label = displayName(t);
      line.colour = trackerColour(t, i);
      // Side by side, so that the error bars do not hide each other.
      const double offset = 0.06 * (static_cast<double>(i) - 0.5 * (results.trackers.size() - 1));
      for (const auto& entry : combinations_per_count) {
        const int count = entry.first;
        const Pooled p = pool(select(results.camera_runs, [&](const BenchmarkRun& r) {
          return r.tracker == t && static_cast<int>(r.cameras.size()) == count;
        }));
        line.x.push_back(count + offset);
        line.y.push_back(p.stats.mean_mm);
        line.error_bars.push_back(std::isfinite(p.stats.sd_mm) ? p.stats.sd_mm : 0.0);
      }
      series.push_back(line);
    }
    // An unlabelled series without points that widens the x axis by one camera on each side,
    // so that the ticks fall on whole numbers of cameras.
    PlotSeries range;
    range.x = {combinations_per_count.begin()->first - 1.0,
               combinations_per_count.rbegin()->first + 1.0};
    range.y = {kNaN, kNaN};
    series.push_back(range);
    writePng(dir + "/camera_counts.png",
             linePlot(series, "Fingertip error vs number of cameras (mean, sd bars)",
                      "number of cameras", "error (mm)", 700, 420));
  }
}

}  // namespace

const std::vector<std::string>& benchmarkSequences() {
  static const std::vector<std::string> sequences{"adbadd", "fingercount", "fingerwave", "flexex1",
                                                  "pinch",  "random",      "tigergrasp"};
  return sequences;
}

std::string benchmarkUsage() {
  return R"(Usage: benchmark [options]

Renders the studio sequences (render_bag's code), tracks each with SAG and with SoG (track_bag's
code), and prints the fingertip error per sequence, the paper's Table 1, the speed, and with
--camera-counts the paper's Figure 6. Writes DIR/results.md, the CSVs and PNG plots.

Options:
  --sequences a,b,..   sequences (names or motion files; default: adbadd fingercount fingerwave
                       flexex1 pinch random tigergrasp)
  --camera-counts      also track every combination of 2..N of the N cameras, on every sequence
                       but random (Figure 6)
  --frames N           render N frames per sequence, the first 10 without the hand (full length)
  --out-dir DIR        where the bags, tracks, tables and plots go (benchmark)
  --csv FILE           the per-sequence CSV (DIR/results.csv)
  --rig R              camera rig (dexter5)
  --iterations N       optimiser iterations per frame (10)
  --models a,b         models to compare (sag,sog; or model files)
  --reuse              reuse the bags in DIR/bags rendered with the same settings (default)
  --rerender           render the bags again
  --config-dir DIR     the built-in motions, rigs and models (the package's config/)
  --no-plots           no PNG plots
  --help               this text
)";
}

BenchmarkOptions parseBenchmarkArguments(const std::vector<std::string>& args) {
  BenchmarkOptions options;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    auto value = [&]() -> const std::string& { return nextOptionValue(args, &i); };
    if (arg == "--help" || arg == "-h") {
      options.help = true;
    } else if (arg == "--sequences") {
      options.sequences = parseListOption(arg, value());
    } else if (arg == "--camera-counts") {
      options.camera_counts = true;
    } else if (arg == "--frames") {
      options.frames = parseIntOption(arg, value(), 1);
    } else if (arg == "--out-dir") {
      options.out_dir = value();
    } else if (arg == "--csv") {
      options.csv = value();
    } else if (arg == "--rig") {
      options.rig = value();
    } else if (arg == "--iterations") {
      options.iterations = parseIntOption(arg, value(), 1);
    } else if (arg == "--models") {
      options.models = parseListOption(arg, value());
    } else if (arg == "--reuse") {
      options.rerender = false;
    } else if (arg == "--rerender") {
      options.rerender = true;
    } else if (arg == "--config-dir") {
      options.config_dir = value();
    } else if (arg == "--no-plots") {
      options.plots = false;
    } else {
      throw UsageError("unknown argument '" + arg + "'");
    }
  }
  if (options.sequences.empty()) options.sequences = benchmarkSequences();
  std::set<std::string> labels;
  for (const std::string& model : options.models) {
    if (!labels.insert(trackerLabel(model)).second) {
      throw UsageError("--models names '" + trackerLabel(model) + "' twice");
    }
  }
  if (options.frames > 0 && options.frames <= 10) {
    throw UsageError("--frames must be more than the 10 frames without the hand");
  }
  return options;
}

RunErrors matchToGroundTruth(const std::string& ground_truth_csv, const std::string& tracked_csv) {
  const TrackingCsv truth = readTrackingCsv(ground_truth_csv);
  TrackingCsv tracked = tracked_csv.empty() ? TrackingCsv() : readTrackingCsv(tracked_csv);
  std::sort(tracked.rows.begin(), tracked.rows.end(),
            [](const TrackingCsvRow& a, const TrackingCsvRow& b) { return a.stamp < b.stamp; });
  RunErrors errors;
  for (const TrackingCsvRow& gt : truth.rows) {
    errors.stamps.push_back(gt.stamp);
    const auto it =
        std::lower_bound(tracked.rows.begin(), tracked.rows.end(), gt.stamp - 1e-4,
                         [](const TrackingCsvRow& row, double stamp) { return row.stamp < stamp; });
    if (it != tracked.rows.end() && std::fabs(it->stamp - gt.stamp) <= 1e-4) {
      errors.errors_mm.push_back(1e3 * meanFingertipError(it->fingertips, gt.fingertips));
    } else {
      errors.errors_mm.push_back(kInf);
    }
  }
  return errors;
}

ErrorStats errorStats(const std::vector<double>& errors_mm) {
  ErrorStats stats;
  std::vector<double> finite;
  for (double e : errors_mm) {
    if (std::isfinite(e)) finite.push_back(e);
  }
  stats.frames = static_cast<int>(errors_mm.size());
  stats.failed = stats.frames - static_cast<int>(finite.size());
  const ErrorSummary tracked = summariseErrors(finite);
  stats.mean_mm = finite.empty() ? kNaN : tracked.mean_mm;
  stats.sd_mm = finite.empty() ? kNaN : tracked.sd_mm;
  // +inf is below no bound, so the percentages over all frames count failures as misses.
  stats.percent_below = summariseErrors(errors_mm).percent_below;
  return stats;
}

BenchmarkResults runBenchmark(const BenchmarkOptions& options, std::ostream& log) {
  const auto start = std::chrono::steady_clock::now();
  BenchmarkResults results;
  for (const std::string& model : options.models) results.trackers.push_back(trackerLabel(model));
  const fs::path dir(options.out_dir);
  fs::create_directories(dir / "tracks");

  std::vector<SequenceBag> bags;
  for (const std::string& sequence : options.sequences) {
    bags.push_back(prepareBag(options, sequence, log));
    results.sequences.push_back(bags.back().name);
  }
  {
    BagReader reader(bags.front().bag, BagReaderOptions());
    results.rig_cameras = static_cast<int>(reader.cameras().size());
  }

  const int total_main = static_cast<int>(bags.size() * options.models.size());
  int done = 0;
  for (const SequenceBag& bag : bags) {
    for (const std::string& model : options.models) {
      const std::string csv =
          (dir / "tracks" / (bag.name + "_" + trackerLabel(model) + ".csv")).string();
      results.runs.push_back(trackRun(options, bag, model, {}, csv));
      log << "benchmark: [" << ++done << "/" << total_main << "] " << runLine(results.runs.back())
          << "\n"
          << std::flush;
    }
  }

  std::map<int, int> combinations_per_count;
  if (options.camera_counts) {
    std::vector<std::vector<int>> combos;
    for (int k = 2; k <= results.rig_cameras; ++k) {
      const auto of_k = combinations(results.rig_cameras, k);
      combinations_per_count[k] = static_cast<int>(of_k.size());
      combos.insert(combos.end(), of_k.begin(), of_k.end());
    }
    std::vector<const SequenceBag*> sequences;
    for (const SequenceBag& bag : bags) {
      if (bag.name != "random") sequences.push_back(&bag);
    }
    if (sequences.empty()) sequences.push_back(&bags.front());  // only random was asked for
    const std::string scratch = (dir / "tracks" / "camera_count_run.csv").string();
    const int total = static_cast<int>(combos.size() * sequences.size() * options.models.size());
    int run_index = 0;
    for (const auto& cameras : combos) {
      for (const SequenceBag* bag : sequences) {
        for (const std::string& model : options.models) {
          results.camera_runs.push_back(trackRun(options, *bag, model, cameras, scratch));
          log << "benchmark: cameras [" << ++run_index << "/" << total << "] "
              << runLine(results.camera_runs.back()) << "\n"
              << std::flush;
        }
      }
    }
    std::error_code ignored;
    fs::remove(scratch, ignored);
  }

  results.markdown = report(options, results, combinations_per_count);
  { writeOutputFile((dir / "results.md").string(), results.markdown); }
  writeResultsCsv(options.csv.empty() ? (dir / "results.csv").string() : options.csv, results);
  if (options.camera_counts) writeCameraCsvs(dir.string(), results, combinations_per_count);
  if (options.plots) writePlots(dir.string(), results, combinations_per_count);
  results.seconds = secondsSince(start);
  return results;
}

}  // namespace sag_hand_tracker
