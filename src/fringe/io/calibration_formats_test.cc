#include "fringe/io/calibration_formats.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <string>

#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::io {
namespace {

namespace fs = std::filesystem;
using test::ErrorOf;

// Tolerances: a round trip through a file written with 17 significant digits is exact up to the
// rotation's quaternion storage and metre/mm scaling (~1e-14); files written in single precision
// (SLStudio's Matx33f) carry float rounding.
constexpr double kRoundTripTol = 1e-12;
constexpr double kFloatRotationTol = 1e-6;

// A rig unlike the reference one: other sizes, a tilted vergence, a projector off the axis.
StereoRig TestRig(bool with_k3 = true) {
  StereoRig rig;
  rig.left.width = rig.right.width = 2048;
  rig.left.height = rig.right.height = 1536;
  rig.left.fx = 3012.345678901234;
  rig.left.fy = 3011.987654321098;
  rig.left.cx = 1019.123456789;
  rig.left.cy = 771.98765432;
  rig.left.SetDistortion({-0.0812345, 0.1234567, 0.00031, -0.00027, with_k3 ? -0.211 : 0.0});
  rig.right = rig.left;
  rig.right.fx = 3020.5;
  rig.right.cx = 1030.25;
  rig.right.SetDistortion({-0.07, 0.09, -0.0001, 0.0002, with_k3 ? 0.05 : 0.0});
  rig.right_from_left = Rigid3d::FromAxisAngle(Eigen::Vector3d(0.1, -0.97, 0.05).normalized(), 0.38,
                                               Eigen::Vector3d(-243.21, 3.456, 41.7));
  CameraModel p;
  p.width = 912;
  p.height = 1140;
  p.fx = 1650.75;
  p.fy = 1651.125;
  p.cx = 455.5;
  p.cy = 1100.25;
  p.SetDistortion({0.011, -0.02, 0.0, 0.0, 0.0});
  rig.projector = p;
  rig.projector_from_left = Rigid3d::FromAxisAngle(Eigen::Vector3d(0.05, -1, 0.02).normalized(),
                                                   0.19, Eigen::Vector3d(-121.6, -30.5, 12.25));
  return rig;
}

void ExpectCameraNear(const CameraModel& a, const CameraModel& b, double tol, const char* what) {
  SCOPED_TRACE(what);
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_NEAR(a.fx, b.fx, tol);
  EXPECT_NEAR(a.fy, b.fy, tol);
  EXPECT_NEAR(a.cx, b.cx, tol);
  EXPECT_NEAR(a.cy, b.cy, tol);
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(a.Distortion()[i], b.Distortion()[i], tol) << i;
}

void ExpectPoseNear(const Rigid3d& a, const Rigid3d& b, double rot_tol, double t_tol,
                    const char* what) {
  SCOPED_TRACE(what);
  EXPECT_LE((a.rotation_matrix() - b.rotation_matrix()).cwiseAbs().maxCoeff(), rot_tol);
  EXPECT_LE((a.translation() - b.translation()).cwiseAbs().maxCoeff(), t_tol);
}

std::string Num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

void WriteText(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

// An OpenCV XML matrix as cv::FileStorage writes a cv::Matx<float> (SLStudio's types).
std::string XmlMatrix(const std::string& key, int rows, int cols, const std::vector<double>& v) {
  std::string s = "<" + key + " type_id=\"opencv-matrix\">\n  <rows>" + std::to_string(rows) +
                  "</rows>\n  <cols>" + std::to_string(cols) + "</cols>\n  <dt>f</dt>\n  <data>\n";
  for (const double x : v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, " %.8e", static_cast<double>(static_cast<float>(x)));
    s += buf;
  }
  return s + "</data></" + key + ">\n";
}

std::vector<double> Row(const Eigen::Matrix3d& m) {
  return {m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2)};
}
std::vector<double> K(const CameraModel& c) { return {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1}; }
std::vector<double> D(const CameraModel& c) {
  const auto d = c.Distortion();
  return {d.begin(), d.end()};
}

TEST(CalibrationFormats, SlStudioCalibrationXmlWithItsOwnKeysAndTypes) {
  test::TempDir dir;
  const StereoRig rig = TestRig();
  const CameraModel& p = *rig.projector;
  // CalibrationData::saveXML: Kc kc Kp kp Rp Tp (cv::Matx33f / cv::Vec<float,5> / cv::Vec3f),
  // the errors, then the camera and projector sizes. Rp/Tp: projector_from_camera, mm.
  const fs::path f = dir / "calibration.xml";
  WriteText(f, "<?xml version=\"1.0\"?>\n<opencv_storage>\n" + XmlMatrix("Kc", 3, 3, K(rig.left)) +
                   XmlMatrix("kc", 5, 1, D(rig.left)) + XmlMatrix("Kp", 3, 3, K(p)) +
                   XmlMatrix("kp", 5, 1, D(p)) +
                   XmlMatrix("Rp", 3, 3, Row(rig.projector_from_left.rotation_matrix())) +
                   XmlMatrix("Tp", 3, 1,
                             {rig.projector_from_left.translation()[0],
                              rig.projector_from_left.translation()[1],
                              rig.projector_from_left.translation()[2]}) +
                   "<cam_error>0.1234</cam_error>\n<proj_error>0.2</proj_error>\n"
                   "<stereo_error>0.3</stereo_error>\n<frameWidth>2048</frameWidth>\n"
                   "<frameHeight>1536</frameHeight>\n<screenResX>912</screenResX>\n"
                   "<screenResY>1140</screenResY>\n</opencv_storage>\n");
  EXPECT_EQ(DetectCalibrationFormats({f}),
            std::vector<CalibrationFormat>{CalibrationFormat::kSlStudio});
  const OpenCvCalibration c = ReadCalibration({f});
  EXPECT_EQ(c.format, "slstudio");
  const StereoRig got = c.ToCameraProjectorRig("calibration.xml");
  // Single precision in the file: relative float rounding of each value.
  ExpectCameraNear(got.left, rig.left, 1e-3, "camera");
  ExpectCameraNear(*got.projector, p, 1e-3, "projector");
  ExpectPoseNear(got.projector_from_left, rig.projector_from_left, kFloatRotationTol, 1e-4,
                 "projector_from_left");
  const std::string d = c.Describe();
  for (const char* k : {"calibration.xml: Kc -> left camera matrix", ": kc -> left distortion",
                        ": Kp -> projector camera matrix", ": Rp -> projector_from_left rotation",
                        ": Tp -> projector_from_left translation (mm)",
                        ": frameWidth frameHeight -> camera size 2048x1536",
                        ": screenResX screenResY -> projector size 912x1140"}) {
    EXPECT_NE(d.find(k), std::string::npos) << k << "\n" << d;
  }
}

// ROS camera_info for a stereo pair, as camera_calibration writes it: its R and P come from
// cv::stereoRectify with the extrinsics in metres (an independent construction of the
// rectification, not fringe's writer).
TEST(CalibrationFormats, RosCameraInfoPairInMetres) {
  test::TempDir dir;
  const StereoRig rig = TestRig();
  const auto cvk = [](const CameraModel& c) -> cv::Mat {
    return (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  };
  const auto cvd = [](const CameraModel& c) { return cv::Mat(D(c)).reshape(1, 1).clone(); };
  cv::Mat r(3, 3, CV_64F), t(3, 1, CV_64F);
  const Eigen::Matrix3d rm = rig.right_from_left.rotation_matrix();
  for (int i = 0; i < 9; ++i) r.at<double>(i / 3, i % 3) = rm(i / 3, i % 3);
  for (int i = 0; i < 3; ++i) t.at<double>(i) = rig.right_from_left.translation()[i] / 1000.0;
  cv::Mat r1, r2, p1, p2, q;
  cv::stereoRectify(cvk(rig.left), cvd(rig.left), cvk(rig.right), cvd(rig.right),
                    cv::Size(rig.left.width, rig.left.height), r, t, r1, r2, p1, p2, q,
                    cv::CALIB_ZERO_DISPARITY, 0.0);
  const auto matrix = [](const std::string& key, const cv::Mat& m) {
    std::string s = key + ":\n  rows: " + std::to_string(m.rows) +
                    "\n  cols: " + std::to_string(m.cols) + "\n  data: [";
    for (int i = 0; i < static_cast<int>(m.total()); ++i) {
      s += (i ? ", " : "") + Num(m.at<double>(i / m.cols, i % m.cols));
    }
    return s + "]\n";
  };
  const auto info = [&](const char* name, const CameraModel& c, const cv::Mat& rect,
                        const cv::Mat& proj) {
    return "image_width: " + std::to_string(c.width) +
           "\nimage_height: " + std::to_string(c.height) + "\ncamera_name: " + name + "\n" +
           matrix("camera_matrix", cvk(c)) + "distortion_model: plumb_bob\n" +
           matrix("distortion_coefficients", cvd(c)) + matrix("rectification_matrix", rect) +
           matrix("projection_matrix", proj);
  };
  // Given right first: the file whose P holds the baseline is the right camera.
  WriteText(dir / "right.yaml", info("narrow_stereo/right", rig.right, r2, p2));
  WriteText(dir / "left.yaml", info("narrow_stereo/left", rig.left, r1, p1));
  ASSERT_NE(p2.at<double>(0, 3), 0.0);
  const OpenCvCalibration c = ReadCalibration({dir / "right.yaml", dir / "left.yaml"});
  EXPECT_EQ(c.format, "ros");
  const StereoRig got = c.ToRig("ros");
  ExpectCameraNear(got.left, rig.left, kRoundTripTol, "left");
  ExpectCameraNear(got.right, rig.right, kRoundTripTol, "right");
  ExpectPoseNear(got.right_from_left, rig.right_from_left, 1e-12, 1e-9, "right_from_left");
  EXPECT_NE(c.Describe().find("left.yaml -> left camera, right.yaml -> right camera"),
            std::string::npos)
      << c.Describe();
  // One file without its partner: the left camera alone reads; two left cameras do not pair.
  EXPECT_FALSE(ReadCalibration({dir / "left.yaml"}).right);
  const std::string msg = ErrorOf([&] { ReadCalibration({dir / "left.yaml", dir / "left.yaml"}); });
  EXPECT_NE(msg.find("left.yaml"), std::string::npos) << msg;
}

TEST(CalibrationFormats, KalibrCamchainInMetresWithAProjector) {
  test::TempDir dir;
  const StereoRig rig = TestRig(/*with_k3=*/false);
  // T_cn_cnm1 chains: cam1 from cam0, cam2 (the projector) from cam1; metres.
  const Rigid3d cam2_from_cam1 = rig.projector_from_left * rig.right_from_left.Inverse();
  const auto tf = [](const Rigid3d& t) {
    const Eigen::Matrix3d r = t.rotation_matrix();
    std::string s = "  T_cn_cnm1:\n";
    for (int i = 0; i < 3; ++i) {
      s += "  - [" + Num(r(i, 0)) + ", " + Num(r(i, 1)) + ", " + Num(r(i, 2)) + ", " +
           Num(t.translation()[i] / 1000.0) + "]\n";
    }
    return s + "  - [0.0, 0.0, 0.0, 1.0]\n";
  };
  const auto cam = [](const std::string& name, const CameraModel& c, const std::string& extra,
                      const std::string& topic) {
    return name + ":\n" + extra +
           "  cam_overlaps: [1]\n  camera_model: pinhole\n  distortion_coeffs: [" + Num(c.k1) +
           ", " + Num(c.k2) + ", " + Num(c.p1) + ", " + Num(c.p2) +
           "]\n  distortion_model: radtan\n  intrinsics: [" + Num(c.fx) + ", " + Num(c.fy) + ", " +
           Num(c.cx) + ", " + Num(c.cy) + "]\n  resolution: [" + std::to_string(c.width) + ", " +
           std::to_string(c.height) + "]\n  rostopic: " + topic + "\n";
  };
  const fs::path f = dir / "camchain.yaml";
  WriteText(f, cam("cam0", rig.left, "", "/cam0/image_raw") +
                   cam("cam1", rig.right, tf(rig.right_from_left), "/cam1/image_raw") +
                   cam("cam2", *rig.projector, tf(cam2_from_cam1), "/projector/image_raw"));
  const OpenCvCalibration c = ReadCalibration({f});
  EXPECT_EQ(c.format, "kalibr");
  const StereoRig got = c.ToRig("kalibr");
  ExpectCameraNear(got.left, rig.left, kRoundTripTol, "left");
  ExpectCameraNear(got.right, rig.right, kRoundTripTol, "right");
  ExpectCameraNear(*got.projector, *rig.projector, kRoundTripTol, "projector");
  ExpectPoseNear(got.right_from_left, rig.right_from_left, 1e-12, 1e-9, "right_from_left");
  ExpectPoseNear(got.projector_from_left, rig.projector_from_left, 1e-12, 1e-9, "projector");
  EXPECT_NE(c.Describe().find("cam2 -> projector (its rostopic says so)"), std::string::npos)
      << c.Describe();
  EXPECT_NE(c.Describe().find("cam1.T_cn_cnm1 -> cam1 from the previous camera (m -> mm)"),
            std::string::npos)
      << c.Describe();
  // Kalibr's other camera models are refused by name.
  std::string text = cam("cam0", rig.left, "", "/cam0/image_raw");
  text.replace(text.find("radtan"), 6, "equidistant");
  WriteText(dir / "fisheye.yaml", text);
  const std::string msg = ErrorOf([&] { ReadCalibration({dir / "fisheye.yaml"}); });
  EXPECT_NE(msg.find("cam0.distortion_model: equidistant"), std::string::npos) << msg;
}

TEST(CalibrationFormats, ExplicitKeyMappingReadsAnyFile) {
  test::TempDir dir;
  const StereoRig rig = TestRig();
  const auto list = [](const std::vector<double>& v) {
    std::string s = "[";
    for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + Num(v[i]);
    return s + "]";
  };
  const fs::path f = dir / "mine.yaml";
  WriteText(
      f,
      "cam_K: " + list(K(rig.left)) + "\ncam_dist: " + list(D(rig.left)) +
          "\nsize: [2048, 1536]\nproj_K: " + list(K(*rig.projector)) +
          "\nproj_size: [912, 1140]\nrot: " + list(Row(rig.projector_from_left.rotation_matrix())) +
          "\ntrans: " +
          list({rig.projector_from_left.translation()[0], rig.projector_from_left.translation()[1],
                rig.projector_from_left.translation()[2]}) +
          "\n");
  // Not recognised without a mapping (no tool's signature, no OpenCV header).
  EXPECT_TRUE(DetectCalibrationFormats({f}).empty());
  CalibrationReadOptions o;
  o.keys = CalibrationKeyMap::Parse({"left=cam_K,cam_dist", "left_size=size", "projector=proj_K",
                                     "projector_size=proj_size", "projector_from_left=rot,trans"});
  const OpenCvCalibration c = ReadCalibration({f}, o);
  EXPECT_EQ(c.format, "keys");
  const StereoRig got = c.ToCameraProjectorRig("mine");
  ExpectCameraNear(got.left, rig.left, kRoundTripTol, "left");
  EXPECT_EQ(got.projector->k1, 0.0);  // no distortion key mapped
  ExpectPoseNear(got.projector_from_left, rig.projector_from_left, 1e-12, 1e-12, "projector");
  EXPECT_NE(c.Describe().find("mine.yaml: cam_dist -> left distortion"), std::string::npos);
  // Bad mappings name the argument.
  EXPECT_NE(ErrorOf([] { CalibrationKeyMap::Parse({"middle=K"}); }).find("'middle=K'"),
            std::string::npos);
  EXPECT_NE(ErrorOf([] {
              CalibrationKeyMap::Parse({"right_from_left=R"});
            }).find("right_from_left takes 2 non-empty key names"),
            std::string::npos);
  o.keys = CalibrationKeyMap::Parse({"left=nothere", "left_size=size"});
  EXPECT_NE(ErrorOf([&] { ReadCalibration({f}, o); }).find("no key nothere"), std::string::npos);
}

TEST(CalibrationFormats, AFileTwoReadersMatchIsAnErrorNamingBoth) {
  test::TempDir dir;
  const fs::path f = dir / "both.yaml";
  const std::string m = "{rows: 3, cols: 3, data: [1, 0, 0, 0, 1, 0, 0, 0, 1]}";
  WriteText(f, "camera_matrix: " + m + "\nrectification_matrix: " + m +
                   "\nprojection_matrix: {rows: 3, cols: 4, data: [1,0,0,0,0,1,0,0,0,0,1,0]}\n"
                   "Kc: " +
                   m + "\nKp: " + m + "\nRp: " + m + "\nTp: [0, 0, 0]\n");
  const std::string msg = ErrorOf([&] { ReadCalibration({f}); });
  EXPECT_NE(msg.find("both.yaml: matches the slstudio and ros readers"), std::string::npos) << msg;
}

TEST(CalibrationFormats, EveryWriterRoundTripsExactly) {
  test::TempDir dir;
  for (const bool stereo : {true, false}) {
    for (const CalibrationFormat format : {CalibrationFormat::kOpenCv, CalibrationFormat::kSlStudio,
                                           CalibrationFormat::kRos, CalibrationFormat::kKalibr}) {
      SCOPED_TRACE(std::string(CalibrationFormatName(format)) + (stereo ? " stereo" : " single"));
      StereoRig rig = TestRig(format != CalibrationFormat::kKalibr);
      if (!stereo) {
        rig.right = rig.left;
        rig.right_from_left = Rigid3d::Identity();
      }
      if (!stereo && format == CalibrationFormat::kRos) {
        // camera_info holds cameras; a camera-projector rig is refused before anything is written.
        const fs::path out = dir / "single_left.yaml";
        EXPECT_NE(ErrorOf([&] {
                    WriteCalibration(format, {out, dir / "r.yaml"}, rig);
                  }).find("ROS camera_info describes a camera pair"),
                  std::string::npos);
        EXPECT_FALSE(fs::exists(out));
        continue;
      }
      const std::string ext = format == CalibrationFormat::kSlStudio ? ".xml" : ".yaml";
      std::vector<fs::path> outs = {dir / (std::string(CalibrationFormatName(format)) + ext)};
      if (format == CalibrationFormat::kRos) {
        outs = {dir / "ros_left.yaml", dir / "ros_right.yaml"};
      }
      const std::vector<std::string> notes = WriteCalibration(format, outs, rig);
      const OpenCvCalibration c = ReadCalibration(outs);
      EXPECT_EQ(c.format, CalibrationFormatName(format));
      const bool with_right = stereo && format != CalibrationFormat::kSlStudio;
      const bool with_projector = format != CalibrationFormat::kRos;
      const StereoRig got = with_right ? c.ToRig("x") : c.ToCameraProjectorRig("x");
      ExpectCameraNear(got.left, rig.left, kRoundTripTol, "left");
      if (with_right) {
        ExpectCameraNear(got.right, rig.right, kRoundTripTol, "right");
        ExpectPoseNear(got.right_from_left, rig.right_from_left, kRoundTripTol, kRoundTripTol,
                       "right_from_left");
      }
      ASSERT_EQ(got.projector.has_value(), with_projector);
      if (with_projector) {
        ExpectCameraNear(*got.projector, *rig.projector, kRoundTripTol, "projector");
        ExpectPoseNear(got.projector_from_left, rig.projector_from_left, kRoundTripTol,
                       kRoundTripTol, "projector_from_left");
      }
      // What a format cannot hold is said, not silently dropped.
      EXPECT_EQ(notes.empty(), with_right == stereo && with_projector) << notes.size();
    }
  }
}

TEST(CalibrationFormats, WritersRefuseWhatTheFormatCannotHold) {
  test::TempDir dir;
  StereoRig rig = TestRig();
  EXPECT_NE(ErrorOf([&] {
              WriteCalibration(CalibrationFormat::kKalibr, {dir / "k.yaml"}, rig);
            }).find("Kalibr's radtan model has no k3; the left camera has k3 = -0.211"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "k.yaml"));
  rig.projector.reset();
  EXPECT_NE(ErrorOf([&] {
              WriteCalibration(CalibrationFormat::kSlStudio, {dir / "s.xml"}, rig);
            }).find("this rig has no projector"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] {
              WriteCalibration(CalibrationFormat::kRos, {dir / "l.yaml"}, rig);
            }).find("2 output files (left, right) expected, 1 given"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] {
              WriteCalibration(CalibrationFormat::kOpenCv, {dir / "o.txt"}, rig);
            }).find("o.txt: a OpenCV file must end in .yml .yaml .xml"),
            std::string::npos);
}

// The captures in ../shared/data keep reading with the OpenCV reader (no other signature).
TEST(CalibrationFormats, SharedDataFilesAreOpenCvFiles) {
  FRINGE_SHARED_DATA_OR_SKIP(slsdk, "slsdk-stereo-phasegray");
  EXPECT_EQ(DetectCalibrationFormats({slsdk / "intrinsic.yml", slsdk / "extrinsic.yml"}),
            std::vector<CalibrationFormat>{CalibrationFormat::kOpenCv});
  FRINGE_SHARED_DATA_OR_SKIP(slmaster, "slmaster-mono-camproj-relief");
  EXPECT_EQ(DetectCalibrationFormats({slmaster / "caliInfo.yml"}),
            std::vector<CalibrationFormat>{CalibrationFormat::kOpenCv});
}

}  // namespace
}  // namespace fringe::io
