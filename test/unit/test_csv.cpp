#include <gtest/gtest.h>

#include "test_support/temp_files.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "sag_hand_tracker/apps/csv.h"

using namespace sag_hand_tracker;
namespace fs = std::filesystem;

namespace {

class CsvFiles : public sag_test::TempDirTest {};

TrackingCsvRow exampleRow(double stamp, int num_parameters) {
  TrackingCsvRow row;
  row.stamp = stamp;
  for (int finger = 0; finger < kNumFingers; ++finger) {
    row.fingertips[finger] = Eigen::Vector3d(0.125 + 0.01 * finger, -0.25 + 0.001 * finger, 0.6);
  }
  row.parameters = Eigen::VectorXd::LinSpaced(num_parameters, -1.5, 2.25);
  row.energy = 0.731234567;
  return row;
}

}  // namespace

TEST(CsvColumns, CsvHeaderNamesEveryColumn) {
  const std::vector<std::string> columns = trackingCsvColumns({"tx", "ty", "index_mcp_flex"});
  const std::vector<std::string> expected{
      "stamp",    "thumb_x",  "thumb_y",  "thumb_z", "index_x",        "index_y", "index_z",
      "middle_x", "middle_y", "middle_z", "ring_x",  "ring_y",         "ring_z",  "pinky_x",
      "pinky_y",  "pinky_z",  "tx",       "ty",      "index_mcp_flex", "energy"};
  EXPECT_EQ(columns, expected);
}

TEST_F(CsvFiles, CsvWritesHeaderAndRows) {
  std::vector<std::string> names;
  for (int i = 0; i < 26; ++i) names.push_back("p" + std::to_string(i));
  {
    TrackingCsvWriter writer(path("out.csv"), names);
    writer.write(exampleRow(1700000000.04, 26));
    writer.write(exampleRow(1700000000.08, 26));
    EXPECT_EQ(writer.rows(), 2);
  }
  const std::string text = readAll(path("out.csv"));
  std::istringstream lines(text);
  std::string header, first, second, extra;
  ASSERT_TRUE(std::getline(lines, header));
  ASSERT_TRUE(std::getline(lines, first));
  ASSERT_TRUE(std::getline(lines, second));
  EXPECT_FALSE(std::getline(lines, extra));
  EXPECT_EQ(header.rfind("stamp,thumb_x,thumb_y,thumb_z,index_x,", 0), 0u) << header;
  EXPECT_NE(header.find(",pinky_z,p0,p1,"), std::string::npos) << header;
  EXPECT_EQ(header.substr(header.size() - 11), ",p25,energy");
  EXPECT_EQ(std::count(first.begin(), first.end(), ','), 15 + 26 + 1);
  EXPECT_EQ(first.rfind("1700000000.040000,0.125,-0.25,0.6,0.135,-0.249,0.6,", 0), 0u) << first;
  EXPECT_EQ(first.substr(first.size() - 12), ",0.731234567") << first;
}

TEST_F(CsvFiles, CsvRoundTrip) {
  const std::vector<std::string> names{"a", "b", "c"};
  TrackingCsvRow row = exampleRow(12.5, 3);
  row.parameters << 0.123456789, -3.0e-7, 1.0;
  TrackingCsvRow ground_truth = exampleRow(12.54, 3);
  ground_truth.energy = std::nan("");
  {
    TrackingCsvWriter writer(path("r.csv"), names);
    writer.write(row);
    writer.write(ground_truth);
    writer.close();
  }
  const TrackingCsv csv = readTrackingCsv(path("r.csv"));
  EXPECT_EQ(csv.parameter_names, names);
  ASSERT_EQ(csv.rows.size(), 2u);
  EXPECT_DOUBLE_EQ(csv.rows[0].stamp, 12.5);
  EXPECT_NEAR(csv.rows[1].stamp, 12.54, 1e-9);
  for (int finger = 0; finger < kNumFingers; ++finger) {
    EXPECT_LT((csv.rows[0].fingertips[finger] - row.fingertips[finger]).norm(), 1e-9);
  }
  EXPECT_DOUBLE_EQ(csv.rows[0].parameters[0], 0.123456789);
  EXPECT_DOUBLE_EQ(csv.rows[0].parameters[1], -3.0e-7);
  EXPECT_DOUBLE_EQ(csv.rows[0].energy, 0.731234567);
  EXPECT_TRUE(std::isnan(csv.rows[1].energy));
}

TEST_F(CsvFiles, CsvRejectsWrongParameterCount) {
  TrackingCsvWriter writer(path("w.csv"), {"a", "b"});
  EXPECT_THROW(writer.write(exampleRow(0.0, 3)), std::invalid_argument);
  EXPECT_EQ(writer.rows(), 0);
}

TEST_F(CsvFiles, CsvErrors) {
  EXPECT_NE(sag_test::inputErrorOf([&] {
              TrackingCsvWriter(path("no/such/dir/x.csv"), {"a"});
            }).find("cannot create the CSV file"),
            std::string::npos);
  EXPECT_NE(
      sag_test::inputErrorOf([&] { readTrackingCsv(path("absent.csv")); }).find("cannot open"),
      std::string::npos);
  EXPECT_NE(sag_test::inputErrorOf([&] {
              readTrackingCsv(write("h.csv", "stamp,x,energy\n"));
            }).find("h.csv:1: not a tracking CSV header"),
            std::string::npos);

  {
    TrackingCsvWriter writer(path("good.csv"), {"a"});
    writer.write(exampleRow(1.0, 1));
  }
  std::string text = readAll(path("good.csv"));
  const std::string short_row = write("short.csv", text + "2.0,1,2\n");
  EXPECT_NE(sag_test::inputErrorOf([&] {
              readTrackingCsv(short_row);
            }).find("short.csv:3: 3 fields, expected 18"),
            std::string::npos);
  const std::size_t last_comma = text.rfind(',');
  const std::string bad_number = write("bad.csv", text.substr(0, last_comma) + ",0.5x\n");
  EXPECT_NE(sag_test::inputErrorOf([&] {
              readTrackingCsv(bad_number);
            }).find("bad.csv:2: column 'energy' is not a number: '0.5x'"),
            std::string::npos);
}
