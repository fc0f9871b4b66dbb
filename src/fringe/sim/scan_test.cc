#include "fringe/sim/scan.h"
#include "fringe/sim/sim.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/testing/file_size_limit.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::sim {
namespace {

namespace fs = std::filesystem;

ScanOptions SmallScan() {
  ScanOptions o;
  o.scene = "sphere";
  o.views = 2;
  o.calibration_images = 2;
  o.render.sensor.supersampling = 1;
  return o;
}

TEST(Scan, OptionDefaultsPassCheck) {
  EXPECT_NO_THROW(ScanOptions().Check());
  ScanOptions bad;
  bad.views = -1;
  EXPECT_THROW(bad.Check(), Error);
  EXPECT_THROW(MakeSceneByName("teapot"), Error);
  EXPECT_THROW(MakeSceneByName("mesh:/nonexistent.ply"), Error);
  for (const std::string& name : SceneNames()) {
    if (name == "demo") continue;  // built in DemoPart tests
    EXPECT_FALSE(MakeSceneByName(name).objects().empty()) << name;
  }
}

TEST(Scan, WritesTheScanFolderWithTruth) {
  test::TempDir dir;
  const StereoRig rig = ScaledRig(StereoRig::Reference(), 0.25);
  const ScanOptions opt = SmallScan();
  const ScanSummary summary = SimulateScan(rig, opt, dir / "scan");
  EXPECT_EQ(summary.views, 2);
  EXPECT_EQ(summary.fringe_images, 12);
  EXPECT_EQ(summary.calibration_images, 2);
  const fs::path root = dir / "scan";
  for (const char* f :
       {"scan.json", "scheme.json", "calibration/target.json", "truth/rig.json", "truth/poses.json",
        "truth/markers.json", "truth/scene.ply", "truth/scene.json", "truth/calibration.json",
        "views/001/right/11.png", "calibration/left/001.png", "calibration/right/000.png",
        "truth/views/001/left/depth.tiff", "truth/views/000/right/valid.png"}) {
    EXPECT_TRUE(fs::exists(root / f)) << f;
  }
  EXPECT_FALSE(fs::exists(root / "views/002"));
  // The true rig round-trips.
  const StereoRig read = io::ReadRig(root / "truth/rig.json");
  EXPECT_EQ(read.left, rig.left);
  // Poses and the sphere are recorded.
  const auto poses = io::ReadJson(root / "truth/poses.json");
  ASSERT_EQ(poses["views"].size(), 2u);
  const Rigid3d pose0 = io::RigidFromJson(poses["views"][0]["world_from_sensor"], "poses");
  const auto scene = io::ReadJson(root / "truth/scene.json");
  EXPECT_DOUBLE_EQ(scene["objects"][0]["sphere"]["radius_mm"].get<double>(), 15.0);
  // Truth maps: every valid pixel's point lies on the sphere (float precision in files).
  const CameraTruth truth = ReadCameraTruth(root / "truth/views/000/left", rig.left);
  const Eigen::Vector3d centre(0, 0, 15);
  int valid = 0;
  for (int r = 0; r < truth.valid.rows; ++r) {
    for (int c = 0; c < truth.valid.cols; ++c) {
      if (truth.object_id.at<int>(r, c) != 0) continue;
      const cv::Vec3d p = truth.points.at<cv::Vec3d>(r, c);
      const Eigen::Vector3d w = pose0 * Eigen::Vector3d(p[0], p[1], p[2]);
      EXPECT_NEAR((w - centre).norm(), 15.0, 1e-3);
      ++valid;
    }
  }
  EXPECT_GT(valid, 100);
  // Calibration truth has every feature's centre for both cameras.
  const auto calib = io::ReadJson(root / "truth/calibration.json");
  ASSERT_EQ(calib["images"].size(), 2u);
  EXPECT_EQ(calib["images"][0]["left"]["centres_px"].size(), 63u);
  const cv::Mat img = io::ReadGrayImage(root / "views/000/left/00.png");
  EXPECT_EQ(img.cols, rig.left.width);

  // The scan-folder reader finds what the simulator wrote, and the truth records equal the
  // simulator's own poses and markers.
  const scan::ScanFolder folder = scan::ScanFolder::Open(root);
  EXPECT_EQ(folder.views(), (std::vector<std::string>{"000", "001"}));
  EXPECT_EQ(folder.calibration_images(), (std::vector<std::string>{"000.png", "001.png"}));
  EXPECT_EQ(folder.manifest().image_width, rig.left.width);
  EXPECT_EQ(folder.ReadScheme().ImageNames().size(), 12u);
  EXPECT_EQ(folder.ReadStack("001", scan::Camera::kRight, folder.ReadScheme()).size(), 12u);
  const ScanSimulator sim(rig, opt);
  const scan::TruthPoses truth_poses = folder.ReadTruthPoses();
  ASSERT_EQ(truth_poses.views.size(), 2u);
  for (int v = 0; v < 2; ++v) {
    const Rigid3d& expected = sim.view_poses()[v];
    const Rigid3d& got = truth_poses.Find(scan::IndexName(v))->world_from_sensor;
    EXPECT_LT((got.translation() - expected.translation()).norm(), 1e-9);
    EXPECT_LT(got.rotation().angularDistance(expected.rotation()), 1e-12);
  }
  const scan::TruthMarkers markers = folder.ReadTruthMarkers();
  ASSERT_EQ(markers.markers.size(), sim.scene().markers().size());
  ASSERT_EQ(markers.views.size(), 2u);
  const ViewImages view1 = sim.RenderView(1);
  ASSERT_EQ(markers.Find("001")->observations.size(), view1.markers.size());
  for (size_t i = 0; i < view1.markers.size(); ++i) {
    const scan::MarkerObservation& a = markers.views[1].observations[i];
    const scan::MarkerObservation& b = view1.markers[i];
    EXPECT_EQ(a.id, b.id);
    EXPECT_LT((a.centre_in_sensor - b.centre_in_sensor).norm(), 1e-9);
    EXPECT_EQ(a.visible_left, b.visible_left);
  }
  const scan::TruthScene truth_scene = folder.ReadTruthScene();
  ASSERT_NE(truth_scene.Find("sphere"), nullptr);
  EXPECT_DOUBLE_EQ(truth_scene.Find("sphere")->sphere->radius_mm, 15.0);
  EXPECT_EQ(folder.ReadTruthMesh().NumTriangles(), sim.scene().NumTriangles());
  EXPECT_EQ(folder.ReadTruthRig().left, rig.left);
}

TEST(Scan, DeterministicForASeed) {
  test::TempDir dir;
  const StereoRig rig = ScaledRig(StereoRig::Reference(), 0.25);
  ScanOptions opt = SmallScan();
  opt.views = 1;
  opt.calibration_images = 1;
  opt.truth_maps = false;
  SimulateScan(rig, opt, dir / "a");
  SimulateScan(rig, opt, dir / "b");
  opt.seed = 2;
  SimulateScan(rig, opt, dir / "c");
  for (const char* f : {"views/000/left/03.png", "calibration/right/000.png"}) {
    const cv::Mat a = io::ReadGrayImage(dir / "a" / f);
    const cv::Mat b = io::ReadGrayImage(dir / "b" / f);
    const cv::Mat c = io::ReadGrayImage(dir / "c" / f);
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0) << f;
    EXPECT_GT(cv::norm(a, c, cv::NORM_L1), 0.0) << f;
  }
  EXPECT_FALSE(fs::exists(dir / "a" / "truth/views"));
  // The in-memory simulator gives the same images as the files.
  opt.seed = 1;
  const ScanSimulator sim(rig, opt);
  ASSERT_EQ(sim.view_poses().size(), 1u);
  const ViewImages view = sim.RenderView(0);
  EXPECT_EQ(cv::norm(view.left.images[3], io::ReadGrayImage(dir / "a/views/000/left/03.png"),
                     cv::NORM_INF),
            0.0);
  const StereoBoardImages board = sim.RenderBoard(0);
  EXPECT_EQ(cv::norm(board.right.image, io::ReadGrayImage(dir / "a/calibration/right/000.png"),
                     cv::NORM_INF),
            0.0);
  EXPECT_THROW(sim.RenderView(1), Error);
}

TEST(Scan, FullDiskFailsNamingTheFileAndLeavesNothing) {
  // A full disk (a file size limit, tests/file_size_limit.h): the first file that does not fit
  // (the truth mesh) is named inside the output folder, never the temporary one, and nothing is
  // left behind.
  test::TempDir dir;
  ScanOptions opt = SmallScan();
  opt.views = 1;
  opt.calibration_images = 0;
  opt.truth_maps = false;
  std::string message;
  {
    const test::FileSizeLimit full(10000);
    message = test::ErrorOf(
        [&] { SimulateScan(ScaledRig(StereoRig::Reference(), 0.25), opt, dir / "scan"); });
  }
  EXPECT_NE(message.find((dir / "scan" / "truth" / "scene.ply").string() +
                         ": cannot write: File too large"),
            std::string::npos)
      << message;
  EXPECT_EQ(message.find(".tmp"), std::string::npos) << message;
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(Scan, WritesOneCameraScanFoldersWithBothDirectionsAndExposures) {
  // A camera + projector scan folder (docs/scan-folder.md): scan.json "cameras": 1, views with
  // left/ only, board pose folders of the projector calibration layout; with both directions
  // left/vertical/ and left/horizontal/ (scheme_horizontal.json), with two exposures e0/ and
  // e1/ in each. The images are the simulator's: the vertical exposure-0 stack equals the
  // one-direction single-exposure scan's, and exposure 1 is darker by its factor.
  test::TempDir dir;
  const StereoRig rig = ScaledRig(StereoRig::Reference(), 0.25);
  ScanOptions opt = SmallScan();
  opt.views = 1;
  opt.cameras = 1;
  opt.truth_maps = true;
  const ScanSummary plain = SimulateScan(rig, opt, dir / "one");
  EXPECT_EQ(plain.calibration_images, 2);
  opt.both_directions = true;
  opt.exposures = {1.0, 0.5};
  SimulateScan(rig, opt, dir / "both");
  for (const fs::path& root : {dir / "one", dir / "both"}) {
    const scan::ScanFolder folder = scan::ScanFolder::Open(root);
    EXPECT_FALSE(folder.stereo()) << root;
    EXPECT_FALSE(fs::exists(root / "views/000/right")) << root;
    EXPECT_FALSE(fs::exists(root / "truth/views/000/right")) << root;
    EXPECT_TRUE(fs::exists(root / "truth/views/000/left/depth.tiff")) << root;
    EXPECT_EQ(folder.calibration_images(), (std::vector<std::string>{"000", "001"})) << root;
    for (const char* f : {"calibration/target.json", "calibration/001/board.png",
                          "calibration/001/vertical/manifest.json",
                          "calibration/001/horizontal/manifest.json", "truth/calibration.json"}) {
      EXPECT_TRUE(fs::exists(root / f)) << root << " " << f;
    }
  }
  const scan::ScanFolder one = scan::ScanFolder::Open(dir / "one");
  EXPECT_FALSE(one.both_directions());
  EXPECT_EQ(one.ReadStack("000", scan::Camera::kLeft, one.ReadScheme()).size(), 12u);

  const scan::ScanFolder both = scan::ScanFolder::Open(dir / "both");
  ASSERT_TRUE(both.both_directions());
  const std::vector<phase::PatternScheme> schemes = both.ReadSchemes();
  ASSERT_EQ(schemes.size(), 2u);
  EXPECT_EQ(schemes[0].direction, phase::FringeDirection::kVertical);
  EXPECT_EQ(schemes[1].direction, phase::FringeDirection::kHorizontal);
  EXPECT_TRUE(fs::exists(dir / "both/views/000/left/horizontal/e1/11.png"));
  const auto stacks = both.ReadViewStacks("000", scan::Camera::kLeft, schemes);
  ASSERT_EQ(stacks.size(), 2u);  // [scheme][exposure]
  for (const auto& exposures : stacks) {
    ASSERT_EQ(exposures.size(), 2u);
    for (const auto& images : exposures) EXPECT_EQ(images.size(), 12u);
  }
  const cv::Mat single = io::ReadGrayImage(dir / "one/views/000/left/05.png");
  EXPECT_EQ(cv::norm(stacks[0][0][5], single, cv::NORM_INF), 0.0);
  // The horizontal fringes differ from the vertical ones; exposure 1 gets half the light.
  EXPECT_GT(cv::norm(stacks[1][0][5], stacks[0][0][5], cv::NORM_L1), 0.0);
  const double ratio = cv::mean(stacks[0][1][5])[0] / cv::mean(stacks[0][0][5])[0];
  EXPECT_NEAR(ratio, 0.5, 0.05);

  // Both directions need one camera; exposure factors are bounded.
  ScanOptions bad = opt;
  bad.cameras = 2;
  EXPECT_THROW(bad.Check(), Error);
  bad = opt;
  bad.exposures = {1.0, 0.0};
  EXPECT_THROW(bad.Check(), Error);
  bad.exposures = {};
  EXPECT_THROW(bad.Check(), Error);
}

}  // namespace
}  // namespace fringe::sim
