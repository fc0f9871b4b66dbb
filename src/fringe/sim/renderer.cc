#include "fringe/sim/renderer.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "fringe/util/error.h"
#include "fringe/util/random.h"

namespace fringe::sim {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A projector image prepared for sampling: linear light in [black, 1], padded by one replicated
// pixel on every side so bilinear lookups at the image's outer half pixel need no branches.
struct PreparedPattern {
  std::vector<float> data;
  int stride = 0;
};

PreparedPattern PreparePattern(const cv::Mat& pattern, const CameraModel& projector,
                               const ProjectorOptions& opt, size_t index) {
  if (pattern.channels() != 1 || (pattern.depth() != CV_8U && pattern.depth() != CV_32F)) {
    throw Error(util::StrCat("pattern ", index, ": expected CV_8UC1 (0..255) or CV_32FC1 (0..1)"));
  }
  if (pattern.cols != projector.width || pattern.rows != projector.height) {
    throw Error(util::StrCat("pattern ", index, ": size ", pattern.cols, "x", pattern.rows,
                             " differs from the projector's ", projector.width, "x",
                             projector.height));
  }
  cv::Mat f;
  if (pattern.depth() == CV_8U) {
    pattern.convertTo(f, CV_32F, 1.0 / 255.0);
  } else {
    f = pattern.clone();
  }
  const float black = static_cast<float>(opt.black_level);
  const float gamma = static_cast<float>(opt.gamma);
  for (int r = 0; r < f.rows; ++r) {
    float* p = f.ptr<float>(r);
    for (int c = 0; c < f.cols; ++c) {
      const float v = std::clamp(p[c], 0.0f, 1.0f);
      p[c] = black + (1.0f - black) * (gamma == 1.0f ? v : std::pow(v, gamma));
    }
  }
  if (opt.defocus_sigma_px > 0) {
    cv::GaussianBlur(f, f, cv::Size(0, 0), opt.defocus_sigma_px, opt.defocus_sigma_px,
                     cv::BORDER_REPLICATE);
  }
  cv::Mat padded;
  cv::copyMakeBorder(f, padded, 1, 1, 1, 1, cv::BORDER_REPLICATE);
  PreparedPattern out;
  out.stride = padded.cols;
  out.data.assign(padded.begin<float>(), padded.end<float>());
  return out;
}

// Standard normal numbers, fast and seeded: xoshiro256** (Blackman & Vigna) feeding the
// Box-Muller transform, both outputs used. One generator per image row keeps results independent
// of the thread count.
class GaussianNoise {
 public:
  explicit GaussianNoise(uint64_t seed) {
    for (auto& s : state_) {
      seed += 0x9e3779b97f4a7c15ULL;
      uint64_t z = seed;
      z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
      z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
      s = z ^ (z >> 31);
    }
  }
  double operator()() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = (static_cast<double>(Next() >> 11) + 0.5) * (1.0 / 9007199254740992.0);
    const double u2 = static_cast<double>(Next() >> 11) * (1.0 / 9007199254740992.0);
    const double radius = std::sqrt(-2.0 * std::log(u1));
    const double angle = 6.283185307179586 * u2;
    spare_ = radius * std::sin(angle);
    has_spare_ = true;
    return radius * std::cos(angle);
  }

 private:
  static uint64_t Rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  uint64_t Next() {
    const uint64_t result = Rotl(state_[1] * 5, 7) * 9;
    const uint64_t t = state_[1] << 17;
    state_[2] ^= state_[0];
    state_[3] ^= state_[1];
    state_[1] ^= state_[2];
    state_[0] ^= state_[3];
    state_[2] ^= t;
    state_[3] = Rotl(state_[3], 45);
    return result;
  }
  uint64_t state_[4];
  double spare_ = 0;
  bool has_spare_ = false;
};

}  // namespace

// ---------------------------------------------------------------------------------------------

void SensorOptions::Check() const {
  using util::CheckOption;
  CheckOption(supersampling >= 1 && supersampling <= 16, "SensorOptions", "supersampling",
              supersampling, "must be in [1, 16]");
  CheckOption(exposure > 0 && exposure <= 100, "SensorOptions", "exposure", exposure,
              "must be in (0, 100]");
  CheckOption(bit_depth == 8 || bit_depth == 12, "SensorOptions", "bit_depth", bit_depth,
              "must be 8 or 12");
  CheckOption(read_noise_dn >= 0, "SensorOptions", "read_noise_dn", read_noise_dn, "must be >= 0");
  CheckOption(electrons_per_dn > 0, "SensorOptions", "electrons_per_dn", electrons_per_dn,
              "must be > 0");
  CheckOption(defocus_sigma_px >= 0, "SensorOptions", "defocus_sigma_px", defocus_sigma_px,
              "must be >= 0");
}

void ProjectorOptions::Check() const {
  using util::CheckOption;
  CheckOption(gamma > 0 && gamma <= 10, "ProjectorOptions", "gamma", gamma, "must be in (0, 10]");
  CheckOption(black_level >= 0 && black_level < 1, "ProjectorOptions", "black_level", black_level,
              "must be in [0, 1)");
  CheckOption(brightness >= 0, "ProjectorOptions", "brightness", brightness, "must be >= 0");
  CheckOption(ambient >= 0, "ProjectorOptions", "ambient", ambient, "must be >= 0");
  CheckOption(defocus_sigma_px >= 0, "ProjectorOptions", "defocus_sigma_px", defocus_sigma_px,
              "must be >= 0");
}

void RenderOptions::Check() const {
  sensor.Check();
  projector.Check();
  util::CheckOption(shadow_offset_mm > 0, "RenderOptions", "shadow_offset_mm", shadow_offset_mm,
                    "must be > 0");
  util::CheckOption(marker_visibility_tolerance_mm > 0, "RenderOptions",
                    "marker_visibility_tolerance_mm", marker_visibility_tolerance_mm,
                    "must be > 0");
}

// ---------------------------------------------------------------------------------------------

Eigen::Vector2d UnprojectFrom(const CameraModel& camera, const Eigen::Vector2d& pixel,
                              const Eigen::Vector2d& guess, int fixed_iterations) {
  const Eigen::Vector2d target = camera.NormalizedDistortedFromPixel(pixel);
  if (!camera.HasDistortion()) return target;
  Eigen::Vector2d xy = guess;
  for (int it = 0; it < fixed_iterations; ++it) {
    const Eigen::Vector2d r = camera.Distort(xy) - target;
    const Eigen::Matrix2d j = camera.DistortJacobian(xy);
    const double det = j(0, 0) * j(1, 1) - j(0, 1) * j(1, 0);
    xy.x() -= (j(1, 1) * r.x() - j(0, 1) * r.y()) / det;
    xy.y() -= (j(0, 0) * r.y() - j(1, 0) * r.x()) / det;
  }
  if (fixed_iterations > 0) return xy;
  for (int it = 0; it < 8; ++it) {
    const Eigen::Vector2d r = camera.Distort(xy) - target;
    const Eigen::Matrix2d j = camera.DistortJacobian(xy);
    const double det = j(0, 0) * j(1, 1) - j(0, 1) * j(1, 0);
    if (!(std::abs(det) > 1e-12)) break;
    const Eigen::Vector2d step((j(1, 1) * r.x() - j(0, 1) * r.y()) / det,
                               (j(0, 0) * r.y() - j(1, 0) * r.x()) / det);
    xy -= step;
    if (step.squaredNorm() < 1e-30) return xy;
  }
  return camera.Unproject(pixel);
}

cv::Mat ApplySensor(const cv::Mat& radiance, const SensorOptions& opt, uint64_t stream) {
  assert(radiance.type() == CV_32F);
  cv::Mat rad = radiance;
  if (opt.defocus_sigma_px > 0) {
    cv::GaussianBlur(radiance, rad, cv::Size(0, 0), opt.defocus_sigma_px, opt.defocus_sigma_px,
                     cv::BORDER_REPLICATE);
  }
  const int type = opt.float_output ? CV_32F : (opt.bit_depth == 8 ? CV_8U : CV_16U);
  cv::Mat out(rad.size(), type);
  const double full = opt.FullScale();
  const double scale = opt.exposure * full;
  tbb::parallel_for(tbb::blocked_range<int>(0, rad.rows), [&](const tbb::blocked_range<int>& rr) {
    for (int r = rr.begin(); r < rr.end(); ++r) {
      GaussianNoise normal(util::MixSeed(stream, static_cast<uint64_t>(r)));
      const float* in = rad.ptr<float>(r);
      for (int c = 0; c < rad.cols; ++c) {
        double dn = scale * in[c];
        if (opt.noise) {
          if (opt.shot_noise) dn += std::sqrt(std::max(dn, 0.0) / opt.electrons_per_dn) * normal();
          if (opt.read_noise_dn > 0) dn += opt.read_noise_dn * normal();
        }
        if (type == CV_32F) {
          out.ptr<float>(r)[c] = static_cast<float>(dn);
        } else {
          const double q = dn <= 0 ? 0.0 : (dn >= full ? full : std::floor(dn + 0.5));
          if (type == CV_8U) {
            out.ptr<uint8_t>(r)[c] = static_cast<uint8_t>(q);
          } else {
            out.ptr<uint16_t>(r)[c] = static_cast<uint16_t>(q);
          }
        }
      }
    }
  });
  return out;
}

// ---------------------------------------------------------------------------------------------

// Undistorted normalized coordinates at every pixel corner, bilinearly interpolated for
// sub-pixel samples (the undistortion is smooth: interpolation error ~1e-5 px on the reference
// rig), so hot loops avoid Newton iterations. View independent: built once per camera.
struct RayTable {
  CameraModel camera;
  std::vector<Eigen::Vector2d> xy;  // (height + 1) x (width + 1) corners (c - 0.5, r - 0.5)

  RayTable() = default;
  explicit RayTable(const CameraModel& cam) : camera(cam) {
    const int W = cam.width, H = cam.height;
    xy.resize(static_cast<size_t>(W + 1) * (H + 1));
    tbb::parallel_for(tbb::blocked_range<int>(0, H + 1), [&](const tbb::blocked_range<int>& rr) {
      for (int r = rr.begin(); r < rr.end(); ++r) {
        Eigen::Vector2d guess = cam.Unproject(Eigen::Vector2d(-0.5, r - 0.5));
        for (int c = 0; c <= W; ++c) {
          guess = UnprojectFrom(cam, Eigen::Vector2d(c - 0.5, r - 0.5), guess);
          xy[static_cast<size_t>(r) * (W + 1) + c] = guess;
        }
      }
    });
  }

  // Pixel position (x, y) with x in [-0.5, width - 0.5], y likewise.
  Eigen::Vector2d At(double x, double y) const {
    const int W = camera.width, H = camera.height;
    const double cx = x + 0.5, cy = y + 0.5;
    const int i = std::clamp(static_cast<int>(std::floor(cx)), 0, W - 1);
    const int j = std::clamp(static_cast<int>(std::floor(cy)), 0, H - 1);
    const double a = cx - i, b = cy - j;
    const Eigen::Vector2d* p = &xy[static_cast<size_t>(j) * (W + 1) + i];
    const Eigen::Vector2d top = p[0] + a * (p[1] - p[0]);
    const Eigen::Vector2d bottom = p[W + 1] + a * (p[W + 2] - p[W + 1]);
    return top + b * (bottom - top);
  }
};

struct Renderer::Impl {
  Impl(const Scene& scene, const StereoRig& rig)
      : caster(scene), left_table(rig.left), right_table(rig.right) {}
  RayCaster caster;
  RayTable left_table;
  RayTable right_table;
};

// ---------------------------------------------------------------------------------------------

Renderer::Renderer(const Scene& scene, const StereoRig& rig, const RenderOptions& options)
    : rig_(rig), options_(options) {
  options_.Check();
  rig_.Check();
  if (!rig_.projector) throw Error("Renderer: the rig has no projector (projector_from_left)");
  impl_ = std::make_unique<Impl>(scene, rig_);
}

Renderer::~Renderer() = default;

const Scene& Renderer::scene() const { return impl_->caster.scene(); }

std::optional<Hit> Renderer::CastRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                                     double t_min) const {
  return impl_->caster.Cast(origin, dir.normalized(), t_min);
}

double Renderer::AlbedoAt(const Hit& hit) const { return impl_->caster.Albedo(hit); }

CameraImages Renderer::RenderCamera(const CameraModel& camera, const Rigid3d& world_from_camera,
                                    const Rigid3d& world_from_projector,
                                    const std::vector<cv::Mat>& patterns, uint64_t view_index,
                                    int camera_index) const {
  camera.Check();
  const CameraModel& projector = *rig_.projector;
  std::vector<PreparedPattern> prepared;
  prepared.reserve(patterns.size());
  for (size_t i = 0; i < patterns.size(); ++i) {
    prepared.push_back(PreparePattern(patterns[i], projector, options_.projector, i));
  }
  const int W = camera.width, H = camera.height;
  const int n = options_.sensor.supersampling;
  const int samples_per_px = n * n;
  const bool centre_is_sample = (n % 2) == 1;
  const Eigen::Matrix3d R = world_from_camera.rotation_matrix();
  const Eigen::Vector3d origin = world_from_camera.translation();
  const Rigid3d projector_from_world = world_from_projector.Inverse();
  const Eigen::Vector3d projector_centre = world_from_projector.translation();
  const ProjectorOptions& popt = options_.projector;
  const double shadow_offset = options_.shadow_offset_mm;
  const int pstride = projector.width + 2;

  CameraImages out;
  std::vector<cv::Mat> radiance(patterns.size());
  for (auto& m : radiance) m.create(H, W, CV_32F);
  CameraTruth& truth = out.truth;
  if (options_.truth) {
    truth.depth.create(H, W, CV_64F);
    truth.points.create(H, W, CV_64FC3);
    truth.normals.create(H, W, CV_64FC3);
    truth.projector.create(H, W, CV_64FC2);
    truth.valid.create(H, W, CV_8U);
    truth.object_id.create(H, W, CV_32S);
  }

  struct Sample {
    Eigen::Vector2d uv;  // projector pixel
    double weight;       // albedo * brightness * cos * lit
    bool lit;
  };
  // Shading of one hit up to the shadow test: albedo, projector coordinate and the lit weight
  // albedo * brightness * cos. Returns false when the projector cannot light the point (behind
  // it, outside its image, facing away); the caller tests the shadow (alone or batched).
  auto illuminate = [&](const Hit& hit, const Eigen::Vector3d& d_world, double* albedo,
                        Eigen::Vector2d* uv, double* weight, Eigen::Vector3d* shadow_from) {
    Eigen::Vector3d normal = hit.normal;
    if (normal.dot(d_world) > 0) normal = -normal;  // two-sided: face the camera
    *albedo = impl_->caster.Albedo(hit);
    *uv = Eigen::Vector2d(kNaN, kNaN);
    const Eigen::Vector3d p_in_projector = projector_from_world * hit.point;
    if (p_in_projector.z() <= 0) return false;
    *uv = projector.Project(p_in_projector);
    if (!projector.InImage(*uv)) return false;
    const double cos_term = normal.dot((projector_centre - hit.point).normalized());
    if (cos_term <= 0) return false;
    *weight = *albedo * popt.brightness * cos_term;
    *shadow_from = hit.point + shadow_offset * normal;
    return true;
  };
  // Shades one hit completely (with its own shadow ray).
  auto shade = [&](const Hit& hit, const Eigen::Vector3d& d_world, double* albedo, Sample* s) {
    s->weight = 0;
    s->lit = false;
    double weight = 0;
    Eigen::Vector3d from;
    if (!illuminate(hit, d_world, albedo, &s->uv, &weight, &from)) return;
    if (impl_->caster.index().Occluded(from, projector_centre)) return;
    s->lit = true;
    s->weight = weight;
  };
  auto WriteTruth = [&](const std::optional<Hit>& ch, const Eigen::Vector3d& dc, const Sample& cs,
                        int r, int c) {
    if (ch) {
      const Eigen::Vector3d p_cam = ch->t * dc;
      Eigen::Vector3d n_cam = world_from_camera.rotation().conjugate() * ch->normal;
      if (n_cam.dot(dc) > 0) n_cam = -n_cam;
      truth.depth.at<double>(r, c) = p_cam.z();
      truth.points.at<cv::Vec3d>(r, c) = cv::Vec3d(p_cam.x(), p_cam.y(), p_cam.z());
      truth.normals.at<cv::Vec3d>(r, c) = cv::Vec3d(n_cam.x(), n_cam.y(), n_cam.z());
      truth.projector.at<cv::Vec2d>(r, c) = cv::Vec2d(cs.uv.x(), cs.uv.y());
      truth.valid.at<uint8_t>(r, c) = cs.lit ? 255 : 0;
      truth.object_id.at<int32_t>(r, c) = ch->object;
    } else {
      truth.depth.at<double>(r, c) = kNaN;
      truth.points.at<cv::Vec3d>(r, c) = cv::Vec3d(kNaN, kNaN, kNaN);
      truth.normals.at<cv::Vec3d>(r, c) = cv::Vec3d(kNaN, kNaN, kNaN);
      truth.projector.at<cv::Vec2d>(r, c) = cv::Vec2d(kNaN, kNaN);
      truth.valid.at<uint8_t>(r, c) = 0;
      truth.object_id.at<int32_t>(r, c) = -1;
    }
  };

  std::unique_ptr<RayTable> local_table;
  const RayTable* table = nullptr;
  if (camera == impl_->left_table.camera) {
    table = &impl_->left_table;
  } else if (camera == impl_->right_table.camera) {
    table = &impl_->right_table;
  } else {
    local_table = std::make_unique<RayTable>(camera);
    table = local_table.get();
  }

  tbb::parallel_for(tbb::blocked_range<int>(0, H), [&](const tbb::blocked_range<int>& rows) {
    const size_t row_samples = static_cast<size_t>(W) * samples_per_px;
    const size_t line = static_cast<size_t>(W) * n;  // samples in one sub-row
    std::vector<int32_t> base(row_samples);
    std::vector<float> fx(row_samples), fy(row_samples), weight(row_samples);
    std::vector<double> ambient(W);
    std::vector<Eigen::Vector3d> d_cam(line), d_world(line), shadow_from;
    std::vector<std::optional<Hit>> hits;
    std::vector<Eigen::Vector2d> uv(line);
    std::vector<double> candidate_weight(line);
    std::vector<uint8_t> lit(line), occluded;
    std::vector<size_t> shadow_index;
    for (int r = rows.begin(); r < rows.end(); ++r) {
      std::fill(ambient.begin(), ambient.end(), 0.0);
      for (int sj = 0; sj < n; ++sj) {
        const double y = r + (sj + 0.5) / n - 0.5;
        const bool centre_line = centre_is_sample && 2 * sj + 1 == n;
        // All rays of this sub-row, cast as one coherent Embree stream.
        for (int c = 0; c < W; ++c) {
          for (int si = 0; si < n; ++si) {
            const double x = c + (si + 0.5) / n - 0.5;
            Eigen::Vector2d xy = table->At(x, y);
            // Pixel centres carry the ground truth: exact undistortion.
            if (centre_line && 2 * si + 1 == n) {
              xy = UnprojectFrom(camera, Eigen::Vector2d(x, y), xy);
            }
            const size_t j = static_cast<size_t>(c) * n + si;
            d_cam[j] = Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
            d_world[j] = R * d_cam[j];
          }
        }
        impl_->caster.CastBatch(origin, d_world, &hits);
        shadow_from.clear();
        shadow_index.clear();
        for (size_t j = 0; j < line; ++j) {
          const int c = static_cast<int>(j / n), si = static_cast<int>(j % n);
          const size_t k = static_cast<size_t>(c) * samples_per_px + sj * n + si;
          base[k] = -1;
          weight[k] = 0;
          lit[j] = 0;
          uv[j] = Eigen::Vector2d(kNaN, kNaN);
          if (!hits[j]) continue;
          double albedo = 0;
          Eigen::Vector3d from;
          const bool candidate =
              illuminate(*hits[j], d_world[j], &albedo, &uv[j], &candidate_weight[j], &from);
          ambient[c] += albedo * popt.ambient;
          if (!candidate) continue;
          shadow_from.push_back(from);
          shadow_index.push_back(j);
        }
        impl_->caster.index().OccludedBatch(shadow_from, projector_centre, &occluded);
        for (size_t q = 0; q < shadow_index.size(); ++q) {
          if (occluded[q]) continue;
          const size_t j = shadow_index[q];
          const int c = static_cast<int>(j / n), si = static_cast<int>(j % n);
          const size_t k = static_cast<size_t>(c) * samples_per_px + sj * n + si;
          lit[j] = 1;
          double u = uv[j].x(), v = uv[j].y();
          if (popt.pixelated) {
            u = std::floor(u + 0.5);
            v = std::floor(v + 0.5);
          }
          const double fu = std::floor(u), fv = std::floor(v);
          base[k] = static_cast<int32_t>((fv + 1) * pstride + (fu + 1));  // +1: padded border
          fx[k] = static_cast<float>(u - fu);
          fy[k] = static_cast<float>(v - fv);
          weight[k] = static_cast<float>(candidate_weight[j]);
        }
        if (options_.truth && centre_line) {
          // Truth from the ray through the pixel centre: the middle sample.
          for (int c = 0; c < W; ++c) {
            const size_t j = static_cast<size_t>(c) * n + n / 2;
            WriteTruth(hits[j], d_cam[j], Sample{uv[j], 0, lit[j] != 0}, r, c);
          }
        }
      }
      if (options_.truth && !centre_is_sample) {
        // Even n: the pixel centre is no sample; cast it on its own.
        for (int c = 0; c < W; ++c) {
          const Eigen::Vector2d xy = UnprojectFrom(camera, Eigen::Vector2d(c, r), table->At(c, r));
          const Eigen::Vector3d dc = Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
          const Eigen::Vector3d dw = R * dc;
          const std::optional<Hit> ch = impl_->caster.Cast(origin, dw, 0);
          Sample cs{Eigen::Vector2d(kNaN, kNaN), 0, false};
          double albedo = 0;
          if (ch) shade(*ch, dw, &albedo, &cs);
          WriteTruth(ch, dc, cs, r, c);
        }
      }
      // Shade every pattern from the cached samples.
      const float inv = 1.0f / static_cast<float>(samples_per_px);
      for (size_t p = 0; p < prepared.size(); ++p) {
        const float* img = prepared[p].data.data();
        float* dst = radiance[p].ptr<float>(r);
        for (int c = 0; c < W; ++c) {
          float acc = 0;
          const size_t k0 = static_cast<size_t>(c) * samples_per_px;
          for (int s = 0; s < samples_per_px; ++s) {
            const size_t k = k0 + s;
            if (base[k] < 0) continue;
            const float* q = img + base[k];
            const float a = fx[k], b = fy[k];
            const float top = q[0] + a * (q[1] - q[0]);
            const float bottom = q[pstride] + a * (q[pstride + 1] - q[pstride]);
            acc += weight[k] * (top + b * (bottom - top));
          }
          dst[c] = static_cast<float>(ambient[c]) * inv + acc * inv;
        }
      }
    }
  });

  out.images.resize(patterns.size());
  const uint64_t view_stream = util::MixSeed(options_.sensor.seed, view_index);
  const uint64_t camera_stream = util::MixSeed(view_stream, static_cast<uint64_t>(camera_index));
  for (size_t p = 0; p < patterns.size(); ++p) {
    out.images[p] = ApplySensor(radiance[p], options_.sensor, util::MixSeed(camera_stream, p));
  }
  return out;
}

ViewImages Renderer::RenderView(const Rigid3d& world_from_sensor,
                                const std::vector<cv::Mat>& patterns, uint64_t view_index) const {
  ViewImages view;
  view.world_from_sensor = world_from_sensor;
  const Rigid3d world_from_projector = world_from_sensor * rig_.projector_from_left.Inverse();
  view.left =
      RenderCamera(rig_.left, world_from_sensor, world_from_projector, patterns, view_index, 0);
  view.right = RenderCamera(rig_.right, world_from_sensor * rig_.right_from_left.Inverse(),
                            world_from_projector, patterns, view_index, 1);
  view.markers = ObserveMarkers(world_from_sensor);
  return view;
}

std::vector<MarkerObservation> Renderer::ObserveMarkers(const Rigid3d& world_from_sensor) const {
  std::vector<MarkerObservation> out;
  const Rigid3d sensor_from_world = world_from_sensor.Inverse();
  const Rigid3d world_from_right = world_from_sensor * rig_.right_from_left.Inverse();
  for (const Marker& m : impl_->caster.scene().markers()) {
    MarkerObservation o;
    o.id = m.id;
    o.centre_in_sensor = sensor_from_world * m.centre_in_world;
    auto observe = [&](const CameraModel& cam, const Rigid3d& world_from_cam, Eigen::Vector2d* px) {
      const Eigen::Vector3d p_cam = world_from_cam.Inverse() * m.centre_in_world;
      if (p_cam.z() <= 0) {
        *px = Eigen::Vector2d(kNaN, kNaN);
        return false;
      }
      *px = cam.Project(p_cam);
      if (!cam.InImage(*px)) return false;
      const Eigen::Vector3d eye = world_from_cam.translation();
      const Eigen::Vector3d to_eye = eye - m.centre_in_world;
      if (m.normal_in_world.dot(to_eye) <= 0) return false;
      const double dist = to_eye.norm();
      const std::optional<Hit> hit = impl_->caster.Cast(eye, -to_eye / dist, 0);
      return hit && hit->t >= dist - options_.marker_visibility_tolerance_mm;
    };
    o.visible_left = observe(rig_.left, world_from_sensor, &o.left_px);
    o.visible_right = observe(rig_.right, world_from_right, &o.right_px);
    out.push_back(o);
  }
  return out;
}

StereoRig ScaledRig(const StereoRig& rig, double scale) {
  util::CheckOption(scale > 0, "ScaledRig", "scale", scale, "must be > 0");
  auto scaled = [scale](CameraModel c) {
    c.width = std::max(1, static_cast<int>(std::lround(c.width * scale)));
    c.height = std::max(1, static_cast<int>(std::lround(c.height * scale)));
    c.fx *= scale;
    c.fy *= scale;
    // Pixel centres at integers: the image edge -0.5 maps to -0.5.
    c.cx = (c.cx + 0.5) * scale - 0.5;
    c.cy = (c.cy + 0.5) * scale - 0.5;
    return c;
  };
  StereoRig out = rig;
  out.left = scaled(rig.left);
  out.right = scaled(rig.right);
  if (rig.projector) out.projector = scaled(*rig.projector);
  return out;
}

}  // namespace fringe::sim
