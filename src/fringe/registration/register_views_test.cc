#include "fringe/registration/register_views.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <random>
#include <tuple>

#include "fringe/io/ply.h"
#include "fringe/registration/registration_io.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/testing/registration_views.h"

namespace fringe::registration {
namespace {

// Quarter-resolution views (one pixel ~0.8 mm on the part, depth noise ~0.1 mm): pose figures
// are a few times looser than the full-resolution targets of bench_registration.
constexpr double kRotTolDeg = 0.02;
constexpr double kCentroidTolMm = 0.05;
constexpr double kMarkerOnlyRotTolDeg = 0.1;

struct Fixture {
  StereoRig rig = testing::SmallRig();
  std::vector<Rigid3d> truth;  // world_from_sensor
  std::vector<RegistrationView> views;
  std::vector<ViewGrid> grids;  // each view's organized grid (the views do not carry it)
};

// Plane, box and sphere with a ring of markers on the plane, seen from four sides at 60 degrees
// elevation: every view shares >= 3 markers with its neighbours.
const Fixture& Views() {
  static const Fixture* f = [] {
    auto* fx = new Fixture;
    sim::Scene scene = testing::PlaneWithBox();
    sim::SceneObject ball;
    ball.name = "ball";
    const sim::Sphere sphere{Eigen::Vector3d(45, 40, 20), 20};
    ball.mesh = sim::MakeSphereMesh(sphere, 0.05);
    ball.sphere = sphere;
    scene.AddObject(ball);
    // Two turned boxes: walls facing many directions, so that ICP has every direction
    // constrained (plane, box top and sphere alone leave turns about the sphere's vertical free).
    for (const auto& [centre, size, angle] :
         std::vector<std::tuple<Eigen::Vector3d, Eigen::Vector3d, double>>{
             {{-45, 35, 0}, {18, 12, 15}, 0.5}, {{15, -48, 0}, {22, 14, 12}, -0.35}}) {
      sim::SceneObject b;
      b.name = "turned_box";
      b.mesh = sim::MakeBoxMesh(-0.5 * size, 0.5 * size);
      b.mesh.Transform(Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitZ(), angle,
                                              centre + Eigen::Vector3d(0, 0, 0.5 * size.z())));
      b.albedo = 0.55;
      scene.AddObject(b);
    }
    int id = 0;
    for (int k = 0; k < 14; ++k) {
      const double a = 2 * M_PI * k / 14 + 0.1 * (k % 3);
      const double r = k % 2 ? 104 : 92;
      scene.AddMarker(testing::MakeMarker(id++, {r * std::cos(a), r * std::sin(a), 0}));
    }
    for (int v = 0; v < 4; ++v) {
      const double az = M_PI / 2 * v + 0.3, el = M_PI / 3;
      const Eigen::Vector3d from(std::cos(az) * std::cos(el), std::sin(az) * std::cos(el),
                                 std::sin(el));
      const Rigid3d pose =
          sim::SensorPoseLookingAt(fx->rig, Eigen::Vector3d(0, 0, 10), from, 0.1 * v);
      const testing::SimulatedView sv = testing::SimulateView(fx->rig, scene, pose, v);
      RegistrationView rv;
      rv.name = "view" + std::to_string(v);
      rv.cloud = sv.rec.cloud.Compact();
      rv.markers =
          DetectViewMarkers(fx->rig, sv.rec.texture_left, sv.rec.texture_right, sv.rec.cloud)
              .markers;
      fx->truth.push_back(pose);
      fx->views.push_back(std::move(rv));
      fx->grids.push_back(IndexViewGrid(sv.rec.cloud));
    }
    return fx;
  }();
  return *f;
}

// Pose error of view v with the world fixed at view 0 (the registration's gauge): rotation
// angle, and displacement of the view's cloud centroid.
RigidDifference PoseError(const Fixture& f, const std::vector<Rigid3d>& est, int v) {
  const Rigid3d true_pose = f.truth[0].Inverse() * f.truth[v];
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : f.views[v].cloud.points) c += p;
  c /= static_cast<double>(f.views[v].cloud.size());
  RigidDifference d;
  d.angle_rad = (true_pose.rotation().inverse() * est[v].rotation())
                    .angularDistance(Eigen::Quaterniond::Identity());
  d.translation_mm = (est[v] * c - true_pose * c).norm();
  return d;
}

std::vector<Rigid3d> Poses(const RegistrationResult& r) {
  std::vector<Rigid3d> p;
  for (const auto& v : r.views) p.push_back(v.world_from_sensor);
  return p;
}

TEST(RegistrationOptions, DefaultsPassCheck) { EXPECT_NO_THROW(RegistrationOptions().Check()); }
TEST(IcpOptions, DefaultsPassCheck) { EXPECT_NO_THROW(IcpOptions().Check()); }

TEST(RegisterViews, MarkersThenIcpRecoverTheTruePoses) {
  const Fixture& f = Views();
  for (const auto& v : f.views) ASSERT_GE(v.markers.size(), 5u) << v.name;
  const RegistrationResult r = RegisterViews(f.views);
  ASSERT_TRUE(r.summary.ok()) << r.summary.BriefReport();
  EXPECT_EQ(r.views[0].path, ViewPath::kWorld);
  for (int v = 1; v < 4; ++v) {
    EXPECT_EQ(r.views[v].path, ViewPath::kMarkers) << r.views[v].message;
    std::vector<Rigid3d> marker_only;
    for (const auto& x : r.views) marker_only.push_back(x.world_from_sensor_markers);
    EXPECT_LT(PoseError(f, marker_only, v).angle_rad * 180 / M_PI, kMarkerOnlyRotTolDeg);
    const RigidDifference d = PoseError(f, Poses(r), v);
    EXPECT_LT(d.angle_rad * 180 / M_PI, kRotTolDeg) << "view " << v;
    EXPECT_LT(d.translation_mm, kCentroidTolMm) << "view " << v;
    EXPECT_GT(r.views[v].overlap_fraction, 0.1);
  }
  // The map: every true marker seen twice or more is one map marker.
  EXPECT_TRUE(r.summary.adjustment.ok()) << r.summary.adjustment.BriefReport();
  EXPECT_LT(r.summary.adjustment.rms_final_mm, 0.1);  // marker centres ~0.05 mm apart
  // The threshold schedule shrinks, and the residual falls.
  const auto& levels = r.summary.icp.levels;
  ASSERT_FALSE(levels.empty()) << r.summary.icp.BriefReport();
  EXPECT_LT(levels.front().threshold_end_mm, levels.front().threshold_start_mm);
  for (size_t l = 1; l < levels.size(); ++l) {
    EXPECT_LE(levels[l].threshold_start_mm, levels[l - 1].threshold_end_mm + 1e-12);
  }
  EXPECT_LT(levels.back().rms_end_mm, 0.5);
}

TEST(RegisterViews, BadViewsAreReportedAndGoodViewsKept) {
  const Fixture& f = Views();
  std::vector<RegistrationView> views = f.views;
  RegistrationView empty;
  empty.name = "empty";
  RegistrationView metres = f.views[1];
  metres.name = "metres";
  for (auto& p : metres.cloud.points) p *= 1e-3;
  metres.markers.clear();
  RegistrationView no_normals = f.views[3];
  no_normals.name = "no_normals";
  no_normals.cloud.normals.clear();
  // Noise far from everything: no markers, nothing to overlap.
  RegistrationView stray;
  stray.name = "stray";
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-30, 30);
  for (int k = 0; k < 3000; ++k) {
    stray.cloud.points.emplace_back(u(rng), u(rng), 900 + u(rng));
    stray.cloud.normals.push_back(Eigen::Vector3d(u(rng), u(rng), -30).normalized());
  }
  views.push_back(empty);
  views.push_back(metres);
  views.push_back(no_normals);
  views.push_back(stray);
  const RegistrationResult r = RegisterViews(views);
  EXPECT_EQ(r.summary.status, RegistrationStatus::kPartial);
  EXPECT_EQ(r.summary.placed, 4);
  EXPECT_EQ(r.views[4].path, ViewPath::kBadInput);
  EXPECT_NE(r.views[4].message.find("empty"), std::string::npos);
  EXPECT_EQ(r.views[5].path, ViewPath::kBadInput);
  EXPECT_NE(r.views[5].message.find("metres"), std::string::npos);
  EXPECT_EQ(r.views[6].path, ViewPath::kBadInput);
  EXPECT_NE(r.views[6].message.find("normals"), std::string::npos);
  EXPECT_EQ(r.views[7].path, ViewPath::kUnplaced) << r.views[7].message;
  EXPECT_FALSE(r.views[7].message.empty());
  for (int v = 1; v < 4; ++v) {
    EXPECT_LT(PoseError(f, Poses(r), v).angle_rad * 180 / M_PI, kRotTolDeg);
  }
}

// Unorganized clouds (issue 29): the multi-view refinement of the four simulated views (placed
// by their markers) is as accurate with the views as unorganized clouds (k-d tree association)
// as with their grids (projective association): both reach the truth to the same tolerances,
// and each other.
constexpr double kOrganizedVsUnorganizedDeg = 0.01;
constexpr double kOrganizedVsUnorganizedMm = 0.02;

TEST(RegisterViews, UnorganizedViewsRefineAsAccuratelyAsOrganizedOnes) {
  const Fixture& f = Views();
  std::vector<std::vector<Rigid3d>> results;
  for (const bool organized : {true, false}) {
    SCOPED_TRACE(organized ? "organized" : "unorganized");
    std::vector<RegistrationView> views = f.views;
    for (size_t v = 0; v < views.size(); ++v) {
      if (organized) views[v].grid = f.grids[v];
    }
    const RegistrationResult r = RegisterViews(views);
    ASSERT_TRUE(r.summary.ok()) << r.summary.BriefReport();
    ASSERT_FALSE(r.summary.icp.levels.empty()) << r.summary.icp.BriefReport();
    EXPECT_EQ(r.summary.icp.levels.back().projective_pairs > 0, organized);
    for (int v = 1; v < 4; ++v) {
      const RigidDifference d = PoseError(f, Poses(r), v);
      EXPECT_LT(d.angle_rad * 180 / M_PI, kRotTolDeg) << "view " << v;
      EXPECT_LT(d.translation_mm, kCentroidTolMm) << "view " << v;
    }
    results.push_back(Poses(r));
  }
  for (int v = 1; v < 4; ++v) {
    const RigidDifference d = Difference(results[0][v], results[1][v]);
    EXPECT_LT(d.angle_rad * 180 / M_PI, kOrganizedVsUnorganizedDeg) << "view " << v;
    EXPECT_LT(d.translation_mm, kOrganizedVsUnorganizedMm) << "view " << v;
  }
}

// Marker-free placement must never be confidently wrong. Synthetic complete scans (every
// surface sampled on a 1 mm grid, noise 0.02 mm) of a round plate with a square box in its
// centre: every quarter turn about the box's axis maps the scene onto itself, so the second
// view (no markers) has four equally good poses and must be refused ("cannot place"). With an
// off-centre block and a dome added the pose is unique and must be found.
constexpr double kSyntheticNoiseMm = 0.02;
constexpr double kMarkerFreeRotTolDeg = 0.01;  // exact synthetic surfaces, 0.02 mm noise
constexpr double kMarkerFreeCentroidTolMm = 0.01;

// Points and outward normals of the scene, world frame (plate z = 0).
void AddPatch(const Eigen::Vector3d& origin, const Eigen::Vector3d& u, const Eigen::Vector3d& v,
              double lu, double lv, PointCloud* c) {
  const Eigen::Vector3d n = u.cross(v).normalized();
  for (double a = 0.5; a < lu; a += 1) {
    for (double b = 0.5; b < lv; b += 1) {
      c->points.push_back(origin + a * u + b * v);
      c->normals.push_back(n);
    }
  }
}
void AddBox(const Eigen::Vector3d& centre, double sx, double sy, double h, double turn_rad,
            PointCloud* c) {
  const Rigid3d t = Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitZ(), turn_rad, centre);
  PointCloud b;
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(),
                        z = Eigen::Vector3d::UnitZ();
  AddPatch({-sx / 2, -sy / 2, h}, x, y, sx, sy, &b);  // top
  AddPatch({-sx / 2, -sy / 2, 0}, z, y, h, sy, &b);   // -x wall (z x y = -x)
  AddPatch({sx / 2, -sy / 2, 0}, y, z, sy, h, &b);    // +x
  AddPatch({-sx / 2, -sy / 2, 0}, x, z, sx, h, &b);   // -y
  AddPatch({-sx / 2, sy / 2, 0}, z, x, h, sx, &b);    // +y
  for (size_t i = 0; i < b.size(); ++i) {
    c->points.push_back(t * b.points[i]);
    c->normals.push_back(t.RotateDirection(b.normals[i]));
  }
}
PointCloud SyntheticScene(bool asymmetric) {
  PointCloud c;
  const double plate_r = 90, box = 60;
  for (double x = -plate_r + 0.5; x < plate_r; x += 1) {
    for (double y = -plate_r + 0.5; y < plate_r; y += 1) {
      if (x * x + y * y > plate_r * plate_r) continue;
      if (std::abs(x) < box / 2 && std::abs(y) < box / 2) continue;  // under the box
      if (asymmetric && (x - 55) * (x - 55) + (y + 45) * (y + 45) < 15 * 15) continue;
      c.points.emplace_back(x, y, 0);
      c.normals.push_back(Eigen::Vector3d::UnitZ());
    }
  }
  AddBox(Eigen::Vector3d::Zero(), box, box, 25, 0, &c);
  if (asymmetric) {
    AddBox({-50, 50, 0}, 24, 10, 14, 0.4, &c);
    for (double a = 0; a < 1.45; a += 0.06) {  // a dome: sphere cap, radius 15 at (55, -45)
      for (double b = 0; b < 2 * M_PI; b += 0.06 / std::max(0.1, std::sin(a))) {
        const Eigen::Vector3d n(std::sin(a) * std::cos(b), std::sin(a) * std::sin(b), std::cos(a));
        c.points.push_back(Eigen::Vector3d(55, -45, 0) + 15 * n);
        c.normals.push_back(n);
      }
    }
  }
  return c;
}
RegistrationView SeeSynthetic(const PointCloud& world, const Rigid3d& world_from_sensor,
                              const std::string& name, uint64_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, kSyntheticNoiseMm);
  const Rigid3d sensor_from_world = world_from_sensor.Inverse();
  RegistrationView v;
  v.name = name;
  for (size_t i = 0; i < world.size(); ++i) {
    v.cloud.points.push_back(sensor_from_world * world.points[i] +
                             Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    v.cloud.normals.push_back(sensor_from_world.RotateDirection(world.normals[i]));
  }
  return v;
}

// The coarse alignment alone: the RANSAC's best candidate lies within the reach of the ICP that
// refines it (RegisterViews starts it at 3 voxels; a wrong copy of the scene would be tens of
// degrees off), and it is the same on one thread as on all (each iteration has its own seed,
// the parallel blocks are reduced in order).
constexpr double kCoarseRotTolDeg = 10;
constexpr double kCoarseCentroidTolMm = 9;  // 3 voxels
TEST(AlignCoarse, FindsTheMotionAndIsTheSameOnOneThread) {
  const Rigid3d pose0 =
      Rigid3d::FromAxisAngle(Eigen::Vector3d(1, 0, 0), M_PI * 0.9, Eigen::Vector3d(0, 20, 450));
  const Rigid3d pose1 = Rigid3d::FromAxisAngle(Eigen::Vector3d(0.9, 0.3, 0.1).normalized(),
                                               M_PI * 0.8, Eigen::Vector3d(25, -10, 430));
  const Rigid3d truth = pose0.Inverse() * pose1;  // 0_from_1
  const PointCloud world = SyntheticScene(true);
  const RegistrationView a = SeeSynthetic(world, pose0, "a", 1);
  const RegistrationView b = SeeSynthetic(world, pose1, "b", 2);
  CoarseOptions o;
  o.voxel_mm = 3;
  o.max_ransac_iterations = 20000;
  o.hypotheses = 2;
  const CoarseResult all = AlignCoarse(b.cloud, a.cloud, o);
  ASSERT_TRUE(all.ok()) << all.BriefReport();
  const RigidDifference d = Difference(all.target_from_source, truth);
  EXPECT_LT(d.angle_rad * 180 / M_PI, kCoarseRotTolDeg) << all.BriefReport();
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : b.cloud.points) c += p;
  c /= static_cast<double>(b.cloud.size());
  EXPECT_LT((all.target_from_source * c - truth * c).norm(), kCoarseCentroidTolMm);
  CoarseResult one;
  tbb::task_arena(1).execute([&] { one = AlignCoarse(b.cloud, a.cloud, o); });
  ASSERT_EQ(one.candidates.size(), all.candidates.size());
  for (size_t k = 0; k < all.candidates.size(); ++k) {
    EXPECT_EQ(one.candidates[k].fitness, all.candidates[k].fitness);
    EXPECT_EQ(one.candidates[k].target_from_source.ToMatrix4(),
              all.candidates[k].target_from_source.ToMatrix4());
  }
}

TEST(RegisterViews, MarkerFreePathPlacesAUniqueSceneAndRefusesASymmetricOne) {
  const Rigid3d pose0 =
      Rigid3d::FromAxisAngle(Eigen::Vector3d(1, 0, 0), M_PI * 0.9, Eigen::Vector3d(0, 20, 450));
  const Rigid3d pose1 = Rigid3d::FromAxisAngle(Eigen::Vector3d(0.9, 0.3, 0.1).normalized(),
                                               M_PI * 0.8, Eigen::Vector3d(25, -10, 430));
  const Rigid3d truth = pose0.Inverse() * pose1;  // world = view 0's sensor frame
  for (const bool asymmetric : {true, false}) {
    SCOPED_TRACE(asymmetric ? "unique scene" : "four-fold symmetric scene");
    const PointCloud world = SyntheticScene(asymmetric);
    const std::vector<RegistrationView> views = {SeeSynthetic(world, pose0, "a", 1),
                                                 SeeSynthetic(world, pose1, "b", 2)};
    RegistrationOptions o;
    // Smaller than the defaults, for a test of seconds: ~5000 samples (the scene's features are
    // >= 10 mm), 20000 RANSAC iterations per hypothesis (the later, unexplained ones run to it).
    o.coarse.voxel_mm = 3;
    o.coarse.max_ransac_iterations = 20000;
    const RegistrationResult r = RegisterViews(views, o);
    const ViewRegistration& b = r.views[1];
    if (asymmetric) {
      ASSERT_EQ(b.path, ViewPath::kMarkerFree) << b.message;
      const RigidDifference d = Difference(b.world_from_sensor, truth);
      EXPECT_LT(d.angle_rad * 180 / M_PI, kMarkerFreeRotTolDeg) << b.message;
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (const auto& p : views[1].cloud.points) c += p;
      c /= static_cast<double>(views[1].cloud.size());
      EXPECT_LT((b.world_from_sensor * c - truth * c).norm(), kMarkerFreeCentroidTolMm)
          << b.message;
    } else {
      EXPECT_EQ(b.path, ViewPath::kUnplaced) << b.message;
      EXPECT_NE(b.message.find("cannot place"), std::string::npos) << b.message;
      EXPECT_EQ(r.summary.status, RegistrationStatus::kPartial);
    }
  }
}

// Four partial views (only the surfaces facing each sensor) of the asymmetric scene, 34 deg
// apart around it, no markers: every pair is aligned and verified, the pose graph places all views
// (its triangles close) and the multi-view ICP refines them to the truth.
TEST(RegisterViews, MarkerFreePlacesFourPartialViews) {
  const PointCloud world = SyntheticScene(true);
  const StereoRig rig = testing::SmallRig();
  std::vector<RegistrationView> views;
  std::vector<Rigid3d> truth;
  for (int v = 0; v < 4; ++v) {
    const double az = 0.6 * v + 0.4, el = 0.9;
    const Eigen::Vector3d from(std::cos(az) * std::cos(el), std::sin(az) * std::cos(el),
                               std::sin(el));
    const Rigid3d pose = sim::SensorPoseLookingAt(rig, Eigen::Vector3d(0, 0, 10), from, 0.2 * v);
    PointCloud facing;
    for (size_t i = 0; i < world.size(); ++i) {
      if (world.normals[i].dot(pose.translation() - world.points[i]) > 0) {
        facing.points.push_back(world.points[i]);
        facing.normals.push_back(world.normals[i]);
      }
    }
    views.push_back(SeeSynthetic(facing, pose, "view" + std::to_string(v), 10 + v));
    truth.push_back(pose);
  }
  RegistrationOptions o;
  o.coarse.voxel_mm = 3;
  o.coarse.max_ransac_iterations = 20000;
  const RegistrationResult r = RegisterViews(views, o);
  EXPECT_EQ(r.summary.placed, 4) << r.summary.BriefReport();
  for (int v = 1; v < 4; ++v) {
    ASSERT_EQ(r.views[v].path, ViewPath::kMarkerFree) << r.views[v].message;
    EXPECT_NE(r.views[v].message.find("confirmed by"), std::string::npos) << r.views[v].message;
    const Rigid3d t = truth[0].Inverse() * truth[v];
    const RigidDifference d = Difference(r.views[v].world_from_sensor, t);
    EXPECT_LT(d.angle_rad * 180 / M_PI, kMarkerFreeRotTolDeg) << r.views[v].message;
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const auto& p : views[v].cloud.points) c += p;
    c /= static_cast<double>(views[v].cloud.size());
    EXPECT_LT((r.views[v].world_from_sensor * c - t * c).norm(), kMarkerFreeCentroidTolMm)
        << r.views[v].message;
  }
}

// A plate with one turned block (30 x 20 x 15 mm; its walls ~6 % of the points, less than the
// ICP trims, and the only constraint on the slides and the turn in the plate's plane), seen
// twice; the second view placed without markers, by an initial pose slid 1 mm along the plate,
// as a marker-free pairwise alignment can leave it. The refinement must remove the slide. With
// the marker settings (`icp`: uniform samples, weak directions held) the walls are trimmed and
// the view stays 1 mm off. The turn about the plate's normal rests on the block's walls alone
// (lever ~15 mm), hence a rotation tolerance of the quarter-rig fixture's kRotTolDeg.
TEST(RegisterViews, RefinementWithoutMarkersRemovesASlideAlongAPlate) {
  const Eigen::Vector3d block_centre(20, -10, 0);
  PointCloud world;
  for (double x = -89.5; x < 90; x += 1) {
    for (double y = -89.5; y < 90; y += 1) {
      if (x * x + y * y > 90 * 90) continue;
      if (std::hypot(x - block_centre.x(), y - block_centre.y()) < 19) continue;  // under it
      world.points.emplace_back(x, y, 0);
      world.normals.push_back(Eigen::Vector3d::UnitZ());
    }
  }
  AddBox(block_centre, 30, 20, 15, 0.4, &world);
  const Rigid3d pose0 =
      Rigid3d::FromAxisAngle(Eigen::Vector3d(1, 0, 0), M_PI * 0.9, Eigen::Vector3d(0, 20, 450));
  const Rigid3d pose1 = Rigid3d::FromAxisAngle(Eigen::Vector3d(0.9, 0.3, 0.1).normalized(),
                                               M_PI * 0.8, Eigen::Vector3d(25, -10, 430));
  const Rigid3d truth = pose0.Inverse() * pose1;  // world = view 0's sensor frame
  std::vector<RegistrationView> views = {SeeSynthetic(world, pose0, "a", 1),
                                         SeeSynthetic(world, pose1, "b", 2)};
  // 1 mm along the plate, in view 0's frame.
  const Eigen::Vector3d slide =
      pose0.Inverse().RotateDirection(Eigen::Vector3d(0.6, 0.8, 0).normalized());
  views[1].initial_world_from_sensor = Rigid3d(Eigen::Quaterniond::Identity(), slide) * truth;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : views[1].cloud.points) c += p;
  c /= static_cast<double>(views[1].cloud.size());
  RegistrationOptions o;
  o.use_markers = false;
  o.coarse_fallback = false;
  const RegistrationResult r = RegisterViews(views, o);
  ASSERT_TRUE(r.summary.ok()) << r.summary.BriefReport();
  const ViewRegistration& b = r.views[1];
  EXPECT_EQ(b.path, ViewPath::kInitial) << b.message;
  const RigidDifference d = Difference(b.world_from_sensor, truth);
  EXPECT_LT(d.angle_rad * 180 / M_PI, kRotTolDeg) << r.summary.icp.BriefReport();
  EXPECT_LT((b.world_from_sensor * c - truth * c).norm(), kMarkerFreeCentroidTolMm)
      << r.summary.icp.BriefReport();
}

// A featureless plate (a disc, nothing on it) seen twice: every slide and turn in its plane
// fits, so the second view must be refused, not placed.
TEST(RegisterViews, MarkerFreeRefusesAFeaturelessPlate) {
  PointCloud plate;
  for (double x = -89.5; x < 90; x += 1) {
    for (double y = -89.5; y < 90; y += 1) {
      if (x * x + y * y > 90 * 90) continue;
      plate.points.emplace_back(x, y, 0);
      plate.normals.push_back(Eigen::Vector3d::UnitZ());
    }
  }
  const Rigid3d pose0 =
      Rigid3d::FromAxisAngle(Eigen::Vector3d(1, 0, 0), M_PI * 0.9, Eigen::Vector3d(0, 20, 450));
  const Rigid3d pose1 = Rigid3d::FromAxisAngle(Eigen::Vector3d(0.9, 0.3, 0.1).normalized(),
                                               M_PI * 0.8, Eigen::Vector3d(25, -10, 430));
  const std::vector<RegistrationView> views = {SeeSynthetic(plate, pose0, "a", 1),
                                               SeeSynthetic(plate, pose1, "b", 2)};
  RegistrationOptions o;
  o.coarse.voxel_mm = 3;
  o.coarse.max_ransac_iterations = 20000;
  const RegistrationResult r = RegisterViews(views, o);
  EXPECT_EQ(r.views[1].path, ViewPath::kUnplaced) << r.views[1].message;
  EXPECT_NE(r.views[1].message.find("cannot place"), std::string::npos) << r.views[1].message;
}

// The refinement associates only views that overlap: a chain of views along a strip (each
// overlapping its two neighbours only), started 0.2 mm and 0.02 deg off, searches each view's
// samples in its neighbours only, 2 (N - 1) - 1 ordered pairs per iteration (the fixed world
// view's samples are not used) instead of (N - 1)^2, and aligns them to each other (residual
// RMS at the noise of two views; a chain drifts along its length, the non-neighbours having
// nothing to hold it). With every view overlapping all the others, each is associated with at
// most max_partners of them, and the poses come back to the truth.
constexpr int kChainViews = 10;
constexpr double kStackRotTolDeg = 0.01;
constexpr double kStackCentroidTolMm = 0.02;
TEST(RegisterViews, RefinementAssociatesOnlyOverlappingViews) {
  // One strip for every view (each sees its window of it): a plate with a turned box per 20 mm,
  // walls in every direction within each window (large enough for smooth-normal samples on
  // them, marker_free_icp's sample_max_normal_spread_deg).
  PointCloud strip;
  const double strip_mm = 50.0 * (kChainViews - 1) + 70;
  for (double x = 0.5; x < strip_mm; x += 1) {
    for (double y = -19.5; y < 20; y += 1) {
      strip.points.emplace_back(x, y, 0);
      strip.normals.push_back(Eigen::Vector3d::UnitZ());
    }
  }
  for (double bx = 10; bx < strip_mm; bx += 20) {
    AddBox({bx, 6 * std::sin(bx), 0}, 14, 10, 10, 0.3 + 0.01 * bx, &strip);
  }
  const auto window = [&](double x0, double x1) {
    PointCloud c;
    for (size_t i = 0; i < strip.size(); ++i) {
      if (strip.points[i].x() >= x0 && strip.points[i].x() < x1) c.PushBackFrom(strip, i);
    }
    return c;
  };
  const auto run = [&](bool chain, int max_partners) {
    std::vector<RegistrationView> views;
    std::vector<Rigid3d> truth;
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> unit(-1, 1);
    for (int v = 0; v < kChainViews; ++v) {
      const double x0 = chain ? 50.0 * v : 0.0;
      // The sensor above the window's middle, looking down.
      const Rigid3d pose =
          Rigid3d::FromAxisAngle(Eigen::Vector3d::UnitX(), M_PI, Eigen::Vector3d(x0 + 35, 0, 400));
      views.push_back(SeeSynthetic(window(x0, x0 + 70), pose, "v" + std::to_string(v), v + 1));
      truth.push_back(pose);
      const Eigen::Vector3d axis = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
      const Eigen::Vector3d slide = 0.2 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
      views.back().initial_world_from_sensor =
          v == 0 ? pose : Rigid3d::FromAxisAngle(axis, 0.02 * M_PI / 180, slide) * pose;
    }
    RegistrationOptions o;
    o.use_markers = false;
    o.coarse_fallback = false;
    o.marker_free_icp.max_partners = max_partners;
    RegistrationResult r = RegisterViews(views, o);
    EXPECT_TRUE(r.summary.ok()) << r.summary.BriefReport();
    EXPECT_FALSE(r.summary.icp.levels.empty()) << r.summary.icp.BriefReport();
    if (!chain) {
      for (int v = 0; v < kChainViews; ++v) {
        const RigidDifference d = Difference(r.views[v].world_from_sensor, truth[v]);
        EXPECT_LT(d.angle_rad * 180 / M_PI, kStackRotTolDeg) << "view " << v;
        Eigen::Vector3d c = Eigen::Vector3d::Zero();
        for (const auto& p : views[v].cloud.points) c += p;
        c /= static_cast<double>(views[v].cloud.size());
        EXPECT_LT((r.views[v].world_from_sensor * c - truth[v] * c).norm(), kStackCentroidTolMm)
            << "view " << v << ": " << r.summary.icp.BriefReport();
      }
    }
    return r.summary.icp;
  };
  const IcpSummary chain = run(true, 8);
  ASSERT_FALSE(chain.levels.empty());
  // sqrt(2) x the noise along the normal, and the noise's 3D scatter moving points along the
  // surface: 1.5 x sqrt(2) x the noise.
  EXPECT_LT(chain.levels.back().rms_end_mm, 1.5 * std::sqrt(2.0) * kSyntheticNoiseMm)
      << chain.BriefReport();
  EXPECT_EQ(chain.touching_pairs, kChainViews - 1) << chain.BriefReport();
  EXPECT_EQ(chain.associated_pairs, kChainViews - 1) << chain.BriefReport();
  for (const IcpLevelReport& l : chain.levels) {
    EXPECT_EQ(l.searched_pairs, 2 * (kChainViews - 1) - 1) << chain.BriefReport();
  }
  constexpr int kPartners = 3;
  const IcpSummary stack = run(false, kPartners);
  EXPECT_EQ(stack.touching_pairs, kChainViews * (kChainViews - 1) / 2) << stack.BriefReport();
  EXPECT_LE(stack.associated_pairs, kChainViews * kPartners) << stack.BriefReport();
  EXPECT_GE(stack.associated_pairs, kChainViews * kPartners / 2) << stack.BriefReport();
  for (const IcpLevelReport& l : stack.levels) {
    EXPECT_LE(l.searched_pairs, 2 * stack.associated_pairs) << stack.BriefReport();
  }
}

// Bad input: an unorganized cloud without normals gets them estimated (and says so), oriented
// toward the sensor; a cloud in metres read with --units m comes back in millimetres.
constexpr double kEstimatedNormalTolDeg = 3;  // 20-neighbour PCA on a 1 mm grid, no noise

TEST(ReadRegistrationView, MissingNormalsAreEstimatedTowardTheSensorAndReported) {
  test::TempDir dir;
  PointCloud c;  // a gently curved sheet 300 mm in front of the sensor, facing it
  for (double x = -40; x <= 40; x += 1) {
    for (double y = -30; y <= 30; y += 1) {
      c.points.emplace_back(x, y, 300 + 0.002 * x * x);
    }
  }
  io::WritePly(dir / "sheet.ply", c);
  std::string note;
  const RegistrationView v = ReadRegistrationView(dir / "sheet.ply", 1.0, false, &note);
  EXPECT_NE(note.find("normals estimated"), std::string::npos) << note;
  ASSERT_EQ(v.cloud.normals.size(), v.cloud.size());
  for (size_t i = 0; i < v.cloud.size(); i += 97) {
    const Eigen::Vector3d& p = v.cloud.points[i];
    const Eigen::Vector3d truth = Eigen::Vector3d(0.004 * p.x(), 0, -1).normalized();
    EXPECT_LT(std::acos(std::min(1.0, v.cloud.normals[i].dot(truth))) * 180 / M_PI,
              kEstimatedNormalTolDeg)
        << "point " << i;
  }
  // The same sheet written in metres and read with scale 1000 is the millimetre sheet.
  PointCloud m = c;
  for (auto& p : m.points) p *= 1e-3;
  io::WritePly(dir / "sheet_m.ply", m);
  const RegistrationView vm = ReadRegistrationView(dir / "sheet_m.ply", 1000.0, false, nullptr);
  ASSERT_EQ(vm.cloud.size(), c.size());
  EXPECT_LT((vm.cloud.points[5] - c.points[5]).norm(), 1e-3);
}

}  // namespace
}  // namespace fringe::registration
