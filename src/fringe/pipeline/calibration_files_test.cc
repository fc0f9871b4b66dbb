#include "fringe/pipeline/calibration_files.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

#include "fringe/io/calibration_formats.h"
#include "fringe/io/calibration_io.h"
#include "fringe/testing/fringe_test.h"

namespace fringe::pipeline {
namespace {

namespace fs = std::filesystem;

constexpr double kTolMm = 1e-9;

TEST(CalibrationFiles, DefaultsPassCheck) {
  EXPECT_NO_THROW(CalibrationFiles().Check());
  EXPECT_TRUE(CalibrationFiles().empty());
}

// Conflicting or incomplete flags: the error names the field, the value and the flags.
TEST(CalibrationFiles, ConflictsAreRefusedNamingTheFlags) {
  CalibrationFiles f;
  f.opencv_intrinsics = "intrinsics.yml";
  std::string e = test::ErrorOf([&] { f.Check("ScanOptions"); });
  EXPECT_NE(e.find("ScanOptions.opencv_intrinsics = intrinsics.yml"), std::string::npos) << e;
  EXPECT_NE(e.find("--opencv-extrinsics"), std::string::npos) << e;
  f = {};
  f.calib = "rig.json";
  f.opencv = {"calibration.xml"};
  e = test::ErrorOf([&] { f.Check(); });
  EXPECT_NE(e.find("calib = rig.json"), std::string::npos) << e;
  EXPECT_NE(e.find("not both"), std::string::npos) << e;
  f = {};
  f.opencv = {"calibration.xml"};
  f.opencv_intrinsics = "i.yml";
  f.opencv_extrinsics = "e.yml";
  e = test::ErrorOf([&] { f.Check(); });
  EXPECT_NE(e.find("opencv = calibration.xml"), std::string::npos) << e;
  f = {};
  f.calib = "rig.json";
  f.opencv_keys = {"left=Kc,kc"};
  e = test::ErrorOf([&] { f.Check(); });
  EXPECT_NE(e.find("--opencv-keys"), std::string::npos) << e;
}

void ExpectSameRig(const StereoRig& a, const StereoRig& b) {
  EXPECT_NEAR(a.left.fx, b.left.fx, kTolMm);
  EXPECT_NEAR(a.right.fx, b.right.fx, kTolMm);
  EXPECT_NEAR(a.BaselineMm(), b.BaselineMm(), kTolMm);
}

// Every way of giving one rig reads the same rig: a rig JSON, the same rig as an OpenCV file
// given as --calib or --opencv, as two ROS files (--opencv twice), and as the OpenCV pair.
TEST(CalibrationFiles, EveryKindOfFileGivesTheSameRig) {
  test::TempDir dir;
  const StereoRig truth = StereoRig::Reference();
  io::WriteRig(dir / "rig.json", truth);
  io::WriteCalibration(io::CalibrationFormat::kOpenCv, {dir / "stereo.yml"}, truth);
  io::WriteCalibration(io::CalibrationFormat::kRos, {dir / "left.yaml", dir / "right.yaml"}, truth);
  {
    // stereo_calib's pair: M1 D1 M2 D2 in one file, R T in the other.
    cv::FileStorage in((dir / "stereo.yml").string(), cv::FileStorage::READ);
    cv::FileStorage intr((dir / "intrinsics.yml").string(), cv::FileStorage::WRITE);
    for (const char* k : {"M1", "D1", "M2", "D2"}) intr << k << in[k].mat();
    cv::FileStorage extr((dir / "extrinsics.yml").string(), cv::FileStorage::WRITE);
    for (const char* k : {"R", "T"}) extr << k << in[k].mat();
  }
  RigReadOptions read;
  read.devices = RigDevices::kStereo;
  read.camera_width = truth.left.width;
  read.camera_height = truth.left.height;
  std::vector<CalibrationFiles> kinds(5);
  kinds[0].calib = dir / "rig.json";
  kinds[1].calib = dir / "stereo.yml";
  kinds[2].opencv = {dir / "stereo.yml"};
  kinds[3].opencv = {dir / "left.yaml", dir / "right.yaml"};
  kinds[4].opencv_intrinsics = dir / "intrinsics.yml";
  kinds[4].opencv_extrinsics = dir / "extrinsics.yml";
  for (const CalibrationFiles& f : kinds) {
    const std::optional<ResolvedRig> r = LookUpRig(f, read, {dir / "none.json"});
    ASSERT_TRUE(r);
    EXPECT_EQ(r->source.find(dir.path().string()), 0u) << r->source;
    ExpectSameRig(r->rig, truth);
  }
  EXPECT_EQ(LookUpRig(kinds[3], read)->source,
            (dir / "left.yaml").string() + " + " + (dir / "right.yaml").string());
}

TEST(CalibrationFiles, DefaultsAreLookedUpInOrder) {
  test::TempDir dir;
  io::WriteRig(dir / "b.json", StereoRig::Reference());
  EXPECT_FALSE(LookUpRig({}, {}, {dir / "a.json"}));
  const std::optional<ResolvedRig> r = LookUpRig({}, {}, {dir / "a.json", dir / "b.json"});
  ASSERT_TRUE(r);
  EXPECT_EQ(r->source, (dir / "b.json").string());
}

// One camera in the files but two wanted: the error names the files and why two are needed.
TEST(CalibrationFiles, MissingRightCameraNamesTheFileAndTheReason) {
  test::TempDir dir;
  StereoRig one = StereoRig::Reference();
  one.projector = one.right;
  one.projector_from_left = one.right_from_left;
  io::WriteCalibration(io::CalibrationFormat::kSlStudio, {dir / "calibration.xml"}, one);
  CalibrationFiles f;
  f.calib = dir / "calibration.xml";
  RigReadOptions read;
  read.devices = RigDevices::kStereo;
  read.stereo_needed_by = "SCAN is a stereo scan";
  const std::string e = test::ErrorOf([&] { LookUpRig(f, read); });
  EXPECT_NE(e.find((dir / "calibration.xml").string() + ": holds no right camera, but SCAN is a "
                                                        "stereo scan"),
            std::string::npos)
      << e;
  read.devices = RigDevices::kAuto;  // camera + projector
  EXPECT_TRUE(LookUpRig(f, read)->rig.projector);
}

}  // namespace
}  // namespace fringe::pipeline
