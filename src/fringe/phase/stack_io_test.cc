#include "fringe/phase/stack_io.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "fringe/io/image_io.h"
#include "fringe/phase/synthetic.h"
#include "fringe/util/error.h"
#include "fringe_test.h"

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

}  // namespace
}  // namespace fringe::phase
