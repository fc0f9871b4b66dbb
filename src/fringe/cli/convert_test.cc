// fringe convert-calib between formats and fringe info on other tools' calibration files.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "fringe/cli/run_cli_for_test.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/json.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/testing/fringe_test.h"

namespace fringe::cli {
namespace {

namespace fs = std::filesystem;

// The tolerance of a chain of exact round trips (17 significant digits, quaternion storage).
constexpr double kChainTol = 1e-11;

TEST(ConvertCalib, RigThroughEveryToolFormatAndBack) {
  test::TempDir dir;
  StereoRig rig = StereoRig::Reference();
  rig.left.k3 = rig.right.k3 = 0;  // Kalibr's radtan has no k3
  if (rig.projector) rig.projector->k3 = 0;
  ASSERT_TRUE(rig.projector);
  io::WriteRig(dir / "rig.json", rig);
  std::string out, err;
  // rig -> kalibr -> opencv -> rig (a stereo rig with its projector keeps everything).
  ASSERT_EQ(RunCli({"convert-calib", (dir / "rig.json").string(), "--to", "kalibr", "--out",
                    (dir / "camchain.yaml").string()},
                   &out, &err),
            0)
      << err;
  ASSERT_EQ(RunCli({"convert-calib", (dir / "camchain.yaml").string(), "--to", "opencv", "--out",
                    (dir / "cv.yml").string()},
                   &out, &err),
            0)
      << err;
  EXPECT_NE(out.find("format: kalibr"), std::string::npos) << out;
  EXPECT_NE(out.find("cam2 -> projector"), std::string::npos) << out;
  ASSERT_EQ(
      RunCli({"convert-calib", (dir / "cv.yml").string(), "--out", (dir / "back.json").string()},
             &out, &err),
      0)
      << err;
  EXPECT_NE(out.find("cv.yml: M1 -> left camera matrix"), std::string::npos) << out;
  const StereoRig back = io::ReadRig(dir / "back.json");
  EXPECT_NEAR(back.left.fx, rig.left.fx, kChainTol);
  EXPECT_NEAR(back.right.cy, rig.right.cy, kChainTol);
  EXPECT_NEAR(back.right.k1, rig.right.k1, kChainTol);
  EXPECT_LE((back.right_from_left.translation() - rig.right_from_left.translation()).norm(),
            kChainTol);
  EXPECT_LE((back.projector_from_left.translation() - rig.projector_from_left.translation()).norm(),
            kChainTol);
  // ros writes two files; slstudio one camera + projector, and says what it left out.
  EXPECT_EQ(RunCli({"convert-calib", (dir / "rig.json").string(), "--to", "ros", "--out",
                    (dir / "left.yaml").string()},
                   &out, &err),
            1);
  EXPECT_NE(err.find("--to ros writes 2 files (left, right), 1 given"), std::string::npos) << err;
  ASSERT_EQ(RunCli({"convert-calib", (dir / "rig.json").string(), "--to", "ros", "--out",
                    (dir / "left.yaml").string(), (dir / "right.yaml").string()},
                   &out, &err),
            0)
      << err;
  EXPECT_NE(out.find("note: ros: the projector is not stored"), std::string::npos) << out;
  ASSERT_EQ(RunCli({"convert-calib", (dir / "left.yaml").string(), (dir / "right.yaml").string(),
                    "--out", (dir / "ros.json").string()},
                   &out, &err),
            0)
      << err;
  EXPECT_NEAR(io::ReadRig(dir / "ros.json").BaselineMm(), rig.BaselineMm(), kChainTol);
  ASSERT_EQ(RunCli({"convert-calib", (dir / "rig.json").string(), "--to", "slstudio", "--out",
                    (dir / "calibration.xml").string()},
                   &out, &err),
            0)
      << err;
  EXPECT_NE(out.find("note: slstudio: the right camera is not stored"), std::string::npos) << out;
  // fringe info names the format and every key it used.
  ASSERT_EQ(RunCli({"info", (dir / "calibration.xml").string()}, &out, &err), 0) << err;
  EXPECT_NE(out.find("format: slstudio"), std::string::npos) << out;
  EXPECT_NE(out.find("calibration.xml: Rp -> projector_from_left rotation"), std::string::npos)
      << out;
  EXPECT_NE(out.find("screenResX screenResY -> projector size 1280x800"), std::string::npos) << out;
  // The same file through an explicit mapping.
  ASSERT_EQ(
      RunCli({"convert-calib", (dir / "calibration.xml").string(), "--opencv-keys", "left=Kc,kc",
              "left_size=frameWidth,frameHeight", "--out", (dir / "cam.json").string()},
             &out, &err),
      1);
  EXPECT_NE(err.find("camera-projector mode needs"), std::string::npos) << err;
  ASSERT_EQ(RunCli({"convert-calib", (dir / "calibration.xml").string(), "--opencv-keys",
                    "left=Kc,kc", "left_size=frameWidth,frameHeight", "projector=Kp,kp",
                    "projector_size=screenResX,screenResY", "projector_from_left=Rp,Tp", "--out",
                    (dir / "cam.json").string()},
                   &out, &err),
            0)
      << err;
  EXPECT_NE(out.find("format: keys"), std::string::npos) << out;
  EXPECT_NEAR(io::ReadRig(dir / "cam.json").projector->fx, rig.projector->fx, kChainTol);
}

// Issue 27 item 5: `fringe info DIR --init` writes the scan.json inferred for a folder of views
// another tool wrote (L/ R/ view folders, scheme.json), and only where none exists.
TEST(InfoInit, WritesTheInferredManifestOnce) {
  test::TempDir dir;
  const fs::path root = dir / "capture";
  const phase::PatternScheme scheme = phase::MakeScheme("heterodyne-3x3", 320, 200);
  fs::create_directories(root);
  phase::WriteScheme(root / "scheme.json", scheme);
  const cv::Mat grey(12, 16, CV_16U, cv::Scalar(900));
  for (const char* v : {"000", "001"}) {
    for (const char* c : {"L", "R"}) {
      fs::create_directories(root / "views" / v / c);
      for (const std::string& n : scheme.ImageNames()) {
        io::WriteImage(root / "views" / v / c / n, grey);
      }
    }
  }
  std::string out, err;
  ASSERT_EQ(RunCli({"info", root.string()}, &out, &err), 0) << err;
  EXPECT_NE(out.find("manifest: inferred (no scan.json"), std::string::npos) << out;
  EXPECT_NE(out.find("2 views (views/000 .. views/001), two cameras L/ R/"), std::string::npos)
      << out;
  EXPECT_NE(out.find("images 16x12, 16-bit"), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(root / "scan.json"));
  ASSERT_EQ(RunCli({"info", root.string(), "--init"}, &out, &err), 0) << err;
  EXPECT_NE(out.find("wrote " + (root / "scan.json").string()), std::string::npos) << out;
  const nlohmann::json j = io::ReadJson(root / "scan.json");
  EXPECT_EQ(j["views"], 2);
  EXPECT_EQ(j["bit_depth"], 16);
  EXPECT_EQ(j["camera_folders"], nlohmann::json({"L", "R"}));
  EXPECT_EQ(RunCli({"info", root.string(), "--init"}, &out, &err), 1);
  EXPECT_NE(err.find("already has scan.json (not overwritten)"), std::string::npos) << err;
  // `fringe scan --write-manifest` writes the same manifest before it scans (here the folder has
  // no calibration, so the scan itself then fails, naming what is missing).
  const fs::path copy = dir / "copy";
  fs::copy(root, copy, fs::copy_options::recursive);
  fs::remove(copy / "scan.json");
  EXPECT_EQ(RunCli({"scan", copy.string(), "--out", (dir / "out").string(), "--write-manifest"},
                   &out, &err),
            1);
  EXPECT_NE(out.find("wrote " + (copy / "scan.json").string()), std::string::npos) << out;
  EXPECT_NE(out.find("inferred: "), std::string::npos) << out;
  EXPECT_NE(err.find("calibration"), std::string::npos) << err;
  EXPECT_EQ(io::ReadJson(copy / "scan.json"), j);
  EXPECT_FALSE(fs::exists(dir / "out"));
}

}  // namespace
}  // namespace fringe::cli
