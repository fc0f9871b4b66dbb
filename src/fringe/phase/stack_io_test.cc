#include "fringe/phase/stack_io.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "fringe/io/image_io.h"
#include "fringe/phase/synthetic.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::phase {
namespace {

void ExpectErrorMentions(const std::function<void()>& f, const std::string& what) {
  try {
    f();
    FAIL() << "expected an error mentioning " << what;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}

TEST(StackIo, RoundTripAndBadStacksNameTheFile) {
  test::TempDir dir;
  const PatternScheme s = MakeScheme("gray+4", 640, 400);
  const cv::Mat u = LinearProjectorMap(s, cv::Size(96, 64));
  const auto images = RenderSyntheticStack(s, u, SyntheticStackOptions());
  const auto names = s.ImageNames();
  std::filesystem::create_directories(dir / "stack");
  for (size_t i = 0; i < images.size(); ++i) {
    cv::imwrite((dir / "stack" / names[i]).string(), images[i]);
  }
  const auto read = ReadStack(dir / "stack", s);
  ASSERT_EQ(read.size(), images.size());
  EXPECT_EQ(cv::norm(read[3], images[3], cv::NORM_INF), 0.0);

  const DecodeResult r = Decode(s, read);
  WriteDecodeFolder(dir / "out", r);
  const cv::Mat abs = io::ReadFloatImage(dir / "out" / "absolute_phase.tiff");
  cv::Mat a = abs.clone(), b = r.absolute_phase.clone();
  a.setTo(0, r.mask == 0);
  b.setTo(0, r.mask == 0);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "summary.json"));
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "absolute_phase_preview.png"));

  // Extra image.
  cv::imwrite((dir / "stack" / "zz_extra.png").string(), images[0]);
  ExpectErrorMentions([&] { ReadStack(dir / "stack", s); }, "zz_extra.png");
  std::filesystem::remove(dir / "stack" / "zz_extra.png");
  // Differently sized image.
  cv::imwrite((dir / "stack" / names[2]).string(), cv::Mat(10, 10, CV_8U, cv::Scalar(0)));
  ExpectErrorMentions([&] { ReadStack(dir / "stack", s); }, names[2]);
  // Missing image.
  std::filesystem::remove(dir / "stack" / names[2]);
  ExpectErrorMentions([&] { ReadStack(dir / "stack", s); }, names[2]);
}

// Exposure folders e0/, e1/: read in order; images beside them, or an exposure of another size,
// are errors naming the file or folder; a plain folder is one exposure.
TEST(StackIo, ExposureFolders) {
  test::TempDir dir;
  const PatternScheme s = MakeScheme("gray+4", 640, 400);
  const cv::Mat u = LinearProjectorMap(s, cv::Size(96, 64));
  SyntheticStackOptions dim, bright;
  dim.modulation_dn = 20;
  dim.background_dn = 30;
  const auto names = s.ImageNames();
  const std::vector<std::vector<cv::Mat>> written = {RenderSyntheticStack(s, u, dim),
                                                     RenderSyntheticStack(s, u, bright)};
  for (int e = 0; e < 2; ++e) {
    std::filesystem::create_directories(ExposureDir(dir / "cam", e));
    for (size_t i = 0; i < names.size(); ++i) {
      cv::imwrite((ExposureDir(dir / "cam", e) / names[i]).string(), written[e][i]);
    }
  }
  EXPECT_TRUE(HasExposureFolders(dir / "cam"));
  const auto stacks = ReadExposureStacks(dir / "cam", s);
  ASSERT_EQ(stacks.size(), 2u);
  EXPECT_EQ(cv::norm(stacks[1][2], written[1][2], cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(stacks[0][2], written[0][2], cv::NORM_INF), 0.0);
  const auto plain = ReadExposureStacks(ExposureDir(dir / "cam", 1), s);
  ASSERT_EQ(plain.size(), 1u);
  // The summary JSON lists the exposures of a combined decode.
  const DecodeResult r = DecodeExposures(s, stacks);
  const nlohmann::json j = ToJson(r.summary);
  ASSERT_TRUE(j.contains("exposures"));
  EXPECT_EQ(j["exposures"].size(), 2u);
  EXPECT_FALSE(ToJson(Decode(s, stacks[0]).summary).contains("exposures"));
  // An image beside the exposure folders.
  cv::imwrite((dir / "cam" / names[0]).string(), written[0][0]);
  ExpectErrorMentions([&] { ReadExposureStacks(dir / "cam", s); },
                      (dir / "cam" / names[0]).string());
  std::filesystem::remove(dir / "cam" / names[0]);
  // An exposure of another size.
  std::filesystem::create_directories(ExposureDir(dir / "cam", 2));
  for (const auto& n : names) {
    cv::imwrite((ExposureDir(dir / "cam", 2) / n).string(), cv::Mat(32, 48, CV_8U, cv::Scalar(9)));
  }
  ExpectErrorMentions([&] { ReadExposureStacks(dir / "cam", s); },
                      ExposureDir(dir / "cam", 2).string());
}

}  // namespace
}  // namespace fringe::phase
