#include "fringe/phase/spatial_decode.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <queue>
#include <utility>

#include "fringe/util/error.h"

namespace fringe::phase {
namespace {

using util::StrCat;

constexpr double kTwoPi = 2.0 * M_PI;

// Frequency (cycles per pixel) of DFT bin i of n.
double BinFrequency(int i, int n) {
  return static_cast<double>(i <= n / 2 ? i : i - n) / static_cast<double>(n);
}

// Complex spectrum (CV_32FC2) of `image` minus `mean`, zero-padded by at least `pad` pixels on
// each axis (to the optimal DFT size): the transform is circular, and without the margin the
// filter would mix the image's opposite borders.
cv::Mat Spectrum(const cv::Mat& image, double mean, int pad = 0) {
  const int rows = cv::getOptimalDFTSize(image.rows + pad);
  const int cols = cv::getOptimalDFTSize(image.cols + pad);
  cv::Mat padded = cv::Mat::zeros(rows, cols, CV_32F);
  cv::Mat roi = padded(cv::Rect(0, 0, image.cols, image.rows));
  cv::subtract(image, cv::Scalar(mean), roi);
  cv::Mat spectrum;
  cv::dft(padded, spectrum, cv::DFT_COMPLEX_OUTPUT);
  return spectrum;
}

// Hann window of radius r at distance d.
inline double Hann(double d, double r) {
  return d >= r ? 0.0 : 0.5 * (1.0 + std::cos(M_PI * d / r));
}

// Wrap to [-0.5, 0.5).
inline double WrapHalf(double x) { return x - std::floor(x + 0.5); }

}  // namespace

cv::Point2d FindCarrier(const cv::Mat& image) {
  CV_Assert(image.type() == CV_32F && !image.empty());
  // A Hann taper across the image first: the peak of a tapered fringe is smooth (no sinc side
  // lobes from the image border), so a parabola through its log power locates it to a few
  // hundredths of a bin.
  cv::Mat tapered = image - cv::mean(image)[0];
  cv::Mat taper;
  cv::createHanningWindow(taper, image.size(), CV_32F);
  tapered = tapered.mul(taper);
  const cv::Mat spec = Spectrum(tapered, 0.0);
  const double min_d = 3.0 / std::min(image.cols, image.rows);
  double best = -1;
  cv::Point2d carrier(0, 0);
  for (int y = 0; y < spec.rows; ++y) {
    const cv::Vec2f* row = spec.ptr<cv::Vec2f>(y);
    const double fy = BinFrequency(y, spec.rows);
    for (int x = 0; x < spec.cols; ++x) {
      const double fx = BinFrequency(x, spec.cols);
      if (std::hypot(fx, fy) < min_d) continue;
      const double p =
          static_cast<double>(row[x][0]) * row[x][0] + static_cast<double>(row[x][1]) * row[x][1];
      if (p > best) {
        best = p;
        carrier = {fx, fy};
      }
    }
  }
  // Sub-bin position: a parabola through the log power of the peak and its neighbours along
  // each axis (a plane's fringe is a single frequency; the window then sits on it).
  const int px = static_cast<int>(std::lround(carrier.x * spec.cols + spec.cols)) % spec.cols;
  const int py = static_cast<int>(std::lround(carrier.y * spec.rows + spec.rows)) % spec.rows;
  const auto log_power = [&](int y, int x) {
    const cv::Vec2f v =
        spec.at<cv::Vec2f>((y + spec.rows) % spec.rows, (x + spec.cols) % spec.cols);
    return std::log(static_cast<double>(v[0]) * v[0] + static_cast<double>(v[1]) * v[1] + 1e-30);
  };
  const auto vertex = [](double a, double b, double c) {
    const double d = a - 2 * b + c;
    return d < 0 ? std::clamp(0.5 * (a - c) / d, -0.5, 0.5) : 0.0;
  };
  carrier.x += vertex(log_power(py, px - 1), log_power(py, px), log_power(py, px + 1)) / spec.cols;
  carrier.y += vertex(log_power(py - 1, px), log_power(py, px), log_power(py + 1, px)) / spec.rows;
  const bool flip = std::abs(carrier.x) >= std::abs(carrier.y) ? carrier.x < 0 : carrier.y < 0;
  return flip ? -carrier : carrier;
}

FourierFringe FourierAnalysis(const cv::Mat& image, cv::Point2d carrier, const cv::Mat& known,
                              int iterations) {
  CV_Assert(image.type() == CV_32F && !image.empty());
  CV_Assert(known.empty() || (known.type() == CV_8U && known.size() == image.size()));
  const double mean = known.empty() ? cv::mean(image)[0] : cv::mean(image, known)[0];
  const double radius = 0.5 * std::hypot(carrier.x, carrier.y);
  // The filter's kernel reaches about 1 / radius pixels: pad by twice that (at most the image).
  const int pad =
      static_cast<int>(std::min<double>(std::max(image.rows, image.cols), std::ceil(2.0 / radius)));
  const int rows = cv::getOptimalDFTSize(image.rows + pad);
  const int cols = cv::getOptimalDFTSize(image.cols + pad);
  // The windows (two channels, to scale complex spectra): the carrier lobe, and the band (DC and
  // both lobes) that describes the fringe image.
  cv::Mat lobe_window(rows, cols, CV_32FC2), band_window(rows, cols, CV_32FC2);
  tbb::parallel_for(tbb::blocked_range<int>(0, rows, 32), [&](const auto& range) {
    for (int y = range.begin(); y < range.end(); ++y) {
      const double fy = BinFrequency(y, rows);
      cv::Vec2f* l = lobe_window.ptr<cv::Vec2f>(y);
      cv::Vec2f* b = band_window.ptr<cv::Vec2f>(y);
      for (int x = 0; x < cols; ++x) {
        const double fx = BinFrequency(x, cols);
        const double wc = Hann(std::hypot(fx - carrier.x, fy - carrier.y), radius);
        const double wn = Hann(std::hypot(fx + carrier.x, fy + carrier.y), radius);
        const double w0 = Hann(std::hypot(fx, fy), radius);
        l[x] = cv::Vec2f(static_cast<float>(wc), static_cast<float>(wc));
        const float wb = static_cast<float>(wc + wn + w0);
        b[x] = cv::Vec2f(wb, wb);
      }
    }
  });
  const cv::Rect roi(0, 0, image.cols, image.rows);
  cv::Mat extended = cv::Mat::zeros(rows, cols, CV_32F);
  cv::Mat inside = cv::Mat::zeros(rows, cols, CV_8U);
  cv::subtract(image, cv::Scalar(mean), extended(roi), known);
  if (known.empty()) {
    inside(roi).setTo(255);
  } else {
    known.copyTo(inside(roi));
  }
  const cv::Mat outside = inside == 0;
  // Fringe continuation (Gerchberg-Papoulis): the band-limited image replaces the unknown pixels
  // (the padding and, with `known`, the image's invalid ones) while the known ones stay, so the
  // fringe runs on past the border instead of stopping: the filter then no longer leaks the
  // opposite lobe into the analytic signal near edges.
  cv::Mat spec, rec;
  for (int it = 0; it < iterations; ++it) {
    cv::dft(extended, spec, cv::DFT_COMPLEX_OUTPUT);
    cv::multiply(spec, band_window, spec);
    cv::idft(spec, rec, cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
    rec.copyTo(extended, outside);
  }
  cv::dft(extended, spec, cv::DFT_COMPLEX_OUTPUT);
  FourierFringe out;
  out.carrier = carrier;
  cv::Mat lobe, band, z, zb;
  cv::multiply(spec, lobe_window, lobe);
  cv::multiply(spec, band_window, band);
  cv::idft(lobe, z, cv::DFT_SCALE | cv::DFT_COMPLEX_OUTPUT);
  cv::idft(band, zb, cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
  out.analytic = z(roi).clone();
  out.band_limited = zb(roi) + mean;
  return out;
}

int UnwrapQualityGuided(const cv::Mat& cycles, const cv::Mat& quality, const cv::Mat& valid,
                        double max_step, cv::Mat* unwrapped, cv::Mat* labels) {
  CV_Assert(cycles.type() == CV_32F && quality.type() == CV_32F && valid.type() == CV_8U);
  const int w = cycles.cols, h = cycles.rows;
  unwrapped->create(cycles.size(), CV_32F);
  unwrapped->setTo(std::numeric_limits<float>::quiet_NaN());
  labels->create(cycles.size(), CV_32S);
  labels->setTo(-1);
  const float* f = cycles.ptr<float>();
  const float* q = quality.ptr<float>();
  const uint8_t* m = valid.ptr<uint8_t>();
  float* out = unwrapped->ptr<float>();
  int32_t* lab = labels->ptr<int32_t>();
  CV_Assert(cycles.isContinuous() && quality.isContinuous() && valid.isContinuous());
  // Seeds in order of quality: every region starts at its best pixel.
  std::vector<int> order;
  for (int i = 0; i < w * h; ++i) {
    if (m[i]) order.push_back(i);
  }
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return q[a] > q[b] || (q[a] == q[b] && a < b); });
  // Queue entries: quality of the pixel, the pixel, and the unwrapped value of the neighbour that
  // reached it.
  struct Entry {
    float quality;
    int pixel;
    int from;
    bool operator<(const Entry& o) const {
      return quality < o.quality || (quality == o.quality && pixel > o.pixel);
    }
  };
  std::priority_queue<Entry> queue;
  int regions = 0;
  const auto push_neighbours = [&](int p) {
    const int x = p % w, y = p / w;
    const int nb[4] = {x > 0 ? p - 1 : -1, x + 1 < w ? p + 1 : -1, y > 0 ? p - w : -1,
                       y + 1 < h ? p + w : -1};
    for (const int n : nb) {
      if (n >= 0 && m[n] && lab[n] < 0) queue.push({q[n], n, p});
    }
  };
  for (const int seed : order) {
    if (lab[seed] >= 0) continue;
    const int region = regions++;
    lab[seed] = region;
    out[seed] = f[seed];
    push_neighbours(seed);
    while (!queue.empty()) {
      const Entry e = queue.top();
      queue.pop();
      if (lab[e.pixel] >= 0) continue;
      const double step = WrapHalf(static_cast<double>(f[e.pixel]) - f[e.from]);
      // Half a cycle between neighbours is ambiguous: reach the pixel another way, or not at all.
      if (std::abs(step) > max_step) continue;
      lab[e.pixel] = region;
      out[e.pixel] = static_cast<float>(out[e.from] + step);
      push_neighbours(e.pixel);
    }
  }
  return regions;
}

namespace {

// Markers are not looked for this close to the image's border (the band-limited image rings
// where the fringe is cut), and are at most this large in the camera (a five-pixel plus seen at
// up to ~3 camera pixels per projector pixel).
constexpr int kMarkerBorderPx = 12;
constexpr int kMaxMarkerPixels = 64;
constexpr int kMaxMarkerSidePx = 12;

// Per-pixel reasons as decode.cc's kernel orders them.
inline uint8_t Code(PixelReason r) { return static_cast<uint8_t>(r); }

// The angle of sum(z1 conj(z0)) over the image: the phase step from image 0 to image 1 as the
// analytic signals see it.
double PhaseStepAngle(const cv::Mat& z0, const cv::Mat& z1) {
  double re = 0, im = 0;
  for (int y = 0; y < z0.rows; ++y) {
    const cv::Vec2f* a = z0.ptr<cv::Vec2f>(y);
    const cv::Vec2f* b = z1.ptr<cv::Vec2f>(y);
    for (int x = 0; x < z0.cols; ++x) {
      re += static_cast<double>(b[x][0]) * a[x][0] + static_cast<double>(b[x][1]) * a[x][1];
      im += static_cast<double>(b[x][1]) * a[x][0] - static_cast<double>(b[x][0]) * a[x][1];
    }
  }
  return std::atan2(im, re);
}

}  // namespace

void DecodeSpatial(const PatternScheme& scheme, const std::vector<cv::Mat>& images,
                   const DecodeOptions& options, double full, DecodeResult* result,
                   std::vector<FoundMarker>* found_markers) {
  if (!scheme.markers.Present()) {
    throw Error(StrCat("scheme '", scheme.name,
                       "': \"unwrapping\": \"spatial\" needs markers in the patterns to fix the "
                       "absolute period (\"markers\"; OpenCV's setMarkers, fringe's --markers); "
                       "without them the phase is known up to a whole number of periods only"));
  }
  const PhaseShiftSet& set = scheme.phase_sets[0];
  const int n = set.steps;
  const int first = scheme.PhaseImageIndex(0);
  const cv::Size size = images[first].size();
  const int w = size.width, h = size.height;
  const std::vector<double> shifts = set.Shifts();
  const double period = set.period_px;
  const double offset = set.phase_offset_rad;

  // Camera noise and the modulation threshold (spatial unwrapping has no temporal step: the
  // threshold is the level noise alone exceeds with order_error_probability).
  const ModulationLimit limit = ChooseModulationThreshold(scheme, images, options, full);
  const NoiseEstimate& noise = limit.noise;
  const double b_min = limit.min_modulation_dn;
  const bool bounded = limit.bounded;

  std::vector<cv::Mat> f(n);
  for (int k = 0; k < n; ++k) images[first + k].convertTo(f[k], CV_32F);

  // 1. Fourier analysis of every image, around the first image's carrier.
  const cv::Point2d carrier = FindCarrier(f[0]);
  std::vector<FourierFringe> fourier(n);
  // The pixels the continuation keeps: those with a fringe by the least squares (not saturated,
  // modulation above the threshold); the others (shadows, the background) are filled in.
  cv::Mat known(size, CV_8U);
  {
    const cv::Mat c = DemodulationMatrix(set);
    tbb::parallel_for(tbb::blocked_range<int>(0, h, 16), [&](const auto& range) {
      for (int y = range.begin(); y < range.end(); ++y) {
        uint8_t* kn = known.ptr<uint8_t>(y);
        for (int x = 0; x < w; ++x) {
          double a = 0, b = 0;
          float maxi = 0;
          for (int k = 0; k < n; ++k) {
            const float v = f[k].ptr<float>(y)[x];
            a += c.at<double>(1, k) * v;
            b += c.at<double>(2, k) * v;
            maxi = std::max(maxi, v);
          }
          kn[x] = a * a + b * b >= b_min * b_min && maxi < full ? 255 : 0;
        }
      }
    });
  }
  for (int k = 0; k < n; ++k) {
    fourier[k] = FourierAnalysis(f[k], carrier, known, kFringeContinuationIterations);
  }
  // The lobe's sign: arg(z_k) = sign (phase_k); the scheme's step from image 0 to 1 decides it.
  const double nominal = shifts[1] - shifts[0];
  if (std::abs(std::sin(nominal)) < 0.2) {
    throw Error(StrCat("scheme '", scheme.name,
                       "': spatial unwrapping takes the sign of the phase from the shift between "
                       "the first two images, which must not be a multiple of pi (got ",
                       nominal, " rad)"));
  }
  const double step_angle = PhaseStepAngle(fourier[0].analytic, fourier[1].analytic);
  const double sign = std::cos(step_angle - nominal) >= std::cos(step_angle + nominal) ? 1.0 : -1.0;

  // 2. Markers: a pixel of image k far above its band-limited image while no other image is.
  const double sigma = noise.sigma_dn;
  const int marker_images = std::min(3, n);
  cv::Mat marker_mask = cv::Mat::zeros(size, CV_8U);
  std::vector<FoundMarker> markers;
  {
    std::vector<cv::Mat> residual(marker_images);
    for (int k = 0; k < marker_images; ++k) residual[k] = f[k] - fourier[k].band_limited;
    for (int k = 0; k < marker_images; ++k) {
      cv::Mat cand = cv::Mat::zeros(size, CV_8U);
      tbb::parallel_for(tbb::blocked_range<int>(0, h, 16), [&](const auto& range) {
        for (int y = range.begin(); y < range.end(); ++y) {
          const cv::Vec2f* z0 = fourier[0].analytic.ptr<cv::Vec2f>(y);
          const float* rk = residual[k].ptr<float>(y);
          uint8_t* c = cand.ptr<uint8_t>(y);
          for (int x = 0; x < w; ++x) {
            const double b = 2.0 * std::hypot(z0[x][0], z0[x][1]);
            double other = -std::numeric_limits<double>::infinity();
            for (int j = 0; j < marker_images; ++j) {
              if (j != k)
                other = std::max(other, static_cast<double>(residual[j].ptr<float>(y)[x]));
            }
            c[x] = rk[x] > std::max(0.8 * b, 6.0 * sigma) && rk[x] - other > 0.5 * b ? 255 : 0;
          }
        }
      });
      // Every candidate pixel is rejected (a marker breaks the least squares there); markers are
      // only taken away from the image's border, where the band-limited image rings (the fringe
      // is cut) and mimics them.
      marker_mask |= cand;
      const cv::Rect inside(kMarkerBorderPx, kMarkerBorderPx, w - 2 * kMarkerBorderPx,
                            h - 2 * kMarkerBorderPx);
      if (inside.width <= 0 || inside.height <= 0) continue;
      cv::Mat inner = cv::Mat::zeros(size, CV_8U);
      cand(inside).copyTo(inner(inside));
      cv::Mat labels, stats, centroids;
      const int count =
          cv::connectedComponentsWithStats(inner, labels, stats, centroids, 8, CV_32S);
      for (int c = 1; c < count; ++c) {
        // A marker is a small plus: a larger or elongated blob is a highlight or an edge.
        const int area = stats.at<int>(c, cv::CC_STAT_AREA);
        if (area > kMaxMarkerPixels || stats.at<int>(c, cv::CC_STAT_WIDTH) > kMaxMarkerSidePx ||
            stats.at<int>(c, cv::CC_STAT_HEIGHT) > kMaxMarkerSidePx) {
          continue;
        }
        FoundMarker fm;
        fm.image = first + k;
        fm.centre = {centroids.at<double>(c, 0), centroids.at<double>(c, 1)};
        fm.pixels = area;
        markers.push_back(fm);
      }
    }
    cv::dilate(marker_mask, marker_mask, cv::Mat::ones(3, 3, CV_8U));
  }

  // 3. Wrapped phase, background and modulation per pixel; reasons.
  for (cv::Mat* m : {&result->absolute_phase, &result->wrapped_phase, &result->modulation,
                     &result->background}) {
    m->create(size, CV_32F);
  }
  result->mask.create(size, CV_8U);
  result->reason.create(size, CV_8U);
  result->exposure.release();
  result->repaired_px.clear();
  cv::Mat cycles(size, CV_32F);
  const cv::Mat coeffs = DemodulationMatrix(set);  // 3 x n
  const float saturation =
      static_cast<float>(options.saturation_dn > 0 ? options.saturation_dn : full);
  const double min_background = options.min_background_fraction * full;
  const double ratio = options.min_modulation_ratio;
  const PhaseRetrieval method = scheme.phase_retrieval;
  tbb::parallel_for(tbb::blocked_range<int>(0, h, 8), [&](const auto& range) {
    std::vector<const float*> rows(n);
    std::vector<const cv::Vec2f*> z(n);
    for (int y = range.begin(); y < range.end(); ++y) {
      for (int k = 0; k < n; ++k) {
        rows[k] = f[k].ptr<float>(y);
        z[k] = fourier[k].analytic.ptr<cv::Vec2f>(y);
      }
      const float* band0 = fourier[0].band_limited.ptr<float>(y);
      const uint8_t* mk = marker_mask.ptr<uint8_t>(y);
      float* out_wrapped = result->wrapped_phase.ptr<float>(y);
      float* out_b = result->modulation.ptr<float>(y);
      float* out_a = result->background.ptr<float>(y);
      float* out_c = cycles.ptr<float>(y);
      uint8_t* reason = result->reason.ptr<uint8_t>(y);
      for (int x = 0; x < w; ++x) {
        double a = 0, c = 0, s = 0;  // A, B cos(phi), B sin(phi)
        float maxi = 0;
        for (int k = 0; k < n; ++k) maxi = std::max(maxi, rows[k][x]);
        if (method == PhaseRetrieval::kFtp) {
          const double re = z[0][x][0], im = z[0][x][1];
          const double phi = sign * std::atan2(im, re) - shifts[0];
          const double b = 2.0 * std::hypot(re, im);
          c = b * std::cos(phi);
          s = b * std::sin(phi);
          a = band0[x] - 2.0 * re;
        } else if (method == PhaseRetrieval::kFaps) {
          // Each image's shift from the analytic signals, near the nominal shift; then the least
          // squares with those shifts (normal equations of the rows [1, cos d, -sin d]).
          const double arg0 = std::atan2(z[0][x][1], z[0][x][0]);
          cv::Matx33d mtm = cv::Matx33d::zeros();
          cv::Vec3d mti(0, 0, 0);
          for (int k = 0; k < n; ++k) {
            double d = shifts[0];
            if (k > 0) {
              const double argk = std::atan2(z[k][x][1], z[k][x][0]);
              const double nominal_k = shifts[k] - shifts[0];
              d = shifts[0] + nominal_k +
                  kTwoPi * WrapHalf((sign * (argk - arg0) - nominal_k) / kTwoPi);
            }
            const cv::Vec3d r(1.0, std::cos(d), -std::sin(d));
            mtm += r * r.t();
            mti += r * static_cast<double>(rows[k][x]);
          }
          cv::Vec3d sol;
          if (cv::determinant(mtm) > 1e-6) {
            sol = mtm.solve(mti, cv::DECOMP_LU);
          } else {
            sol = cv::Vec3d(0, 0, 0);  // degenerate shifts: rejected as low modulation below
          }
          a = sol[0];
          c = sol[1];
          s = sol[2];
        } else {
          for (int k = 0; k < n; ++k) {
            a += coeffs.at<double>(0, k) * rows[k][x];
            c += coeffs.at<double>(1, k) * rows[k][x];
            s += coeffs.at<double>(2, k) * rows[k][x];
          }
        }
        const double b2 = c * c + s * s;
        const double psi = std::atan2(s, c);  // Phi + offset
        out_wrapped[x] = static_cast<float>(psi);
        out_b[x] = static_cast<float>(std::sqrt(b2));
        out_a[x] = static_cast<float>(a);
        double cyc = (psi - offset) / kTwoPi;
        cyc -= std::floor(cyc);
        out_c[x] = static_cast<float>(cyc >= 1.0 ? 0.0 : cyc);
        PixelReason r = PixelReason::kValid;
        if (maxi >= saturation) {
          r = PixelReason::kSaturated;
        } else if (a < min_background) {
          r = PixelReason::kUnderexposed;
        } else if (b2 < b_min * b_min) {
          r = PixelReason::kLowModulation;
        } else if (b2 < ratio * ratio * a * a) {
          r = PixelReason::kShadow;
        } else if (mk[x]) {
          r = PixelReason::kSpatial;  // a marker's pixels: no image model holds there
        }
        reason[x] = Code(r);
      }
    }
  });

  // 4. Quality-guided unwrapping over the valid pixels.
  cv::Mat valid = result->reason == Code(PixelReason::kValid);
  cv::Mat unwrapped, labels;
  const int regions = UnwrapQualityGuided(cycles, result->modulation, valid,
                                          options.max_order_residual, &unwrapped, &labels);

  // 5. Each region's whole number of periods from its markers.
  const int span = scheme.Span();
  const int layout_period = scheme.markers.Period(span);
  const int group = scheme.markers.Group();
  std::vector<int> region_size(regions, 0);
  std::vector<float> region_min(regions, std::numeric_limits<float>::infinity());
  std::vector<float> region_max(regions, -std::numeric_limits<float>::infinity());
  for (int y = 0; y < h; ++y) {
    const int32_t* lab = labels.ptr<int32_t>(y);
    const float* uw = unwrapped.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      if (lab[x] < 0) continue;
      ++region_size[lab[x]];
      region_min[lab[x]] = std::min(region_min[lab[x]], uw[x]);
      region_max[lab[x]] = std::max(region_max[lab[x]], uw[x]);
    }
  }
  // Per region: each marker's interval [T, T + group - 1] of possible K.
  std::vector<std::vector<int>> region_t(regions);
  int markers_inconsistent = 0;
  for (const FoundMarker& fm : markers) {
    const int cx = static_cast<int>(std::lround(fm.centre.x));
    const int cy = static_cast<int>(std::lround(fm.centre.y));
    std::map<int, std::pair<double, int>> sums;  // region -> (sum, count)
    for (int y = std::max(0, cy - 4); y <= std::min(h - 1, cy + 4); ++y) {
      for (int x = std::max(0, cx - 4); x <= std::min(w - 1, cx + 4); ++x) {
        const int l = labels.at<int32_t>(y, x);
        if (l < 0) continue;
        auto& e = sums[l];
        e.first += unwrapped.at<float>(y, x);
        ++e.second;
      }
    }
    int best = -1, best_count = 0;
    for (const auto& [l, e] : sums) {
      if (e.second > best_count) best = l, best_count = e.second;
    }
    if (best < 0 || best_count < 8) continue;
    const double c_rel = sums[best].first / best_count;
    const int i = fm.image - first;
    const int c0 = 3 * layout_period / 4 + i * layout_period * group - i * layout_period / 3;
    const double t = (c0 + 0.5) / period - c_rel;
    if (std::abs(t - std::round(t)) > 0.25) {
      ++markers_inconsistent;  // not where a marker of that image can be: a false detection
      continue;
    }
    region_t[best].push_back(static_cast<int>(std::lround(t)));
  }
  std::vector<int> region_k(regions, std::numeric_limits<int>::min());
  int anchored = 0, ambiguous = 0, small = 0;
  for (int r = 0; r < regions; ++r) {
    if (region_size[r] < kMinRegionPixels) {
      ++small;
      continue;
    }
    const auto& ts = region_t[r];
    std::map<int, int> votes;
    for (const int t : ts) {
      for (int j = 0; j < group; ++j) ++votes[t + j];
    }
    int max_votes = 0;
    for (const auto& [k, v] : votes) max_votes = std::max(max_votes, v);
    std::vector<int> candidates;
    if (max_votes >= 3 && max_votes >= 0.75 * static_cast<double>(ts.size())) {
      for (const auto& [k, v] : votes) {
        if (v != max_votes) continue;
        // The region must lie on the projector (half a period of slack for noise).
        const double lo = (region_min[r] + k) * period - 0.5;
        const double hi = (region_max[r] + k) * period - 0.5;
        if (lo >= -0.5 * period && hi <= span - 0.5 + 0.5 * period) candidates.push_back(k);
      }
    }
    if (candidates.size() == 1) {
      region_k[r] = candidates[0];
      ++anchored;
    } else {
      ++ambiguous;
    }
  }

  // Outputs.
  std::array<int64_t, 7> counts{};
  for (int y = 0; y < h; ++y) {
    const int32_t* lab = labels.ptr<int32_t>(y);
    const float* uw = unwrapped.ptr<float>(y);
    uint8_t* reason = result->reason.ptr<uint8_t>(y);
    uint8_t* mask = result->mask.ptr<uint8_t>(y);
    float* abs = result->absolute_phase.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      abs[x] = std::numeric_limits<float>::quiet_NaN();
      mask[x] = 0;
      if (reason[x] == Code(PixelReason::kValid)) {
        const int l = lab[x];
        if (l < 0 || region_size[l] < kMinRegionPixels) {
          reason[x] = Code(PixelReason::kSpatial);
        } else if (region_k[l] == std::numeric_limits<int>::min()) {
          reason[x] = Code(PixelReason::kOrderAmbiguous);
        } else {
          abs[x] = static_cast<float>((uw[x] + region_k[l]) * period - 0.5);
          mask[x] = 255;
        }
      }
      ++counts[reason[x]];
    }
  }
  DecodeSummary& sum = result->summary;
  sum = DecodeSummary();
  sum.pixels = static_cast<int64_t>(size.area());
  sum.valid = counts[0];
  sum.rejected_saturated = counts[1];
  sum.rejected_underexposed = counts[2];
  sum.rejected_low_modulation = counts[3];
  sum.rejected_shadow = counts[4];
  sum.rejected_order_ambiguous = counts[5];
  sum.rejected_spatial = counts[6];
  sum.min_modulation_dn = b_min;
  sum.threshold_bounded = bounded;
  sum.full_scale_dn = full;
  sum.noise = noise;
  if (sum.valid == 0) sum.status = DecodeStatus::kNoValidPixels;
  sum.message = StrCat(PhaseRetrievalName(method), " phase, spatial unwrapping: ", markers.size(),
                       " markers found (", markers_inconsistent, " off their phase), ", anchored,
                       " of ", regions - small, " regions anchored by them");
  if (ambiguous > 0) {
    sum.message += StrCat("; ", ambiguous,
                          " regions without markers that fix their period (rejected as ambiguous "
                          "orders)");
  }
  if (found_markers) *found_markers = markers;
}

}  // namespace fringe::phase
