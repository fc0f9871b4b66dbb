#include "fringe/pipeline/view_checkpoint.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <type_traits>

#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::pipeline {
namespace {

namespace fs = std::filesystem;

// Every field of a marker is written (PutMarker): a field added to ViewMarker must be added there.
static_assert(sizeof(registration::ViewMarker) == 192,
              "ViewMarker changed: update PutMarker/GetMarker");

constexpr char kMagic[8] = {'F', 'R', 'V', 'I', 'E', 'W', '0', '3'};

// FNV-1a over the payload: a torn or altered checkpoint is ignored, not half-read.
uint64_t Checksum(const char* data, size_t size) {
  uint64_t h = 1469598103934665603ull;
  for (size_t i = 0; i < size; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 1099511628211ull;
  }
  return h;
}

class Writer {
 public:
  template <class T>
  void Pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    buf_.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  void Bytes(const void* data, size_t n) {
    Pod<uint64_t>(n);
    buf_.append(static_cast<const char*>(data), n);
  }
  void Str(const std::string& s) { Bytes(s.data(), s.size()); }
  // Fixed-size Eigen values (not trivially copyable as types, plain doubles in memory).
  template <int R, int C>
  void Eig(const Eigen::Matrix<double, R, C>& m) {
    buf_.append(reinterpret_cast<const char*>(m.data()), sizeof(double) * R * C);
  }
  template <class T>
  void Vec(const std::vector<T>& v) {
    Bytes(v.data(), v.size() * sizeof(T));
  }
  std::string& buf() { return buf_; }

 private:
  std::string buf_;
};

// Every read checks the bytes left first: a checkpoint from a killed run may be anything.
class Reader {
 public:
  Reader(const char* data, size_t size) : p_(data), end_(data + size) {}
  template <class T>
  bool Pod(T* v) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (static_cast<size_t>(end_ - p_) < sizeof(T)) return false;
    std::memcpy(v, p_, sizeof(T));
    p_ += sizeof(T);
    return true;
  }
  bool Bytes(std::string* out) {
    uint64_t n = 0;
    if (!Pod(&n) || n > static_cast<uint64_t>(end_ - p_)) return false;
    out->assign(p_, static_cast<size_t>(n));
    p_ += n;
    return true;
  }
  template <int R, int C>
  bool Eig(Eigen::Matrix<double, R, C>* m) {
    constexpr size_t n = sizeof(double) * R * C;
    if (static_cast<size_t>(end_ - p_) < n) return false;
    std::memcpy(m->data(), p_, n);
    p_ += n;
    return true;
  }
  template <class T>
  bool Vec(std::vector<T>* v) {
    uint64_t n = 0;
    if (!Pod(&n) || n > static_cast<uint64_t>(end_ - p_) || n % sizeof(T) != 0) return false;
    v->resize(static_cast<size_t>(n / sizeof(T)));
    if (n > 0) std::memcpy(v->data(), p_, static_cast<size_t>(n));
    p_ += n;
    return true;
  }
  bool AtEnd() const { return p_ == end_; }

 private:
  const char* p_;
  const char* end_;
};

// The view-stage figures of a summary (registration and truth come later in the scan).
void PutSummary(Writer& w, const ScanViewSummary& s) {
  w.Str(s.name);
  w.Pod<int32_t>(s.points);
  w.Pod<int32_t>(s.markers);
  for (double d : {s.valid_fraction, s.decode_valid_left, s.decode_valid_right, s.read_s,
                   s.decode_s, s.reconstruct_s, s.markers_s, s.drift.projector_bias_px,
                   s.drift.projector_rms_px, s.drift.projector_systematic_px}) {
    w.Pod(d);
  }
  w.Pod<int32_t>(s.drift.projector_samples);
}

bool GetSummary(Reader& r, ScanViewSummary* s) {
  int32_t points = 0, markers = 0;
  if (!r.Bytes(&s->name) || !r.Pod(&points) || !r.Pod(&markers)) return false;
  s->points = points;
  s->markers = markers;
  for (double* d : {&s->valid_fraction, &s->decode_valid_left, &s->decode_valid_right, &s->read_s,
                    &s->decode_s, &s->reconstruct_s, &s->markers_s, &s->drift.projector_bias_px,
                    &s->drift.projector_rms_px, &s->drift.projector_systematic_px}) {
    if (!r.Pod(d)) return false;
  }
  int32_t projector_samples = 0;
  if (!r.Pod(&projector_samples)) return false;
  s->drift.projector_samples = projector_samples;
  s->ok = true;
  return true;
}

// The measured points only (a view is mostly empty pixels); the others come back as a new
// OrganizedPointCloud holds them (NaN, zero), which nothing downstream reads.
void PutCloud(Writer& w, const OrganizedPointCloud& g) {
  w.Pod<int32_t>(g.width);
  w.Pod<int32_t>(g.height);
  w.Vec(g.valid);
  const PointCloud& c = g.cloud;
  const uint8_t flags = (c.has_normals() ? 1 : 0) | (c.has_colors() ? 2 : 0) |
                        (c.has_intensity() ? 4 : 0) | (c.has_quality() ? 8 : 0) |
                        (c.has_residual() ? 16 : 0);
  w.Pod(flags);
  for (size_t i = 0; i < g.valid.size(); ++i) {
    if (!g.valid[i]) continue;
    w.Eig(c.points[i]);
    if (flags & 1) w.Eig(c.normals[i]);
    if (flags & 2) w.Pod(c.colors[i]);
    if (flags & 4) w.Pod(c.intensity[i]);
    if (flags & 8) w.Pod(c.quality[i]);
    if (flags & 16) w.Pod(c.residual_px[i]);
  }
}

bool GetCloud(Reader& r, OrganizedPointCloud* g) {
  int32_t width = 0, height = 0;
  std::vector<uint8_t> valid;
  uint8_t flags = 0;
  if (!r.Pod(&width) || !r.Pod(&height) || width < 0 || height < 0 || !r.Vec(&valid) ||
      valid.size() != static_cast<size_t>(width) * static_cast<size_t>(height) || !r.Pod(&flags)) {
    return false;
  }
  *g = OrganizedPointCloud(width, height, flags & 1, flags & 4, flags & 8);
  g->valid = std::move(valid);
  PointCloud& c = g->cloud;
  const size_t n = g->valid.size();
  if (flags & 2) c.colors.assign(n, Color3u8{});
  if (flags & 16) c.residual_px.assign(n, std::numeric_limits<float>::quiet_NaN());
  for (size_t i = 0; i < n; ++i) {
    if (!g->valid[i]) continue;
    if (!r.Eig(&c.points[i])) return false;
    if ((flags & 1) && !r.Eig(&c.normals[i])) return false;
    if ((flags & 2) && !r.Pod(&c.colors[i])) return false;
    if ((flags & 4) && !r.Pod(&c.intensity[i])) return false;
    if ((flags & 8) && !r.Pod(&c.quality[i])) return false;
    if ((flags & 16) && !r.Pod(&c.residual_px[i])) return false;
  }
  return true;
}

void PutMarker(Writer& w, const registration::ViewMarker& m) {
  w.Pod<int32_t>(m.id);
  w.Eig(m.centre_in_sensor);
  w.Eig(m.normal_in_sensor);
  w.Eig(m.left_px);
  w.Eig(m.right_px);
  w.Pod(m.outer_radius_mm);
  w.Pod(m.sigma_mm);
  w.Pod(m.depth_difference_mm);
  w.Eig(m.covariance_mm2);
}

bool GetMarker(Reader& r, registration::ViewMarker* m) {
  int32_t id = 0;
  if (!r.Pod(&id)) return false;
  m->id = id;
  return r.Eig(&m->centre_in_sensor) && r.Eig(&m->normal_in_sensor) && r.Eig(&m->left_px) &&
         r.Eig(&m->right_px) && r.Pod(&m->outer_radius_mm) && r.Pod(&m->sigma_mm) &&
         r.Pod(&m->depth_difference_mm) && r.Eig(&m->covariance_mm2);
}

void PutMat(Writer& w, const cv::Mat& m) {
  const cv::Mat c = m.isContinuous() ? m : m.clone();
  w.Pod<int32_t>(c.rows);
  w.Pod<int32_t>(c.cols);
  w.Pod<int32_t>(c.type());
  w.Bytes(c.data, c.total() * c.elemSize());
}

bool GetMat(Reader& r, cv::Mat* m) {
  int32_t rows = 0, cols = 0, type = 0;
  std::string bytes;
  if (!r.Pod(&rows) || !r.Pod(&cols) || !r.Pod(&type) || !r.Bytes(&bytes)) return false;
  if (rows < 0 || cols < 0 || type < 0 || type > CV_MAKETYPE(CV_DEPTH_MAX - 1, 4)) return false;
  if (rows == 0 || cols == 0) {
    *m = cv::Mat();
    return bytes.empty();
  }
  cv::Mat out(rows, cols, type);
  if (bytes.size() != out.total() * out.elemSize()) return false;
  std::memcpy(out.data, bytes.data(), bytes.size());
  *m = out;
  return true;
}

}  // namespace

std::string ViewCheckpointKey(const scan::ScanFolder& folder, const std::string& view,
                              const std::string& rig_and_schemes, const std::string& options_key) {
  std::string key =
      util::StrCat("options\n", options_key, "\nrig and schemes\n", rig_and_schemes, "\nfiles\n");
  const fs::path dir = folder.layout().ViewDir(view);
  std::vector<std::string> lines;
  std::error_code ec;
  // Links followed: a view assembled from links to a capture changes when the capture does.
  for (fs::recursive_directory_iterator
           it(dir, fs::directory_options::follow_directory_symlink, ec),
       end;
       !ec && it != end; it.increment(ec)) {
    std::error_code fec;
    if (!it->is_regular_file(fec)) continue;
    const auto size = fs::file_size(it->path(), fec);
    const auto time = fs::last_write_time(it->path(), fec).time_since_epoch().count();
    lines.push_back(
        util::StrCat(it->path().lexically_relative(dir).string(), " ", size, " ", time));
  }
  std::sort(lines.begin(), lines.end());
  for (const std::string& l : lines) key += l + "\n";
  return key;
}

uint64_t WriteViewCheckpoint(const fs::path& dir, const std::string& key, const ViewResult& v) {
  Writer w;
  w.buf().append(kMagic, sizeof(kMagic));
  w.Str(key);
  PutSummary(w, v.summary);
  PutCloud(w, v.cloud);
  w.Pod<uint64_t>(v.markers.size());
  for (const registration::ViewMarker& m : v.markers) PutMarker(w, m);
  w.Pod<uint64_t>(v.pictures.size());
  for (const ReportImage& p : v.pictures) {
    w.Str(p.caption);
    PutMat(w, p.image);
  }
  PutMat(w, v.phase_left);
  const uint64_t sum = Checksum(w.buf().data(), w.buf().size());
  w.Pod(sum);

  const fs::path folder = dir / kCheckpointFolder;
  const fs::path path = folder / (v.summary.name + ".view");
  const fs::path tmp = folder / (v.summary.name + ".view.tmp");
  fs::create_directories(folder);
  std::error_code ec;
  try {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(w.buf().data(), static_cast<std::streamsize>(w.buf().size()));
    util::CloseOutput(out, path);
  } catch (...) {
    fs::remove(tmp, ec);  // no partial checkpoint left taking the disk
    throw;
  }
  fs::rename(tmp, path, ec);
  if (ec) throw Error(util::StrCat(path.string(), ": cannot write: ", ec.message()));
  return w.buf().size();
}

std::optional<ViewResult> ReadViewCheckpoint(const fs::path& dir, const std::string& name,
                                             const std::string& key) {
  const fs::path path = dir / kCheckpointFolder / (name + ".view");
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return std::nullopt;
  std::string data;
  try {
    // Bounded like every read: a full-size view with everything is ~100 MB.
    data = util::ReadTextFile(path, std::uintmax_t{1} << 32);
  } catch (const Error&) {
    return std::nullopt;
  }
  if (data.size() < sizeof(kMagic) + sizeof(uint64_t) ||
      std::memcmp(data.data(), kMagic, sizeof(kMagic)) != 0) {
    return std::nullopt;
  }
  uint64_t sum = 0;
  const size_t payload = data.size() - sizeof(uint64_t);
  std::memcpy(&sum, data.data() + payload, sizeof(sum));
  if (sum != Checksum(data.data(), payload)) return std::nullopt;
  Reader r(data.data() + sizeof(kMagic), payload - sizeof(kMagic));
  std::string stored_key;
  if (!r.Bytes(&stored_key) || stored_key != key) return std::nullopt;
  ViewResult v;
  if (!GetSummary(r, &v.summary) || v.summary.name != name || !GetCloud(r, &v.cloud)) {
    return std::nullopt;
  }
  uint64_t count = 0;
  if (!r.Pod(&count) || count > payload / sizeof(double)) return std::nullopt;
  v.markers.resize(static_cast<size_t>(count));
  for (auto& m : v.markers) {
    if (!GetMarker(r, &m)) return std::nullopt;
  }
  if (!r.Pod(&count) || count > payload) return std::nullopt;
  v.pictures.resize(static_cast<size_t>(count));
  for (auto& p : v.pictures) {
    if (!r.Bytes(&p.caption) || !GetMat(r, &p.image)) return std::nullopt;
  }
  if (!GetMat(r, &v.phase_left) || !r.AtEnd()) return std::nullopt;
  return v;
}

}  // namespace fringe::pipeline
