#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "fringe/calib/calibrate_folder.h"
#include "fringe/cli/run_cli_for_test.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/mesh_io.h"
#include "fringe/io/ply.h"
#include "fringe/phase/pattern_scheme.h"
#include "fringe/registration/markers.h"
#include "fringe/registration/registration_io.h"
#include "fringe/scan/scan_folder.h"
#include "fringe/scan/truth.h"
#include "fringe/sim/demo_part.h"
#include "fringe/sim/scan.h"
#include "fringe/testing/file_size_limit.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::cli {
namespace {

TEST(Cli, HelpListsSubcommandsAndVersion) {
  std::string out;
  EXPECT_EQ(RunCli({"--help"}, &out), 0);
  EXPECT_NE(out.find("info"), std::string::npos);
  EXPECT_NE(out.find("demo"), std::string::npos);
  EXPECT_EQ(RunCli({"--version"}, &out), 0);
  EXPECT_NE(out.find("fringe "), std::string::npos);
}

TEST(Cli, UsageErrorsExitWith2) {
  std::string err;
  EXPECT_EQ(RunCli({"frobnicate"}, nullptr, &err), 2);
  EXPECT_NE(err.find("usage error"), std::string::npos) << err;
  EXPECT_EQ(RunCli({"info", "--no-such-flag", "x"}), 2);
  EXPECT_EQ(RunCli({}), 2);
}

TEST(Cli, InfoOnPlyAndTruncatedPly) {
  test::TempDir dir;
  PointCloud c;
  for (int i = 0; i < 1000; ++i) c.points.emplace_back(i, 2 * i, 3 * i);
  io::WritePly(dir / "c.ply", c);
  std::string out, err;
  EXPECT_EQ(RunCli({"info", (dir / "c.ply").string()}, &out), 0);
  EXPECT_NE(out.find("points: 1000"), std::string::npos) << out;
  const std::string data = util::ReadTextFile(dir / "c.ply");
  {
    std::ofstream f(dir / "t.ply", std::ios::binary);
    f << data.substr(0, data.size() / 2);
  }
  EXPECT_EQ(RunCli({"info", (dir / "t.ply").string()}, &out, &err), 1);
  EXPECT_NE(err.find("t.ply: truncated"), std::string::npos) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << "one-line error: " << err;
}

// A body of garbage or NaN is said to be one (issue 30), not described with NaN bounds: a few NaN
// vertices (how PCL keeps invalid pixels) are counted apart, a file of nothing else is refused.
TEST(Cli, InfoSaysWhenAPlyBodyIsNotPoints) {
  test::TempDir dir;
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n";
  std::ofstream(dir / "some.ply") << header << "nan nan nan\n1 2 3\ninf 0 0\n";
  std::ofstream(dir / "none.ply") << header << "nan nan nan\n1e30 2 3\n-inf 0 0\n";
  std::string out, err;
  EXPECT_EQ(RunCli({"info", (dir / "some.ply").string()}, &out), 0);
  EXPECT_NE(out.find("damaged: 2 vertices NaN or infinite"), std::string::npos) << out;
  EXPECT_NE(out.find("bounds: [1.000 2.000 3.000] .. [1.000 2.000 3.000]"), std::string::npos)
      << out;
  EXPECT_EQ(out.find("nan"), std::string::npos) << out;
  EXPECT_EQ(RunCli({"info", (dir / "none.ply").string()}, &out, &err), 1);
  EXPECT_NE(err.find("none.ply: none of its 3 vertices is a usable point"), std::string::npos)
      << err;
}

// A small scan: quarter-size rig, 2 views of the sphere (truth maps when `truth_maps`).
void SimulateSmallSphereScan(const std::filesystem::path& scan_dir, bool truth_maps) {
  sim::ScanOptions o;
  o.scene = "sphere";
  o.views = 2;
  o.calibration_images = 0;
  o.render.sensor.supersampling = 1;
  o.truth_maps = truth_maps;
  sim::SimulateScan(sim::ScaledRig(StereoRig::Reference(), 0.25), o, scan_dir);
}

TEST(Cli, ScanKeepGoingExitsWith3AndFailureExitsWith1) {
  test::TempDir dir;
  SimulateSmallSphereScan(dir / "scan", true);
  std::filesystem::remove(dir / "scan" / "views" / "001" / "left" / "00.png");
  const std::string rig = (dir / "scan" / "truth" / "rig.json").string();
  const std::string scan = (dir / "scan").string(), out = (dir / "out").string();
  std::string stdout_text, err;
  EXPECT_EQ(RunCli({"--threads", "1", "scan", scan, "--calib", rig, "--out", out}, nullptr, &err),
            1);
  EXPECT_NE(err.find("view 001"), std::string::npos) << err;
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));
  EXPECT_EQ(RunCli({"-q", "--threads", "1", "scan", scan, "--calib", rig, "--out", out,
                    "--keep-going", "--json"},
                   &stdout_text, &err),
            3)
      << err;
  EXPECT_NE(stdout_text.find("\"status\": \"partial\""), std::string::npos) << stdout_text;
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "views" / "000.ply"));
  EXPECT_EQ(RunCli({"--threads", "-1", "scan", scan, "--out", out}), 2);
}

TEST(Cli, SimulateOneCameraScanThenScanIt) {
  // `fringe simulate ... --cameras 1 --both-directions --exposures 1,0.5 && fringe scan ...`:
  // the camera + projector scanner end to end from the CLI (quarter-size rig, 2 views of the
  // sphere on its marked plate).
  test::TempDir dir;
  const std::string scan = (dir / "scan").string(), out = (dir / "out").string();
  std::string stdout_text, err;
  ASSERT_EQ(RunCli({"-q", "simulate", "sphere", "--rig-scale", "0.25", "--views", "2", "--cameras",
                    "1", "--both-directions", "--exposures", "1,0.5", "--calibration-images", "0",
                    "--supersampling", "1", "--no-truth-maps", "--out", scan},
                   &stdout_text, &err),
            0)
      << err;
  EXPECT_NE(stdout_text.find("one camera + projector"), std::string::npos) << stdout_text;
  const scan::ScanFolder folder = scan::ScanFolder::Open(dir / "scan");
  EXPECT_FALSE(folder.stereo());
  EXPECT_TRUE(folder.both_directions());
  EXPECT_TRUE(std::filesystem::exists(dir / "scan/views/001/left/horizontal/e1/00.png"));
  EXPECT_FALSE(std::filesystem::exists(dir / "scan/views/001/right"));
  // The rig as another tool writes it (SLStudio's calibration.xml: the camera and the projector),
  // read by `fringe scan --opencv` with the format detected.
  ASSERT_EQ(RunCli({"convert-calib", (dir / "scan/truth/rig.json").string(), "--to", "slstudio",
                    "--out", (dir / "calibration.xml").string()},
                   &stdout_text, &err),
            0)
      << err;
  ASSERT_EQ(RunCli({"-q", "scan", scan, "--opencv", (dir / "calibration.xml").string(), "--out",
                    out, "--poisson-depth", "7", "--no-report", "--write-manifest"},
                   &stdout_text, &err),
            0)
      << err;
  EXPECT_NE(stdout_text.find("exists: --write-manifest leaves it as it is"), std::string::npos)
      << stdout_text;
  const nlohmann::json summary = io::ReadJson(dir / "out" / "summary.json");
  EXPECT_EQ(summary["mode"].get<std::string>(), "camera-projector");
  EXPECT_EQ(summary["views_ok"].get<int>(), 2);
  for (const auto& v : summary["view_results"]) {
    EXPECT_GT(v["decode_valid_right"].get<double>(), 0.2) << "the horizontal stack is decoded";
  }
  // Against the truth: the bounds of the pipeline's camera + projector tests.
  EXPECT_LT(summary["pose_trans_err_mm"].get<double>(), 0.1);
  EXPECT_LT(summary["single_view_all_rms_mm"].get<double>(), 0.15);
  // `fringe reconstruct` on one of its views: the scan's two schemes, both exposures, the same
  // points as the scan's view cloud; the calibration file read through an explicit key mapping.
  ASSERT_EQ(RunCli({"reconstruct", (dir / "scan/views/001").string(), "--opencv",
                    (dir / "calibration.xml").string(), "--opencv-keys", "left=Kc,kc",
                    "left_size=frameWidth,frameHeight", "projector=Kp,kp",
                    "projector_size=screenResX,screenResY", "projector_from_left=Rp,Tp", "--out",
                    (dir / "001.ply").string(), "--no-markers"},
                   &stdout_text, &err),
            0)
      << err;
  EXPECT_NE(stdout_text.find("vertical and horizontal fringes"), std::string::npos) << stdout_text;
  EXPECT_EQ(io::ReadOrganizedPly(dir / "001.ply").NumValid(),
            io::ReadOrganizedPly(dir / "out/views/001.ply").NumValid());
  // Both directions need one camera: a usage error.
  EXPECT_EQ(RunCli({"simulate", "sphere", "--both-directions", "--out", (dir / "stereo").string()},
                   nullptr, &err),
            2);
  EXPECT_NE(err.find("--cameras 1"), std::string::npos) << err;
}

TEST(Cli, ScanOnAFullDiskExitsWith1NamingTheFileAndTheStage) {
  // A full disk simulated by a file size limit (tests/file_size_limit.h): 100 kB fit every JSON
  // file but no view cloud.
  test::TempDir dir;
  SimulateSmallSphereScan(dir / "scan", false);
  const std::string rig = (dir / "scan" / "truth" / "rig.json").string();
  std::string err;
  int rc = 0;
  {
    const test::FileSizeLimit full(100000);
    rc = RunCli({"-q", "scan", (dir / "scan").string(), "--calib", rig, "--out",
                 (dir / "out").string(), "--keep-going"},
                nullptr, &err);
  }
  EXPECT_EQ(rc, 1) << err;
  EXPECT_NE(err.find("stage 'write'"), std::string::npos) << err;
  EXPECT_NE(err.find((dir / "out" / "views" / "00").string()), std::string::npos) << err;
  EXPECT_NE(err.find("File too large"), std::string::npos) << err;
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
    EXPECT_EQ(e.path().filename(), "scan") << "left behind: " << e.path();
  }
}

// Issue 15, item 9: a full disk while `reconstruct` and `calibrate` write their outputs is
// reported naming the user's file (never the hidden temporary beside it), exits 1 and leaves no
// output and no temporary behind. The file size limit (tests/file_size_limit.h) lets the small
// files through and stops the first large one.
TEST(Cli, ReconstructAndCalibrateOnAFullDiskNameTheUsersFile) {
  namespace fs = std::filesystem;
  test::TempDir dir;
  sim::ScanOptions o;
  o.scene = "sphere";
  o.views = 1;
  o.calibration_images = 6;
  o.render.sensor.supersampling = 1;
  sim::SimulateScan(sim::ScaledRig(StereoRig::Reference(), 0.25), o, dir / "scan");
  fs::create_directories(dir / "out");
  const auto leftovers = [&] {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir / "out")) {
      names.push_back(e.path().filename().string());
    }
    return names;
  };
  const std::string cloud = (dir / "out" / "view.ply").string();
  std::string err;
  int rc = 0;
  {
    const test::FileSizeLimit full(20000);  // the view's cloud is several 100 kB
    rc = RunCli({"-q", "reconstruct", (dir / "scan" / "views" / "000").string(), "--calib",
                 (dir / "scan" / "truth" / "rig.json").string(), "--out", cloud},
                nullptr, &err);
  }
  EXPECT_EQ(rc, 1) << err;
  EXPECT_NE(err.find(cloud + ": cannot write: File too large"), std::string::npos) << err;
  EXPECT_EQ(err.find(".tmp"), std::string::npos) << err;
  EXPECT_TRUE(leftovers().empty()) << leftovers().front();

  const std::string rig = (dir / "out" / "rig.json").string();
  const std::string residuals = (dir / "out" / "residuals.tiff").string();
  {
    const test::FileSizeLimit full(20000);  // the rig fits, the float residual image does not
    rc = RunCli({"-q", "calibrate", (dir / "scan" / "calibration").string(), "--target",
                 (dir / "scan" / "calibration" / "target.json").string(), "--out", rig,
                 "--residual-image", residuals},
                nullptr, &err);
  }
  EXPECT_EQ(rc, 1) << err;
  EXPECT_NE(err.find(residuals + ": cannot write"), std::string::npos) << err;
  EXPECT_EQ(err.find(".tmp"), std::string::npos) << err;
  EXPECT_TRUE(leftovers().empty()) << leftovers().front();
  // Without the limit both succeed: the failures above were the disk's, not the inputs'.
  EXPECT_EQ(RunCli({"-q", "calibrate", (dir / "scan" / "calibration").string(), "--target",
                    (dir / "scan" / "calibration" / "target.json").string(), "--out", rig,
                    "--residual-image", residuals},
                   nullptr, &err),
            0)
      << err;
  EXPECT_TRUE(fs::exists(rig) && fs::exists(residuals));
}

// ---------------------------------------------------------------------------------------------
// Hostile and broken inputs (issue 15): each class asserts the exit code, a message naming the
// user's file and the problem, and that nothing was written, deleted or overwritten.

namespace fs = std::filesystem;

// Every regular file below `dir` (relative names), to compare before and after a command.
std::vector<std::string> Listing(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    names.push_back(fs::relative(e.path(), dir).string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// A small pattern folder (the projector's own images serve as a decodable camera stack).
fs::path SmallStack(const test::TempDir& dir) {
  const fs::path stack = dir / "stack";
  EXPECT_EQ(RunCli({"patterns", "--scheme", "gray+4", "--width", "64", "--height", "16", "--out",
                    stack.string()}),
            0);
  return stack;
}

TEST(CliBadInput, DecodeOutIntoItsOwnStackIsRefusedAndKeepsTheImages) {
  test::TempDir dir;
  const fs::path stack = SmallStack(dir);
  const auto before = Listing(stack);
  std::string err;
  EXPECT_EQ(RunCli({"decode", stack.string(), "--scheme", (stack / "manifest.json").string(),
                    "--out", stack.string()},
                   nullptr, &err),
            1);
  EXPECT_NE(err.find(stack.string() + ": is also an input"), std::string::npos) << err;
  EXPECT_EQ(Listing(stack), before);
  // And it works into a fresh folder, which a second run may replace (it holds the marker). The
  // projector's own images reach 255 (saturated for an 8-bit camera): scaled to 80 % they read
  // as an unsaturated capture.
  for (const auto& name : before) {
    if (fs::path(name).extension() != ".png") continue;
    cv::Mat img = cv::imread((stack / name).string(), cv::IMREAD_UNCHANGED);
    img.convertTo(img, CV_8U, 0.8);
    cv::imwrite((stack / name).string(), img);
  }
  EXPECT_EQ(RunCli({"decode", stack.string(), "--scheme", (stack / "manifest.json").string(),
                    "--out", (dir / "dec").string()}),
            0);
  EXPECT_TRUE(fs::exists(dir / "dec" / "absolute_phase.tiff"));
  EXPECT_EQ(RunCli({"decode", stack.string(), "--scheme", (stack / "manifest.json").string(),
                    "--out", (dir / "dec").string()}),
            0);
}

TEST(CliBadInput, PatternsNeverDeleteAForeignFolder) {
  test::TempDir dir;
  fs::create_directories(dir / "mine");
  WriteText(dir / "mine" / "thesis.pdf", "precious");
  std::string err;
  EXPECT_EQ(
      RunCli({"patterns", "--scheme", "gray+4", "--out", (dir / "mine").string()}, nullptr, &err),
      1);
  EXPECT_NE(err.find("was not written by fringe"), std::string::npos) << err;
  EXPECT_EQ(util::ReadTextFile(dir / "mine" / "thesis.pdf"), "precious");
}

TEST(CliBadInput, CalibrateAndReconstructNeverOverwriteTheirInputs) {
  test::TempDir dir;
  fs::create_directories(dir / "imgs");
  WriteText(dir / "t.json", "{}");
  std::string err;
  EXPECT_EQ(RunCli({"calibrate", (dir / "imgs").string(), "--target", (dir / "t.json").string(),
                    "--out", (dir / "t.json").string()},
                   nullptr, &err),
            1);
  EXPECT_NE(err.find("is also an input"), std::string::npos) << err;
  EXPECT_EQ(util::ReadTextFile(dir / "t.json"), "{}");
  const fs::path stack = SmallStack(dir);
  fs::create_directories(dir / "view");
  fs::copy(stack, dir / "view" / "left");
  fs::copy(stack, dir / "view" / "right");
  WriteText(dir / "rig.json", "{}");
  EXPECT_EQ(
      RunCli({"reconstruct", (dir / "view").string(), "--calib", (dir / "rig.json").string(),
              "--scheme", (stack / "manifest.json").string(), "--out", (dir / "rig.json").string()},
             nullptr, &err),
      1);
  EXPECT_NE(err.find("is also an input"), std::string::npos) << err;
  EXPECT_EQ(util::ReadTextFile(dir / "rig.json"), "{}");
  // Residuals: a format that cannot hold floats, or a missing folder, fail before any work and
  // leave no cloud behind.
  for (const std::string& res : {(dir / "r.png").string(), (dir / "nodir" / "r.tiff").string()}) {
    EXPECT_EQ(RunCli({"reconstruct", (dir / "view").string(), "--calib",
                      (dir / "rig.json").string(), "--scheme", (stack / "manifest.json").string(),
                      "--out", (dir / "r.ply").string(), "--residuals", res},
                     nullptr, &err),
              1);
    EXPECT_NE(err.find(res), std::string::npos) << err;
    EXPECT_FALSE(fs::exists(dir / "r.ply"));
  }
}

// The cloud is PLY: an --out without .ply (no extension, or another one) would be a file that
// `fringe info` does not recognise; it is refused before any work, naming the path and the
// extension to use, and nothing is written.
TEST(CliBadInput, ReconstructRefusesAnOutWithoutPlyExtension) {
  test::TempDir dir;
  const fs::path stack = SmallStack(dir);
  fs::create_directories(dir / "view");
  fs::copy(stack, dir / "view" / "left");
  fs::copy(stack, dir / "view" / "right");
  WriteText(dir / "rig.json", "{}");
  auto listing = [&] {
    std::vector<fs::path> files;
    for (const auto& e : fs::recursive_directory_iterator(dir.path())) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    return files;
  };
  const std::vector<fs::path> before = listing();
  for (const std::string& out : {(dir / "o3").string(), (dir / "o3.txt").string()}) {
    std::string err;
    EXPECT_EQ(
        RunCli({"reconstruct", (dir / "view").string(), "--calib", (dir / "rig.json").string(),
                "--scheme", (stack / "manifest.json").string(), "--out", out},
               nullptr, &err),
        1)
        << out;
    EXPECT_NE(err.find(out + ": --out writes a PLY point cloud; use a .ply name"),
              std::string::npos)
        << err;
    EXPECT_EQ(listing(), before) << out;
  }
}

// --centres picks CSV or JSON by the extension; anything else is refused before any work, and
// a ball bar needs its calibrated distance.
TEST(CliBadInput, CentresFileAndBallBarDistanceAreCheckedFirst) {
  test::TempDir dir;
  fs::create_directories(dir / "imgs");
  WriteText(dir / "t.json", "{}");
  std::string err;
  EXPECT_EQ(
      RunCli({"calibrate", (dir / "imgs").string(), "--target", (dir / "t.json").string(), "--out",
              (dir / "rig.json").string(), "--centres", (dir / "centres.txt").string()},
             nullptr, &err),
      1);
  EXPECT_NE(err.find("centres.txt: centres file must end in .csv or .json"), std::string::npos)
      << err;
  EXPECT_FALSE(fs::exists(dir / "rig.json"));
  PointCloud c;
  for (int i = 0; i < 200; ++i) c.points.emplace_back(i, 0.5 * i, 100);
  io::WritePly(dir / "c.ply", c);
  EXPECT_EQ(RunCli({"evaluate", (dir / "c.ply").string(), "--artefact", "ballbar"}, nullptr, &err),
            2);
  EXPECT_NE(err.find("--artefact ballbar needs --distance"), std::string::npos) << err;
}

TEST(CliBadInput, ManifestImageNamesCannotEscapeTheirFolder) {
  test::TempDir dir;
  const fs::path stack = SmallStack(dir);
  nlohmann::json m = nlohmann::json::parse(util::ReadTextFile(stack / "manifest.json"));
  m["images"][0] = "../../escaped.png";
  fs::create_directories(dir / "evil");
  WriteText(dir / "evil" / "m.json", m.dump());
  std::string err;
  EXPECT_EQ(RunCli({"patterns", "--scheme", (dir / "evil" / "m.json").string(), "--out",
                    (dir / "evil" / "out").string()},
                   nullptr, &err),
            1);
  EXPECT_NE(err.find("m.json.images: image name '../../escaped.png': '..'"), std::string::npos)
      << err;
  EXPECT_EQ(RunCli({"decode", stack.string(), "--scheme", (dir / "evil" / "m.json").string(),
                    "--out", (dir / "d").string()},
                   nullptr, &err),
            1);
  EXPECT_FALSE(fs::exists(dir.path().parent_path() / "escaped.png"));
  EXPECT_FALSE(fs::exists(dir / "d"));
  m["images"][0] = "/tmp/abs.png";
  WriteText(dir / "evil" / "m.json", m.dump());
  EXPECT_EQ(RunCli({"patterns", "--scheme", (dir / "evil" / "m.json").string(), "--out",
                    (dir / "evil" / "out").string()},
                   nullptr, &err),
            1);
  EXPECT_NE(err.find("absolute path"), std::string::npos) << err;
  m["images"][0] = m["images"][1];
  WriteText(dir / "evil" / "m.json", m.dump());
  EXPECT_EQ(RunCli({"patterns", "--scheme", (dir / "evil" / "m.json").string(), "--out",
                    (dir / "evil" / "out").string()},
                   nullptr, &err),
            1);
  EXPECT_NE(err.find("appears twice"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "evil" / "out"));
}

TEST(CliBadInput, DeepOrHugeValuesInSmallFilesFailCleanly) {
  test::TempDir dir;
  std::string err;
  // A scheme whose "format" is 40 000 levels deep.
  WriteText(dir / "deep.json",
            "{\"format\": " + std::string(40000, '[') + std::string(40000, ']') + "}");
  EXPECT_EQ(
      RunCli({"patterns", "--scheme", (dir / "deep.json").string(), "--out", (dir / "o").string()},
             nullptr, &err),
      1);
  EXPECT_NE(err.find("deep.json: JSON nested deeper than"), std::string::npos) << err;
  // 40 000 nested YAML sequences.
  std::string yaml = "%YAML:1.0\n---\nM1: ";
  for (int i = 0; i < 40000; ++i) yaml += "- ";
  WriteText(dir / "deep.yml", yaml + "1\n");
  EXPECT_EQ(RunCli({"info", (dir / "deep.yml").string()}, nullptr, &err), 1);
  EXPECT_NE(err.find("deep.yml: line 3"), std::string::npos) << err;
  // An OpenCV matrix declaring 300000 rows in a few bytes.
  WriteText(dir / "rows.yml",
            "%YAML:1.0\n---\nM1: !!opencv-matrix\n   rows: 300000\n   cols: 3\n   dt: d\n   "
            "data: [ 1. ]\n");
  EXPECT_EQ(RunCli({"info", (dir / "rows.yml").string()}, nullptr, &err), 1);
  EXPECT_NE(
      err.find("rows.yml: M1 (left camera matrix): rows and cols must be integers in [1, 64]"),
      std::string::npos)
      << err;
  // A PLY of a few hundred bytes declaring 10^8 rich vertices.
  WriteText(dir / "huge.ply",
            "ply\nformat binary_little_endian 1.0\nelement vertex 100000000\nproperty float x\n"
            "property float y\nproperty float z\nproperty float nx\nproperty float ny\n"
            "property float nz\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
            "end_header\n" +
                std::string(64, '\0'));
  EXPECT_EQ(RunCli({"info", (dir / "huge.ply").string()}, nullptr, &err), 1);
  EXPECT_NE(err.find("huge.ply: truncated or inconsistent: header declares 100000000 vertex items"),
            std::string::npos)
      << err;
  // An organized PLY whose grid comment claims 15000 x 15000 pixels.
  WriteText(dir / "grid.ply",
            "ply\nformat ascii 1.0\ncomment fringe_grid 15000 15000\nelement vertex 1\n"
            "property float x\nproperty float y\nproperty float z\nproperty uint grid_index\n"
            "end_header\n1 2 3 0\n");
  EXPECT_EQ(RunCli({"info", (dir / "grid.ply").string()}, nullptr, &err), 1);
  EXPECT_NE(err.find("grid.ply: header line 3: malformed 'comment fringe_grid"), std::string::npos)
      << err;
  WriteText(dir / "abc.ply",
            "ply\nformat ascii 1.0\nelement vertex abc\nproperty float x\nproperty float y\n"
            "property float z\nend_header\n");
  EXPECT_EQ(RunCli({"info", (dir / "abc.ply").string()}, nullptr, &err), 1);
  EXPECT_NE(err.find("abc.ply: header line 3: bad element declaration"), std::string::npos) << err;
}

TEST(CliBadInput, OutOfRangeNumbersAreRejectedNotWrapped) {
  test::TempDir dir;
  const fs::path stack = SmallStack(dir);
  const nlohmann::json good = nlohmann::json::parse(util::ReadTextFile(stack / "manifest.json"));
  std::string err;
  for (const auto& [pointer, value, expected] :
       std::vector<std::tuple<std::string, nlohmann::json, std::string>>{
           {"/projector/width", 4294967936ULL, "projector.width = 4294967936: must be in"},
           {"/phase_sets/0/steps", 4294967300ULL, "steps = 4294967300: must be in"},
           {"/phase_sets/0/steps", 4.5, "steps: expected an integer"},
           {"/phase_sets/0/steps", 1000000, "steps = 1000000: must be in [3, 64]"},
           {"/phase_sets/0/period_px", "20", "period_px: expected a number"}}) {
    nlohmann::json m = good;
    m[nlohmann::json::json_pointer(pointer)] = value;
    WriteText(dir / "m.json", m.dump());
    EXPECT_EQ(
        RunCli({"patterns", "--scheme", (dir / "m.json").string(), "--out", (dir / "o").string()},
               nullptr, &err),
        1)
        << pointer;
    EXPECT_NE(err.find("m.json"), std::string::npos) << err;
    EXPECT_NE(err.find(expected), std::string::npos) << err;
  }
  WriteText(dir / "m.json", "{\"format\": \"fringe-patterns\", \"projector\": {\"width\": 1e999}}");
  EXPECT_EQ(
      RunCli({"patterns", "--scheme", (dir / "m.json").string(), "--out", (dir / "o").string()},
             nullptr, &err),
      1);
  EXPECT_NE(err.find("m.json: invalid JSON"), std::string::npos) << err;
  EXPECT_EQ(RunCli({"patterns", "--scheme", "gray+4", "--width", "2147483647", "--out",
                    (dir / "o").string()},
                   nullptr, &err),
            2);
  EXPECT_FALSE(fs::exists(dir / "o"));
}

TEST(CliBadInput, FailuresWithoutAResultExit1) {
  test::TempDir dir;
  const fs::path stack = SmallStack(dir);
  // An all-black stack: nothing decodes, nothing is written.
  fs::create_directories(dir / "black");
  const auto names = nlohmann::json::parse(util::ReadTextFile(stack / "manifest.json"))["images"];
  for (const auto& n : names) {
    fs::copy_file(stack / n.get<std::string>(), dir / "black" / n.get<std::string>());
    cv::Mat img(16, 64, CV_8UC1, cv::Scalar(0));
    cv::imwrite((dir / "black" / n.get<std::string>()).string(), img);
  }
  std::string out, err;
  EXPECT_EQ(RunCli({"decode", (dir / "black").string(), "--scheme",
                    (stack / "manifest.json").string(), "--out", (dir / "dec").string()},
                   &out, &err),
            1);
  EXPECT_NE(err.find("black: decoding failed"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "dec"));
  // An empty cloud.
  WriteText(dir / "empty.ply",
            "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
            "property float z\nend_header\n");
  EXPECT_EQ(RunCli({"evaluate", (dir / "empty.ply").string(), "--artefact", "plane"}, &out, &err),
            1);
  EXPECT_NE(err.find("empty.ply: evaluation failed"), std::string::npos) << err;
  // A missing manifest file is a missing file, not an unknown preset.
  EXPECT_EQ(RunCli({"decode", stack.string(), "--scheme", (dir / "nope.json").string(), "--out",
                    (dir / "dec").string()},
                   nullptr, &err),
            1);
  EXPECT_NE(err.find("nope.json: scheme manifest: no such file"), std::string::npos) << err;
}

// Issue 10: every JSON reader (target, scheme, rig, scan folder) refuses an unknown key, naming
// the file, the key and the nearest valid key; the keys a rig deliberately carries (the
// calibration's residuals and standard deviations) are known.
TEST(CliBadInput, EveryJsonReaderNamesAnUnknownKeyAndTheNearestOne) {
  test::TempDir dir;
  const auto refused = [&](const std::string& name, nlohmann::json j, const std::string& typo,
                           const std::string& nearest, const auto& read) {
    j[typo] = j.contains(nearest) ? j[nearest] : nlohmann::json(1);
    j.erase(nearest);
    WriteText(dir / name, j.dump());
    std::string err;
    try {
      read(dir / name);
    } catch (const Error& e) {
      err = e.what();
    }
    EXPECT_NE(err.find(name), std::string::npos) << err;
    EXPECT_NE(err.find("unknown key \"" + typo + "\" (did you mean '" + nearest + "'?)"),
              std::string::npos)
        << err;
  };
  // (The issue's "radius_mm" names the three radii it could mean: io/json_test.cc.)
  refused("target.json", io::TargetToJson(CalibrationTarget::Reference()), "outer_radius",
          "outer_radius_mm", [](const fs::path& p) { io::ReadTarget(p); });
  const phase::PatternScheme scheme = phase::MakeScheme("heterodyne-4x3");
  refused("scheme.json", phase::SchemeToJson(scheme), "phase_set", "phase_sets",
          [](const fs::path& p) { phase::ReadScheme(p); });
  refused("rig.json", io::RigToJson(StereoRig::Reference()), "right_from_lft", "right_from_left",
          [](const fs::path& p) { io::ReadRig(p); });
  scan::ScanManifest manifest;
  manifest.views = 1;
  manifest.image_width = 64;
  manifest.image_height = 48;
  manifest.scheme = "scheme.json";
  refused("scan.json", scan::ManifestToJson(manifest), "bitdepth", "bit_depth",
          [](const fs::path& p) { scan::ManifestFromJson(io::ReadJson(p), p.string()); });
  // A rig written by `fringe calibrate` carries "calibration" (residuals, standard deviations).
  calib::FolderCalibration cal;
  cal.stereo = true;
  cal.pair.rig = StereoRig::Reference();
  calib::WriteFolderCalibration(dir / "calibrated.json", cal);
  ASSERT_TRUE(io::ReadJson(dir / "calibrated.json").contains("calibration"));
  EXPECT_NO_THROW(io::ReadRig(dir / "calibrated.json"));
}

// Issue 10: a failed calibration prints no figures that look like a result (it used to print
// "fx 2500.000 +- 0.000"), only the reason, and writes nothing.
TEST(CliBadInput, FailedCalibrationPrintsOnlyTheReason) {
  test::TempDir dir;
  fs::create_directories(dir / "boards");
  for (int i = 0; i < 3; ++i) {  // grey images: no board anywhere
    cv::imwrite((dir / "boards" / ("0" + std::to_string(i) + ".png")).string(),
                cv::Mat(256, 320, CV_8UC1, cv::Scalar(128)));
  }
  io::WriteJson(dir / "target.json", io::TargetToJson(CalibrationTarget::Reference()));
  std::string out, err;
  EXPECT_EQ(RunCli({"calibrate", (dir / "boards").string(), "--target",
                    (dir / "target.json").string(), "--out", (dir / "rig.json").string()},
                   &out, &err),
            1);
  EXPECT_NE(err.find("boards: calibration failed: only 0 usable views"), std::string::npos) << err;
  for (const char* figure : {"fx", "RMS", "rms", "+-", "±"}) {
    EXPECT_EQ(out.find(figure), std::string::npos) << figure << " in: " << out;
    EXPECT_EQ(err.find(figure), std::string::npos) << figure << " in: " << err;
  }
  EXPECT_FALSE(fs::exists(dir / "rig.json"));
}

// Issue 10: a scheme whose phase offset does not match the capture shifts the order decisions;
// the many repaired orders are warned about, naming the scheme. The real capture decodes
// without the warning with its own offset and with it when the offset is 0.
TEST(Cli, DecodeWarnsWhenThePhaseOffsetDoesNotMatchTheCapture) {
  FRINGE_SHARED_DATA_OR_SKIP(data, "slsdk-stereo-phasegray");
  test::TempDir dir;
  const std::string stack = (data / "L").string();
  std::string out, err;
  ASSERT_EQ(RunCli({"decode", stack, "--scheme", "slsdk-phasegray", "--out",
                    (dir / "right_offset").string()},
                   &out, &err),
            0)
      << err;
  EXPECT_EQ(err.find("probably does not match"), std::string::npos) << err;
  ASSERT_EQ(RunCli({"decode", stack, "--scheme", "slsdk-phasegray", "--phase-offset", "0", "--out",
                    (dir / "wrong_offset").string()},
                   &out, &err),
            0)
      << err;
  EXPECT_NE(err.find("the phase offset or Gray-code convention of the scheme 'slsdk-phasegray' "
                     "probably does not match the capture"),
            std::string::npos)
      << err;
  EXPECT_NE(err.find(stack), std::string::npos) << err;
}

// Issue 10: a view folder holding another tool's manifest.json or rig.json: the error names the
// file that was picked up and the flag that gives the right one.
TEST(CliBadInput, ForeignManifestOrRigInAViewFolderIsNamed) {
  test::TempDir dir;
  const fs::path stack = SmallStack(dir);
  const fs::path view = dir / "view";
  for (const char* camera : {"left", "right"}) {
    fs::create_directories(view / camera);
    for (const auto& e : fs::directory_iterator(stack)) {
      if (e.path().extension() == ".png")
        fs::copy_file(e.path(), view / camera / e.path().filename());
    }
  }
  // Another tool's capture settings as manifest.json.
  WriteText(view / "manifest.json", R"({"exposure_us": 8000, "pattern": "sinus", "steps": 4})");
  io::WriteRig(view / "rig.json", StereoRig::Reference());
  std::string err;
  EXPECT_EQ(
      RunCli({"reconstruct", view.string(), "--out", (dir / "a.ply").string()}, nullptr, &err), 1);
  EXPECT_NE(err.find((view / "manifest.json").string() + ": not a fringe pattern manifest"),
            std::string::npos)
      << err;
  EXPECT_NE(err.find("--scheme"), std::string::npos) << err;
  // With the scheme given, another tool's rig.json is named the same way.
  WriteText(view / "rig.json", R"({"camera_matrix": [1, 0, 0, 0, 1, 0, 0, 0, 1]})");
  EXPECT_EQ(RunCli({"reconstruct", view.string(), "--scheme", (stack / "manifest.json").string(),
                    "--out", (dir / "b.ply").string()},
                   nullptr, &err),
            1);
  EXPECT_NE(err.find((view / "rig.json").string() + ": not a fringe rig file"), std::string::npos)
      << err;
  EXPECT_NE(err.find("--calib"), std::string::npos) << err;
  EXPECT_NE(err.find("--opencv"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "a.ply"));
  EXPECT_FALSE(fs::exists(dir / "b.ply"));
}

// What `fringe calibrate` writes for one camera is a rig file the readers and `fringe info`
// accept (issue 9: ReadRig used to throw "missing 'cameras'").
TEST(Cli, InfoAndReadRigOnASingleCameraCalibration) {
  test::TempDir dir;
  calib::FolderCalibration cal;
  cal.stereo = false;
  cal.mono.camera = StereoRig::Reference().left;
  cal.mono.summary.final_rms_px = 0.125;
  calib::WriteFolderCalibration(dir / "mono.json", cal);
  const StereoRig rig = io::ReadRig(dir / "mono.json");
  EXPECT_TRUE(rig.left == cal.mono.camera);
  EXPECT_EQ(rig.BaselineMm(), 0.0);  // no second camera: a stereo consumer's Check() refuses it
  EXPECT_THROW(rig.Check(), Error);
  std::string out, err;
  EXPECT_EQ(RunCli({"info", (dir / "mono.json").string()}, &out, &err), 0) << err;
  EXPECT_NE(out.find("single-camera calibration"), std::string::npos) << out;
  EXPECT_NE(out.find("1280x1024"), std::string::npos) << out;
}

// evaluate --align: points on the demo part's surface (float PLY), moved by a known 1 deg / 1 mm,
// are best-fitted back onto the mesh, and the transform is reported.
TEST(Cli, EvaluateAlignRecoversAKnownMotion) {
  test::TempDir dir;
  sim::DemoPartOptions part;
  part.grid_mm = 1.0;
  part.ribs = part.engraving = false;
  const TriangleMesh mesh = sim::MakeDemoPart(part).CombinedMesh();
  io::WriteMesh(dir / "part.ply", mesh);
  const Rigid3d cloud_from_mesh = Rigid3d::FromAxisAngle(
      Eigen::Vector3d(1, -2, 0.5).normalized(), M_PI / 180, Eigen::Vector3d(0.6, -0.5, 0.62));
  PointCloud cloud;
  for (size_t i = 0; i < mesh.triangles.size(); i += 5) {  // triangle centroids: walls too
    const auto& t = mesh.triangles[i];
    cloud.points.push_back(cloud_from_mesh *
                           ((mesh.vertices[t[0]] + mesh.vertices[t[1]] + mesh.vertices[t[2]]) / 3));
  }
  io::WritePly(dir / "cloud.ply", cloud);
  std::string out, err;
  ASSERT_EQ(RunCli({"evaluate", (dir / "cloud.ply").string(), "--truth",
                    (dir / "part.ply").string(), "--align", "--json"},
                   &out, &err),
            0)
      << out << err;
  const nlohmann::json j = nlohmann::json::parse(out);
  const Rigid3d mesh_from_cloud =
      io::RigidFromJson(j["align"]["mesh_from_cloud"], "align.mesh_from_cloud");
  const RigidDifference d = Difference(mesh_from_cloud, cloud_from_mesh.Inverse());
  EXPECT_LT(d.angle_rad * 180 / M_PI, 1e-4) << out;
  EXPECT_LT(d.translation_mm, 1e-3) << out;
  EXPECT_LT(j["deviation"]["rms_mm"].get<double>(), 1e-3) << out;
  // Too few picked pairs: a clear message naming the file, exit 1.
  WriteText(dir / "pairs.json", R"({"pairs": [{"cloud": [0, 0, 0], "mesh": [0, 0, 0]}]})");
  EXPECT_EQ(RunCli({"evaluate", (dir / "cloud.ply").string(), "--truth",
                    (dir / "part.ply").string(), "--align-pairs", (dir / "pairs.json").string()},
                   &out, &err),
            1);
  EXPECT_NE(err.find("pairs.json: the point pairs do not fix a pose"), std::string::npos) << err;
}

// fringe register on a folder of view PLYs (organized) with markers beside them: a wavy surface
// seen from three poses, markers stuck on it; poses.json gets every view, relative to the first;
// registered/ keeps the grids, and fringe fuse reads the folder.
TEST(Cli, RegisterWritesPosesAndAFusableFolder) {
  test::TempDir dir;
  auto height = [](double x, double y) {
    return 6 * std::sin(x / 15) * std::cos(y / 19) + 0.003 * x * x;
  };
  std::vector<Eigen::Vector3d> marker_world;
  for (int k = 0; k < 10; ++k) {
    const double x = -50 + 11 * k, y = (k % 3 - 1) * 25 + k;
    marker_world.emplace_back(x, y, height(x, y));
  }
  std::vector<Rigid3d> world_from_sensor;
  for (int v = 0; v < 3; ++v) {
    world_from_sensor.push_back(
        Rigid3d::FromAxisAngle(Eigen::Vector3d(0.1 * v, 1, 0.2).normalized(), M_PI + 0.15 * (v - 1),
                               Eigen::Vector3d(5.0 * v, -3.0 * v, 450)));
  }
  for (int v = 0; v < 3; ++v) {
    const Rigid3d sensor_from_world = world_from_sensor[v].Inverse();
    // An organized cloud (a grid over x, y), as fringe reconstruct writes: the registered
    // clouds must stay organized for fringe fuse.
    OrganizedPointCloud c(201, 143, true, true, true);
    for (int r = 0; r < c.height; ++r) {
      for (int col = 0; col < c.width; ++col) {
        const double x = -70 + 0.7 * col, y = -50 + 0.7 * r;
        const double z = height(x, y);
        const double dzdx = 6 / 15.0 * std::cos(x / 15) * std::cos(y / 19) + 0.006 * x;
        const double dzdy = -6 / 19.0 * std::sin(x / 15) * std::sin(y / 19);
        const size_t i = c.index(col, r);
        c.cloud.points[i] = sensor_from_world * Eigen::Vector3d(x, y, z);
        c.cloud.normals[i] =
            sensor_from_world.RotateDirection(Eigen::Vector3d(-dzdx, -dzdy, 1).normalized());
        c.cloud.intensity[i] = 100;
        c.cloud.quality[i] = 50;
        c.valid[i] = 1;
      }
    }
    const std::string name = "view" + std::to_string(v);
    io::WritePly(dir / (name + ".ply"), c);
    std::vector<registration::ViewMarker> markers;
    for (size_t k = 0; k < marker_world.size(); ++k) {
      registration::ViewMarker m;
      m.id = static_cast<int>(k);
      m.centre_in_sensor = sensor_from_world * marker_world[k];
      m.normal_in_sensor = sensor_from_world.RotateDirection(Eigen::Vector3d::UnitZ());
      m.outer_radius_mm = 2.5;
      m.sigma_mm = 0.02;
      markers.push_back(m);
    }
    registration::WriteViewMarkers(dir / (name + ".markers.json"), markers);
  }
  std::string out, err;
  ASSERT_EQ(RunCli({"register", (dir / "view0.ply").string(), (dir / "view1.ply").string(),
                    (dir / "view2.ply").string(), "--out", (dir / "reg").string()},
                   &out, &err),
            0)
      << out << err;
  const scan::TruthPoses poses = scan::ReadTruthPoses(dir / "reg" / "poses.json");
  ASSERT_EQ(poses.views.size(), 3u);
  for (int v = 0; v < 3; ++v) {
    const Rigid3d expected = world_from_sensor[0].Inverse() * world_from_sensor[v];
    const RigidDifference d =
        Difference(poses.Find("view" + std::to_string(v))->world_from_sensor, expected);
    EXPECT_LT(d.angle_rad * 180 / M_PI, 0.01) << v;
    EXPECT_LT(d.translation_mm, 0.05) << v;
  }
  EXPECT_TRUE(std::filesystem::exists(dir / "reg" / "markers.json"));
  // The registered clouds keep the input's grid, moved into the world frame.
  const OrganizedPointCloud reg2 = io::ReadOrganizedPly(dir / "reg" / "registered" / "view2.ply");
  ASSERT_EQ(reg2.width, 201);
  ASSERT_EQ(reg2.height, 143);
  const Eigen::Vector3d corner(-70, -50, height(-70, -50));  // grid slot (0, 0), world frame
  const Eigen::Vector3d corner_in_reg =
      world_from_sensor[0].Inverse() * corner;  // the registration's world = view 0's frame
  EXPECT_LT((reg2.cloud.points[0] - corner_in_reg).norm(), 0.05);
  // register -> fuse REGDIR: the folder is fusable as it stands.
  ASSERT_EQ(
      RunCli({"fuse", (dir / "reg").string(), "--out", (dir / "fused.ply").string(), "--json"},
             &out, &err),
      0)
      << out << err;
  const nlohmann::json fused = nlohmann::json::parse(out);
  EXPECT_EQ(fused["fusion"]["status"], "ok") << out;
  EXPECT_GT(fused["fusion"]["overlap_points"].get<int64_t>(), 1000) << out;
  // An output folder holding an input is refused, the inputs untouched.
  EXPECT_EQ(
      RunCli({"register", (dir / "view0.ply").string(), "--out", dir.path().string()}, &out, &err),
      1);
  EXPECT_TRUE(std::filesystem::exists(dir / "view0.ply"));
}

}  // namespace
}  // namespace fringe::cli
