#include "fringe/phase/synthetic.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "fringe/util/error.h"
#include "fringe/util/random.h"

namespace fringe::phase {

void SyntheticStackOptions::Check() const {
  const char* o = "SyntheticStackOptions";
  util::CheckOption(modulation_dn >= 0, o, "modulation_dn", modulation_dn, "must be >= 0");
  util::CheckOption(noise_sigma_dn >= 0, o, "noise_sigma_dn", noise_sigma_dn, "must be >= 0");
  util::CheckOption(projector_gamma > 0, o, "projector_gamma", projector_gamma, "must be > 0");
  util::CheckOption(precompensate_gamma > 0, o, "precompensate_gamma", precompensate_gamma,
                    "must be > 0");
  util::CheckOption(bit_depth == 8 || bit_depth == 16, o, "bit_depth", bit_depth,
                    "must be 8 or 16");
}

cv::Mat LinearProjectorMap(const PatternScheme& scheme, cv::Size size) {
  cv::Mat u(size, CV_32F);
  const double shear = 0.03;
  const double denom = (size.width - 1) + shear * (size.height - 1);
  const double span = scheme.Span() - 1;
  for (int r = 0; r < size.height; ++r) {
    for (int c = 0; c < size.width; ++c) {
      u.at<float>(r, c) = static_cast<float>(span * (c + shear * r) / denom);
    }
  }
  return u;
}

std::vector<cv::Mat> RenderSyntheticStack(const PatternScheme& scheme, const cv::Mat& projector_u,
                                          const SyntheticStackOptions& opt) {
  scheme.Check();
  opt.Check();
  CV_Assert(projector_u.type() == CV_32F);
  const int n = scheme.NumImages();
  const double full = opt.bit_depth == 8 ? 255.0 : 65535.0;
  std::vector<cv::Mat> out(n);
  for (auto& m : out) m.create(projector_u.size(), opt.bit_depth == 8 ? CV_8U : CV_16U);
  const int h = projector_u.rows, w = projector_u.cols;
  tbb::parallel_for(0, n * h, [&](int item) {
    const int i = item / h, r = item % h;
    util::Rng rng(util::MixSeed(opt.seed, static_cast<uint64_t>(item)));
    std::normal_distribution<double> noise(0.0, 1.0);
    const float* u = projector_u.ptr<float>(r);
    for (int c = 0; c < w; ++c) {
      double p = std::clamp(PatternIntensity(scheme, i, u[c]), 0.0, 1.0);
      p = std::pow(p, 1.0 / opt.precompensate_gamma);
      if (opt.quantize_patterns) p = std::round(255.0 * p) / 255.0;
      p = std::pow(p, opt.projector_gamma);
      double v = opt.background_dn + opt.modulation_dn * (2.0 * p - 1.0);
      if (opt.noise_sigma_dn > 0) v += opt.noise_sigma_dn * noise(rng);
      v = std::clamp(std::round(v), 0.0, full);
      if (opt.bit_depth == 8) {
        out[i].ptr<uint8_t>(r)[c] = static_cast<uint8_t>(v);
      } else {
        out[i].ptr<uint16_t>(r)[c] = static_cast<uint16_t>(v);
      }
    }
  });
  return out;
}

}  // namespace fringe::phase
