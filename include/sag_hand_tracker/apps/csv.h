// The tracking CSV: one row per frame with the stamp, the five fingertips in the root frame, the
// 26 pose parameters and the energy. track_bag writes it; render_bag writes the ground truth in
// the same columns; the benchmark reads both. No ROS.
//
//   stamp,thumb_x,thumb_y,thumb_z,index_x,...,pinky_z,<parameter names...>,energy[,status]
//
// track_bag adds the column `status` (started, tracked or lost); the ground truth has none.
// stamp in seconds (6 decimals), fingertips in metres, parameters in metres and radians (the
// order of HandModel::parameterNames()), numbers with 9 significant digits; "nan" where a value
// does not exist (for example the energy of a ground-truth row).
#pragma once

#include <Eigen/Core>
#include <array>
#include <fstream>
#include <string>
#include <vector>

#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

// Every column name in order, for the given parameter names.
std::vector<std::string> trackingCsvColumns(const std::vector<std::string>& parameter_names);

struct TrackingCsvRow {
  double stamp = 0.0;
  Fingertips fingertips;       // thumb..pinky, root frame (metres)
  Eigen::VectorXd parameters;  // one per parameter name
  double energy = 0.0;
  std::string status;  // "" when the file has no status column
};

class TrackingCsvWriter {
 public:
  // Creates (truncates) `path` and writes the header row, with the status column if asked.
  // Throws InputError if it cannot.
  TrackingCsvWriter(const std::string& path, std::vector<std::string> parameter_names,
                    bool status_column = false);
  ~TrackingCsvWriter();
  TrackingCsvWriter(const TrackingCsvWriter&) = delete;
  TrackingCsvWriter& operator=(const TrackingCsvWriter&) = delete;

  // Throws std::invalid_argument if the row has the wrong number of parameters, InputError if
  // the file cannot be written.
  void write(const TrackingCsvRow& row);
  // Flushes and closes; throws InputError on a write error. Called by the destructor (which
  // swallows errors) if not called before.
  void close();

  int rows() const { return rows_; }
  const std::string& path() const { return path_; }
  const std::vector<std::string>& parameterNames() const { return parameter_names_; }

 private:
  std::string path_;
  std::vector<std::string> parameter_names_;
  bool status_column_ = false;
  std::ofstream file_;
  int rows_ = 0;
};

struct TrackingCsv {
  std::vector<std::string> parameter_names;
  bool has_status = false;
  std::vector<TrackingCsvRow> rows;
};

// Reads a tracking CSV. Throws InputError naming the file, the line and the problem (missing
// file, a header that is not the tracking columns, a row with the wrong number of fields or a
// field that is not a number).
TrackingCsv readTrackingCsv(const std::string& path);

}  // namespace sag_hand_tracker
