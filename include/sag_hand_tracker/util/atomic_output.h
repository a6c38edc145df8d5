// Output files that are never half-written and never lose a file: the tools write to a temporary
// file in the output's folder and rename it over the output only when everything succeeded. On
// failure the temporary file is removed and whatever was at the output path is untouched. No ROS.
#pragma once

#include <string>
#include <vector>

namespace sag_hand_tracker {

// Throws InputError "<option> <out> is the input <input>" when `out` names the same file as one
// of `inputs` (the same path, or the same file through a symlink or a hard link), and when `out`
// exists but is not a regular file (a directory, a device such as /dev/full). Call it before
// anything is opened.
void checkOutputPath(const std::string& out, const std::vector<std::string>& inputs,
                     const std::string& option = "--out");

// Throws InputError "<option> <out><refusal>" when something is at `out` (a symlink to a file
// counts) and `overwrite` is false: a tool replaces no file that existed before it ran unless
// asked to (--overwrite; calibrate_hand never, with its own `refusal`). Call it with
// checkOutputPath, before anything is opened.
void checkOutputIsNew(const std::string& out, bool overwrite, const std::string& option = "--out",
                      const std::string& refusal =
                          " exists; it is not replaced (--overwrite "
                          "replaces it, or choose another name)");

class AtomicOutputFile {
 public:
  // Creates an empty temporary file next to `path` (same folder, so the final rename is atomic;
  // it keeps the extension, for writers that choose the format by it). A symlink at `path` is
  // followed: its target is what gets replaced. Throws InputError if the folder is not writable.
  explicit AtomicOutputFile(const std::string& path);
  // Removes the temporary file unless commit() succeeded.
  ~AtomicOutputFile();
  AtomicOutputFile(const AtomicOutputFile&) = delete;
  AtomicOutputFile& operator=(const AtomicOutputFile&) = delete;

  // The file to write to.
  const std::string& tempPath() const { return temp_path_; }
  // Where the result goes.
  const std::string& path() const { return path_; }
  // Renames the temporary file to path(); throws InputError if it cannot.
  void commit();

 private:
  std::string path_;       // as given (for messages)
  std::string target_;     // path_ with a symlink resolved
  std::string temp_path_;  // empty once committed
};

}  // namespace sag_hand_tracker
