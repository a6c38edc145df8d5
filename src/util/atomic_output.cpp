#include "sag_hand_tracker/util/atomic_output.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace {

namespace fs = std::filesystem;

}  // namespace

void checkOutputPath(const std::string& out, const std::vector<std::string>& inputs,
                     const std::string& option) {
  std::error_code error;
  const fs::file_status status = fs::status(out, error);
  if (fs::exists(status) && !fs::is_regular_file(status)) {
    throw InputError(option + " " + out +
                     " exists and is not a regular file; refusing to replace it");
  }
  for (const std::string& input : inputs) {
    if (input.empty()) continue;
    const bool same_path = fs::weakly_canonical(out, error) == fs::weakly_canonical(input, error);
    // equivalent() compares device and inode: symlinks and hard links to the input too.
    const bool same_file =
        fs::exists(status) && fs::exists(input, error) && fs::equivalent(out, input, error);
    if (same_path || same_file) {
      throw InputError(option + " " + out + " is the input " + input +
                       "; refusing to overwrite an input");
    }
  }
}

void checkDistinctOutputs(const std::vector<std::pair<std::string, std::string>>& outputs) {
  std::error_code error;
  for (std::size_t b = 0; b < outputs.size(); ++b) {
    if (outputs[b].second.empty()) continue;
    for (std::size_t a = 0; a < b; ++a) {
      if (outputs[a].second.empty()) continue;
      if (fs::weakly_canonical(outputs[a].second, error) ==
          fs::weakly_canonical(outputs[b].second, error)) {
        throw InputError(outputs[b].first + " " + outputs[b].second + " is also " +
                         outputs[a].first + " " + outputs[a].second +
                         "; each output needs a file of its own");
      }
    }
  }
}

void checkOutputIsNew(const std::string& out, bool overwrite, const std::string& option,
                      const std::string& refusal) {
  std::error_code error;
  // symlink_status: a dangling symlink is something at `out` too.
  if (overwrite || !fs::exists(fs::symlink_status(out, error))) return;
  throw InputError(option + " " + out + refusal);
}

AtomicOutputFile::AtomicOutputFile(const std::string& path, bool overwrite,
                                   const std::string& option)
    : path_(path),
      target_(path),
      named_(option.empty() ? path : option + " " + path),
      overwrite_(overwrite) {
  std::error_code error;
  if (overwrite && fs::is_symlink(fs::symlink_status(path, error))) {
    target_ = fs::weakly_canonical(path, error).string();
    if (error) throw InputError(named_ + ": cannot resolve the symlink: " + error.message());
  }
  const fs::path target(target_);
  const fs::path folder = target.has_parent_path() ? target.parent_path() : fs::path(".");
  if (!fs::is_directory(folder, error)) {
    throw InputError(named_ + ": the folder " + folder.string() + " does not exist");
  }
  const std::string extension = target.extension().string();
  std::string pattern =
      (folder / ("." + target.filename().string() + ".tmp-XXXXXX")).string() + extension;
  const int fd = ::mkstemps(&pattern[0], static_cast<int>(extension.size()));
  if (fd < 0) {
    throw InputError(named_ + ": cannot create a file in " + folder.string() + ": " +
                     std::strerror(errno));
  }
  // mkstemp makes the file 0600; an output gets the usual 0666 minus the umask.
  const mode_t mask = ::umask(0);
  ::umask(mask);
  ::fchmod(fd, 0666 & ~mask);
  ::close(fd);
  temp_path_ = pattern;
}

AtomicOutputFile::~AtomicOutputFile() {
  if (!temp_path_.empty()) std::remove(temp_path_.c_str());
}

void AtomicOutputFile::commit() {
  if (temp_path_.empty()) return;
  std::string problem;
  if (overwrite_) {
    if (std::rename(temp_path_.c_str(), target_.c_str()) != 0) {
      problem = std::string("cannot replace it with the new output: ") + std::strerror(errno);
    }
  } else {
    // A check before a rename would leave a window in which a file created at path_ is lost.
    int result = ::link(temp_path_.c_str(), path_.c_str());
    bool linked = result == 0;
    if (result != 0 && (errno == EPERM || errno == EOPNOTSUPP || errno == ENOSYS)) {
      // A file system without hard links (vfat, some network mounts): the kernel's own
      // no-replace rename, where it has one.
      result = ::renameat2(AT_FDCWD, temp_path_.c_str(), AT_FDCWD, path_.c_str(), RENAME_NOREPLACE);
    }
    if (result != 0) {
      problem = errno == EEXIST ? std::string(
                                      "a file was created there while the output was "
                                      "written; it is not replaced")
                                : std::string("cannot create it: ") + std::strerror(errno);
    } else if (linked) {
      ::unlink(temp_path_.c_str());
    }
  }
  if (!problem.empty()) {
    kept_path_ = temp_path_;
    temp_path_.clear();
    throw InputError(named_ + ": " + problem + "; the new output is kept in " + kept_path_);
  }
  temp_path_.clear();
}

}  // namespace sag_hand_tracker
