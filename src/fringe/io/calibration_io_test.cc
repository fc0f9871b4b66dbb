#include "fringe/io/calibration_io.h"

#include <gtest/gtest.h>

#include <fstream>

#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::io {
namespace {

TEST(CalibrationIo, RigRoundTrip) {
  test::TempDir dir;
  const StereoRig rig = StereoRig::Reference();
  WriteRig(dir / "rig.json", rig);
  const StereoRig r = ReadRig(dir / "rig.json");
  EXPECT_TRUE(r.left == rig.left);
  EXPECT_TRUE(r.right == rig.right);
  ASSERT_TRUE(r.projector.has_value());
  EXPECT_TRUE(*r.projector == *rig.projector);
  EXPECT_LT(Difference(r.right_from_left, rig.right_from_left).angle_rad, 1e-12);
  EXPECT_LT(Difference(r.right_from_left, rig.right_from_left).translation_mm, 1e-12);
  EXPECT_LT(Difference(r.projector_from_left, rig.projector_from_left).translation_mm, 1e-12);
}

// A camera + projector rig (camera-projector mode) is written without a right camera and reads
// back as one: right = copy of the left at zero baseline.
TEST(CalibrationIo, CameraProjectorRigRoundTrip) {
  test::TempDir dir;
  StereoRig rig = StereoRig::Reference();
  rig.right = rig.left;
  rig.right_from_left = Rigid3d();
  WriteRig(dir / "cp.json", rig);
  EXPECT_FALSE(ReadJson(dir / "cp.json")["cameras"].contains("right"));
  EXPECT_FALSE(ReadJson(dir / "cp.json").contains("right_from_left"));
  const StereoRig r = ReadRig(dir / "cp.json");
  EXPECT_EQ(r.BaselineMm(), 0.0);
  ASSERT_TRUE(r.projector.has_value());
  EXPECT_TRUE(*r.projector == *rig.projector);
  EXPECT_LT(Difference(r.projector_from_left, rig.projector_from_left).translation_mm, 1e-12);
}

// A rig file as the first versions wrote it (two cameras, rotation matrices, no projector)
// still loads.
TEST(CalibrationIo, OldStereoRigFileLoads) {
  test::TempDir dir;
  {
    std::ofstream f(dir / "old.json");
    f << R"({"format": "fringe-rig", "version": 1, "units": "mm",
  "cameras": {
    "left": {"width": 1280, "height": 1024, "fx": 2500, "fy": 2500, "cx": 639.5, "cy": 511.5,
             "distortion": [0, 0, 0, 0, 0]},
    "right": {"width": 1280, "height": 1024, "fx": 2506, "fy": 2505, "cx": 635.4, "cy": 513.4,
              "distortion": [-0.075, 0.1, -6e-5, 8e-5, 0]}},
  "right_from_left": {"rotation": [[0.6, 0, 0.8], [0, 1, 0], [-0.8, 0, 0.6]],
                      "translation_mm": [-200, 0, 0]}})";
  }
  const StereoRig r = ReadRig(dir / "old.json");
  EXPECT_FALSE(r.projector.has_value());
  EXPECT_DOUBLE_EQ(r.right.fx, 2506);
  EXPECT_NEAR(r.BaselineMm(), 200, 1e-12);
}

TEST(CalibrationIo, ErrorsNameFileAndField) {
  test::TempDir dir;
  nlohmann::json j = RigToJson(StereoRig::Reference());
  j["cameras"]["right"]["fx"] = "big";
  WriteJson(dir / "bad.json", j);
  try {
    ReadRig(dir / "bad.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cameras.right.fx"), std::string::npos) << e.what();
  }
  j = RigToJson(StereoRig::Reference());
  j["right_from_left"]["rotation"][0][0] = 3.0;
  WriteJson(dir / "rot.json", j);
  EXPECT_THROW(ReadRig(dir / "rot.json"), Error);
  {
    std::ofstream f(dir / "junk.json");
    f << "{ not json";
  }
  EXPECT_THROW(ReadRig(dir / "junk.json"), Error);
}

// Issue 10: the target's geometry is required, never filled from the reference board (a
// misspelt radius once silently used 8 mm instead of 5 mm): removing any geometry field of a
// ring target is an error naming the file and the field.
TEST(CalibrationIo, TargetGeometryIsRequired) {
  test::TempDir dir;
  const nlohmann::json ring = TargetToJson(CalibrationTarget::Reference());
  ASSERT_FALSE(ring.at("distinct_features").empty());  // so dot_radius_mm is required too
  for (const char* field : {"type", "rows", "cols", "spacing_mm", "outer_radius_mm",
                            "inner_radius_mm", "distinct_features", "dot_radius_mm"}) {
    nlohmann::json j = ring;
    ASSERT_TRUE(j.contains(field)) << field;
    j.erase(field);
    WriteJson(dir / "t.json", j);
    try {
      ReadTarget(dir / "t.json");
      ADD_FAILURE() << "no error without " << field;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("t.json"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(util::StrCat("missing field '", field, "'")),
                std::string::npos)
          << e.what();
    }
  }
  EXPECT_NO_THROW(TargetFromJson(ring, "ring"));
}

TEST(CalibrationIo, TargetRoundTripAndErrors) {
  test::TempDir dir;
  CalibrationTarget t;
  t.type = TargetType::kAsymmetricCircleGrid;
  t.rows = 4;
  t.cols = 11;
  t.spacing_mm = 20;
  t.outer_radius_mm = 5;
  WriteJson(dir / "t.json", TargetToJson(t));
  const CalibrationTarget r = ReadTarget(dir / "t.json");
  EXPECT_EQ(r.type, t.type);
  EXPECT_EQ(r.cols, 11);
  EXPECT_DOUBLE_EQ(r.spacing_mm, 20);
  nlohmann::json bad = TargetToJson(t);
  bad["outer_radius_mm"] = 50;
  WriteJson(dir / "bad.json", bad);
  try {
    ReadTarget(dir / "bad.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("outer_radius_mm"), std::string::npos) << e.what();
  }
}

TEST(CalibrationIo, ImportsOpenCvStereoYaml) {
  FRINGE_SHARED_DATA_OR_SKIP(data, "slsdk-stereo-phasegray");
  const StereoRig rig =
      ImportOpenCvStereo(data / "intrinsic.yml", data / "extrinsic.yml", 2048, 1536);
  EXPECT_NEAR(rig.BaselineMm(), 302, 5);  // ../shared/data/README.md: baseline ~302 mm
  EXPECT_GT(rig.left.fx, 1000);
}

}  // namespace
}  // namespace fringe::io
