#include "fringe/eval/check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fringe/testing/report.h"
#include "fringe/util/error.h"
#include "fringe/util/random.h"

namespace fringe::eval {
namespace {

// A sphere (radius 15 mm) sampled over its upper hemisphere with radial noise, and a 100 x 100 mm
// plane with noise, in one cloud: what an artefact check sees.
PointCloud SphereAndPlane(double sphere_noise_mm, double plane_noise_mm, uint64_t seed) {
  util::Rng rng(seed);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(0, 1);
  PointCloud cloud;
  const Eigen::Vector3d centre(0, 0, 15);
  for (int i = 0; i < 6000; ++i) {
    Eigen::Vector3d d(normal(rng), normal(rng), std::abs(normal(rng)));
    d.normalize();
    cloud.points.push_back(centre + (15 + sphere_noise_mm * normal(rng)) * d);
  }
  for (int i = 0; i < 20000; ++i) {
    cloud.points.emplace_back(100 + 100 * uniform(rng), 100 * uniform(rng) - 50,
                              plane_noise_mm * normal(rng));
  }
  return cloud;
}

Artefact SphereAndPlaneArtefact(double mpe_mm) {
  Artefact a;
  a.sphere = SphereArtefact{30.0, 0.001};
  a.plane = PlaneArtefact{0.0, 0.001};
  a.mpe.PF_mm = a.mpe.PS_mm = a.mpe.F_mm = mpe_mm;
  return a;
}

TEST(Check, FiguresAreThoseOfTheVdiFunctionsAndTheVerdictFollowsTheMpe) {
  const std::vector<CheckInput> inputs = {{"a", SphereAndPlane(0.01, 0.01, 1)},
                                          {"b", SphereAndPlane(0.02, 0.005, 2)}};
  const CheckSummary loose = CheckArtefact(inputs, SphereAndPlaneArtefact(1.0));
  ASSERT_EQ(loose.positions.size(), 2u);
  for (size_t k = 0; k < inputs.size(); ++k) {
    const SphereResult sphere = EvaluateSphere(inputs[k].cloud, 30.0);
    const PlaneResult plane = EvaluatePlane(inputs[k].cloud);
    ASSERT_TRUE(sphere.ok() && plane.ok());
    const CheckPosition& p = loose.positions[k];
    ASSERT_EQ(p.figures.size(), 3u);
    EXPECT_EQ(p.figures[0].name, "PF");
    EXPECT_DOUBLE_EQ(p.figures[0].value_mm, sphere.PF_mm);
    EXPECT_DOUBLE_EQ(p.figures[1].value_mm, sphere.PS_mm);
    EXPECT_DOUBLE_EQ(p.figures[2].value_mm, plane.F_mm);
  }
  EXPECT_EQ(loose.status, CheckStatus::kPass) << loose.message;
  // The worst PF is position b's (twice the noise).
  EXPECT_DOUBLE_EQ(loose.worst[0].value_mm, loose.positions[1].figures[0].value_mm);

  // An MPE between the two positions' PF: b fails on PF, a passes.
  const double pf_a = loose.positions[0].figures[0].value_mm;
  const double pf_b = loose.positions[1].figures[0].value_mm;
  ASSERT_LT(pf_a, pf_b);
  Artefact tight = SphereAndPlaneArtefact(1.0);
  tight.mpe.PF_mm = 0.5 * (pf_a + pf_b);
  const CheckSummary s = CheckArtefact(inputs, tight);
  EXPECT_EQ(s.status, CheckStatus::kFail);
  EXPECT_TRUE(s.positions[0].figures[0].pass);
  EXPECT_FALSE(s.positions[1].figures[0].pass);
  EXPECT_NE(s.message.find("PF"), std::string::npos);
  EXPECT_NE(s.message.find(" b "), std::string::npos) << s.message;
}

TEST(Check, AnArtefactFoundNowhereOrAFigureWithoutMpeIsIncomplete) {
  const std::vector<CheckInput> inputs = {{"a", SphereAndPlane(0.01, 0.01, 3)}};
  Artefact bar = SphereAndPlaneArtefact(1.0);
  bar.ballbar = BallBarArtefact{200.0, 0.002, 25.0, 0.002};
  bar.mpe.SD_mm = 1.0;
  const CheckSummary s = CheckArtefact(inputs, bar);
  EXPECT_EQ(s.status, CheckStatus::kIncomplete);
  EXPECT_NE(s.message.find("SD was measured in no position"), std::string::npos) << s.message;
  EXPECT_FALSE(s.positions[0].figures[2].measured);

  Artefact no_mpe = SphereAndPlaneArtefact(1.0);
  no_mpe.mpe.F_mm = 0;
  const CheckSummary t = CheckArtefact(inputs, no_mpe);
  EXPECT_EQ(t.status, CheckStatus::kIncomplete);
  EXPECT_NE(t.message.find("F has no MPE"), std::string::npos) << t.message;
  EXPECT_THROW(CheckArtefact({}, no_mpe), Error);
}

TEST(Check, JsonAndPageHoldEveryPosition) {
  const std::vector<CheckInput> inputs = {{"a", SphereAndPlane(0.01, 0.01, 4)},
                                          {"b", SphereAndPlane(0.01, 0.01, 5)}};
  const Artefact artefact = SphereAndPlaneArtefact(1.0);
  const CheckSummary s = CheckArtefact(inputs, artefact);
  const nlohmann::json j = ToJson(s, artefact, {});
  EXPECT_EQ(j["status"], "pass");
  ASSERT_EQ(j["positions"].size(), 2u);
  EXPECT_DOUBLE_EQ(j["positions"][1]["figures"]["PF"]["value_mm"].get<double>(),
                   s.positions[1].figures[0].value_mm);
  EXPECT_EQ(j["positions"][0]["figures"]["F"]["verdict"], "pass");
  EXPECT_DOUBLE_EQ(j["artefact"]["sphere"]["diameter_mm"].get<double>(), 30.0);
  const std::string html = CheckReport(s, artefact).ToHtml();
  int sources = 0;
  EXPECT_EQ(io::testing::EmbeddedImages(html, &sources).size(), 1u);
  EXPECT_NE(html.find("<td>b</td>"), std::string::npos);
}

}  // namespace
}  // namespace fringe::eval
