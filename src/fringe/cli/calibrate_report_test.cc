// fringe calibrate --report: the calibration report folder on a small simulated calibration.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "fringe/cli/run_cli_for_test.h"
#include "fringe/io/json.h"
#include "fringe/sim/scan.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/testing/report.h"
#include "fringe/util/files.h"

namespace fringe::cli {
namespace {

TEST(CalibrateReport, WritesSummaryAndSelfContainedReport) {
  namespace fs = std::filesystem;
  test::TempDir dir;
  sim::ScanOptions o;
  o.scene = "sphere";
  o.views = 1;
  o.calibration_images = 8;
  o.render.sensor.supersampling = 1;
  sim::SimulateScan(sim::ScaledRig(StereoRig::Reference(), 0.25), o, dir / "scan");
  const std::string calibration = (dir / "scan" / "calibration").string();
  const std::string target = (dir / "scan" / "calibration" / "target.json").string();
  std::string out, err;
  ASSERT_EQ(
      RunCli({"calibrate", calibration, "--target", target, "--out", (dir / "rig.json").string(),
              "--report", (dir / "report").string(), "--pixel-size-um", "19.2"},
             &out, &err),
      0)
      << err;
  EXPECT_NE(out.find("calibration diagnostics:"), std::string::npos) << out;
  const nlohmann::json summary = io::ReadJson(dir / "report" / "summary.json");
  const nlohmann::json& d = summary["diagnostics"];
  EXPECT_EQ(summary["calibration"]["status"], "success");
  ASSERT_EQ(d["devices"].size(), 2u);
  EXPECT_EQ(d["devices"][0]["name"], "left");
  EXPECT_GT(d["devices"][0]["coverage"].get<double>(), 0);
  EXPECT_EQ(d["poses"].size(), 8u);
  EXPECT_EQ(d["predicted_depth_sigma_mm"].size(), 9u);
  // The quarter-size reference rig has 4 x 4.8 um pixels and a 12 mm lens: no focal warning.
  for (const auto& w : d["warnings"]) EXPECT_NE(w["code"], "focal") << w;
  const nlohmann::json t = io::ReadJson(dir / "rig.json")["right_from_left"]["translation_mm"];
  EXPECT_NEAR(d["distances_mm"]["baseline"].get<double>(),
              std::hypot(t[0].get<double>(), t[1].get<double>(), t[2].get<double>()), 1e-9);
  const std::string html = util::ReadTextFile(dir / "report" / "report.html");
  int sources = 0;
  EXPECT_EQ(io::testing::EmbeddedImages(html, &sources).size(), 5u);
  EXPECT_EQ(sources, 5);
  // No external reference (the embedded 3D viewer's script names the XHTML namespace URI, which
  // is not fetched: the scan report's test checks the same).
  for (const char* external : {"src=\"http", "src=\"//", "href=\"http", "href=\"//"}) {
    EXPECT_EQ(html.find(external), std::string::npos) << external;
  }
  EXPECT_NE(html.find("fringe-scene-0-description"), std::string::npos);  // the 3D view

  // --keep-all is accepted and rejects nothing; the report folder may not hold the rig file.
  ASSERT_EQ(
      RunCli({"-q", "calibrate", calibration, "--target", target, "--out",
              (dir / "rig2.json").string(), "--keep-all", "--report", (dir / "report2").string()},
             &out, &err),
      0)
      << err;
  EXPECT_TRUE(io::ReadJson(dir / "report2" / "summary.json")["diagnostics"]["rejections"].empty());
  fs::create_directories(dir / "report3");
  EXPECT_EQ(
      RunCli({"calibrate", calibration, "--target", target, "--out",
              (dir / "report3" / "rig.json").string(), "--report", (dir / "report3").string()},
             &out, &err),
      1);
  EXPECT_NE(err.find("inside the --report folder"), std::string::npos) << err;
  EXPECT_TRUE(fs::is_empty(dir / "report3"));
}

}  // namespace
}  // namespace fringe::cli
