// Output files that are never half-written and never lose a file: the tools write to a temporary
// file in the output's folder and move it to the output only when everything succeeded (over a
// file already there only when asked to). On failure the temporary file is removed and whatever was
// at the output path is untouched. No ROS.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace sag_hand_tracker {

// Throws InputError "<option> <out> is the input <input>" when `out` names the same file as one
// of `inputs` (the same path, or the same file through a symlink or a hard link), and when `out`
// exists but is not a regular file (a directory, a device such as /dev/full). Call it before
// anything is opened.
void checkOutputPath(const std::string& out, const std::vector<std::string>& inputs,
                     const std::string& option = "--out");

// Throws InputError "<option b> <path b> is also <option a> <path a>; each output needs a file of
// its own" when two of `outputs` ({option, path}; empty paths are skipped) name one file. Call it
// with checkOutputPath, before anything is opened.
void checkDistinctOutputs(const std::vector<std::pair<std::string, std::string>>& outputs);

// Throws InputError "<option> <out><refusal>" when something is at `out` (any symlink counts, even
// a dangling one: replacing it would put a regular file where the user had a link) and `overwrite`
// is false: a tool replaces no file that existed before it ran unless
// asked to (--overwrite; calibrate_hand never, with its own `refusal`). Call it with
// checkOutputPath, before anything is opened.
void checkOutputIsNew(const std::string& out, bool overwrite, const std::string& option = "--out",
                      const std::string& refusal =
                          " exists; it is not replaced (--overwrite "
                          "replaces it, or choose another name)");

class AtomicOutputFile {
 public:
  // Creates an empty temporary file next to `path` (same folder, so the final rename is atomic;
  // it keeps the extension, for writers that choose the format by it). With `overwrite` a symlink
  // at `path` is followed: its target is what gets replaced. Without it commit() replaces
  // nothing, not even what appeared at `path` while the output was written. `option` names the
  // path in messages ("--out"; empty: the path alone). Throws InputError if the folder is missing
  // or no file can be created in it: made before a long run, it checks that its output can be
  // written (calibrate_hand).
  AtomicOutputFile(const std::string& path, bool overwrite, const std::string& option = "");
  // Removes the temporary file unless commit() succeeded or kept it (keptPath()).
  ~AtomicOutputFile();
  AtomicOutputFile(const AtomicOutputFile&) = delete;
  AtomicOutputFile& operator=(const AtomicOutputFile&) = delete;

  // The file to write to.
  const std::string& tempPath() const { return temp_path_; }
  // Where the result goes.
  const std::string& path() const { return path_; }
  // Puts the temporary file at path(). With overwrite, rename(2) over whatever is there. Without,
  // link(2) to path() (which fails if anything is there, a dangling symlink too, with no window
  // between a check and the move), then the temporary name is removed. Throws InputError naming
  // the path and the problem if it cannot; the finished output is then kept at keptPath(), named
  // in the message: a run's work is never lost, and neither is the file at path().
  void commit();
  // Where a failed commit() left the output (empty: it did not fail).
  const std::string& keptPath() const { return kept_path_; }

 private:
  std::string path_;       // as given (for messages)
  std::string target_;     // path_ with a symlink resolved (with overwrite only)
  std::string temp_path_;  // empty once committed or kept
  std::string kept_path_;  // the temporary file left after a failed commit
  std::string named_;      // path_ as messages name it: "<option> <path>", or the path alone
  bool overwrite_ = false;
};

}  // namespace sag_hand_tracker
