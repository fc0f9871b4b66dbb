// fringe fuse on small synthetic views: two overlapping planar grids with their poses.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "fringe/cli/run_cli_for_test.h"
#include "fringe/io/calibration_io.h"
#include "fringe/io/ply.h"
#include "fringe/testing/fringe_test.h"

namespace fringe::cli {
namespace {

namespace fs = std::filesystem;

// A 60 x 40 grid of a fronto-parallel plane 500 mm in front of the sensor, 0.5 mm spacing.
OrganizedPointCloud PlaneGrid(bool normals = true) {
  OrganizedPointCloud g(60, 40, normals, true, true);
  for (int r = 0; r < g.height; ++r) {
    for (int c = 0; c < g.width; ++c) {
      const size_t i = g.index(c, r);
      g.cloud.points[i] = {0.5 * c - 15, 0.5 * r - 10, 500};
      if (normals) g.cloud.normals[i] = {0, 0, -1};
      g.cloud.intensity[i] = 100;
      g.cloud.quality[i] = 50;
      g.valid[i] = 1;
    }
  }
  return g;
}

// poses.json with the second view shifted by 15 mm: half of each view overlaps the other.
void WritePoses(const fs::path& path, const std::vector<std::string>& names) {
  nlohmann::json views = nlohmann::json::array();
  for (size_t v = 0; v < names.size(); ++v) {
    const Rigid3d pose(Eigen::Quaterniond::Identity(), Eigen::Vector3d(15.0 * v, 0, 0));
    views.push_back({{"view", names[v]}, {"world_from_sensor", io::RigidToJson(pose)}});
  }
  io::WriteJson(path, {{"format", "fringe-poses"}, {"version", 1}, {"views", views}});
}

TEST(CliFuse, FusesViewsWithPosesAndWritesMesh) {
  test::TempDir dir;
  io::WritePly(dir / "a.ply", PlaneGrid());
  io::WritePly(dir / "b.ply", PlaneGrid());
  WritePoses(dir / "poses.json", {"a", "b"});
  std::string out, err;
  ASSERT_EQ(RunCli({"fuse", (dir / "a.ply").string(), (dir / "b.ply").string(), "--poses",
                    (dir / "poses.json").string(), "--out", (dir / "fused.ply").string(), "--mesh",
                    (dir / "mesh.stl").string(), "--poisson-depth", "6", "--json"},
                   &out, &err),
            0)
      << err;
  const nlohmann::json j = nlohmann::json::parse(out);
  EXPECT_EQ(j["fusion"]["status"], "ok");
  const int64_t fused = j["fusion"]["fused_points"];
  // Two 2400-point views overlapping by half: one layer keeps about 3 x 1200 points.
  EXPECT_LT(fused, 2400 * 2 * 0.85);
  EXPECT_GT(fused, 2400 * 1.3);
  const io::PlyData d = io::ReadPly(dir / "fused.ply");
  EXPECT_EQ(static_cast<int64_t>(d.cloud.size()), fused);
  EXPECT_TRUE(d.cloud.has_normals() && d.cloud.has_colors() && d.cloud.has_intensity());
  EXPECT_TRUE(fs::exists(dir / "mesh.stl"));
  EXPECT_GT(j["mesh"]["triangles"].get<int64_t>(), 100);
}

TEST(CliFuse, ReadsARegistrationFolder) {
  test::TempDir dir;
  fs::create_directories(dir / "reg" / "registered");
  // Registered clouds are in the world frame: view b moved by its pose.
  OrganizedPointCloud b = PlaneGrid();
  for (auto& p : b.cloud.points) p.x() += 15;
  io::WritePly(dir / "reg" / "registered" / "a.ply", PlaneGrid());
  io::WritePly(dir / "reg" / "registered" / "b.ply", b);
  WritePoses(dir / "reg" / "poses.json", {"a", "b"});
  std::string out, err;
  ASSERT_EQ(RunCli({"fuse", (dir / "reg").string(), "--out", (dir / "f.ply").string(), "--json"},
                   &out, &err),
            0)
      << err;
  const nlohmann::json j = nlohmann::json::parse(out);
  EXPECT_EQ(j["fusion"]["status"], "ok");
  EXPECT_GT(j["fusion"]["overlap_points"].get<int64_t>(), 1000);
  // The pose is applied once: the fused cloud spans x in [-15, 29.5] (twice would reach 44.5).
  const io::PlyData d = io::ReadPly(dir / "f.ply");
  double max_x = -1e9;
  for (const auto& p : d.cloud.points) max_x = std::max(max_x, p.x());
  EXPECT_NEAR(max_x, 29.5, 0.01);
}

TEST(CliFuse, BadInputsNameTheProblemAndWriteNothing) {
  test::TempDir dir;
  io::WritePly(dir / "a.ply", PlaneGrid());
  io::WritePly(dir / "c.ply", PlaneGrid());
  io::WritePly(dir / "n.ply", PlaneGrid(false));
  WritePoses(dir / "poses.json", {"a", "n"});
  const std::string poses = (dir / "poses.json").string(), fused = (dir / "f.ply").string();
  std::string err;
  // A view the poses file does not name.
  EXPECT_EQ(RunCli({"fuse", (dir / "a.ply").string(), (dir / "c.ply").string(), "--poses", poses,
                    "--out", fused},
                   nullptr, &err),
            1);
  EXPECT_NE(err.find("no pose for view 'c'"), std::string::npos) << err;
  // A cloud without normals.
  EXPECT_EQ(RunCli({"fuse", (dir / "a.ply").string(), (dir / "n.ply").string(), "--poses", poses,
                    "--out", fused},
                   nullptr, &err),
            1);
  EXPECT_NE(err.find("missing normals"), std::string::npos) << err;
  // No poses at all, and an output that would overwrite an input.
  EXPECT_EQ(RunCli({"fuse", (dir / "a.ply").string(), "--out", fused}, nullptr, &err), 1);
  EXPECT_EQ(RunCli({"fuse", (dir / "a.ply").string(), "--poses", poses, "--out",
                    (dir / "a.ply").string()},
                   nullptr, &err),
            1);
  EXPECT_NE(err.find("an output never replaces an input"), std::string::npos) << err;
  // A registration folder whose poses name a missing cloud.
  fs::create_directories(dir / "reg" / "registered");
  WritePoses(dir / "reg" / "poses.json", {"a"});
  EXPECT_EQ(RunCli({"fuse", (dir / "reg").string(), "--out", fused}, nullptr, &err), 1);
  EXPECT_NE(err.find("does not exist"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(fused));
}

}  // namespace
}  // namespace fringe::cli
