// fringe check on simulated VDI/VDE 2634-2 artefacts: its figures are those of fringe evaluate on
// the same clouds, and its verdict follows the MPE.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "fringe/cli/run_cli_for_test.h"
#include "fringe/io/json.h"
#include "fringe/testing/fringe_test.h"

namespace fringe::cli {
namespace {

// fringe evaluate --json of one artefact in a cloud.
nlohmann::json Evaluate(const std::filesystem::path& cloud, std::vector<std::string> args) {
  args.insert(args.begin(), {"evaluate", cloud.string()});
  args.push_back("--json");
  std::string out;
  EXPECT_EQ(RunCli(args, &out), 0) << out;
  return nlohmann::json::parse(out);
}

TEST(Check, FiguresOfEvaluateOnSimulatedArtefactsAndVerdictAgainstTightAndLooseMpe) {
  test::TempDir dir;
  const auto scan = dir / "vdi";
  ASSERT_EQ(RunCli({"-q", "simulate", "vdi", "--views", "2", "--rig-scale", "0.5",
                    "--calibration-images", "0", "--out", scan.string()}),
            0);
  const std::string rig = (scan / "truth" / "rig.json").string();
  // The artefacts of `fringe simulate vdi` (truth/scene.json): a 30 mm sphere, a ball bar of
  // 20 mm spheres 150 mm apart, a plate.
  auto write_artefact = [&](const std::string& name, double mpe_pf_mm) {
    std::ofstream(dir / name) << R"({"sphere": {"diameter_mm": 30, "uncertainty_mm": 0.001},
      "ballbar": {"distance_mm": 150, "sphere_diameter_mm": 20},
      "plane": {"flatness_mm": 0},
      "mpe": {"PF_mm": )" << mpe_pf_mm
                              << R"(, "PS_mm": 1, "SD_mm": 1, "F_mm": 1}})";
    return (dir / name).string();
  };
  const std::string loose = write_artefact("loose.json", 1.0);
  // Below the PF of the simulated sphere (0.17-0.28 mm at half size) and far above its noise.
  const std::string tight = write_artefact("tight.json", 0.05);

  std::vector<std::string> clouds;
  for (const char* view : {"000", "001"}) {
    const auto ply = dir / (std::string(view) + ".ply");
    ASSERT_EQ(RunCli({"-q", "reconstruct", (scan / "views" / view).string(), "--calib", rig,
                      "--out", ply.string(), "--no-markers"}),
              0);
    clouds.push_back(ply.string());
  }
  std::string out;
  std::vector<std::string> args = {"check"};
  args.insert(args.end(), clouds.begin(), clouds.end());
  for (const std::string& a :
       {std::string("--artefact"), loose, std::string("--out"), (dir / "loose").string()}) {
    args.push_back(a);
  }
  ASSERT_EQ(RunCli(args, &out), 0) << out;
  const nlohmann::json check = io::ReadJson(dir / "loose" / "check.json");
  EXPECT_EQ(check["status"], "pass");
  EXPECT_TRUE(std::filesystem::exists(dir / "loose" / "check.html"));
  ASSERT_EQ(check["positions"].size(), 2u);
  for (size_t k = 0; k < clouds.size(); ++k) {
    const nlohmann::json& figures = check["positions"][k]["figures"];
    const nlohmann::json sphere = Evaluate(clouds[k], {"--artefact", "sphere", "--diameter", "30"});
    const nlohmann::json bar =
        Evaluate(clouds[k], {"--artefact", "ballbar", "--diameter", "20", "--distance", "150"});
    const nlohmann::json plane = Evaluate(clouds[k], {"--artefact", "plane"});
    EXPECT_DOUBLE_EQ(figures["PF"]["value_mm"].get<double>(),
                     sphere["sphere"]["PF_mm"].get<double>());
    EXPECT_DOUBLE_EQ(figures["PS"]["value_mm"].get<double>(),
                     sphere["sphere"]["PS_mm"].get<double>());
    EXPECT_DOUBLE_EQ(figures["SD"]["value_mm"].get<double>(),
                     bar["ballbar"]["SD_mm"].get<double>());
    EXPECT_DOUBLE_EQ(figures["F"]["value_mm"].get<double>(), plane["plane"]["F_mm"].get<double>());
    EXPECT_GT(figures["PF"]["value_mm"].get<double>(), 0.05);  // what makes `tight` fail
  }

  // The tight MPE: the check fails (exit code 1) on PF, still writing its results.
  args[args.size() - 3] = tight;
  args.back() = (dir / "tight").string();
  EXPECT_EQ(RunCli(args, &out), 1) << out;
  const nlohmann::json failed = io::ReadJson(dir / "tight" / "check.json");
  EXPECT_EQ(failed["status"], "fail");
  EXPECT_EQ(failed["worst"]["PF"]["verdict"], "FAIL");
  EXPECT_EQ(failed["worst"]["SD"]["verdict"], "pass");

  // The scan folder itself: its views reconstructed with the rig give the same figures (up to
  // the PLY files' float precision).
  ASSERT_EQ(RunCli({"-q", "check", scan.string(), "--calib", rig, "--artefact", loose, "--out",
                    (dir / "scan").string()},
                   &out),
            0)
      << out;
  const nlohmann::json from_scan = io::ReadJson(dir / "scan" / "check.json");
  ASSERT_EQ(from_scan["positions"].size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    for (const char* f : {"PF", "PS", "SD", "F"}) {
      EXPECT_NEAR(from_scan["positions"][k]["figures"][f]["value_mm"].get<double>(),
                  check["positions"][k]["figures"][f]["value_mm"].get<double>(), 2e-3)
          << f;
    }
  }
  // A scan folder without a rig is an error naming it; nothing is written.
  EXPECT_EQ(RunCli({"check", scan.string(), "--artefact", loose, "--out", (dir / "none").string()},
                   &out, &out),
            1);
  EXPECT_NE(out.find("no rig"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(dir / "none"));
}

}  // namespace
}  // namespace fringe::cli
