#include "fringe/scan/scan_folder.h"

#include <gtest/gtest.h>

#include <fstream>

#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/phase/stack_io.h"
#include "fringe/scan/describe.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::scan {
namespace {

namespace fs = std::filesystem;

constexpr int kWidth = 16, kHeight = 12;

// A small, valid scan folder written by hand: `views` views of the N-step scheme, `boards` board
// images per camera, no truth.
ScanManifest WriteSmallScan(const fs::path& root, int views, int boards) {
  const ScanLayout layout{root};
  fs::create_directories(root);
  const phase::PatternScheme scheme =
      phase::MakeScheme("heterodyne-4x3", 320, 200);  // the 0.25-scaled projector
  const cv::Mat grey(kHeight, kWidth, CV_8U, cv::Scalar(90));
  for (int v = 0; v < views; ++v) {
    for (Camera c : {Camera::kLeft, Camera::kRight}) {
      fs::create_directories(layout.CameraDir(IndexName(v), c));
      for (const std::string& n : scheme.ImageNames()) {
        io::WriteImage(layout.CameraDir(IndexName(v), c) / n, grey);
      }
    }
  }
  ScanManifest m;
  m.generator = "test";
  m.views = views;
  m.image_width = kWidth;
  m.image_height = kHeight;
  if (views > 0) {
    phase::WriteScheme(layout.Scheme(), scheme);
    m.scheme = "scheme.json";
  }
  if (boards > 0) {
    for (Camera c : {Camera::kLeft, Camera::kRight}) {
      fs::create_directories(layout.CalibrationDir(c));
      for (int k = 0; k < boards; ++k) {
        io::WriteImage(layout.CalibrationDir(c) / (IndexName(k) + ".png"), grey);
      }
    }
    io::WriteJson(layout.Target(), io::TargetToJson(CalibrationTarget::Reference()));
    m.calibration_images = boards;
    m.calibration_target = "calibration/target.json";
  }
  WriteManifest(layout.Manifest(), m);
  return m;
}

// Runs `f`, expects fringe::Error whose message contains every one of `parts`.
template <typename F>
void ExpectError(F&& f, const std::vector<std::string>& parts) {
  try {
    f();
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    for (const auto& p : parts)
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << p << " in " << e.what();
  }
}

TEST(ScanFolder, OpensAndReadsAValidFolder) {
  test::TempDir dir;
  const fs::path root = dir / "scan";
  WriteSmallScan(root, 2, 3);
  const ScanFolder scan = ScanFolder::Open(root);
  EXPECT_EQ(scan.views(), (std::vector<std::string>{"000", "001"}));
  EXPECT_EQ(scan.calibration_images(), (std::vector<std::string>{"000.png", "001.png", "002.png"}));
  const phase::PatternScheme scheme = scan.ReadScheme();
  EXPECT_EQ(scan.ReadStack("001", Camera::kLeft, scheme).size(), scheme.ImageNames().size());
  EXPECT_EQ(scan.ReadTarget().rows, CalibrationTarget::Reference().rows);
  EXPECT_FALSE(scan.has_truth());
  ExpectError([&] { scan.ReadTruthPoses(); }, {"scan.json", "no truth", "poses.json"});
  ExpectError([&] { scan.ReadStack("007", Camera::kLeft, scheme); }, {"007", "no such view"});
  // A view folder is recognised as part of its scan folder, with or without a trailing slash.
  EXPECT_EQ(ScanFolder::RootOfView(root / "views" / "001"), root);
  EXPECT_EQ(ScanFolder::RootOfView(fs::path((root / "views" / "001").string() + "/")), root);
  EXPECT_FALSE(ScanFolder::RootOfView(root / "calibration").has_value());
  const std::string text = DescribePath(root);
  EXPECT_NE(text.find("scan folder"), std::string::npos) << text;
  EXPECT_NE(text.find("views: 2"), std::string::npos) << text;
}

TEST(ScanFolder, ManifestRoundTripsAndRejectsBadFields) {
  ScanManifest m;
  m.generator = "fringe simulate";
  m.scene = "vdi";
  m.seed = 7;
  m.views = 3;
  m.image_width = 1280;
  m.image_height = 1024;
  m.bit_depth = 12;
  m.scheme = "scheme.json";
  m.calibration_images = 15;
  m.calibration_target = "calibration/target.json";
  m.truth = "truth";
  const ScanManifest r = ManifestFromJson(ManifestToJson(m), "scan.json");
  EXPECT_EQ(r.scene, "vdi");
  EXPECT_EQ(r.seed, 7u);
  EXPECT_EQ(r.bit_depth, 12);
  EXPECT_EQ(r.calibration_target, m.calibration_target);
  EXPECT_EQ(r.truth, "truth");
  auto with = [&](const char* field, const nlohmann::json& value) {
    nlohmann::json j = ManifestToJson(m);
    j[field] = value;
    return j;
  };
  ExpectError([&] { ManifestFromJson(with("format", "other"), "s.json"); }, {"s.json", "format"});
  ExpectError([&] { ManifestFromJson(with("version", 99), "s.json"); }, {"s.json", "version 99"});
  ExpectError([&] { ManifestFromJson(with("views", -1), "s.json"); }, {"s.json", "views"});
  ExpectError([&] { ManifestFromJson(with("views", "three"), "s.json"); }, {"s.json"});
  ExpectError([&] { ManifestFromJson(with("scheme", "../x.json"), "s.json"); },
              {"s.json", "relative path inside the folder"});
  ExpectError([&] { ManifestFromJson(with("scheme", "/etc/x.json"), "s.json"); },
              {"s.json", "relative path"});
  ExpectError([&] { ManifestFromJson(with("scheme", nullptr), "s.json"); },
              {"s.json", "'scheme' is null"});
  // 10 and 14 are GenICam Mono10 / Mono14 captures; odd depths are not a camera's.
  EXPECT_EQ(ManifestFromJson(with("bit_depth", 10), "s.json").bit_depth, 10);
  ExpectError([&] { ManifestFromJson(with("bit_depth", 11), "s.json"); }, {"bit_depth"});
}

TEST(ScanFolder, OneCameraScanHoldsLeftViewsAndBoardPoseFolders) {
  test::TempDir dir;
  const fs::path root = dir / "scan";
  ScanManifest m = WriteSmallScan(root, 2, 0);
  // Without the manifest's word a view without right/ is an error naming the folder.
  fs::remove_all(root / "views" / "001" / "right");
  ExpectError([&] { ScanFolder::Open(root); }, {"001", "right"});
  fs::remove_all(root / "views" / "000" / "right");
  m.cameras = 1;
  // Board poses of the camera + projector calibration layout: one folder each.
  for (const char* pose : {"000", "001"}) fs::create_directories(root / "calibration" / pose);
  io::WriteJson(root / "calibration" / "target.json",
                io::TargetToJson(CalibrationTarget::Reference()));
  m.calibration_images = 2;
  m.calibration_target = "calibration/target.json";
  WriteManifest(root / "scan.json", m);
  const ScanFolder scan = ScanFolder::Open(root);
  EXPECT_FALSE(scan.stereo());
  EXPECT_EQ(scan.calibration_images(), (std::vector<std::string>{"000", "001"}));
  EXPECT_EQ(ManifestFromJson(io::ReadJson(root / "scan.json"), "scan.json").cameras, 1);
  EXPECT_NE(DescribePath(root).find("one camera + projector"), std::string::npos);
  // A right camera in a one-camera scan, or a board pose count that disagrees: named errors.
  fs::create_directories(root / "views" / "001" / "right");
  ExpectError([&] { ScanFolder::Open(root); }, {"001", "right", "'cameras': 1"});
  fs::remove_all(root / "views" / "001" / "right");
  fs::remove_all(root / "calibration" / "001");
  ExpectError([&] { ScanFolder::Open(root); }, {"calibration", "1 board pose folders", "says 2"});
  // Two-camera manifests are written without the key, as before; other counts are refused.
  EXPECT_FALSE(ManifestToJson(ScanManifest()).contains("cameras"));
  nlohmann::json j = ManifestToJson(m);
  j["cameras"] = 3;
  ExpectError([&] { ManifestFromJson(j, "s.json"); }, {"s.json", "cameras"});
}

TEST(ScanFolder, OneCameraScanWithBothDirectionsAndExposures) {
  // left/vertical/ and left/horizontal/, each with exposure folders e0/ and e1/, and
  // scan.json's scheme_horizontal: every direction's exposures are read, and every
  // disagreement is an error naming the file or folder.
  test::TempDir dir;
  const fs::path root = dir / "scan";
  ScanManifest m = WriteSmallScan(root, 1, 0);
  const ScanLayout layout{root};
  fs::remove_all(layout.CameraDir("000", Camera::kRight));
  phase::PatternScheme horizontal = phase::MakeScheme("heterodyne-4x3", 320, 200);
  horizontal.direction = phase::FringeDirection::kHorizontal;
  phase::WriteScheme(layout.HorizontalScheme(), horizontal);
  const cv::Mat grey(kHeight, kWidth, CV_8U, cv::Scalar(90));
  for (const phase::FringeDirection d :
       {phase::FringeDirection::kVertical, phase::FringeDirection::kHorizontal}) {
    for (int e = 0; e < 2; ++e) {
      const fs::path stack = phase::ExposureDir(layout.DirectionDir("000", Camera::kLeft, d), e);
      fs::create_directories(stack);
      for (const std::string& n : horizontal.ImageNames()) io::WriteImage(stack / n, grey);
    }
  }
  for (const std::string& n : horizontal.ImageNames()) {
    fs::remove(layout.CameraDir("000", Camera::kLeft) / n);
  }
  m.cameras = 1;
  m.scheme_horizontal = "scheme_horizontal.json";
  WriteManifest(layout.Manifest(), m);
  const ScanFolder scan = ScanFolder::Open(root);
  ASSERT_TRUE(scan.both_directions());
  const std::vector<phase::PatternScheme> schemes = scan.ReadSchemes();
  ASSERT_EQ(schemes.size(), 2u);
  EXPECT_EQ(schemes[1].direction, phase::FringeDirection::kHorizontal);
  const auto stacks = scan.ReadViewStacks("000", Camera::kLeft, schemes);
  ASSERT_EQ(stacks.size(), 2u);
  EXPECT_EQ(stacks[1].size(), 2u);
  EXPECT_EQ(stacks[1][1].size(), horizontal.ImageNames().size());
  // `fringe info` counts every direction's images over its exposures.
  const std::string text = DescribePath(root);
  EXPECT_NE(text.find("000: left vertical 24 images in 2 exposures, horizontal 24 images in 2 "
                      "exposures"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("both fringe directions"), std::string::npos) << text;
  // One exposure fewer in one direction.
  fs::remove_all(layout.DirectionDir("000", Camera::kLeft, phase::FringeDirection::kHorizontal) /
                 "e1");
  ExpectError([&] { scan.ReadViewStacks("000", Camera::kLeft, schemes); },
              {"horizontal", "1 exposures", "2"});
  // The schemes swapped: each file's direction is checked.
  m.scheme = "scheme_horizontal.json";
  m.scheme_horizontal = "scheme.json";
  WriteManifest(layout.Manifest(), m);
  ExpectError([&] { ScanFolder::Open(root).ReadSchemes(); },
              {"scheme_horizontal.json", "horizontal fringes", "vertical-fringe scheme"});
  // A missing direction folder, and both directions in a stereo scan.
  m.scheme = "scheme.json";
  m.scheme_horizontal = "scheme_horizontal.json";
  WriteManifest(layout.Manifest(), m);
  fs::remove_all(layout.DirectionDir("000", Camera::kLeft, phase::FringeDirection::kVertical));
  ExpectError([&] { ScanFolder::Open(root); }, {"000", "vertical"});
  nlohmann::json j = ManifestToJson(m);
  j.erase("cameras");
  ExpectError([&] { ManifestFromJson(j, "s.json"); },
              {"s.json", "scheme_horizontal", "'cameras': 1"});
}

TEST(ScanFolder, ErrorsNameTheFileThatDisagrees) {
  test::TempDir dir;
  {
    const fs::path root = dir / "missing_view";
    WriteSmallScan(root, 2, 0);
    fs::remove_all(root / "views" / "001");
    ExpectError([&] { ScanFolder::Open(root); }, {"views", "1 view folders", "says 2"});
  }
  {
    const fs::path root = dir / "gap";
    WriteSmallScan(root, 2, 0);
    fs::rename(root / "views" / "001", root / "views" / "002");
    ExpectError([&] { ScanFolder::Open(root); }, {(root / "views" / "001").string(), "missing"});
  }
  {
    const fs::path root = dir / "no_right";
    WriteSmallScan(root, 1, 0);
    fs::remove_all(root / "views" / "000" / "right");
    ExpectError([&] { ScanFolder::Open(root); }, {(root / "views" / "000" / "right").string()});
  }
  {
    const fs::path root = dir / "odd_view";
    WriteSmallScan(root, 1, 0);
    fs::create_directories(root / "views" / "extra");
    ExpectError([&] { ScanFolder::Open(root); }, {"extra", "three-digit"});
  }
  {
    const fs::path root = dir / "boards";
    WriteSmallScan(root, 0, 2);
    fs::rename(root / "calibration" / "right" / "001.png",
               root / "calibration" / "right" / "009.png");
    ExpectError([&] { ScanFolder::Open(root); }, {"calibration", "differently named"});
    fs::remove(root / "calibration" / "right" / "009.png");
    ExpectError([&] { ScanFolder::Open(root); },
                {(root / "calibration" / "right").string(), "1 images"});
  }
  {
    const fs::path root = dir / "no_scheme";
    WriteSmallScan(root, 1, 0);
    fs::remove(root / "scheme.json");
    ExpectError([&] { ScanFolder::Open(root); }, {"scheme.json"});
  }
  {
    const fs::path root = dir / "size";
    WriteSmallScan(root, 1, 0);
    ScanManifest m = ManifestFromJson(io::ReadJson(root / "scan.json"), "scan.json");
    m.image_width = 32;
    WriteManifest(root / "scan.json", m);
    const ScanFolder scan = ScanFolder::Open(root);
    ExpectError([&] { scan.ReadStack("000", Camera::kLeft, scan.ReadScheme()); },
                {"16x12", "32x12"});
  }
  ExpectError([&] { ScanFolder::Open(dir / "nothing"); }, {"nothing"});
  fs::create_directories(dir / "empty");
  ExpectError([&] { ScanFolder::Open(dir / "empty"); }, {"scan.json"});
}

}  // namespace
}  // namespace fringe::scan

namespace fringe::scan {
namespace {

// Issue 27 item 5: a folder of views from another tool (no scan.json, L/ R/ or cam0/ view
// folders) is a scan folder; its manifest is inferred and equals the one fringe would write.
TEST(ScanFolder, ManifestIsInferredForAFolderOfViewsWithoutScanJson) {
  test::TempDir dir;
  const fs::path root = dir / "capture";
  const ScanManifest written = WriteSmallScan(root, 3, 2);
  fs::remove(root / "scan.json");
  for (int v = 0; v < 3; ++v) {
    fs::rename(root / "views" / IndexName(v) / "left", root / "views" / IndexName(v) / "L");
    fs::rename(root / "views" / IndexName(v) / "right", root / "views" / IndexName(v) / "R");
  }
  fs::rename(root / "calibration" / "left", root / "calibration" / "L");
  fs::rename(root / "calibration" / "right", root / "calibration" / "R");
  const ScanFolder scan = ScanFolder::Open(root);
  EXPECT_FALSE(fs::exists(root / "scan.json"));  // nothing written
  ASSERT_TRUE(scan.inferred());
  const ScanManifest& m = scan.manifest();
  EXPECT_EQ(m.views, written.views);
  EXPECT_EQ(m.image_width, kWidth);
  EXPECT_EQ(m.image_height, kHeight);
  EXPECT_EQ(m.bit_depth, 8);
  EXPECT_EQ(m.cameras, 2);
  EXPECT_EQ(m.camera_folders, (std::vector<std::string>{"L", "R"}));
  EXPECT_EQ(m.scheme, "scheme.json");
  EXPECT_EQ(m.calibration_images, 2);
  EXPECT_EQ(m.calibration_target, "calibration/target.json");
  EXPECT_EQ(scan.calibration_images().size(), 2u);
  const phase::PatternScheme scheme = scan.ReadScheme();
  EXPECT_EQ(scan.ReadStack("002", Camera::kRight, scheme).size(),
            static_cast<size_t>(scheme.NumImages()));
  EXPECT_NE(scan.inferred_notes()[0].find("3 views (views/000 .. views/002), two cameras L/ R/"),
            std::string::npos)
      << scan.inferred_notes()[0];
  // Written out and read back, the manifest opens the same folder.
  WriteManifest(root / "scan.json", m);
  const ScanFolder reopened = ScanFolder::Open(root);
  EXPECT_FALSE(reopened.inferred());
  EXPECT_EQ(reopened.layout().CameraDir("001", Camera::kLeft), root / "views" / "001" / "L");

  // One camera as cam0/: camera + projector views.
  const fs::path mono = dir / "mono";
  WriteSmallScan(mono, 2, 0);
  fs::remove(mono / "scan.json");
  for (int v = 0; v < 2; ++v) {
    fs::remove_all(mono / "views" / IndexName(v) / "right");
    fs::rename(mono / "views" / IndexName(v) / "left", mono / "views" / IndexName(v) / "cam0");
  }
  const ScanFolder one = ScanFolder::Open(mono);
  EXPECT_FALSE(one.stereo());
  EXPECT_EQ(one.manifest().camera_folders, std::vector<std::string>{"cam0"});
  EXPECT_EQ(one.manifest().calibration_images, 0);
}

TEST(ScanFolder, InferenceFailuresNameWhatIsMissing) {
  test::TempDir dir;
  WriteSmallScan(dir / "a", 2, 0);
  fs::remove(dir / "a" / "scan.json");
  fs::remove(dir / "a" / "scheme.json");
  ExpectError([&] { ScanFolder::Open(dir / "a"); },
              {"no scan.json, and one cannot be inferred: no scheme.json"});
  WriteSmallScan(dir / "b", 2, 0);
  fs::remove(dir / "b" / "scan.json");
  fs::rename(dir / "b" / "views" / "000" / "left", dir / "b" / "views" / "000" / "links");
  ExpectError([&] { ScanFolder::Open(dir / "b"); },
              {"000: no camera folder (left/ right/, L/ R/ or cam0/ cam1/)"});
  // The other views must use the same folders as view 000.
  WriteSmallScan(dir / "c", 2, 0);
  fs::remove(dir / "c" / "scan.json");
  for (const char* c : {"left", "right"}) {
    fs::rename(dir / "c" / "views" / "000" / c,
               dir / "c" / "views" / "000" / (std::string(c) == "left" ? "L" : "R"));
  }
  ExpectError([&] { ScanFolder::Open(dir / "c"); }, {"001", "L"});
  // camera_folders in a manifest: one of the known namings, one name per camera.
  ScanManifest valid;
  valid.image_width = kWidth;
  valid.image_height = kHeight;
  nlohmann::json j = ManifestToJson(valid);
  j["camera_folders"] = {"L", "right"};
  ExpectError([&] { ManifestFromJson(j, "scan.json"); }, {"'camera_folders' must be"});
  j["camera_folders"] = {"L"};
  ExpectError([&] { ManifestFromJson(j, "scan.json"); }, {"'camera_folders' must list 2"});
}

}  // namespace
}  // namespace fringe::scan
