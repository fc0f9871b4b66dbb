#include "fringe/eval/artefact.h"

#include <gtest/gtest.h>

#include <fstream>

#include "fringe/testing/fringe_test.h"

namespace fringe::eval {
namespace {

const char* kFull = R"({"format": "fringe-artefact", "version": 1, "name": "set 17",
  "sphere": {"diameter_mm": 30.0012, "uncertainty_mm": 0.002},
  "ballbar": {"distance_mm": 200.004, "distance_uncertainty_mm": 0.003,
              "sphere_diameter_mm": 25.0, "sphere_diameter_uncertainty_mm": 0.002},
  "plane": {"flatness_mm": 0.003, "uncertainty_mm": 0.001},
  "mpe": {"PF_mm": 0.05, "PS_mm": 0.04, "SD_mm": 0.08, "F_mm": 0.1}})";

TEST(Artefact, ReadsEveryFieldAndRoundTrips) {
  const Artefact a = ArtefactFromJson(nlohmann::json::parse(kFull), "a.json");
  EXPECT_EQ(a.name, "set 17");
  ASSERT_TRUE(a.sphere && a.ballbar && a.plane);
  EXPECT_DOUBLE_EQ(a.sphere->diameter_mm, 30.0012);
  EXPECT_DOUBLE_EQ(a.sphere->uncertainty_mm, 0.002);
  EXPECT_DOUBLE_EQ(a.ballbar->distance_mm, 200.004);
  EXPECT_DOUBLE_EQ(a.ballbar->distance_uncertainty_mm, 0.003);
  EXPECT_DOUBLE_EQ(a.ballbar->sphere_diameter_mm, 25.0);
  EXPECT_DOUBLE_EQ(a.plane->flatness_mm, 0.003);
  EXPECT_DOUBLE_EQ(a.mpe.PF_mm, 0.05);
  EXPECT_DOUBLE_EQ(a.mpe.PS_mm, 0.04);
  EXPECT_DOUBLE_EQ(a.mpe.SD_mm, 0.08);
  EXPECT_DOUBLE_EQ(a.mpe.F_mm, 0.1);
  EXPECT_EQ(ToJson(ArtefactFromJson(ToJson(a), "again")), ToJson(a));
}

TEST(Artefact, OnlyAnArtefactIsEnough) {
  const Artefact a =
      ArtefactFromJson(nlohmann::json::parse(R"({"ballbar": {"distance_mm": 150}})"), "b.json");
  EXPECT_FALSE(a.sphere);
  ASSERT_TRUE(a.ballbar);
  EXPECT_EQ(a.ballbar->sphere_diameter_mm, 0);  // not certified: free radius
  EXPECT_EQ(a.mpe.SD_mm, 0);                    // no MPE given
}

TEST(Artefact, ReadFromAFileNamesTheFileAndField) {
  test::TempDir dir;
  {
    std::ofstream(dir / "ok.json") << kFull;
    std::ofstream(dir / "typo.json") << R"({"sphere": {"diameter": 30}})";
    std::ofstream(dir / "negative.json") << R"({"sphere": {"diameter_mm": -30}})";
    std::ofstream(dir / "metres.json") << R"({"ballbar": {"distance_mm": 200000}})";
    std::ofstream(dir / "none.json") << R"({"mpe": {"PF_mm": 0.1}})";
    std::ofstream(dir / "u.json") << R"({"sphere": {"diameter_mm": 0.5, "uncertainty_mm": 0.5}})";
    std::ofstream(dir / "overlap.json")
        << R"({"ballbar": {"distance_mm": 20, "sphere_diameter_mm": 25}})";
    std::ofstream(dir / "format.json") << R"({"format": "fringe-rig", "plane": {}})";
  }
  EXPECT_TRUE(ReadArtefact(dir / "ok.json").sphere);
  auto error = [&](const char* name) { return test::ErrorOf([&] { ReadArtefact(dir / name); }); };
  EXPECT_NE(error("typo.json").find("typo.json.sphere: unknown key \"diameter\""),
            std::string::npos)
      << error("typo.json");
  EXPECT_NE(error("negative.json").find("negative.json.sphere.diameter_mm"), std::string::npos);
  EXPECT_NE(error("metres.json").find("metres.json.ballbar.distance_mm"), std::string::npos);
  EXPECT_NE(error("none.json").find("describes no artefact"), std::string::npos);
  EXPECT_NE(error("u.json").find("u.json.sphere.uncertainty_mm"), std::string::npos);
  EXPECT_NE(error("overlap.json").find("overlap"), std::string::npos);
  EXPECT_NE(error("format.json").find("format.json.format"), std::string::npos);
  EXPECT_NE(error("missing.json").find("missing.json"), std::string::npos);
}

}  // namespace
}  // namespace fringe::eval
