#include "fringe/stereo/phase_matching.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "fringe/util/error.h"
#include "fringe/util/timer.h"

namespace fringe::stereo {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A monotonic stretch [begin, end] (end > begin) of valid samples in a rectified row without a
// discontinuity between neighbouring samples. Noise may move the phase against the run's
// direction without ending the run; the search then uses the run's monotone envelope (running
// max of an increasing run, running min of a decreasing one) and finds the FIRST crossing, so a
// noisy wiggle never produces a second candidate.
struct Run {
  int begin = 0;
  int end = 0;
  bool increasing = true;
  // row[begin] and env[end], kept here so the per-pixel scan over a row's runs reads one
  // contiguous array instead of two scattered samples per run.
  float first = 0;
  float last = 0;
  // No other run of the row has a phase range sharing a value with this one's (closed ranges,
  // so conservative): a phi inside this run has exactly one crossing in the row.
  bool isolated = false;
};

using RowRuns = std::vector<std::vector<Run>>;

// Samples per block of the local phase gradient; the gradient of a block is the median |step|
// over the block and one block on each side (48 steps), so a discontinuity or a few noisy steps
// do not move it.
constexpr int kGradientBlock = 16;
// Blocks with fewer valid steps than this use the row's median; the local gradient is never
// taken below kGradientFloor times the row's median (a turning point has a true gradient of 0,
// and noise there must not split the run into many pieces).
constexpr int kMinGradientSteps = 4;
constexpr float kGradientFloor = 0.25f;

// Sorts a[0..kGradientBlock) ascending: a bitonic network of min / max (no branches; the loops
// have constant bounds and unroll). +inf pads the missing steps of a block to the end.
void SortBlock(float* a) {
  static_assert(kGradientBlock == 16, "the network is written for 16 samples");
  for (int k = 2; k <= kGradientBlock; k *= 2) {
    for (int j = k / 2; j > 0; j /= 2) {
      for (int i = 0; i < kGradientBlock; ++i) {
        const int l = i ^ j;
        if (l <= i) continue;
        const float lo = std::min(a[i], a[l]), hi = std::max(a[i], a[l]);
        const bool up = (i & k) == 0;
        a[i] = up ? lo : hi;
        a[l] = up ? hi : lo;
      }
    }
  }
}

// The element of rank k (0-based) of the union of the sorted x[0..nx) and y[0..ny), k < nx + ny:
// a binary search for the number i of elements taken from x (x[i - 1] <= y[k - i + 1] ...),
// O(log) instead of walking the merge. Only the value is returned, which does not depend on how
// ties are split.
float RankOfTwo(const float* x, int nx, const float* y, int ny, int k) {
  // i elements from x and k + 1 - i from y make the first k + 1 of the merge when
  // x[i - 1] <= y[k + 1 - i] and y[k - i] <= x[i] (absent elements: -inf before, +inf after).
  int lo = std::max(0, k + 1 - ny), hi = std::min(k + 1, nx);
  // The smallest i in [lo, hi] with i == nx or x[i] >= y[k - i] (too many from x beyond it).
  while (lo < hi) {
    const int i = (lo + hi) / 2;
    if (x[i] < y[k - i]) {
      lo = i + 1;
    } else {
      hi = i;
    }
  }
  const int i = lo;
  const float from_x = i > 0 ? x[i - 1] : -std::numeric_limits<float>::infinity();
  const float from_y = k - i >= 0 ? y[k - i] : -std::numeric_limits<float>::infinity();
  return std::max(from_x, from_y);
}

// The local phase gradient (projector pixels per rectified pixel) at every step u -> u + 1 of a
// row: the median |step| around it. It includes the noise of the steps, which is what the
// matcher's step and reversal thresholds must stay above. Multiplying the phase by a power of
// two multiplies it exactly by the same factor, so thresholds in its units do not depend on the
// phase scale.
void LocalGradient(const float* row, int cols, std::vector<float>* gradient,
                   std::vector<float>* scratch) {
  gradient->assign(std::max(cols - 1, 0), 0.0f);
  if (cols < 2) return;
  const int num_steps = cols - 1;
  const int num_blocks = (num_steps + kGradientBlock - 1) / kGradientBlock;
  // The finite |steps| of every block, each block sorted (block b at [b * kGradientBlock,
  // + count[b]), +inf after), then the row's steps for the row median. A window's median is the
  // element size / 2 of the merge of its three sorted blocks: the value nth_element on the
  // window gives, at a fraction of the cost (each block is sorted once, not once per window it
  // is part of). Then the 2 * kGradientBlock slots of the merge of two blocks.
  std::vector<float>& buf = *scratch;
  buf.resize(static_cast<size_t>(num_blocks) * kGradientBlock + num_steps + 2 * kGradientBlock);
  float* sorted = buf.data();
  float* all = sorted + static_cast<size_t>(num_blocks) * kGradientBlock;
  float* pair = all + num_steps;
  static thread_local std::vector<int> block_counts;
  block_counts.resize(num_blocks);
  int* counts = block_counts.data();
  int num_all = 0;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  for (int b = 0; b < num_blocks; ++b) {
    float* block = sorted + static_cast<size_t>(b) * kGradientBlock;
    int n = 0;
    const int begin = b * kGradientBlock;
    const int end = std::min(num_steps, begin + kGradientBlock);
    for (int u = begin; u < begin + kGradientBlock; ++u) {
      const float d = u < end ? row[u + 1] - row[u] : kInf;
      const bool finite = std::isfinite(d);
      const float a = std::abs(d);
      all[num_all] = a;
      num_all += finite;
      n += finite;
      block[u - begin] = finite ? a : kInf;
    }
    SortBlock(block);
    counts[b] = n;
  }
  const float row_median =
      num_all > 0 ? (std::nth_element(all, all + num_all / 2, all + num_all), all[num_all / 2])
                  : 0.0f;
  const float floor = kGradientFloor * row_median;
  for (int b = 0; b < num_blocks; ++b) {
    // The window: blocks b - 1, b, b + 1 (those that exist); the two upper ones merged.
    const float* mid = sorted + static_cast<size_t>(b) * kGradientBlock;
    const int n_mid = counts[b];
    const float* x = mid;
    int nx = n_mid;
    if (b + 1 < num_blocks) {
      const float* up = mid + kGradientBlock;
      const int n_up = counts[b + 1];
      // Branch-free merge of the finite parts (the +inf after each block bounds the indices).
      int i = 0, j = 0;
      for (int t = 0; t < n_mid + n_up; ++t) {
        const float p = mid[std::min(i, kGradientBlock - 1)];
        const float q = up[std::min(j, kGradientBlock - 1)];
        const bool take_mid = i < n_mid && (j >= n_up || p <= q);
        pair[t] = take_mid ? p : q;
        i += take_mid;
        j += !take_mid;
      }
      x = pair;
      nx = n_mid + n_up;
    }
    const float* y = b > 0 ? mid - kGradientBlock : nullptr;
    const int ny = b > 0 ? counts[b - 1] : 0;
    const int size = nx + ny;
    float g = row_median;
    if (size >= kMinGradientSteps) g = ny > 0 ? RankOfTwo(x, nx, y, ny, size / 2) : x[size / 2];
    const int end = std::min(num_steps, (b + 1) * kGradientBlock);
    for (int u = b * kGradientBlock; u < end; ++u) (*gradient)[u] = std::max(g, floor);
  }
}

// Sets Run::isolated: the runs sorted by the low end of their phase range; a run is isolated when
// it starts above every earlier run's high end and the next run starts above its own.
void MarkIsolated(std::vector<Run>* runs, std::vector<int>* order) {
  auto lo = [&](int k) { return std::min((*runs)[k].first, (*runs)[k].last); };
  auto hi = [&](int k) { return std::max((*runs)[k].first, (*runs)[k].last); };
  const int n = static_cast<int>(runs->size());
  order->resize(n);
  for (int k = 0; k < n; ++k) (*order)[k] = k;
  std::sort(order->begin(), order->end(), [&](int a, int b) { return lo(a) < lo(b); });
  float max_hi = -std::numeric_limits<float>::infinity();
  for (int t = 0; t < n; ++t) {
    const int k = (*order)[t];
    (*runs)[k].isolated = lo(k) > max_hi && (t + 1 == n || lo((*order)[t + 1]) > hi(k));
    max_hi = std::max(max_hi, hi(k));
  }
}

// Runs per row, and the envelope image (same size as rect_phase). A step larger than
// max_step_gradients local gradients ends a run (a discontinuity). The direction of a run is
// that of its first net change larger than max_reversal_gradients local gradients, and the run
// turns when the phase has retreated from the run's extreme by more than that: judged against
// the envelope, not one step, so that a run whose first step is a small noise step against the
// trend still follows the trend (phase advancing by a fraction of a projector pixel per camera
// pixel, with noise of the same size, is common with fine cameras or coarse projectors).
RowRuns FindRuns(const cv::Mat& rect_phase, double max_step_gradients,
                 double max_reversal_gradients, cv::Mat* envelope) {
  RowRuns runs(rect_phase.rows);
  *envelope = rect_phase.clone();
  const float step_ratio = static_cast<float>(max_step_gradients);
  const float reversal_ratio = static_cast<float>(max_reversal_gradients);
  tbb::parallel_for(tbb::blocked_range<int>(0, rect_phase.rows), [&](const auto& range) {
    std::vector<float> gradient, scratch;
    std::vector<int> order;
    for (int v = range.begin(); v < range.end(); ++v) {
      const float* row = rect_phase.ptr<float>(v);
      float* env = envelope->ptr<float>(v);
      auto& out = runs[v];
      const int cols = rect_phase.cols;
      LocalGradient(row, cols, &gradient, &scratch);
      int begin = -1;
      int dir = 0;         // 0: not decided yet
      int lo = 0, hi = 0;  // undecided: samples of the lowest / highest phase since begin
      int extreme = 0;     // decided: sample of the run's extreme so far
      auto push = [&](int b, int e, int d) {
        env[b] = row[b];
        for (int u = b + 1; u <= e; ++u) {
          env[u] = d > 0 ? std::max(env[u - 1], row[u]) : std::min(env[u - 1], row[u]);
        }
        out.push_back({b, e, d > 0});
      };
      auto close = [&](int end) {
        if (begin < 0 || end <= begin) return;
        if (dir != 0) {
          push(begin, end, dir);
        } else if (row[hi] != row[lo]) {
          // A short stretch whose net change stayed below the reversal threshold: its extremes
          // give the direction.
          push(std::min(lo, hi), std::max(lo, hi), hi > lo ? 1 : -1);
        }
      };
      for (int u = 0; u + 1 < cols; ++u) {
        const float a = row[u], b = row[u + 1];
        const float step = b - a;
        const float g = gradient[u];
        const bool ok = std::isfinite(a) && std::isfinite(b) && std::abs(step) <= step_ratio * g;
        if (!ok) {
          close(u);
          begin = -1;
          continue;
        }
        const float reversal = reversal_ratio * g;
        const int next = u + 1;
        if (begin < 0) {
          begin = u;
          dir = 0;
          lo = hi = u;
        }
        if (dir == 0) {
          if (b > row[hi]) hi = next;
          if (b < row[lo]) lo = next;
          if (row[hi] - row[lo] > reversal) {
            dir = hi > lo ? 1 : -1;
            begin = std::min(lo, hi);
            extreme = std::max(lo, hi);
          }
          continue;
        }
        if (dir * (b - row[extreme]) > 0) {
          extreme = next;
        } else if (dir * (row[extreme] - b) > reversal) {
          // Turning point at the extreme: the run ends there and a new one, in the other
          // direction, starts at the same sample.
          close(extreme);
          begin = extreme;
          dir = -dir;
          int e = begin + 1;
          for (int k = begin + 2; k <= next; ++k) {
            if (dir * (row[k] - row[e]) > 0) e = k;
          }
          extreme = e;
        }
      }
      close(cols - 1);
      // After all runs are closed: a run starting at the previous run's turning point resets
      // that envelope sample to the row's value, and the crossing search uses the final one.
      for (Run& run : out) {
        run.first = row[run.begin];
        run.last = env[run.end];
      }
      MarkIsolated(&out, &order);
    }
  });
  return runs;
}

// Position u where the row's phase first equals phi in one run (the caller checked that phi
// lies within the run's envelope range).
double CrossingInRun(const float* row, const float* env, const Run& run, double phi,
                     CrossingInterpolation interp, int* hint) {
  int lo = run.begin, hi = run.end;  // invariant: env[lo] "below" phi, env[hi] not below
  auto below = [&](int u) { return run.increasing ? env[u] < phi : env[u] > phi; };
  // The envelope is monotone, so "below" flips exactly once in (begin, end]: any bracketing
  // finds the same sample. Neighbouring pixels cross close to each other, so gallop out from
  // the previous crossing (*hint) before halving; this saves most of the dependent loads.
  const int h = *hint;
  if (h > lo && h < hi) {
    if (below(h)) {
      lo = h;
      int step = 1;
      while (lo + step < hi && below(lo + step)) {
        lo += step;
        step *= 2;
      }
      if (lo + step < hi) hi = lo + step;
    } else {
      hi = h;
      int step = 1;
      while (hi - step > lo && !below(hi - step)) {
        hi -= step;
        step *= 2;
      }
      if (hi - step > lo) lo = hi - step;
    }
  }
  while (hi - lo > 1) {
    const int mid = (lo + hi) / 2;
    (below(mid) ? lo : hi) = mid;
  }
  *hint = hi;
  // env[hi] == row[hi] (a new extreme) and row[lo] <= env[lo]: phi is bracketed by the samples.
  lo = hi - 1;
  const double p0 = row[lo], p1 = row[lo + 1];
  double t = (phi - p0) / (p1 - p0);
  if (interp == CrossingInterpolation::kCubic && lo - 1 >= run.begin && lo + 2 <= run.end) {
    // Lagrange cubic through samples lo-1 .. lo+2 at t = -1, 0, 1, 2; Newton from the linear t.
    const double pm = row[lo - 1], p2 = row[lo + 2];
    const double c0 = p0;
    const double c1 = -pm / 3 - p0 / 2 + p1 - p2 / 6;
    const double c2 = pm / 2 - p0 + p1 / 2;
    const double c3 = -pm / 6 + p0 / 2 - p1 / 2 + p2 / 6;
    for (int it = 0; it < 4; ++it) {
      const double f = c0 + t * (c1 + t * (c2 + t * c3)) - phi;
      const double df = c1 + t * (2 * c2 + t * 3 * c3);
      if (df == 0) break;
      t -= f / df;
    }
    t = std::clamp(t, 0.0, 1.0);
  }
  return lo + t;
}

// Number of crossings of phi in rectified row v (0, 1 or 2 meaning "several"); *u set when 1.
struct RectifiedPhase {
  cv::Mat phase;
  cv::Mat envelope;
  RowRuns runs;
};

// *run_hint: the run of the caller's last single crossing (any value): when that run is isolated
// and holds phi, it is the only one and the scan over the row's runs is skipped.
int FindCrossing(const RectifiedPhase& rp, int v, double phi, CrossingInterpolation interp,
                 double* u, int* hint, int* run_hint) {
  if (v < 0 || v >= rp.phase.rows) return 0;
  const float* row = rp.phase.ptr<float>(v);
  const float* env = rp.envelope.ptr<float>(v);
  const std::vector<Run>& runs = rp.runs[v];
  // Strict at the start so that a run beginning exactly at the previous run's turning point
  // does not count that crossing twice.
  auto holds = [phi](const Run& run) {
    const double a = run.first, b = run.last;
    return !(run.increasing ? (phi <= a || phi > b) : (phi >= a || phi < b));
  };
  const int h = *run_hint;
  if (h >= 0 && h < static_cast<int>(runs.size()) && runs[h].isolated && holds(runs[h])) {
    *u = CrossingInRun(row, env, runs[h], phi, interp, hint);
    return 1;
  }
  int count = 0;
  for (size_t k = 0; k < runs.size(); ++k) {
    if (!holds(runs[k])) continue;
    if (++count > 1) return 2;
    *u = CrossingInRun(row, env, runs[k], phi, interp, hint);
    *run_hint = static_cast<int>(k);
  }
  return count;
}

enum class RowMatch { kOk, kNone, kAmbiguous, kDiscontinuity };

// Crossing at fractional rectified row v: from rows floor(v) and floor(v)+1, interpolated.
// hints: the caller's last crossing positions in the two rows (search start only; any value),
// then the runs of those crossings (FindCrossing's run_hint).
RowMatch MatchAtRow(const RectifiedPhase& rp, double v, double phi, const MatchingOptions& options,
                    double* u, int* hints) {
  constexpr double kOnRow = 1e-3;  // closer than this to a row: that row alone decides
  const int v0 = static_cast<int>(std::floor(v));
  const double w = v - v0;
  double u0 = 0, u1 = 0;
  int n0 = 1, n1 = 1;
  if (w < 1 - kOnRow)
    n0 = FindCrossing(rp, v0, phi, options.interpolation, &u0, &hints[0], &hints[2]);
  if (w > kOnRow)
    n1 = FindCrossing(rp, v0 + 1, phi, options.interpolation, &u1, &hints[1], &hints[3]);
  if (n0 == 0 || n1 == 0) return RowMatch::kNone;
  if (n0 > 1 || n1 > 1) return RowMatch::kAmbiguous;
  if (w <= kOnRow) {
    *u = u0;
  } else if (w >= 1 - kOnRow) {
    *u = u1;
  } else {
    if (std::abs(u0 - u1) > options.max_row_crossing_diff_px) return RowMatch::kDiscontinuity;
    *u = (1 - w) * u0 + w * u1;
  }
  return RowMatch::kOk;
}

cv::Mat ValidPhase(const PhaseImage& img, const CameraModel& cam, const char* side) {
  auto fail = [&](const std::string& what) {
    throw Error(util::StrCat("phase matching: ", side, " ", what, " must be ", cam.width, "x",
                             cam.height, " (the rig's camera size)"));
  };
  if (img.phase.type() != CV_32FC1 || img.phase.cols != cam.width || img.phase.rows != cam.height) {
    fail("phase (CV_32F)");
  }
  if (!img.mask.empty() && (img.mask.type() != CV_8UC1 || img.mask.size() != img.phase.size())) {
    fail("mask (CV_8U)");
  }
  if (!img.modulation.empty() &&
      (img.modulation.type() != CV_32FC1 || img.modulation.size() != img.phase.size())) {
    fail("modulation (CV_32F)");
  }
  if (!img.texture.empty() && img.texture.size() != img.phase.size()) fail("texture");
  cv::Mat phase = img.phase.clone();
  if (!img.mask.empty()) phase.setTo(kNaN, img.mask == 0);
  return phase;
}

}  // namespace

void MatchingOptions::Check() const {
  using util::CheckOption;
  const char* kName = "MatchingOptions";
  CheckOption(min_modulation >= 0, kName, "min_modulation", min_modulation, "must be >= 0");
  CheckOption(max_step_gradients > 0 && std::isfinite(max_step_gradients), kName,
              "max_step_gradients", max_step_gradients, "must be > 0");
  CheckOption(max_reversal_gradients >= 0 && max_reversal_gradients < max_step_gradients, kName,
              "max_reversal_gradients", max_reversal_gradients,
              "must be in [0, max_step_gradients)");
  CheckOption(lr_warning_fraction >= 0 && lr_warning_fraction <= 1, kName, "lr_warning_fraction",
              lr_warning_fraction, "must be in [0, 1]");
  CheckOption(max_row_crossing_diff_px > 0, kName, "max_row_crossing_diff_px",
              max_row_crossing_diff_px, "must be > 0");
  CheckOption(max_lr_error_px > 0, kName, "max_lr_error_px", max_lr_error_px, "must be > 0");
  CheckOption(max_reprojection_error_px > 0, kName, "max_reprojection_error_px",
              max_reprojection_error_px, "must be > 0");
  CheckOption(max_projector_error_px >= 0, kName, "max_projector_error_px", max_projector_error_px,
              "must be >= 0 (0 = off)");
  CheckOption(min_depth_mm >= 0 && min_depth_mm < max_depth_mm, kName, "min_depth_mm", min_depth_mm,
              "must be >= 0 and < max_depth_mm");
  triangulation.Check();
  rectification.Check();
}

const char* ToString(MatchingStatus status) {
  switch (status) {
    case MatchingStatus::kOk:
      return "ok";
    case MatchingStatus::kNoValidPixels:
      return "no valid pixels";
    case MatchingStatus::kNoPoints:
      return "no points";
  }
  return "unknown";
}

std::string MatchingSummary::BriefReport() const {
  return util::StrCat(
      "matching: ", ToString(status), ok() ? "" : " (" + message + ")", ", ", points,
      " points from ", left_valid, " valid left pixels (no crossing ", no_crossing, ", ambiguous ",
      ambiguous, ", discontinuity ", discontinuity, ", left-right ", lr_inconsistent,
      ", triangulation ", triangulation_failed, ", residual ", large_residual, ", projector ",
      projector_inconsistent, ", depth range ", out_of_depth_range, "), mean reprojection error ",
      mean_reprojection_error_px, " px, ", time_s, " s",
      projector_filled > 0
          ? util::StrCat("; ", projector_filled, " added from the left camera + projector")
          : std::string(),
      warning.empty() ? "" : "; warning: ", warning);
}

PhaseMatcher::PhaseMatcher(const StereoRig& rig, const MatchingOptions& options)
    : rig_(rig),
      options_(options),
      rect_((options.Check(), rig), options.rectification),
      triangulator_(rig_, options_.triangulation) {
  const CameraModel& cam = rig_.left;
  left_rect_px_.create(cam.height, cam.width, CV_32FC2);
  left_rays_.create(cam.height, cam.width, CV_32FC3);
  tbb::parallel_for(tbb::blocked_range<int>(0, cam.height), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      auto* rect = left_rect_px_.ptr<cv::Vec2f>(r);
      auto* ray = left_rays_.ptr<cv::Vec3f>(r);
      for (int c = 0; c < cam.width; ++c) {
        const Eigen::Vector2d xy = cam.Unproject(Eigen::Vector2d(c, r));
        const Eigen::Vector3d d = Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
        ray[c] = cv::Vec3f(d.x(), d.y(), d.z());
        const Eigen::Vector3d dr = rect_.rect_from_left() * d;
        rect[c] = cv::Vec2f(rect_.focal_px() * dr.x() / dr.z() + rect_.cx(Side::kLeft),
                            rect_.focal_px() * dr.y() / dr.z() + rect_.cy());
      }
    }
  });
}

MatchResult PhaseMatcher::Match(const PhaseImage& left, const PhaseImage& right) const {
  util::Timer timer;
  const cv::Mat phase_left = ValidPhase(left, rig_.left, "left");
  const cv::Mat phase_right = ValidPhase(right, rig_.right, "right");
  RectifiedPhase rect_left, rect_right;
  rect_left.phase = rect_.RectifyFloat(Side::kLeft, phase_left);
  rect_right.phase = rect_.RectifyFloat(Side::kRight, phase_right);
  rect_left.runs = FindRuns(rect_left.phase, options_.max_step_gradients,
                            options_.max_reversal_gradients, &rect_left.envelope);
  rect_right.runs = FindRuns(rect_right.phase, options_.max_step_gradients,
                             options_.max_reversal_gradients, &rect_right.envelope);
  cv::Mat texture;
  if (left.texture.type() == CV_32FC1) {
    texture = left.texture;  // read only: shared, not copied
  } else if (!left.texture.empty()) {
    left.texture.convertTo(texture, CV_32F);
  }

  const int w = rig_.left.width, h = rig_.left.height;
  MatchResult result;
  result.cloud = OrganizedPointCloud(w, h, false, !texture.empty(), !left.modulation.empty());
  result.right_px = cv::Mat(h, w, CV_32FC2, cv::Scalar::all(kNaN));
  result.reprojection_error_px = cv::Mat(h, w, CV_32FC1, cv::Scalar::all(kNaN));
  const bool check_projector = rig_.projector.has_value() && options_.max_projector_error_px > 0;
  std::vector<MatchingSummary> row_summary(h);
  std::vector<double> row_error_sum(h, 0.0);

  tbb::parallel_for(tbb::blocked_range<int>(0, h), [&](const auto& rows) {
    for (int r = rows.begin(); r < rows.end(); ++r) {
      MatchingSummary& s = row_summary[r];
      const float* phi_row = phase_left.ptr<float>(r);
      const float* mod_row = left.modulation.empty() ? nullptr : left.modulation.ptr<float>(r);
      const auto* rect_px = left_rect_px_.ptr<cv::Vec2f>(r);
      const auto* rays = left_rays_.ptr<cv::Vec3f>(r);
      auto* right_px_row = result.right_px.ptr<cv::Vec2f>(r);
      float* err_row = result.reprojection_error_px.ptr<float>(r);
      int right_hints[4] = {-1, -1, -1, -1}, left_hints[4] = {-1, -1, -1, -1};
      for (int c = 0; c < w; ++c) {
        const double phi = phi_row[c];
        if (!std::isfinite(phi)) continue;
        if (mod_row && mod_row[c] < options_.min_modulation) continue;
        ++s.left_valid;
        const double ul = rect_px[c][0], vl = rect_px[c][1];
        double ur = 0;
        switch (MatchAtRow(rect_right, vl, phi, options_, &ur, right_hints)) {
          case RowMatch::kOk:
            break;
          case RowMatch::kNone:
            ++s.no_crossing;
            continue;
          case RowMatch::kAmbiguous:
            ++s.ambiguous;
            continue;
          case RowMatch::kDiscontinuity:
            ++s.discontinuity;
            continue;
        }
        double ul_back = 0;
        if (MatchAtRow(rect_left, vl, phi, options_, &ul_back, left_hints) != RowMatch::kOk ||
            std::abs(ul_back - ul) > options_.max_lr_error_px) {
          ++s.lr_inconsistent;
          continue;
        }
        // The right ray straight from the rectified position (exact, no undistortion), and
        // the distorted pixel for the residual.
        const Eigen::Vector2d xy_right =
            rect_.NormalizedFromRectified(Side::kRight, Eigen::Vector2d(ur, vl));
        const Eigen::Vector2d right_px =
            rig_.right.PixelFromNormalized(rig_.right.Distort(xy_right));
        if (!rig_.right.InImage(right_px)) {
          ++s.no_crossing;
          continue;
        }
        const Eigen::Vector3d ray(rays[c][0], rays[c][1], rays[c][2]);
        const TriangulatedPoint tp =
            triangulator_.Triangulate(ray, Eigen::Vector2d(c, r), xy_right, right_px);
        if (!tp.ok()) {
          ++s.triangulation_failed;
          continue;
        }
        if (tp.reprojection_error_px > options_.max_reprojection_error_px) {
          ++s.large_residual;
          continue;
        }
        if (check_projector) {
          const Eigen::Vector3d p_in_projector = rig_.projector_from_left * tp.p_in_left;
          if (p_in_projector.z() <= 0 || std::abs(rig_.projector->Project(p_in_projector).x() -
                                                  phi) > options_.max_projector_error_px) {
            ++s.projector_inconsistent;
            continue;
          }
        }
        if (tp.p_in_left.z() < options_.min_depth_mm || tp.p_in_left.z() > options_.max_depth_mm) {
          ++s.out_of_depth_range;
          continue;
        }
        const size_t i = result.cloud.index(c, r);
        result.cloud.valid[i] = 1;
        result.cloud.cloud.points[i] = tp.p_in_left;
        if (mod_row) result.cloud.cloud.quality[i] = mod_row[c];
        if (!texture.empty()) result.cloud.cloud.intensity[i] = texture.at<float>(r, c);
        right_px_row[c] = cv::Vec2f(right_px.x(), right_px.y());
        err_row[c] = static_cast<float>(tp.reprojection_error_px);
        row_error_sum[r] += tp.reprojection_error_px;
        ++s.points;
      }
    }
  });

  MatchingSummary& total = result.summary;
  double error_sum = 0;
  for (int r = 0; r < h; ++r) {
    const MatchingSummary& s = row_summary[r];
    total.left_valid += s.left_valid;
    total.no_crossing += s.no_crossing;
    total.ambiguous += s.ambiguous;
    total.discontinuity += s.discontinuity;
    total.lr_inconsistent += s.lr_inconsistent;
    total.triangulation_failed += s.triangulation_failed;
    total.large_residual += s.large_residual;
    total.projector_inconsistent += s.projector_inconsistent;
    total.out_of_depth_range += s.out_of_depth_range;
    total.points += s.points;
    error_sum += row_error_sum[r];
  }
  total.mean_reprojection_error_px = total.points > 0 ? error_sum / total.points : 0.0;
  if (total.left_valid == 0) {
    total.status = MatchingStatus::kNoValidPixels;
    total.message = "no left pixel has a valid absolute phase";
  } else if (total.points == 0) {
    total.status = MatchingStatus::kNoPoints;
    total.message =
        util::StrCat("none of the ", total.left_valid, " valid left pixels was matched and kept");
  }
  if (total.left_valid > 0 &&
      total.lr_inconsistent > options_.lr_warning_fraction * total.left_valid) {
    total.warning = util::StrCat(
        100.0 * total.lr_inconsistent / total.left_valid,
        " % of the valid left pixels failed the left-right check (the phase maps of the two "
        "cameras disagree: check the calibration, the scheme's phase offset and the fringe "
        "modulation)");
  }
  total.time_s = timer.ElapsedSeconds();
  return result;
}

namespace internal {

std::vector<PhaseRun> RowRuns(const std::vector<float>& row, const MatchingOptions& options) {
  options.Check();
  const cv::Mat phase(1, static_cast<int>(row.size()), CV_32FC1, const_cast<float*>(row.data()));
  cv::Mat envelope;
  const auto runs =
      FindRuns(phase, options.max_step_gradients, options.max_reversal_gradients, &envelope);
  std::vector<PhaseRun> out;
  for (const Run& r : runs[0]) out.push_back({r.begin, r.end, r.increasing});
  return out;
}

}  // namespace internal

MatchResult MatchPhase(const StereoRig& rig, const PhaseImage& left, const PhaseImage& right,
                       const MatchingOptions& options) {
  return PhaseMatcher(rig, options).Match(left, right);
}

}  // namespace fringe::stereo
