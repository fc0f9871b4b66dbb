#include "fringe/io/opencv_calibration.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::io {
namespace {

namespace fs = std::filesystem;

std::string Matrix(const std::string& key, int rows, int cols, const std::string& data) {
  return key + ": !!opencv-matrix\n   rows: " + std::to_string(rows) +
         "\n   cols: " + std::to_string(cols) + "\n   dt: d\n   data: [ " + data + " ]\n";
}

const char* kK = "1000., 0., 320., 0., 1001., 240., 0., 0., 1.";
const char* kD = "-0.1, 0.05, 0.001, -0.002, 0.";
const char* kR = "0.9998, 0., 0.0199987, 0., 1., 0., -0.0199987, 0., 0.9998";

fs::path Yaml(const test::TempDir& dir, const std::string& name, const std::string& body) {
  const fs::path p = dir / name;
  std::ofstream(p) << "%YAML:1.0\n---\n" << body;
  return p;
}

using test::ErrorOf;

TEST(OpenCvCalibration, ReadsTheUsualKeySpellingsAndSaysWhichItUsed) {
  test::TempDir dir;
  // stereo_calib's M1/D1/M2/D2 + R/T, cameraMatrix1/distCoeffs1 + Rlr/Tlr, K_left + R_l2r.
  const std::vector<std::array<std::string, 6>> spellings = {
      {"M1", "D1", "M2", "D2", "R", "T"},
      {"cameraMatrix1", "distCoeffs1", "cameraMatrix2", "distCoeffs2", "Rlr", "Tlr"},
      {"K_left", "D_left", "K_right", "D_right", "R_l2r", "T_l2r"}};
  for (const auto& k : spellings) {
    const fs::path f = Yaml(
        dir, "c.yml",
        "image_width: 640\nimage_height: 480\n" + Matrix(k[0], 3, 3, kK) + Matrix(k[1], 1, 5, kD) +
            Matrix(k[2], 3, 3, kK) + Matrix(k[3], 5, 1, kD) + Matrix(k[4], 3, 3, kR) +
            Matrix(k[5], 3, 1, "-150., 0.5, 1.") + Matrix("R1", 3, 3, "1, 0, 0, 0, 1, 0, 0, 0, 1"));
    const OpenCvCalibration cv = ReadOpenCvCalibration({f});
    const StereoRig rig = cv.ToRig("c.yml");
    EXPECT_EQ(rig.left.width, 640);
    EXPECT_DOUBLE_EQ(rig.left.fy, 1001.0);
    EXPECT_DOUBLE_EQ(rig.right.k1, -0.1);
    EXPECT_DOUBLE_EQ(rig.right.p2, -0.002);
    EXPECT_NEAR(rig.BaselineMm(), std::sqrt(150.0 * 150 + 0.25 + 1), 1e-9);
    const std::string d = cv.Describe();
    for (const auto& key : k) EXPECT_NE(d.find(": " + key + " -> "), std::string::npos) << d;
  }
}

TEST(OpenCvCalibration, CameraProjectorFileAndSizeFromTheFile) {
  test::TempDir dir;
  const fs::path f =
      Yaml(dir, "cp.yml",
           Matrix("S", 2, 1, "1280., 1024.") + Matrix("M1", 3, 3, kK) + Matrix("D1", 1, 5, kD) +
               Matrix("M4", 3, 3, kK) + Matrix("D4", 1, 5, kD) +
               "projector_width: 1920\n"
               "projector_height: 1080\n" +
               Matrix("Rlp", 3, 3, kR) + Matrix("Tlp", 3, 1, "100., 0., 0."));
  const OpenCvCalibration cv = ReadOpenCvCalibration({f});
  ASSERT_TRUE(cv.left && cv.projector && cv.projector_from_left);
  EXPECT_FALSE(cv.right);
  EXPECT_EQ(cv.left->width, 1280);
  EXPECT_EQ(cv.projector->width, 1920);
  // fringe reconstructs with two cameras: the error says what the file holds.
  const std::string msg = ErrorOf([&] { cv.ToRig("cp.yml"); });
  EXPECT_NE(msg.find("the file holds: left camera, projector"), std::string::npos) << msg;
  // Camera-projector mode takes it: zero-baseline copy for `right`, the projector as read.
  const StereoRig cp = cv.ToCameraProjectorRig("cp.yml");
  EXPECT_EQ(cp.BaselineMm(), 0.0);
  ASSERT_TRUE(cp.projector);
  EXPECT_EQ(cp.projector->width, 1920);
  EXPECT_NEAR(cp.projector_from_left.translation().x(), 100.0, 1e-12);
}

// A projector whose size the file does not hold (SLMaster's caliInfo.yml) is dropped unless the
// caller gives the size (the scheme's projector size in `fringe reconstruct`).
TEST(OpenCvCalibration, ProjectorSizeGivenByTheCaller) {
  test::TempDir dir;
  const fs::path f = Yaml(dir, "cp.yml",
                          Matrix("S", 2, 1, "1280., 1024.") + Matrix("M1", 3, 3, kK) +
                              Matrix("M4", 3, 3, kK) + Matrix("D4", 1, 5, kD) +
                              Matrix("Rlp", 3, 3, kR) + Matrix("Tlp", 3, 1, "100., 0., 0."));
  const OpenCvCalibration dropped = ReadOpenCvCalibration({f});
  EXPECT_FALSE(dropped.projector);
  const std::string msg = ErrorOf([&] { dropped.ToCameraProjectorRig("cp.yml"); });
  EXPECT_NE(msg.find("camera-projector mode needs"), std::string::npos) << msg;
  const OpenCvCalibration given = ReadOpenCvCalibration({f}, 0, 0, 1920, 1024);
  ASSERT_TRUE(given.projector && given.projector_from_left);
  EXPECT_EQ(given.projector->width, 1920);
  EXPECT_EQ(given.projector->height, 1024);
  EXPECT_NE(given.Describe().find("given (not in the file) -> projector size 1920x1024"),
            std::string::npos)
      << given.Describe();
}

TEST(OpenCvCalibration, LongDistortionAndBadRotationsAreErrors) {
  test::TempDir dir;
  const std::string cams = "image_width: 640\nimage_height: 480\n" + Matrix("M1", 3, 3, kK) +
                           Matrix("M2", 3, 3, kK) + Matrix("T", 3, 1, "-150., 0., 0.");
  std::string msg = ErrorOf([&] {
    ReadOpenCvCalibration({Yaml(
        dir, "d8.yml",
        cams + Matrix("R", 3, 3, kR) + Matrix("D1", 1, 8, "0.1, 0.2, 0., 0., 0.3, 0.01, 0., 0."))});
  });
  EXPECT_NE(msg.find("d8.yml: D1 (left distortion): 8 coefficients"), std::string::npos) << msg;
  EXPECT_NE(msg.find("coefficient 5 is 0.01"), std::string::npos) << msg;
  // Trailing exact zeros lose nothing and are accepted.
  EXPECT_NO_THROW(ReadOpenCvCalibration({Yaml(
      dir, "d8z.yml",
      cams + Matrix("R", 3, 3, kR) + Matrix("D1", 1, 8, "0.1, 0.2, 0., 0., 0.3, 0., 0., 0."))}));
  for (const char* r : {"0, 0, 0, 0, 0, 0, 0, 0, 0", "2, 0, 0, 0, 2, 0, 0, 0, 2"}) {
    msg =
        ErrorOf([&] { ReadOpenCvCalibration({Yaml(dir, "r.yml", cams + Matrix("R", 3, 3, r))}); });
    EXPECT_NE(msg.find("r.yml: R (right_from_left rotation): not a rotation matrix"),
              std::string::npos)
        << msg;
  }
  msg = ErrorOf([&] {
    ReadOpenCvCalibration({Yaml(dir, "s.yml", cams + Matrix("R", 3, 3, kR) + "D1: \"abc\"\n")});
  });
  EXPECT_NE(msg.find("s.yml: D1 (left distortion): not a matrix"), std::string::npos) << msg;
  // Two spellings of one device: fringe does not guess.
  msg = ErrorOf([&] {
    ReadOpenCvCalibration(
        {Yaml(dir, "two.yml", cams + Matrix("R", 3, 3, kR) + Matrix("K1", 3, 3, kK))});
  });
  EXPECT_NE(msg.find("both give the left camera matrix"), std::string::npos) << msg;
}

TEST(OpenCvCalibration, SplitFilesAsStereoCalibWritesThem) {
  FRINGE_SHARED_DATA_OR_SKIP(data, "slsdk-stereo-phasegray");
  const OpenCvCalibration cv =
      ReadOpenCvCalibration({data / "intrinsic.yml", data / "extrinsic.yml"}, 2048, 1536);
  const StereoRig rig = cv.ToRig("slsdk");
  EXPECT_NEAR(rig.BaselineMm(), 302, 5);  // ../shared/data/README.md
  EXPECT_NE(cv.Describe().find("extrinsic.yml: R -> right_from_left rotation"), std::string::npos);
}

// Found by fuzz_opencv: a malformed matrix header ("cols:atrix") made OpenCV's own matrix reader
// allocate ~50 GB; matrices are now read with bounded, checked sizes (io/text_tree.h).
TEST(OpenCvCalibration, MalformedMatrixHeaderIsAnErrorNotAnAllocation) {
  test::TempDir dir;
  const fs::path f = Yaml(dir, "bad.yml",
                          "image_width: 640\nimage_height: 480\nM1: !!opencv-matrix\n"
                          "   rows: 3\n   cols:atrix\n   rows: 1\n   cols: 5\n   dt: d\n"
                          "   data: [ 0.1, -0.2, 0., 0., 0. ]\n");
  const std::string e = ErrorOf([&] { ReadOpenCvCalibration({f}); });
  EXPECT_NE(e.find("bad.yml: line 8: not valid YAML"), std::string::npos) << e;
  // A declared size that the data does not fill is refused as well.
  const fs::path g = Yaml(dir, "short.yml",
                          "M1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                          "   data: [ 1., 0., 320. ]\n");
  const std::string short_error = ErrorOf([&] { ReadOpenCvCalibration({g}); });
  EXPECT_NE(short_error.find("short.yml: M1 (left camera matrix): data holds 3 numbers"),
            std::string::npos)
      << short_error;
}

// Found by fuzz_opencv: a garbled document on which OpenCV's FileNode lookup throws its own
// exception; it must come out as a fringe error naming the file.
TEST(OpenCvCalibration, GarbledDocumentIsAnErrorNamingTheFile) {
  test::TempDir dir;
  const fs::path f = dir / "garbled.yml";
  const std::string bytes(
      "\x25\x59\x41\x4d\x4c\x3a\x31\x2e\x30\x0a\x2d\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x2d\x2d\x0a\x69\x2d\xff\x60\x40\x00\x01\x2f\x4d\x64"
      "\x0a\x20\x20\x20\x64\x61\x74\x61\x3a\x20\x5b\x20\x35\x30\x30\x2e\x2c\x20\x30\x2e\x2c\x20\x33"
      "\x32\x30\x2e\x2c\x20\x30\x2e\x2c\x20\x36\x2e\x30\x20\x30\x2c\x5d\x30\x0a\x44\x31\x3a\x20\x21"
      "\x21\x6f\x70\x65\x6e\x63\x76\x2d\x6d\xa3\xa3\xa3\xa3\xa3\xa3\xa3\xa3\xa3\xa3\xa3\xa3\xa3\xa3"
      "\xa3\xa3\x83\x20\x5d\x0a",
      190);
  std::ofstream(f, std::ios::binary) << bytes;
  EXPECT_NE(ErrorOf([&] { ReadOpenCvCalibration({f}); }).find("garbled.yml"), std::string::npos);
}

// The hostile files fuzz_opencv found against cv::FileStorage (which then read the files: an
// abort, null dereferences, endless loops). yaml-cpp / tinyxml2 read them now (io/text_tree.h):
// each must still be a clear error naming the file, whatever stage finds the fault.
TEST(OpenCvCalibration, EmptyNestedKeyIsAnErrorNotAnAbort) {
  test::TempDir dir;
  const fs::path f = Yaml(dir, "empty_key.yml", "M1: !!opencv-matrix\n   rows: 3\n   :d 5\n");
  const std::string e = ErrorOf([&] { ReadOpenCvCalibration({f}); });
  EXPECT_NE(e.find("empty_key.yml: M1 (left camera matrix): not a matrix"), std::string::npos) << e;
}

TEST(OpenCvCalibration, UnclosedXmlTagIsAnErrorNotASegfault) {
  test::TempDir dir;
  const fs::path f = dir / "open.xml";
  std::ofstream(f) << "<?xml vursion=\"1.8\"?>\n<opencv_sxml vursion=\n";
  const std::string e = ErrorOf([&] { ReadOpenCvCalibration({f}); });
  EXPECT_NE(e.find("open.xml: line 2: not valid XML"), std::string::npos) << e;
}

TEST(OpenCvCalibration, BareValueLineIsAnErrorNotAnEndlessLoop) {
  // Reproducer of the first: fuzz/known/opencv-yaml-bare-line-timeout.yml.
  test::TempDir dir;
  const fs::path f = dir / "loop.yml";
  const auto error = [&](const std::string& text) {
    std::ofstream(f) << text;
    return ErrorOf([&] { ReadOpenCvCalibration({f}); });
  };
  // Not YAML at all.
  for (const std::string text : {"%YAML:1.0\nr: 1\nn0\n-", "%YAML:1.0\n--- - a[0 ]\n",
                                 "%YAML:1.0\nM1: !!opencv-matrix\n      rows: 3\n   cols: 3\n"}) {
    const std::string e = error(text);
    EXPECT_NE(e.find("loop.yml: line "), std::string::npos) << text << " -> " << e;
    EXPECT_NE(e.find("not valid YAML"), std::string::npos) << text << " -> " << e;
  }
  EXPECT_NE(error("%YAML:1.\n---- .\n]\n").find("loop.yml: the top level is not a mapping"),
            std::string::npos);
  // YAML, but no calibration in it.
  for (const std::string text :
       {"%YAML:1.0\n r: 1\nn0\n-", "%YAML:1.0\n      cols: 3\n   dt: d\n", "%YAML:1.0\na: 1 ]\n"}) {
    const std::string e = error(text);
    EXPECT_NE(e.find("loop.yml: no camera matrix found"), std::string::npos) << text << " -> " << e;
  }
  // A value continuing a flow sequence on the next lines stays valid, as OpenCV writes it.
  const fs::path ok =
      Yaml(dir, "flow.yml",
           "M1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 500., 0., 320.,\n"
           "       0., 500., 240.,\n       0., 0., 1. ]\n");
  EXPECT_EQ(ErrorOf([&] { ReadOpenCvCalibration({ok}, 640, 480); }), "");
}

TEST(OpenCvCalibration, IntegerElementTypeThatSaturatesIsAnError) {
  // dt: u stores 8-bit values: OpenCV itself would read a focal length of 500 as 255.
  test::TempDir dir;
  const fs::path f = Yaml(dir, "u8.yml",
                          "M1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: u\n"
                          "   data: [ 500., 0., 320., 0., 500., 240., 0., 0., 1. ]\n");
  const std::string error = ErrorOf([&] { ReadOpenCvCalibration({f}, 640, 480); });
  EXPECT_NE(error.find("u8.yml: M1 (left camera matrix): element type dt: u"), std::string::npos)
      << error;
}

TEST(OpenCvCalibration, KeyGivenTwiceIsAnError) {
  test::TempDir dir;
  const fs::path f =
      Yaml(dir, "twice.yml",
           "M1: !!opencv-matrix\n   rows: 1\n   cols: 1\n   dt: d\n   data: [ 1. ]\n"
           "M1: !!opencv-matrix\n   rows: 1\n   cols: 1\n   dt: d\n   data: [ 2. ]\n");
  EXPECT_NE(ErrorOf([&] { ReadOpenCvCalibration({f}); }).find("key 'M1' appears twice"),
            std::string::npos);
}

TEST(OpenCvCalibration, ControlBytesAreAnErrorNotASegfault) {
  // Reproducer: fuzz/known/opencv-xml-control-bytes-segv.xml.
  test::TempDir dir;
  const std::string text = std::string("<?xml ve_id=") + std::string(32, '\0') +
                           "\"opencv-matrix\"<rows>ols><dt>d</dt></opencv_storage>\n";
  const fs::path f = dir / "nul.xml";
  std::ofstream(f, std::ios::binary) << text;
  const std::string e = ErrorOf([&] { ReadOpenCvCalibration({f}); });
  EXPECT_NE(e.find("nul.xml: holds a NUL byte: not a text calibration file"), std::string::npos)
      << e;
}

}  // namespace
}  // namespace fringe::io
