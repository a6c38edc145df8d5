// Output files are never lost: written next to their path, renamed on success, and an output
// that is an input (same path, symlink, hard link) or not a regular file is refused.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "sag_hand_tracker/util/atomic_output.h"
#include "test_support/temp_files.h"

using namespace sag_hand_tracker;
namespace fs = std::filesystem;

namespace {

class AtomicOutput : public sag_test::TempDirTest {
 protected:
  int filesInDir() const {
    int count = 0;
    for (const auto& entry : fs::directory_iterator(dir_)) {
      (void)entry;
      ++count;
    }
    return count;
  }
};

}  // namespace

TEST_F(AtomicOutput, AFailedWriteLeavesTheOldFileAndNoTemporary) {
  const std::string out = write("out.csv", "precious\n");
  {
    AtomicOutputFile file(out, /*overwrite=*/true);
    EXPECT_NE(file.tempPath(), out);
    EXPECT_EQ(fs::path(file.tempPath()).parent_path(), fs::path(out).parent_path());
    EXPECT_EQ(fs::path(file.tempPath()).extension(), ".csv");  // imwrite goes by the extension
    std::ofstream(file.tempPath()) << "half";
    // No commit: the run failed.
  }
  EXPECT_EQ(readAll(out), "precious\n");
  EXPECT_EQ(filesInDir(), 1);
}

TEST_F(AtomicOutput, CommitReplacesTheFile) {
  const std::string out = write("out.csv", "old\n");
  {
    AtomicOutputFile file(out, /*overwrite=*/true);
    std::ofstream(file.tempPath()) << "new\n";
    file.commit();
  }
  EXPECT_EQ(readAll(out), "new\n");
  EXPECT_EQ(filesInDir(), 1);
}

TEST_F(AtomicOutput, ASymlinkedOutputReplacesItsTargetAndKeepsTheLink) {
  const std::string target = write("target.csv", "old\n");
  fs::create_symlink(target, path("link.csv"));
  {
    AtomicOutputFile file(path("link.csv"), /*overwrite=*/true);
    std::ofstream(file.tempPath()) << "new\n";
    file.commit();
  }
  EXPECT_TRUE(fs::is_symlink(path("link.csv")));
  EXPECT_EQ(readAll(target), "new\n");
}

TEST_F(AtomicOutput, AnOutputThatIsAnInputIsRefused) {
  const std::string input = write("in.bag", "data");
  fs::create_symlink(input, path("link.bag"));
  fs::create_hard_link(input, path("hard.bag"));
  for (const std::string& out :
       {input, path("link.bag"), path("hard.bag"), dir_.string() + "/./in.bag"}) {
    const std::string message = sag_test::inputErrorOf([&] {
      checkOutputPath(out, {"other.yaml", input});
    });
    EXPECT_EQ(message,
              "--out " + out + " is the input " + input + "; refusing to overwrite an input");
  }
  EXPECT_EQ(readAll(input), "data");
  EXPECT_NO_THROW(checkOutputPath(path("new.csv"), {input}));
}

// A file that existed before the run (or a symlink to one) is replaced only when asked to.
TEST_F(AtomicOutput, AnExistingFileIsReplacedOnlyWithOverwrite) {
  const std::string existing = write("old.csv", "precious");
  fs::create_symlink(existing, path("link.csv"));
  for (const std::string& out : {existing, path("link.csv")}) {
    EXPECT_EQ(sag_test::inputErrorOf([&] { checkOutputIsNew(out, false, "--gt-csv"); }),
              "--gt-csv " + out +
                  " exists; it is not replaced (--overwrite replaces it, or choose another name)");
    EXPECT_NO_THROW(checkOutputIsNew(out, true));
  }
  EXPECT_NO_THROW(checkOutputIsNew(path("new.csv"), false));
  EXPECT_EQ(readAll(existing), "precious");
}

TEST_F(AtomicOutput, AnOutputThatIsNotARegularFileIsRefused) {
  EXPECT_NE(sag_test::inputErrorOf([&] {
              checkOutputPath(dir_.string(), {});
            }).find("exists and is not a regular file"),
            std::string::npos);
  EXPECT_NE(sag_test::inputErrorOf([&] {
              checkOutputPath("/dev/null", {}, "--gt-csv");
            }).find("--gt-csv /dev/null exists and is not a regular file"),
            std::string::npos);
}

TEST_F(AtomicOutput, AMissingFolderIsNamed) {
  const std::string message =
      sag_test::inputErrorOf([&] { AtomicOutputFile file(path("no/such/out.csv"), false); });
  EXPECT_NE(message.find("does not exist"), std::string::npos) << message;
}

// Without overwrite the commit replaces nothing, also what appeared at the path while the output
// was written (track_bag checked only before the run, and renamed over a file created meanwhile):
// the file stays, the error names the path and where the finished output was kept.
TEST_F(AtomicOutput, ACommitWithoutOverwriteReplacesAFileCreatedMeanwhile) {
  const std::string out = path("out.csv");
  std::string kept;
  {
    AtomicOutputFile file(out, /*overwrite=*/false, "--out");
    std::ofstream(file.tempPath()) << "the run's rows\n";
    write("out.csv", "mine\n");  // created during the run
    const std::string message = sag_test::inputErrorOf([&] { file.commit(); });
    kept = file.keptPath();
    ASSERT_FALSE(kept.empty());
    EXPECT_EQ(message, "--out " + out +
                           ": a file was created there while the output was written; it is not "
                           "replaced; the new output is kept in " +
                           kept);
  }
  EXPECT_EQ(readAll(out), "mine\n");
  EXPECT_EQ(readAll(kept), "the run's rows\n") << "the work is kept after the object is gone";
  EXPECT_EQ(filesInDir(), 2);
}

TEST_F(AtomicOutput, ACommitWithoutOverwriteCreatesTheFileAndLeavesNoTemporary) {
  const std::string out = path("out.csv");
  {
    AtomicOutputFile file(out, /*overwrite=*/false);
    std::ofstream(file.tempPath()) << "new\n";
    file.commit();
    EXPECT_TRUE(file.keptPath().empty());
  }
  EXPECT_EQ(readAll(out), "new\n");
  EXPECT_EQ(filesInDir(), 1);
}

// A dangling symlink is something at the path: it was replaced by a regular file.
TEST_F(AtomicOutput, ADanglingSymlinkIsNotReplacedWithoutOverwrite) {
  const std::string link = path("link.csv");
  fs::create_symlink("nothere.csv", link);
  EXPECT_EQ(sag_test::inputErrorOf([&] { checkOutputIsNew(link, false); }),
            "--out " + link +
                " exists; it is not replaced (--overwrite replaces it, or choose another name)");
  {
    AtomicOutputFile file(link, /*overwrite=*/false);
    std::ofstream(file.tempPath()) << "new\n";
    EXPECT_NE(sag_test::inputErrorOf([&] { file.commit(); }).find(link + ": a file was created"),
              std::string::npos);
  }
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(fs::read_symlink(link), "nothere.csv");
  EXPECT_FALSE(fs::exists(path("nothere.csv")));
}
