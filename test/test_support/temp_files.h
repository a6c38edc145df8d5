// Test helpers for tests that write files: a fresh temporary folder per test, the message of the
// InputError an action throws, a stream that creates a file when written to, and a run during
// which a file appears at its output.
#pragma once

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <streambuf>
#include <string>

#include "sag_hand_tracker/util/types.h"

namespace sag_test {

class TempDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device random;
    dir_ = std::filesystem::temp_directory_path() /
           ("sag_test_" + std::to_string(random()) + std::to_string(random()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path(name)) << text;
    return path(name);
  }
  static std::string readAll(const std::string& file) {
    std::ifstream in(file);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  }

  // What a program printed and its exit status.
  struct ToolRun {
    int status = -1;
    std::string out;
    std::string err;
  };
  // Runs a shell command line with stdout and stderr captured in this test's folder.
  ToolRun runTool(const std::string& command) const {
    const std::string line =
        command + " > '" + path("stdout.txt") + "' 2> '" + path("stderr.txt") + "'";
    ToolRun run;
    const int status = std::system(line.c_str());
    run.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    run.out = readAll(path("stdout.txt"));
    run.err = readAll(path("stderr.txt"));
    return run;
  }

  std::filesystem::path dir_;
};

// A stream that creates `path` (holding "mine") the first time it is written to: as the output of
// a run's progress bar, which is written after the first frame, the file appears during the run.
class CreateOnWrite : public std::streambuf {
 public:
  explicit CreateOnWrite(std::string path) : path_(std::move(path)) {}

 protected:
  int overflow(int c) override {
    create();
    return traits_type::not_eof(c);
  }
  std::streamsize xsputn(const char*, std::streamsize count) override {
    create();
    return count;
  }

 private:
  void create() {
    if (created_) return;
    std::ofstream(path_) << "mine\n";
    created_ = true;
  }
  std::string path_;
  bool created_ = false;
};

// Runs `action`, expects a sag_hand_tracker::InputError, and returns its message.
template <typename Action>
std::string inputErrorOf(Action action) {
  try {
    action();
  } catch (const sag_hand_tracker::InputError& error) {
    return error.what();
  }
  ADD_FAILURE() << "no InputError thrown";
  return "";
}

// A file created at --out `out` while a tool runs: `run(stream)` runs the tool with its progress
// written to `stream`, which creates `out` (CreateOnWrite) after the first frame. Expects the
// tool to refuse to replace it, naming --out and the file the finished output was kept in (in
// `out`'s folder), and `out` to hold what was created. Returns the kept file's path ("" if not).
template <typename Run>
std::string keptOutputOfARace(const std::string& out, Run run) {
  CreateOnWrite creator(out);
  std::ostream stream(&creator);
  const std::string message = inputErrorOf([&] { run(stream); });
  std::ifstream created(out);
  std::stringstream content;
  content << created.rdbuf();
  EXPECT_EQ(content.str(), "mine\n") << "the file created during the run is kept";
  const std::string prefix = "--out " + out +
                             ": a file was created there while the output was written; it is not "
                             "replaced; the new output is kept in ";
  if (message.rfind(prefix, 0) != 0) {
    ADD_FAILURE() << message;
    return "";
  }
  const std::string kept = message.substr(prefix.size());
  EXPECT_EQ(std::filesystem::path(kept).parent_path(), std::filesystem::path(out).parent_path());
  return kept;
}

}  // namespace sag_test
