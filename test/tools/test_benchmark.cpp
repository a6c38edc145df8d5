// The benchmark end to end on a short sequence: it renders with render_bag's code and tracks with
// track_bag's code, its CSV has the columns and sensible values, the camera-count
// experiment covers every combination, the bags are reused, the ground truth in the CSV agrees
// with the bag, and failed frames are counted as stated (benchmark.h).
#include <geometry_msgs/PoseArray.h>
#include <gtest/gtest.h>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include "test_support/temp_files.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <set>
#include <sstream>

#include "sag_hand_tracker/apps/csv.h"
#include "sag_hand_tracker/apps/evaluation.h"
#include "sag_hand_tracker/apps/metrics.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/model/pose.h"
#include "sag_hand_tracker/studio/hand_shapes.h"
#include "sag_hand_tracker/tracking/tracker.h"
#include "sag_hand_tracker/util/types.h"

using namespace sag_hand_tracker;
namespace fs = std::filesystem;

namespace {

const std::string kConfig = std::string(SAG_SOURCE_DIR) + "/config";

std::vector<std::map<std::string, std::string>> readCsv(const std::string& path,
                                                        std::vector<std::string>* header) {
  std::ifstream in(path);
  std::string line;
  std::vector<std::map<std::string, std::string>> rows;
  auto split = [](const std::string& text) {
    std::vector<std::string> fields;
    std::stringstream stream(text);
    std::string field;
    while (std::getline(stream, field, ',')) fields.push_back(field);
    if (!text.empty() && text.back() == ',') fields.emplace_back();  // an empty last field
    return fields;
  };
  if (!std::getline(in, line)) return rows;
  *header = split(line);
  while (std::getline(in, line)) {
    const auto fields = split(line);
    EXPECT_EQ(fields.size(), header->size()) << line;
    std::map<std::string, std::string> row;
    for (size_t i = 0; i < fields.size() && i < header->size(); ++i) row[(*header)[i]] = fields[i];
    rows.push_back(row);
  }
  return rows;
}

double number(const std::map<std::string, std::string>& row, const std::string& column) {
  const auto it = row.find(column);
  EXPECT_NE(it, row.end()) << column;
  return it == row.end() ? std::nan("") : std::stod(it->second);
}

class BenchmarkTool : public sag_test::TempDirTest {
 protected:
  BenchmarkOptions options(const std::string& extra = "") const {
    // The default hand only, unless a test asks for shapes: keeps the tests fast. An option of
    // `extra` replaces the one here (an option given twice is refused).
    const std::vector<std::pair<std::string, std::string>> base{{"--sequences", "fingerwave"},
                                                                {"--frames", "40"},
                                                                {"--out-dir", dir_.string()},
                                                                {"--config-dir", kConfig},
                                                                {"--shapes", "default"}};
    std::vector<std::string> args;
    for (const auto& [option, value] : base) {
      if ((" " + extra + " ").find(" " + option + " ") != std::string::npos) continue;
      args.push_back(option);
      args.push_back(value);
    }
    std::stringstream stream(extra);
    std::string word;
    while (stream >> word) args.push_back(word);
    return parseBenchmarkArguments(args);
  }
};

}  // namespace

TEST(BenchmarkArguments, BenchmarkParsesOptionsAndRejectsBadOnes) {
  const BenchmarkOptions defaults = parseBenchmarkArguments({});
  EXPECT_EQ(defaults.sequences, benchmarkSequences());
  // The 7 of Dexter 1 first, then issue 9's 5 harder ones.
  ASSERT_EQ(defaults.sequences.size(), 12u);
  EXPECT_EQ(defaults.sequences[0], "adbadd");
  EXPECT_EQ(defaults.sequences[6], "tigergrasp");
  EXPECT_EQ(defaults.sequences[7], "raised");
  EXPECT_EQ(defaults.sequences[11], "natural");
  EXPECT_TRUE(defaults.shapes.empty());  // all of config/hand_shapes.yaml
  EXPECT_FALSE(defaults.discard_bags);
  EXPECT_EQ(defaults.models, (std::vector<std::string>{"sag", "sog"}));
  EXPECT_EQ(defaults.iterations, OptimizerParams().iterations);
  EXPECT_FALSE(defaults.camera_counts);
  EXPECT_FALSE(defaults.rerender);

  const BenchmarkOptions o = parseBenchmarkArguments(
      {"--sequences", "pinch,random", "--camera-counts", "--frames", "50", "--csv", "x.csv",
       "--iterations", "5", "--models", "sag", "--rerender", "--rig", "dexter5"});
  EXPECT_EQ(o.sequences, (std::vector<std::string>{"pinch", "random"}));
  EXPECT_TRUE(o.camera_counts);
  EXPECT_EQ(o.frames, 50);
  EXPECT_EQ(o.csv, "x.csv");
  EXPECT_EQ(o.iterations, 5);
  EXPECT_EQ(o.models, (std::vector<std::string>{"sag"}));
  EXPECT_TRUE(o.rerender);

  const BenchmarkOptions shaped =
      parseBenchmarkArguments({"--shapes", "default,stocky", "--discard-bags"});
  EXPECT_EQ(shaped.shapes, (std::vector<std::string>{"default", "stocky"}));
  EXPECT_TRUE(shaped.discard_bags);
  EXPECT_THROW(parseBenchmarkArguments({"--shapes", "stocky,stocky"}), UsageError);
  // Hands drawn at random: alone, or after the named ones; a drawn hand named twice is refused.
  EXPECT_EQ(parseBenchmarkArguments({"--drawn-hands", "3"}).shapes,
            (std::vector<std::string>{"drawn1", "drawn2", "drawn3"}));
  EXPECT_EQ(parseBenchmarkArguments({"--shapes", "default", "--drawn-hands", "1"}).shapes,
            (std::vector<std::string>{"default", "drawn1"}));
  EXPECT_THROW(parseBenchmarkArguments({"--shapes", "drawn2", "--drawn-hands", "2"}), UsageError);
  EXPECT_THROW(parseBenchmarkArguments({"--drawn-hands", "0"}), UsageError);
  // The rooms run on the hands asked for (runRoomBenchmark; without --shapes the default hand).
  EXPECT_EQ(parseBenchmarkArguments({"--rooms", "office", "--drawn-hands", "2"}).shapes,
            (std::vector<std::string>{"drawn1", "drawn2"}));
  EXPECT_EQ(parseBenchmarkArguments({"--rooms", "office", "--shapes", "stocky"}).shapes,
            (std::vector<std::string>{"stocky"}));
  EXPECT_TRUE(parseBenchmarkArguments({"--rooms", "office"}).shapes.empty());
  EXPECT_THROW(parseBenchmarkArguments({"--shapes", ""}), UsageError);

  EXPECT_THROW(parseBenchmarkArguments({"--frames", "0"}), UsageError);
  EXPECT_THROW(parseBenchmarkArguments({"--frames", "10"}), UsageError);  // no hand frame
  EXPECT_THROW(parseBenchmarkArguments({"--sequences", "a,"}), UsageError);
  EXPECT_THROW(parseBenchmarkArguments({"--models", "sag,sag"}), UsageError);
  EXPECT_THROW(parseBenchmarkArguments({"--iterations"}), UsageError);
  EXPECT_THROW(parseBenchmarkArguments({"--bogus"}), UsageError);
  // An option given twice: the first value was silently ignored.
  EXPECT_THROW(parseBenchmarkArguments({"--sequences", "pinch", "--sequences", "random"}),
               UsageError);
  // An explicitly empty value was taken as the default (--out-dir "": the default folder).
  for (const std::string option :
       {"--out-dir", "--csv", "--rig", "--config-dir", "--fit-sequence", "--shapes"}) {
    SCOPED_TRACE(option);
    try {
      parseBenchmarkArguments({option, ""});
      ADD_FAILURE() << "no error";
    } catch (const UsageError& error) {
      EXPECT_EQ(std::string(error.what()), option + " needs a value, got an empty one");
    }
  }
}

// The outputs' folders are checked before the rendering: a --csv in a missing folder failed only
// when the tables were written at the end, an --out-dir that is a file with a filesystem error.
TEST_F(BenchmarkTool, BenchmarkChecksItsOutputFoldersBeforeRendering) {
  std::ostringstream log;
  const std::string csv = (dir_ / "missing" / "r.csv").string();
  EXPECT_EQ(sag_test::inputErrorOf([&] { runBenchmark(options("--csv " + csv), log); }),
            "--csv " + csv + ": the folder " + (dir_ / "missing").string() + " does not exist");
  const std::string file = write("results", "not a folder\n");
  EXPECT_EQ(sag_test::inputErrorOf([&] { runBenchmark(options("--out-dir " + file), log); }),
            "--out-dir " + file + " exists and is not a folder");
  EXPECT_EQ(readAll(file), "not a folder\n");
  EXPECT_FALSE(std::filesystem::exists(dir_ / "bags")) << "nothing rendered";
}

// Session 30: an unknown name late in --sequences or --models failed only after every run before
// it (a whole benchmark's rendering and tracking), an unknown --fit-sequence failed every hand's
// fit and the benchmark went on; a --csv outside --out-dir replaced the file there; a name given
// twice ran twice.
TEST_F(BenchmarkTool, BenchmarkChecksItsNamesAndCsvBeforeRendering) {
  std::ostringstream log;
  EXPECT_EQ(
      sag_test::inputErrorOf([&] { runBenchmark(options("--sequences fingerwave,nosuch"), log); }),
      "--sequences nosuch: motion nosuch: does not exist");
  EXPECT_EQ(sag_test::inputErrorOf([&] { runBenchmark(options("--models sag,nosuch.yaml"), log); }),
            "--models nosuch.yaml: hand model nosuch.yaml: does not exist");
  EXPECT_EQ(
      sag_test::inputErrorOf([&] { runBenchmark(options("--fitted --fit-sequence nosuch"), log); }),
      "--fit-sequence nosuch: motion nosuch: does not exist");
  fs::create_directories(dir_ / "elsewhere");
  const std::string csv = write("elsewhere/mine.csv", "mine\n");
  EXPECT_EQ(sag_test::inputErrorOf([&] { runBenchmark(options("--csv " + csv), log); }),
            "--csv " + csv +
                " exists; the benchmark replaces files only in its --out-dir (choose another "
                "name)");
  EXPECT_EQ(readAll(csv), "mine\n");
  const std::string file = write("a_file", "mine\n");
  EXPECT_EQ(
      sag_test::inputErrorOf([&] { runBenchmark(options("--out-dir " + file + "/sub"), log); }),
      "--out-dir " + file + "/sub: cannot create the folder: Not a directory");
  EXPECT_FALSE(fs::exists(dir_ / "bags")) << "nothing rendered";
  EXPECT_FALSE(fs::exists(dir_ / "tracks")) << "nothing tracked";

  for (const auto& [args, message] : std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"--sequences", "pinch,motions/pinch.yaml"}, "--sequences names 'pinch' twice"},
           {{"--rooms", "office,office"}, "--rooms names 'office' twice"},
           {{"--rooms", "all,kitchen"}, "--rooms names 'kitchen' twice"},
           {{"--rooms", "office", "--room-configs", "skin,skin"},
            "--room-configs names 'skin' twice"},
           // Options the chosen benchmark does not use were ignored without a word.
           {{"--room-configs", "skin"}, "--room-configs selects runs of --rooms; give --rooms too"},
           {{"--rooms", "office", "--camera-counts"},
            "--camera-counts is not used with --rooms (the rooms write rooms.md and rooms.csv)"},
           {{"--rooms", "office", "--csv", "r.csv"},
            "--csv is not used with --rooms (the rooms write rooms.md and rooms.csv)"}}) {
    try {
      parseBenchmarkArguments(args);
      ADD_FAILURE() << "no error for " << args[1];
    } catch (const UsageError& error) {
      EXPECT_EQ(std::string(error.what()), message);
    }
  }
}

TEST(BenchmarkErrors, BenchmarkCountsFramesWithoutAPoseAsFailures) {
  const double inf = std::numeric_limits<double>::infinity();
  const ErrorStats stats = errorStats({10.0, inf, 30.0, 16.0});
  EXPECT_EQ(stats.frames, 4);
  EXPECT_EQ(stats.failed, 1);
  EXPECT_NEAR(stats.mean_mm, 56.0 / 3.0, 1e-12);  // over the tracked frames
  EXPECT_GT(stats.sd_mm, 0.0);
  EXPECT_NEAR(stats.percent_below[0], 25.0, 1e-12);  // < 15 mm: 1 of 4 frames
  EXPECT_NEAR(stats.percent_below[1], 50.0, 1e-12);  // < 20 mm: 2 of 4
  EXPECT_NEAR(stats.percent_below[4], 75.0, 1e-12);  // < 45 mm: the failure never counts
  const ErrorStats none = errorStats({inf, inf});
  EXPECT_EQ(none.failed, 2);
  EXPECT_TRUE(std::isnan(none.mean_mm));
  EXPECT_EQ(none.percent_below[4], 0.0);
}

TEST_F(BenchmarkTool, BenchmarkMatchesRowsToTheGroundTruthByStamp) {
  // A ground truth of three frames and a track that has the first and the last only.
  const std::vector<std::string> names{"p"};
  {
    TrackingCsvWriter truth((dir_ / "gt.csv").string(), names);
    TrackingCsvWriter track((dir_ / "track.csv").string(), names);
    for (int k = 0; k < 3; ++k) {
      TrackingCsvRow row;
      row.stamp = 1000.0 + 0.04 * k;
      for (auto& tip : row.fingertips) tip = Eigen::Vector3d(0.1 * k, 0.0, 0.5);
      row.parameters = Eigen::VectorXd::Zero(1);
      truth.write(row);
      if (k == 1) continue;
      for (auto& tip : row.fingertips) tip.x() += 0.012;  // 12 mm off
      track.write(row);
    }
  }
  const RunErrors errors =
      matchToGroundTruth((dir_ / "gt.csv").string(), (dir_ / "track.csv").string());
  ASSERT_EQ(errors.errors_mm.size(), 3u);
  EXPECT_NEAR(errors.errors_mm[0], 12.0, 1e-6);
  EXPECT_TRUE(std::isinf(errors.errors_mm[1]));
  EXPECT_NEAR(errors.errors_mm[2], 12.0, 1e-6);
}

TEST_F(BenchmarkTool, BenchmarkShortRunWritesTablesCsvAndPlots) {
  std::ostringstream log;
  const BenchmarkResults results = runBenchmark(options(), log);

  // The bag and the tracks where the issue says.
  EXPECT_TRUE(fs::exists(dir_ / "bags" / "fingerwave.bag"));
  EXPECT_TRUE(fs::exists(dir_ / "bags" / "fingerwave_gt.csv"));
  EXPECT_TRUE(fs::exists(dir_ / "tracks" / "fingerwave_sag.csv"));
  EXPECT_TRUE(fs::exists(dir_ / "tracks" / "fingerwave_sog.csv"));
  EXPECT_NE(log.str().find("rendered fingerwave"), std::string::npos) << log.str();

  std::vector<std::string> header;
  const auto rows = readCsv((dir_ / "results.csv").string(), &header);
  for (const std::string column : {"sequence", "tracker", "frames", "mean_mm", "sd_mm", "pct15",
                                   "pct20", "pct25", "pct30", "pct45", "fps"}) {
    EXPECT_NE(std::find(header.begin(), header.end(), column), header.end()) << column;
  }
  ASSERT_EQ(rows.size(), 4u);  // one row per tracker for the one sequence, then the pooled ones
  EXPECT_EQ(rows[2].at("sequence"), "all");
  EXPECT_EQ(rows[2].at("shape"), "all");
  for (int i : {0, 1}) {  // one sequence and one hand: the pooled rows repeat the runs'
    EXPECT_EQ(rows[i].at("shape"), "default");
    EXPECT_EQ(rows[i + 2].at("mean_mm"), rows[i].at("mean_mm"));
    EXPECT_EQ(rows[i + 2].at("reversed_pct"), rows[i].at("reversed_pct"));
  }
  std::set<std::string> trackers;
  for (const auto& row : rows) {
    SCOPED_TRACE(row.at("tracker"));
    trackers.insert(row.at("tracker"));
    EXPECT_TRUE(row.at("sequence") == "fingerwave" || row.at("sequence") == "all");
    EXPECT_EQ(number(row, "frames"), 30.0);  // 40 rendered, the first 10 without the hand
    const double mean = number(row, "mean_mm"), sd = number(row, "sd_mm");
    EXPECT_TRUE(std::isfinite(mean));
    EXPECT_GT(mean, 0.0);
    EXPECT_LT(mean, 200.0);  // a hand-sized error, not garbage
    EXPECT_TRUE(std::isfinite(sd));
    EXPECT_GE(sd, 0.0);
    double previous = 0.0;
    for (const std::string column : {"pct15", "pct20", "pct25", "pct30", "pct45"}) {
      const double pct = number(row, column);
      EXPECT_GE(pct, previous) << column;  // a larger bound holds at least as many frames
      EXPECT_LE(pct, 100.0);
      previous = pct;
    }
    EXPECT_GT(number(row, "fps"), 0.0);
    EXPECT_GE(number(row, "failed"), 0.0);
    EXPECT_LT(number(row, "failed"), 30.0);
    for (const std::string column : {"reversed_pct", "rolled_pct"}) {
      EXPECT_GE(number(row, column), 0.0) << column;
      EXPECT_LE(number(row, column), 100.0) << column;
    }
    EXPECT_GE(number(row, "wrist_mm"), 0.0);
    EXPECT_LT(number(row, "wrist_mm"), 200.0);
  }
  EXPECT_EQ(trackers, (std::set<std::string>{"sag", "sog"}));

  // The same numbers in the results and in the Markdown.
  ASSERT_EQ(results.runs.size(), 2u);
  EXPECT_EQ(results.runs[0].errors.errors_mm.size(), 30u);
  std::ifstream md_file(dir_ / "results.md");
  std::stringstream md;
  md << md_file.rdbuf();
  EXPECT_EQ(md.str(), results.markdown);
  for (const char* part :
       {"Fingertip error per sequence", "Table 1", "fingerwave SoG", "fingerwave SAG", "Speed",
        "| **all** |", "SAG rev %", "SAG roll %", "SoG wrist"}) {
    EXPECT_NE(md.str().find(part), std::string::npos) << part;
  }
  EXPECT_EQ(md.str().find("Figure 6"), std::string::npos);  // not asked for

  const cv::Mat plot = cv::imread((dir_ / "error_per_frame.png").string());
  ASSERT_FALSE(plot.empty());
  EXPECT_EQ(plot.cols, 900);
  EXPECT_FALSE(cv::imread((dir_ / "orientation_per_frame.png").string()).empty());
  EXPECT_FALSE(fs::exists(dir_ / "camera_counts.png"));
  EXPECT_FALSE(fs::exists(dir_ / "shapes.png"));  // one hand only

  // A second run reuses the bag (same settings); --rerender renders it again.
  const auto written = fs::last_write_time(dir_ / "bags" / "fingerwave.bag");
  std::ostringstream log2;
  const BenchmarkResults again = runBenchmark(options("--models sag --no-plots"), log2);
  EXPECT_NE(log2.str().find("reusing"), std::string::npos) << log2.str();
  EXPECT_EQ(fs::last_write_time(dir_ / "bags" / "fingerwave.bag"), written);
  ASSERT_EQ(again.runs.size(), 1u);
  // The tracker is deterministic: the same bag gives the same errors.
  EXPECT_EQ(again.runs[0].errors.errors_mm, results.runs[0].errors.errors_mm);
  std::ostringstream log3;
  runBenchmark(options("--models sag --no-plots --frames 12 --csv " + (dir_ / "r.csv").string()),
               log3);
  EXPECT_NE(log3.str().find("rendered fingerwave"), std::string::npos) << log3.str();
  const auto rows12 = readCsv((dir_ / "r.csv").string(), &header);
  ASSERT_EQ(rows12.size(), 2u);  // the run and the pooled row
  EXPECT_EQ(number(rows12[0], "frames"), 2.0);
}

// A bag linked into the bags folder from elsewhere (another run's, shared to save the rendering)
// that has to be rendered again (other settings) is not replaced through the link: the other
// run's bag, ground truth and stamp stay as they were, and this run's are files of its own folder.
TEST_F(BenchmarkTool, BenchmarkNeverReplacesABagThroughALink) {
  const std::vector<std::string> names{"fingerwave.bag", "fingerwave_gt.csv",
                                       "fingerwave.render.txt"};
  fs::create_directories(dir_ / "elsewhere");
  fs::create_directories(dir_ / "bags");
  for (const std::string& name : names) {
    write("elsewhere/" + name, "another run's " + name);
    fs::create_symlink(dir_ / "elsewhere" / name, dir_ / "bags" / name);
  }
  std::ostringstream log;
  const BenchmarkResults results =
      runBenchmark(options("--models sag --no-plots --frames 12"), log);
  EXPECT_NE(log.str().find("rendered fingerwave"), std::string::npos) << log.str();
  ASSERT_EQ(results.runs.size(), 1u);
  EXPECT_EQ(results.runs[0].stats.frames, 2);
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    // (Not EXPECT_EQ: a replaced bag would be printed whole.)
    EXPECT_TRUE(readAll(path("elsewhere/" + name)) == "another run's " + name)
        << "the other run's file was replaced through the link";
    EXPECT_FALSE(fs::is_symlink(dir_ / "bags" / name));
    EXPECT_TRUE(fs::is_regular_file(dir_ / "bags" / name));
  }
}

TEST_F(BenchmarkTool, BenchmarkCameraCountsCoverEveryCombination) {
  std::ostringstream log;
  const BenchmarkResults results =
      runBenchmark(options("--camera-counts --frames 14 --models sag,sog"), log);
  ASSERT_EQ(results.rig_cameras, 5);
  ASSERT_EQ(results.camera_runs.size(), 26u * 2u);  // C(5,2..5) = 10+10+5+1, two trackers
  std::map<size_t, std::set<std::vector<int>>> combos;
  for (const auto& run : results.camera_runs) combos[run.cameras.size()].insert(run.cameras);
  EXPECT_EQ(combos[2].size(), 10u);
  EXPECT_EQ(combos[3].size(), 10u);
  EXPECT_EQ(combos[4].size(), 5u);
  EXPECT_EQ(combos[5].size(), 1u);

  std::vector<std::string> header;
  const auto rows = readCsv((dir_ / "camera_counts.csv").string(), &header);
  ASSERT_EQ(rows.size(), 8u);  // 4 camera counts x 2 trackers
  for (const auto& row : rows) {
    const double cameras = number(row, "cameras");
    EXPECT_GE(cameras, 2.0);
    EXPECT_LE(cameras, 5.0);
    EXPECT_EQ(number(row, "frames"), 4.0 * number(row, "combinations"));
    EXPECT_EQ(number(row, "runs"), number(row, "combinations"));
  }
  EXPECT_NE(results.markdown.find("Figure 6"), std::string::npos);
  const cv::Mat plot = cv::imread((dir_ / "camera_counts.png").string());
  EXPECT_FALSE(plot.empty());
  EXPECT_NE(log.str().find("cameras [52/52]"), std::string::npos) << log.str();
}

TEST_F(BenchmarkTool, BenchmarkGroundTruthCsvAgreesWithTheBag) {
  std::ostringstream log;
  runBenchmark(options("--frames 20 --models sag --no-plots"), log);
  const TrackingCsv csv = readTrackingCsv((dir_ / "bags" / "fingerwave_gt.csv").string());
  rosbag::Bag bag((dir_ / "bags" / "fingerwave.bag").string());
  std::vector<geometry_msgs::PoseArray> tips;
  for (const rosbag::MessageInstance& m :
       rosbag::View(bag, rosbag::TopicQuery("/ground_truth/fingertips"))) {
    tips.push_back(*m.instantiate<geometry_msgs::PoseArray>());
    EXPECT_EQ(m.getTime(), tips.back().header.stamp);
  }
  ASSERT_EQ(tips.size(), 10u);  // frames 10..19 show the hand
  ASSERT_EQ(csv.rows.size(), tips.size());
  for (size_t i = 0; i < tips.size(); ++i) {
    SCOPED_TRACE("row " + std::to_string(i));
    EXPECT_NEAR(csv.rows[i].stamp, tips[i].header.stamp.toSec(), 1e-6);
    ASSERT_EQ(tips[i].poses.size(), 5u);
    for (int f = 0; f < 5; ++f) {
      const auto& p = tips[i].poses[f].position;
      EXPECT_LT((csv.rows[i].fingertips[f] - Eigen::Vector3d(p.x, p.y, p.z)).norm(), 1e-8);
    }
    if (i > 0) {
      EXPECT_GT(csv.rows[i].stamp, csv.rows[i - 1].stamp);
    }
  }
}

namespace {

// A tracking CSV row with the model's 26 parameters: the root at `wrist` turned by `rotation`
// (a rotation vector), the joints at 0, and fingertips `offset` metres off along x.
TrackingCsvRow poseRow(double stamp, const Eigen::Vector3d& wrist, const Eigen::Vector3d& rotation,
                       double offset) {
  TrackingCsvRow row;
  row.stamp = stamp;
  for (int f = 0; f < kNumFingers; ++f) row.fingertips[f] = Eigen::Vector3d(offset, 0.01 * f, 0.2);
  row.parameters = Eigen::VectorXd::Zero(26);
  row.parameters.segment<3>(0) = wrist;
  row.parameters.segment<3>(3) = rotation;
  return row;
}

}  // namespace

TEST_F(BenchmarkTool, BenchmarkFlagsReversedAndRolledOverFramesFromThePoseColumns) {
  const HandModel model = loadHandModel(resolveModelPath("sag", kConfig));
  const std::vector<std::string> names = model.parameterNames();
  ASSERT_EQ(names.size(), 26u);
  const Eigen::Vector3d wrist(0.0, -0.06, 0.15);
  const Eigen::Vector3d turn(0.3, -0.2, 1.1);  // the truth's orientation
  const Eigen::Matrix3d truth = rotationFromVector(turn);
  // In the palm frame: a roll of 180 deg about the hand's axis, a turn of 180 deg in the palm's
  // plane, a small error; as rotation vectors of truth * R.
  auto tracked = [&](const Eigen::Vector3d& palm_axis, double degrees) {
    const Eigen::Matrix3d r =
        truth * Eigen::AngleAxisd(degrees * M_PI / 180.0, palm_axis).toRotationMatrix();
    return rotationToVector(r);
  };
  {
    TrackingCsvWriter gt((dir_ / "gt.csv").string(), names);
    TrackingCsvWriter track((dir_ / "track.csv").string(), names);
    for (int k = 0; k < 5; ++k) gt.write(poseRow(100.0 + 0.04 * k, wrist, turn, 0.0));
    track.write(
        poseRow(100.00, wrist + Eigen::Vector3d(0.003, 0.004, 0), tracked({1, 0, 0}, 10), 0.005));
    track.write(poseRow(100.04, wrist, tracked({1, 0, 0}, 180), 0.005));  // rolled over
    track.write(poseRow(100.08, wrist, tracked({0, 0, 1}, 170), 0.005));  // reversed
    track.write(poseRow(100.12, wrist, tracked({0, 1, 0}, 120), 0.005));  // both
    // frame 4 (100.16): no pose
  }
  const Eigen::Vector3d forward = middleKnuckleDirection(model);
  EXPECT_GT(forward.x(), 0.9);
  const RunErrors errors =
      matchToGroundTruth((dir_ / "gt.csv").string(), (dir_ / "track.csv").string(), forward);
  ASSERT_EQ(errors.forward_deg.size(), 5u);
  ASSERT_EQ(errors.back_normal_deg.size(), 5u);
  ASSERT_EQ(errors.wrist_mm.size(), 5u);
  EXPECT_NEAR(errors.wrist_mm[0], 5.0, 1e-6);
  EXPECT_NEAR(errors.back_normal_deg[1], 180.0, 1e-4);
  EXPECT_LT(errors.forward_deg[1],
            10.0);  // a roll keeps the hand's axis (up to the knuckle offset)
  EXPECT_GT(errors.forward_deg[2], 150.0);
  EXPECT_LT(errors.back_normal_deg[2], 1e-4);
  EXPECT_GT(errors.forward_deg[3], 90.0);
  EXPECT_GT(errors.back_normal_deg[3], 90.0);
  EXPECT_TRUE(std::isnan(errors.forward_deg[4]));
  EXPECT_TRUE(std::isinf(errors.errors_mm[4]));

  const ErrorStats stats = errorStats(errors);
  EXPECT_EQ(stats.frames, 5);
  EXPECT_EQ(stats.failed, 1);
  EXPECT_EQ(stats.oriented_frames, 4);          // over the tracked frames
  EXPECT_NEAR(stats.reversed_pct, 50.0, 1e-9);  // frames 2 and 3
  EXPECT_NEAR(stats.rolled_pct, 50.0, 1e-9);    // frames 1 and 3
  EXPECT_NEAR(stats.wrist_mean_mm, 5.0 / 4.0, 1e-6);
  EXPECT_NEAR(stats.mean_mm, 5.0, 1e-6);

  // CSVs without the root columns: no orientation figures, not zeros.
  {
    TrackingCsvWriter gt((dir_ / "gt1.csv").string(), {"p"});
    TrackingCsvRow row;
    row.stamp = 1.0;
    for (auto& tip : row.fingertips) tip = Eigen::Vector3d(0, 0, 0.1);
    row.parameters = Eigen::VectorXd::Zero(1);
    gt.write(row);
  }
  const ErrorStats none =
      errorStats(matchToGroundTruth((dir_ / "gt1.csv").string(), (dir_ / "gt1.csv").string()));
  EXPECT_EQ(none.oriented_frames, 0);
  EXPECT_TRUE(std::isnan(none.reversed_pct));
  EXPECT_NEAR(none.mean_mm, 0.0, 1e-12);
}

TEST_F(BenchmarkTool, BenchmarkReportsPerHandShapeAndPooled) {
  std::ostringstream log;
  const BenchmarkResults results = runBenchmark(
      options("--shapes default,dark_small --models sag --frames 24 --discard-bags"), log);
  EXPECT_EQ(results.shapes, (std::vector<std::string>{"default", "dark_small"}));
  ASSERT_EQ(results.runs.size(), 2u);
  EXPECT_EQ(results.runs[0].shape, "default");
  EXPECT_EQ(results.runs[1].shape, "dark_small");
  EXPECT_NE(log.str().find("rendered fingerwave (hand dark_small)"), std::string::npos)
      << log.str();
  // The ground truth follows each hand: the small hand's fingertips are elsewhere.
  const TrackingCsv gt_default = readTrackingCsv((dir_ / "bags" / "fingerwave_gt.csv").string());
  const TrackingCsv gt_small =
      readTrackingCsv((dir_ / "bags" / "fingerwave__dark_small_gt.csv").string());
  ASSERT_EQ(gt_default.rows.size(), gt_small.rows.size());
  EXPECT_GT((gt_default.rows[0].fingertips[2] - gt_small.rows[0].fingertips[2]).norm(), 0.005);
  EXPECT_EQ(gt_default.rows[0].parameters, gt_small.rows[0].parameters);  // the same motion
  // --discard-bags: the bags are gone, the ground truth and the tracks stay.
  EXPECT_FALSE(fs::exists(dir_ / "bags" / "fingerwave.bag"));
  EXPECT_FALSE(fs::exists(dir_ / "bags" / "fingerwave__dark_small.bag"));
  EXPECT_TRUE(fs::exists(dir_ / "tracks" / "fingerwave__dark_small_sag.csv"));

  std::vector<std::string> header;
  const auto rows = readCsv((dir_ / "results.csv").string(), &header);
  for (const std::string column : {"sequence", "shape", "tracker", "reversed_pct", "rolled_pct",
                                   "wrist_mm", "mean_mm", "pct20", "failed"}) {
    EXPECT_NE(std::find(header.begin(), header.end(), column), header.end()) << column;
  }
  // 2 runs, then per sequence over the shapes (1), per shape over the sequences (2), all (1).
  ASSERT_EQ(rows.size(), 6u);
  std::map<std::pair<std::string, std::string>, std::map<std::string, std::string>> by_key;
  for (const auto& row : rows) by_key[{row.at("sequence"), row.at("shape")}] = row;
  ASSERT_EQ(by_key.size(), 6u);
  using Key = std::pair<std::string, std::string>;
  const auto& all = by_key[Key("all", "all")];
  EXPECT_EQ(number(all, "frames"), 28.0);  // 2 x 14 frames with the hand
  EXPECT_EQ(by_key[Key("fingerwave", "all")].at("mean_mm"), all.at("mean_mm"));
  EXPECT_EQ(by_key[Key("all", "dark_small")].at("mean_mm"),
            by_key[Key("fingerwave", "dark_small")].at("mean_mm"));
  // The pooled mean is the frame-weighted mean of the two runs.
  const auto& on_default = by_key[Key("fingerwave", "default")];
  const auto& on_small = by_key[Key("fingerwave", "dark_small")];
  const double pooled = (number(on_default, "mean_mm") * (14 - number(on_default, "failed")) +
                         number(on_small, "mean_mm") * (14 - number(on_small, "failed"))) /
                        (28 - number(all, "failed"));
  EXPECT_NEAR(number(all, "mean_mm"), pooled, 2e-3);

  for (const char* part : {"Fingertip error per hand shape", "| dark_small |",
                           "SAG: mean fingertip error (mm) per sequence and hand shape",
                           "SAG: reversed % / rolled-over %", "all shapes"}) {
    EXPECT_NE(results.markdown.find(part), std::string::npos) << part;
  }
  EXPECT_FALSE(cv::imread((dir_ / "shapes.png").string()).empty());
  EXPECT_FALSE(cv::imread((dir_ / "orientation_per_frame.png").string()).empty());

  std::ostringstream bad;
  EXPECT_THROW(runBenchmark(options("--shapes no_such_hand --models sag --no-plots"), bad),
               InputError);
}

// A hand drawn at random (--drawn-hands): rendered, tracked and reported with what was drawn.
TEST_F(BenchmarkTool, BenchmarkRendersAndDescribesDrawnHands) {
  std::ostringstream log;
  const BenchmarkResults results =
      runBenchmark(options("--drawn-hands 1 --models sag --frames 14 --discard-bags"), log);
  EXPECT_EQ(results.shapes, (std::vector<std::string>{"default", "drawn1"}));  // the fixture's
  ASSERT_EQ(results.runs.size(), 2u);
  EXPECT_EQ(results.markdown.find("- `default`"), std::string::npos);  // described: drawn only
  EXPECT_NE(log.str().find("rendered fingerwave (hand drawn1)"), std::string::npos) << log.str();
  const std::string described = "- `drawn1`: drawn with seed 1: size ";
  EXPECT_NE(results.markdown.find(described), std::string::npos) << results.markdown;
  EXPECT_NE(results.markdown.find("or drawn at random: listed below"), std::string::npos);
  // The ground truth's fingertips are the drawn hand's at the motion's pose, not the model's.
  const TrackingCsv gt = readTrackingCsv((dir_ / "bags" / "fingerwave__drawn1_gt.csv").string());
  ASSERT_FALSE(gt.rows.empty());
  const HandModel model = loadHandModel(kConfig + "/hand_sag_right.yaml");
  const HandModel drawn =
      studio::shapeHandModel(model, studio::resolveHandShape("drawn1", kConfig).shape);
  const TrackingCsvRow& row = gt.rows.back();
  const Pose pose = Pose::fromVector(row.parameters);
  const Fingertips on_drawn = fingertips(drawn, pose), on_model = fingertips(model, pose);
  double off_model = 0.0;
  for (int f = 0; f < kNumFingers; ++f) {
    EXPECT_LT((on_drawn[f] - row.fingertips[f]).norm(), 1e-5) << f;
    off_model = std::max(off_model, (on_model[f] - row.fingertips[f]).norm());
  }
  EXPECT_GT(off_model, 0.002);
}

TEST(BenchmarkArguments, BenchmarkParsesTheFittedOptions) {
  const BenchmarkOptions plain = parseBenchmarkArguments({});
  EXPECT_FALSE(plain.fitted);
  EXPECT_EQ(plain.routine_frames, 0);  // the routine's full length
  const BenchmarkOptions o =
      parseBenchmarkArguments({"--fitted", "--routine-frames", "60", "--models", "sag"});
  EXPECT_TRUE(o.fitted);
  EXPECT_EQ(o.routine_frames, 60);
  // The fit starts from SAG's default model and is compared with it: sag must be run.
  EXPECT_THROW(parseBenchmarkArguments({"--fitted", "--models", "sog"}), UsageError);
  // The fitted runs' label must not be taken by a model file.
  EXPECT_THROW(parseBenchmarkArguments({"--fitted", "--models", "sag,/tmp/fitted.yaml"}),
               UsageError);
  // With the rooms: each hand's fitted model beside the --models (runRoomBenchmark).
  EXPECT_TRUE(parseBenchmarkArguments({"--fitted", "--rooms", "office"}).fitted);
  EXPECT_THROW(parseBenchmarkArguments({"--routine-frames", "0"}), UsageError);
  EXPECT_EQ(plain.fit_sequence, "calibration_routine");
  EXPECT_EQ(parseBenchmarkArguments({"--fitted", "--fit-sequence", "random", "--models", "sag"})
                .fit_sequence,
            "random");
  EXPECT_THROW(parseBenchmarkArguments({"--fit-sequence"}), UsageError);
}

TEST(BenchmarkArguments, RoomConfigsSelectTheRoomRuns) {
  EXPECT_EQ(parseBenchmarkArguments({}).room_configs.size(), 4u);  // all four by default
  const BenchmarkOptions o =
      parseBenchmarkArguments({"--rooms", "office", "--room-configs", "skin+cues,plate"});
  EXPECT_EQ(o.room_configs, (std::vector<std::string>{"skin+cues", "plate"}));
  EXPECT_THROW(parseBenchmarkArguments({"--room-configs", "skin,cues"}), UsageError);
}

namespace {

std::string readText(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

// --fitted: the routine rendered on each hand, fitted with calibrate_hand's code, the model file
// written and loadable, every sequence tracked with it as the tracker "fitted", the comparison
// table with the bar and the fits' summary; then a routine too short to fit: each shape reported
// as failed, the default model's runs done, the earlier model files left alone.
TEST_F(BenchmarkTool, BenchmarkFittedModelColumnPerHandShape) {
  std::ostringstream log;
  const BenchmarkResults results = runBenchmark(
      options("--fitted --models sag --shapes default,long_distal --frames 24 --no-plots"), log);
  EXPECT_EQ(results.trackers, (std::vector<std::string>{"sag", "fitted"}));
  ASSERT_EQ(results.fits.size(), 2u);
  const HandModel start = loadHandModel(resolveModelPath("sag", kConfig));
  std::map<std::string, double> worst_bone_pct;
  for (const ShapeFit& fit : results.fits) {
    SCOPED_TRACE(fit.shape);
    ASSERT_TRUE(fit.ok) << fit.error << "\n" << log.str();
    EXPECT_EQ(fit.model, (dir_ / "models" / (fit.shape + ".yaml")).string());
    EXPECT_TRUE(fs::exists(dir_ / "bags" / fs::path(fit.routine_bag).filename()));
    // The model loads and is not the start model: the fit changed its shape and colours.
    const HandModel fitted = loadHandModel(fit.model);
    ASSERT_EQ(fitted.gaussians.size(), start.gaussians.size());
    double change = 0.0;  // mean relative change of the covariances' traces
    for (size_t g = 0; g < start.gaussians.size(); ++g) {
      change += std::fabs(fitted.gaussians[g].cov.trace() / start.gaussians[g].cov.trace() - 1.0);
    }
    EXPECT_GT(change / start.gaussians.size(), 0.01);
    // The fitted bones against the rendered hand's skeleton (the default model shaped by it).
    const SkeletonErrors truth = compareSkeletons(
        fitted, studio::shapeHandModel(start, studio::resolveHandShape(fit.shape, kConfig).shape));
    EXPECT_EQ(fit.calibration.truth_shape, fit.shape);
    EXPECT_NEAR(fit.calibration.truth_errors.worst_bone, truth.worst_bone, 1e-4);
    EXPECT_GT(truth.worst_bone, 0.0);
    worst_bone_pct[fit.shape] = 100.0 * truth.worst_bone;
    EXPECT_GT(fit.calibration.tracked_frames, 40);
    EXPECT_GT(fit.calibration.fit.score_after, fit.calibration.fit.score_before);
    EXPECT_NE(log.str().find("fitted the model to hand " + fit.shape), std::string::npos)
        << log.str();
  }
  // calibrate_hand's staging files are gone.
  for (const auto& entry : fs::directory_iterator(dir_ / "models")) {
    EXPECT_NE(entry.path().filename().string().front(), '.') << entry.path();
  }
  // Each sequence of each hand tracked with the default and with that hand's fitted model.
  ASSERT_EQ(results.runs.size(), 4u);
  std::map<std::pair<std::string, std::string>, const BenchmarkRun*> runs;
  for (const BenchmarkRun& run : results.runs) runs[{run.shape, run.tracker}] = &run;
  for (const std::string shape : {"default", "long_distal"}) {
    SCOPED_TRACE(shape);
    ASSERT_TRUE(runs.count({shape, "sag"}));
    ASSERT_TRUE(runs.count({shape, "fitted"}));
    const ErrorStats& stats = runs[{shape, "fitted"}]->stats;
    EXPECT_EQ(stats.frames, 14);
    EXPECT_TRUE(std::isfinite(stats.mean_mm));
    EXPECT_LT(stats.mean_mm, 200.0);
    // Another model gives other poses: not the default model's track under another name.
    const auto& fitted_errors = runs[{shape, "fitted"}]->errors.errors_mm;
    EXPECT_NE(fitted_errors, (runs[{shape, "sag"}]->errors.errors_mm));
  }
  EXPECT_TRUE(fs::exists(dir_ / "tracks" / "fingerwave__long_distal_fitted.csv"));
  EXPECT_TRUE(fs::exists(dir_ / "tracks" / "fingerwave_fitted.csv"));

  // The tables: the fitted tracker beside SAG everywhere, the comparison and the fits.
  for (const char* part :
       {"SAG fitted mean", "Default model against fitted model per hand shape",
        "| hand shape | frames | default mean | fitted mean |", "| default | 14 |", "(reference) |",
        "The fits (calibrate_hand's code", "| long_distal | fitted | ", "| worst bone % |"}) {
    EXPECT_NE(results.markdown.find(part), std::string::npos) << part << "\n" << results.markdown;
  }
  std::vector<std::string> header;
  const auto rows = readCsv((dir_ / "results.csv").string(), &header);
  std::map<std::pair<std::string, std::string>, std::map<std::string, std::string>> pooled;
  for (const auto& row : rows) {
    if (row.at("sequence") == "all") pooled[{row.at("shape"), row.at("tracker")}] = row;
  }
  ASSERT_TRUE(pooled.count({"long_distal", "fitted"}));
  ASSERT_TRUE(pooled.count({"default", "sag"}));
  const auto fitted_rows = readCsv((dir_ / "fitted.csv").string(), &header);
  ASSERT_EQ(fitted_rows.size(), 2u);
  for (const auto& row : fitted_rows) {
    SCOPED_TRACE(row.at("shape"));
    EXPECT_EQ(row.at("fit"), "ok");
    using Key = std::pair<std::string, std::string>;
    EXPECT_EQ(row.at("default_mean_mm"), pooled[Key(row.at("shape"), "sag")].at("mean_mm"));
    EXPECT_EQ(row.at("fitted_mean_mm"), pooled[Key(row.at("shape"), "fitted")].at("mean_mm"));
    // The bar's reference: the default hand with the default model.
    EXPECT_EQ(row.at("reference_mm"), pooled[Key("default", "sag")].at("mean_mm"));
    EXPECT_GT(number(row, "fit_scale"), 0.5);
    EXPECT_LT(number(row, "fit_scale"), 1.5);
    // The routine's tracker's size, where the fit starts: within TrackerParams' bounds.
    EXPECT_GE(number(row, "fit_start_size"), TrackerParams().size_min);
    EXPECT_LE(number(row, "fit_start_size"), TrackerParams().size_max);
    EXPECT_GT(number(row, "energy_after"), 0.0);
    EXPECT_GT(number(row, "fit_seconds"), 0.0);
    EXPECT_NEAR(number(row, "fit_worst_bone_pct"), worst_bone_pct[row.at("shape")], 0.01);
    EXPECT_LE(number(row, "fit_bones_within_5pct"), 15.0);
    const bool lower = number(row, "fitted_mean_mm") < number(row, "default_mean_mm") &&
                       number(row, "fitted_failed") <= number(row, "default_failed");
    EXPECT_EQ(number(row, "fitted_lower"), lower ? 1.0 : 0.0);
    EXPECT_EQ(number(row, "fitted_within_20pct"),
              number(row, "fitted_mean_mm") <= 1.2 * number(row, "reference_mm") ? 1.0 : 0.0);
  }

  // A routine of 30 frames (0.8 s of the hand) is too short: every fit fails, is reported, and
  // the run goes on with the default model; the models of the run above stay as they were.
  const std::string model_before = readText(dir_ / "models" / "long_distal.yaml");
  std::ostringstream short_log;
  const BenchmarkResults failed = runBenchmark(
      options("--fitted --models sag --shapes default,long_distal --frames 24 --routine-frames 30 "
              "--no-plots"),
      short_log);
  ASSERT_EQ(failed.fits.size(), 2u);
  for (const ShapeFit& fit : failed.fits) {
    SCOPED_TRACE(fit.shape);
    EXPECT_FALSE(fit.ok);
    EXPECT_TRUE(fit.model.empty());
    EXPECT_NE(fit.error.find("the fit needs 40"), std::string::npos) << fit.error;
    EXPECT_NE(short_log.str().find("the fit on hand " + fit.shape + " failed"), std::string::npos)
        << short_log.str();
  }
  ASSERT_EQ(failed.runs.size(), 2u);  // the default model on both hands, nothing fitted
  for (const BenchmarkRun& run : failed.runs) EXPECT_EQ(run.tracker, "sag");
  EXPECT_EQ(readText(dir_ / "models" / "long_distal.yaml"), model_before);
  for (const char* part : {"| fit failed |", "no (fit failed)", "| long_distal | failed: "}) {
    EXPECT_NE(failed.markdown.find(part), std::string::npos) << part << "\n" << failed.markdown;
  }
  const auto failed_rows = readCsv((dir_ / "fitted.csv").string(), &header);
  ASSERT_EQ(failed_rows.size(), 2u);
  for (const auto& row : failed_rows) {
    EXPECT_EQ(row.at("fit"), "failed");
    EXPECT_EQ(row.at("fitted_mean_mm"), "-");
    EXPECT_EQ(row.at("fitted_lower"), "0");
    EXPECT_NE(row.at("error").find("the fit needs 40"), std::string::npos) << row.at("error");
  }
}

TEST_F(BenchmarkTool, BenchmarkRunsTheRoomsOnEachHand) {
  std::ostringstream log;
  const BenchmarkResults results = runBenchmark(
      options("--rooms office --room-configs skin+cues --models sag --shapes default,dark_small "
              "--sequences pinch --frames 24"),
      log);
  std::vector<std::string> header;
  const auto rows = readCsv((dir_ / "rooms.csv").string(), &header);
  EXPECT_NE(std::find(header.begin(), header.end(), "hand"), header.end());
  // One row per hand and room (the clean studio and the office), each hand rendered as asked.
  std::map<std::pair<std::string, std::string>, std::map<std::string, std::string>> by_hand_room;
  for (const auto& row : rows) by_hand_room[{row.at("hand"), row.at("room")}] = row;
  ASSERT_EQ(rows.size(), 4u) << results.markdown;
  for (const std::string hand : {"default", "dark_small"}) {
    for (const std::string room : {"clean", "office"}) {
      SCOPED_TRACE(hand + " " + room);
      ASSERT_TRUE(by_hand_room.count({hand, room}));
      const auto& row = by_hand_room[{hand, room}];
      EXPECT_EQ(row.at("model"), "SAG");
      EXPECT_EQ(number(row, "frames"), 14.0);  // 24 rendered, 10 without the hand
      EXPECT_GT(number(row, "recall"), 0.3);
      EXPECT_NE(log.str().find("benchmark --rooms: pinch " + hand + " " + room), std::string::npos);
    }
  }
  // Another hand gives other images: not the default hand's run under another name.
  const auto& dark_clean = by_hand_room[{"dark_small", "clean"}];
  const auto& default_clean = by_hand_room[{"default", "clean"}];
  EXPECT_NE(dark_clean.at("recall"), default_clean.at("recall"));
  EXPECT_NE(dark_clean.at("error_mean_mm"), default_clean.at("error_mean_mm"));
  // The report names the hands and pools each over the sequences, against its own clean run.
  for (const char* part :
       {"Hands: default (", "; dark_small (a small slim hand",
        "## Per hand, pooled over the sequences", "| dark_small | SAG, skin + cues | ",
        "| pinch | dark_small | office | SAG | skin | yes |"}) {
    EXPECT_NE(results.markdown.find(part), std::string::npos) << part << "\n" << results.markdown;
  }
  EXPECT_EQ(readText(dir_ / "rooms.md"), results.markdown);
}
