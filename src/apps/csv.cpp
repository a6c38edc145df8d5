#include "sag_hand_tracker/apps/csv.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

namespace sag_hand_tracker {
namespace {

constexpr int kFixedLeadingColumns = 1 + 3 * kNumFingers;  // stamp + fingertips

void appendNumber(std::string* line, const char* format, double value) {
  char buffer[64];
  if (std::isnan(value)) {
    *line += "nan";
    return;
  }
  std::snprintf(buffer, sizeof(buffer), format, value);
  *line += buffer;
}

std::vector<std::string> splitFields(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream stream(line);
  while (std::getline(stream, field, ',')) fields.push_back(field);
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

}  // namespace

std::vector<std::string> trackingCsvColumns(const std::vector<std::string>& parameter_names) {
  std::vector<std::string> columns{"stamp"};
  for (const char* finger : fingerNames()) {
    for (const char* axis : {"_x", "_y", "_z"}) columns.push_back(std::string(finger) + axis);
  }
  columns.insert(columns.end(), parameter_names.begin(), parameter_names.end());
  columns.push_back("energy");
  return columns;
}

TrackingCsvWriter::TrackingCsvWriter(const std::string& path,
                                     std::vector<std::string> parameter_names, bool status_column)
    : path_(path), parameter_names_(std::move(parameter_names)), status_column_(status_column) {
  for (const std::string& name : parameter_names_) {
    if (name.empty() || name.find_first_of(",\"\n\r") != std::string::npos) {
      throw std::invalid_argument("TrackingCsvWriter: bad parameter name '" + name + "'");
    }
  }
  file_.open(path_, std::ios::out | std::ios::trunc);
  if (!file_) throw InputError(path_ + ": cannot create the CSV file");
  std::vector<std::string> columns = trackingCsvColumns(parameter_names_);
  if (status_column_) columns.push_back("status");
  std::string header;
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (i > 0) header += ',';
    header += columns[i];
  }
  file_ << header << '\n';
  if (!file_) throw InputError(path_ + ": cannot write the CSV file");
}

TrackingCsvWriter::~TrackingCsvWriter() {
  try {
    close();
  } catch (const InputError&) {
  }
}

void TrackingCsvWriter::write(const TrackingCsvRow& row) {
  if (row.parameters.size() != static_cast<Eigen::Index>(parameter_names_.size())) {
    throw std::invalid_argument("TrackingCsvWriter: row has " +
                                std::to_string(row.parameters.size()) + " parameters, expected " +
                                std::to_string(parameter_names_.size()));
  }
  if (!file_.is_open()) throw InputError(path_ + ": the CSV file is closed");
  std::string line;
  line.reserve(32 * (kFixedLeadingColumns + parameter_names_.size() + 1));
  appendNumber(&line, "%.6f", row.stamp);
  for (const Eigen::Vector3d& tip : row.fingertips) {
    for (int axis = 0; axis < 3; ++axis) {
      line += ',';
      appendNumber(&line, "%.9g", tip[axis]);
    }
  }
  for (Eigen::Index i = 0; i < row.parameters.size(); ++i) {
    line += ',';
    appendNumber(&line, "%.9g", row.parameters[i]);
  }
  line += ',';
  appendNumber(&line, "%.9g", row.energy);
  if (status_column_) {
    if (row.status.empty() || row.status.find_first_of(",\"\n\r") != std::string::npos) {
      throw std::invalid_argument("TrackingCsvWriter: bad status '" + row.status + "'");
    }
    line += ',' + row.status;
  }
  line += '\n';
  file_ << line;
  if (!file_) throw InputError(path_ + ": cannot write the CSV file");
  ++rows_;
}

void TrackingCsvWriter::close() {
  if (!file_.is_open()) return;
  file_.close();
  if (file_.fail()) throw InputError(path_ + ": error while writing the CSV file");
}

TrackingCsv readTrackingCsv(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw InputError(path + ": cannot open the CSV file");
  std::string line;
  if (!std::getline(file, line)) throw InputError(path + ": the CSV file is empty");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  std::vector<std::string> header = splitFields(line);
  TrackingCsv csv;
  csv.has_status = !header.empty() && header.back() == "status";
  if (csv.has_status) header.pop_back();
  const int num_columns = static_cast<int>(header.size());
  if (num_columns < kFixedLeadingColumns + 1 || header.back() != "energy") {
    throw InputError(path +
                     ":1: not a tracking CSV header (stamp, fingertips, parameters, energy)");
  }
  csv.parameter_names.assign(header.begin() + kFixedLeadingColumns, header.end() - 1);
  if (header != trackingCsvColumns(csv.parameter_names)) {
    throw InputError(path +
                     ":1: not a tracking CSV header (stamp, fingertips, parameters, energy)");
  }
  const int num_parameters = static_cast<int>(csv.parameter_names.size());
  int line_number = 1;
  while (std::getline(file, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    std::vector<std::string> fields = splitFields(line);
    const int expected = num_columns + (csv.has_status ? 1 : 0);
    if (static_cast<int>(fields.size()) != expected) {
      throw InputError(path + ":" + std::to_string(line_number) + ": " +
                       std::to_string(fields.size()) + " fields, expected " +
                       std::to_string(expected));
    }
    std::string status;
    if (csv.has_status) {
      status = fields.back();
      fields.pop_back();
      if (status != "started" && status != "tracked" && status != "lost") {
        throw InputError(path + ":" + std::to_string(line_number) + ": status '" + status +
                         "' is not started, tracked or lost");
      }
    }
    std::vector<double> values(fields.size());
    for (std::size_t i = 0; i < fields.size(); ++i) {
      const char* begin = fields[i].c_str();
      char* end = nullptr;
      errno = 0;
      values[i] = std::strtod(begin, &end);
      if (fields[i].empty() || end != begin + fields[i].size() ||
          (errno == ERANGE && std::isinf(values[i]))) {
        throw InputError(path + ":" + std::to_string(line_number) + ": column '" + header[i] +
                         "' is not a number: '" + fields[i] + "'");
      }
    }
    TrackingCsvRow row;
    row.stamp = values[0];
    for (int finger = 0; finger < kNumFingers; ++finger) {
      row.fingertips[finger] =
          Eigen::Vector3d(values[1 + 3 * finger], values[2 + 3 * finger], values[3 + 3 * finger]);
    }
    row.parameters =
        Eigen::Map<const Eigen::VectorXd>(values.data() + kFixedLeadingColumns, num_parameters);
    row.energy = values.back();
    row.status = status;
    csv.rows.push_back(std::move(row));
  }
  return csv;
}

}  // namespace sag_hand_tracker
