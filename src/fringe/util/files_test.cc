#include "fringe/util/files.h"

#include <gtest/gtest.h>

#include <fstream>

#include "fringe/testing/file_size_limit.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::util {
namespace {

TEST(WriteAtomically, WritesAndLeavesNoTemporary) {
  test::TempDir dir;
  const fs::path out = dir / "a.txt";
  WriteAtomically(out, [](const fs::path& tmp) { std::ofstream(tmp) << "hello"; });
  EXPECT_EQ(ReadTextFile(out), "hello");
  int n = 0;
  for (auto& e : fs::directory_iterator(dir.path())) n += e.is_regular_file() ? 1 : 0;
  EXPECT_EQ(n, 1);
}

TEST(WriteAtomically, FailureLeavesNothing) {
  test::TempDir dir;
  const fs::path out = dir / "a.txt";
  EXPECT_THROW(WriteAtomically(out,
                               [](const fs::path& tmp) {
                                 std::ofstream(tmp) << "half";
                                 throw Error("boom");
                               }),
               Error);
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

// A full disk, simulated by a file size limit (tests/file_size_limit.h): the stream's failure
// is caught after close, whether a write failed on the way (a large file) or only the final
// flush at close did (a file smaller than the stream's buffer), and the error names the user's
// path and the reason, never the temporary; nothing is left.
TEST(CloseOutput, FullDiskFailsNamingThePathAndLeavesNothing) {
  test::TempDir dir;
  for (const size_t bytes : {size_t{1} << 20, size_t{3000}}) {
    const fs::path out = dir / "big.bin";
    const std::string data(bytes, 'x');
    std::string message;
    {
      const test::FileSizeLimit limit(1000);
      message = test::ErrorOf([&] {
        WriteAtomically(out, [&](const fs::path& tmp) {
          std::ofstream f(tmp, std::ios::binary);
          f.write(data.data(), static_cast<std::streamsize>(data.size()));
          CloseOutput(f, out);
        });
      });
    }
    EXPECT_NE(message.find(out.string() + ": cannot write: File too large"), std::string::npos)
        << bytes << ": " << message;
    EXPECT_EQ(message.find(".tmp"), std::string::npos) << message;
    EXPECT_TRUE(fs::is_empty(dir.path())) << bytes;
  }
  // Under the limit the same write succeeds.
  const test::FileSizeLimit limit(1000);
  WriteAtomically(dir / "small.bin", [&](const fs::path& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f << std::string(999, 'y');
    CloseOutput(f, dir / "small.bin");
  });
  EXPECT_EQ(FileSizeBytes(dir / "small.bin"), 999u);
}

TEST(WriteFolderAtomically, FullDiskNamesTheFileInsideTheOutputNotTheTemporary) {
  test::TempDir dir;
  const fs::path out = dir / "out";
  std::string message;
  {
    const test::FileSizeLimit limit(1000);
    message = test::ErrorOf([&] {
      WriteFolderAtomically(out, [&](const fs::path& tmp) {
        fs::create_directories(tmp / "views");
        WriteAtomically(tmp / "views" / "000.ply", [&](const fs::path& file) {
          std::ofstream f(file, std::ios::binary);
          f << std::string(5000, 'z');
          CloseOutput(f, tmp / "views" / "000.ply");
        });
      });
    });
  }
  EXPECT_NE(message.find((out / "views" / "000.ply").string() + ": cannot write: File too large"),
            std::string::npos)
      << message;
  EXPECT_EQ(message.find(".tmp"), std::string::npos) << message;
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

// A writer's own error names the file it was handed (the temporary): WriteAtomically and
// OutputTransaction::Write rethrow it naming the user's path, and leave nothing behind.
TEST(OutputTransaction, FullDiskNamesTheUsersFileNotTheTemporary) {
  test::TempDir dir;
  const fs::path small = dir / "small.json", big = dir / "big.tiff";
  const auto write_bytes = [](size_t bytes) {
    return [bytes](const fs::path& tmp) {
      std::ofstream f(tmp, std::ios::binary);
      f << std::string(bytes, 'x');
      CloseOutput(f, tmp);
    };
  };
  std::string message;
  {
    const test::FileSizeLimit limit(1000);
    message = test::ErrorOf([&] {
      OutputTransaction outputs;
      outputs.Write(small, write_bytes(10));
      outputs.Write(big, write_bytes(5000));
      outputs.Commit();
    });
  }
  EXPECT_NE(message.find(big.string() + ": cannot write: File too large"), std::string::npos)
      << message;
  EXPECT_EQ(message.find(".tmp"), std::string::npos) << message;
  EXPECT_TRUE(fs::is_empty(dir.path())) << "the staged small file is removed too";
  {
    const test::FileSizeLimit limit(1000);
    message = test::ErrorOf([&] { WriteAtomically(big, write_bytes(5000)); });
  }
  EXPECT_NE(message.find(big.string() + ": cannot write: File too large"), std::string::npos)
      << message;
  EXPECT_EQ(message.find(".tmp"), std::string::npos) << message;
  EXPECT_TRUE(fs::is_empty(dir.path()));
  // Within the limit both outputs arrive together.
  OutputTransaction outputs;
  outputs.Write(small, write_bytes(10));
  outputs.Write(big, write_bytes(500));
  EXPECT_FALSE(fs::exists(small)) << "nothing is in place before Commit()";
  outputs.Commit();
  EXPECT_EQ(FileSizeBytes(small), 10u);
  EXPECT_EQ(FileSizeBytes(big), 500u);
}

// An input folder whose parts are links (a view's left/ linking to the capture's own folder, an
// image linking to a file elsewhere, a link loop): an output that resolves into them is refused
// like one inside the folder itself, a new file there too (the one output rule: nothing is
// written inside an input), and the loop ends the walk.
TEST(CheckOutputFile, FilesReachedThroughLinksInAnInputFolderAreInputsToo) {
  test::TempDir dir;
  fs::create_directories(dir / "capture" / "L");
  std::ofstream(dir / "capture" / "L" / "0.png") << "image";
  std::ofstream(dir / "capture" / "x.png") << "other";
  fs::create_directories(dir / "view");
  fs::create_directory_symlink(dir / "capture" / "L", dir / "view" / "left");
  fs::create_symlink(dir / "capture" / "x.png", dir / "view" / "extra.png");
  fs::create_directory_symlink(dir / "view", dir / "view" / "loop");
  const std::vector<fs::path> inputs = {dir / "view"};
  const std::string through_dir =
      test::ErrorOf([&] { CheckOutputFile(dir / "view" / "left" / "0.png", inputs); });
  EXPECT_NE(through_dir.find("lies inside the input folder"), std::string::npos) << through_dir;
  EXPECT_NE(through_dir.find("linked from it"), std::string::npos) << through_dir;
  const std::string direct =
      test::ErrorOf([&] { CheckOutputFile(dir / "capture" / "L" / "0.png", inputs); });
  EXPECT_NE(direct.find("lies inside the input folder"), std::string::npos) << direct;
  const std::string file_link =
      test::ErrorOf([&] { CheckOutputFile(dir / "capture" / "x.png", inputs); });
  EXPECT_NE(file_link.find("lies inside the input folder"), std::string::npos) << file_link;
  OutputFolderOptions folder;
  folder.inputs = inputs;
  const std::string holder = test::ErrorOf([&] { CheckOutputFolder(dir / "capture", folder); });
  EXPECT_NE(holder.find("contains the input"), std::string::npos) << holder;
  const std::string new_file =
      test::ErrorOf([&] { CheckOutputFile(dir / "view" / "left" / "new.ply", inputs); });
  EXPECT_NE(new_file.find("lies inside the input folder"), std::string::npos) << new_file;
  EXPECT_NO_THROW(CheckOutputFile(dir / "out.ply", inputs));
  EXPECT_EQ(ReadTextFile(dir / "capture" / "L" / "0.png"), "image");
}

// The one output rule for folders: an output folder is not an input, holds none, and lies inside
// none (`fringe scan P --out P/views/002` made P unreadable: an extra view folder).
TEST(CheckOutputFolder, AFolderInsideAnInputFolderIsRefused) {
  test::TempDir dir;
  fs::create_directories(dir / "proj" / "views" / "000");
  std::ofstream(dir / "proj" / "scan.json") << "{}";
  OutputFolderOptions options;
  options.inputs = {dir / "proj"};
  const std::string inside =
      test::ErrorOf([&] { CheckOutputFolder(dir / "proj" / "views" / "002", options); });
  EXPECT_NE(inside.find("lies inside the input folder"), std::string::npos) << inside;
  EXPECT_NE(inside.find("proj"), std::string::npos) << inside;
  const std::string itself = test::ErrorOf([&] { CheckOutputFolder(dir / "proj", options); });
  EXPECT_NE(itself.find("is also an input"), std::string::npos) << itself;
  EXPECT_NO_THROW(CheckOutputFolder(dir / "out", options));
  // A folder beside the input whose name starts like it is not inside it.
  EXPECT_NO_THROW(CheckOutputFolder(dir / "proj2", options));
  EXPECT_FALSE(fs::exists(dir / "proj" / "views" / "002"));
}

// Outputs reach the disk before their names (fsync before the rename): the written bytes are all
// there after the write, for a file, a folder and a transaction, and nothing temporary is left.
TEST(WriteAtomically, SyncedOutputsAreCompleteAndLeaveNoTemporary) {
  test::TempDir dir;
  const std::string big(1 << 20, 'x');
  WriteAtomically(dir / "a.txt", [&](const fs::path& tmp) { std::ofstream(tmp) << big; });
  EXPECT_EQ(ReadTextFile(dir / "a.txt"), big);
  WriteFolderAtomically(dir / "f", [&](const fs::path& tmp) {
    fs::create_directories(tmp / "sub");
    std::ofstream(tmp / "sub" / "b.txt") << big;
  });
  EXPECT_EQ(ReadTextFile(dir / "f" / "sub" / "b.txt"), big);
  OutputTransaction t;
  t.Write(dir / "c.txt", [&](const fs::path& tmp) { std::ofstream(tmp) << "c"; });
  t.Write(dir / "d.txt", [&](const fs::path& tmp) { std::ofstream(tmp) << "d"; });
  t.Commit();
  EXPECT_EQ(ReadTextFile(dir / "c.txt"), "c");
  EXPECT_EQ(ReadTextFile(dir / "d.txt"), "d");
  size_t entries = 0;
  for (const auto& e : fs::directory_iterator(dir.path())) {
    (void)e;
    ++entries;
  }
  EXPECT_EQ(entries, 4u);  // a.txt, f, c.txt, d.txt
}

TEST(WriteAtomically, MissingFolderNamesThePath) {
  test::TempDir dir;
  const fs::path out = dir / "no" / "such" / "a.txt";
  try {
    WriteAtomically(out, [](const fs::path&) {});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("a.txt"), std::string::npos) << e.what();
  }
}

TEST(WriteFolderAtomically, ReplacesExistingFolderOnlyOnSuccess) {
  test::TempDir dir;
  const fs::path out = dir / "scan";
  WriteFolderAtomically(out, [](const fs::path& tmp) { std::ofstream(tmp / "x") << "1"; });
  EXPECT_EQ(ReadTextFile(out / "x"), "1");
  EXPECT_THROW(WriteFolderAtomically(out,
                                     [](const fs::path& tmp) {
                                       std::ofstream(tmp / "x") << "2";
                                       throw Error("boom");
                                     }),
               Error);
  EXPECT_EQ(ReadTextFile(out / "x"), "1");
  WriteFolderAtomically(out, [](const fs::path& tmp) { std::ofstream(tmp / "y") << "3"; });
  EXPECT_FALSE(fs::exists(out / "x"));
  EXPECT_EQ(ReadTextFile(out / "y"), "3");
}

TEST(WriteFolderAtomically, RefusesToReplaceAFolderFringeDidNotWrite) {
  test::TempDir dir;
  const fs::path out = dir / "photos";
  fs::create_directories(out);
  std::ofstream(out / "holiday.jpg") << "precious";
  try {
    WriteFolderAtomically(out, [](const fs::path& tmp) { std::ofstream(tmp / "x") << "1"; });
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("was not written by fringe"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(ReadTextFile(out / "holiday.jpg"), "precious");
  // A legacy layout the caller recognises may be replaced.
  OutputFolderOptions legacy;
  legacy.legacy_layout = [](const fs::path& d) { return fs::exists(d / "holiday.jpg"); };
  WriteFolderAtomically(out, legacy, [](const fs::path& tmp) { std::ofstream(tmp / "x") << "1"; });
  EXPECT_TRUE(fs::exists(out / kOutputMarkerName));
  EXPECT_FALSE(fs::exists(out / "holiday.jpg"));
}

TEST(WriteFolderAtomically, NeverReplacesAFolderHoldingAnInput) {
  test::TempDir dir;
  const fs::path stack = dir / "stack";
  WriteFolderAtomically(stack, [](const fs::path& tmp) { std::ofstream(tmp / "00.png") << "i"; });
  OutputFolderOptions options;
  options.inputs = {stack / "00.png"};
  EXPECT_THROW(WriteFolderAtomically(stack, options, [](const fs::path&) {}), Error);
  options.inputs = {dir / "stack/../stack"};
  try {
    WriteFolderAtomically(stack, options, [](const fs::path&) {});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("is also an input"), std::string::npos) << e.what();
  }
  EXPECT_EQ(ReadTextFile(stack / "00.png"), "i");
}

TEST(WriteFolderAtomically, RemovesTemporariesOfDeadRuns) {
  test::TempDir dir;
  // pid 2^22 + 1 is above Linux's pid_max default ceiling, so no process has it.
  const fs::path stale = dir / ".scan.tmp4194305_0";
  fs::create_directories(stale / "views");
  std::ofstream(stale / "views" / "big.tiff") << "x";
  const fs::path unrelated = dir / ".scan.tmpnotapid";
  std::ofstream(unrelated) << "keep";
  WriteFolderAtomically(dir / "scan", [](const fs::path& tmp) { std::ofstream(tmp / "a") << 1; });
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(unrelated));
}

TEST(CheckOutputFile, RefusesAnInputAndAMissingFolder) {
  test::TempDir dir;
  std::ofstream(dir / "rig.json") << "{}";
  EXPECT_THROW(CheckOutputFile(dir / "rig.json", {dir / "rig.json"}), Error);
  fs::create_hard_link(dir / "rig.json", dir / "link.json");
  EXPECT_THROW(CheckOutputFile(dir / "link.json", {dir / "rig.json"}), Error);
  EXPECT_THROW(CheckOutputFile(dir / "nodir" / "r.tiff"), Error);
  EXPECT_NO_THROW(CheckOutputFile(dir / "out.ply", {dir / "rig.json"}));
  EXPECT_THROW(CheckDistinctOutputs({dir / "a.ply", dir / "./a.ply"}), Error);
}

TEST(CheckOutputFile, NeverReplacesAFileInsideAnInputFolder) {
  // `reconstruct VIEW --out VIEW/left/00.png` once replaced an input image with the cloud.
  test::TempDir dir;
  fs::create_directories(dir / "view" / "left");
  std::ofstream(dir / "view" / "left" / "00.png") << "image";
  EXPECT_THROW(CheckOutputFile(dir / "view" / "left" / "00.png", {dir / "view"}), Error);
  // A new file there too: it changes what the input folder holds (the one output rule).
  EXPECT_THROW(CheckOutputFile(dir / "view" / "cloud.ply", {dir / "view"}), Error);
  EXPECT_NO_THROW(CheckOutputFile(dir / "cloud.ply", {dir / "view"}));
}

TEST(CheckRelativeName, RejectsEscapesAndOddNames) {
  const auto& img = ImageExtensions();
  EXPECT_NO_THROW(CheckRelativeName("00.png", "m.json", img));
  EXPECT_NO_THROW(CheckRelativeName("left/e0/00.PNG", "m.json", img));
  EXPECT_NO_THROW(CheckRelativeName("calibration/target.json", "scan.json"));
  for (const std::string& bad :
       std::vector<std::string>{"", ".", "../x.png", "a/../../x.png", "/etc/passwd.png", "a//b.png",
                                "./a.png", "a\\b.png", std::string("a\nb.png"), "x.exe"}) {
    EXPECT_THROW(CheckRelativeName(bad, "m.json", img), Error) << bad;
  }
  try {
    CheckRelativeNames({"a.png", "b.png", "a.png"}, "m.json", img, "image name");
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "m.json: image name 'a.png' appears twice");
  }
  try {
    CheckRelativeName("../../etc/x.png", "m.json", img, "image name");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("m.json: image name '../../etc/x.png': '..'"),
              std::string::npos)
        << e.what();
  }
}

TEST(CheckRange, NamesContextFieldAndBounds) {
  try {
    CheckRange(100000, 1, 4096, "m.json", "steps");
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "m.json: steps = 100000: must be in [1, 4096]");
  }
}

TEST(ReadTextFile, RefusesOversizedFiles) {
  test::TempDir dir;
  std::ofstream(dir / "a.txt") << std::string(100, 'x');
  EXPECT_THROW(ReadTextFile(dir / "a.txt", 50), Error);
  EXPECT_EQ(ReadTextFile(dir / "a.txt").size(), 100u);
}

TEST(OutputTransaction, CommitsAllOrNothing) {
  test::TempDir dir;
  {
    OutputTransaction tx;
    std::ofstream(tx.Stage(dir / "r.ply")) << "cloud";
    EXPECT_THROW(tx.Stage(dir / "nodir" / "res.tiff"), Error);
  }  // not committed: nothing left
  EXPECT_TRUE(fs::is_empty(dir.path()));
  OutputTransaction tx;
  const fs::path a = tx.Stage(dir / "r.ply");
  EXPECT_EQ(a.extension(), ".ply");
  std::ofstream(a) << "cloud";
  std::ofstream(tx.Stage(dir / "res.tiff")) << "res";
  EXPECT_THROW(tx.Stage(dir / "r.ply"), Error);
  tx.Commit();
  EXPECT_EQ(ReadTextFile(dir / "r.ply"), "cloud");
  EXPECT_EQ(ReadTextFile(dir / "res.tiff"), "res");
  int n = 0;
  for (auto& e : fs::directory_iterator(dir.path())) n += e.is_regular_file() ? 1 : 0;
  EXPECT_EQ(n, 2);
}

TEST(RequireFile, NamesFileAndProblem) {
  try {
    RequireFile("/nonexistent/file.png", "image");
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/file.png: image: no such file");
  }
}

TEST(CheckOption, MessageNamesFieldValueAndConstraint) {
  try {
    CheckOption(false, "IcpOptions", "max_iterations", -3, "must be > 0");
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "IcpOptions.max_iterations = -3: must be > 0");
  }
  EXPECT_NO_THROW(CheckOption(true, "A", "b", 1, "c"));
}

}  // namespace
}  // namespace fringe::util
