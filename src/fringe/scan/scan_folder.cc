#include "fringe/scan/scan_folder.h"

#include <algorithm>
#include <iomanip>
#include <limits>
#include <sstream>

#include "fringe/io/calibration_io.h"
#include "fringe/io/image_io.h"
#include "fringe/io/json.h"
#include "fringe/io/mesh_io.h"
#include "fringe/phase/stack_io.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"
#include "fringe/util/log.h"

namespace fringe::scan {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using util::StrCat;

constexpr const char* kFormat = "fringe-scan";

// A relative path field that may be null.
std::string OptionalPath(const json& j, const char* field) {
  const json& v = j.at(field);
  if (v.is_null()) return {};
  const std::string s = v.get<std::string>();
  const fs::path p(s);
  // The manifest names files inside the folder; anything else would read outside it.
  if (s.empty() || p.is_absolute() || std::find(p.begin(), p.end(), "..") != p.end()) {
    throw Error(StrCat("'", field, "' = '", s, "' must be a relative path inside the folder"));
  }
  return s;
}

json PathOrNull(const std::string& s) { return s.empty() ? json(nullptr) : json(s); }

bool IsIndexName(const std::string& s) {
  return s.size() == 3 &&
         std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

}  // namespace

const char* CameraName(Camera camera) { return camera == Camera::kLeft ? "left" : "right"; }

std::string IndexName(int index) {
  std::ostringstream os;
  os << std::setw(3) << std::setfill('0') << index;
  return os.str();
}

json ManifestToJson(const ScanManifest& m) {
  json j = {{"format", kFormat},
            {"version", ScanManifest::kVersion},
            {"generator", m.generator},
            {"scene", m.scene},
            {"seed", m.seed},
            {"views", m.views},
            {"image_width", m.image_width},
            {"image_height", m.image_height},
            {"bit_depth", m.bit_depth},
            {"scheme", PathOrNull(m.scheme)},
            {"calibration_images", m.calibration_images},
            {"calibration_target", PathOrNull(m.calibration_target)},
            {"truth", PathOrNull(m.truth)}};
  // Written only for one camera: two-camera manifests stay as they were.
  if (m.cameras != 2) j["cameras"] = m.cameras;
  if (!m.scheme_horizontal.empty()) j["scheme_horizontal"] = m.scheme_horizontal;
  if (!m.camera_folders.empty()) j["camera_folders"] = m.camera_folders;
  return j;
}

ScanManifest ManifestFromJson(const json& j, const std::string& context) {
  return io::WithJsonContext(context, [&] {
    if (!j.is_object()) throw Error("not a JSON object");
    const std::string format = j.at("format").get<std::string>();
    if (format != kFormat) {
      throw Error(StrCat("format '", format, "' is not '", kFormat, "'"));
    }
    const long long version = io::GetInteger(j, "version", 1, 1000000, context);
    if (version > ScanManifest::kVersion) {
      throw Error(StrCat("version ", version, " is not supported (this fringe reads version ",
                         ScanManifest::kVersion, ")"));
    }
    // Strict: a misspelt key is an error naming the nearest valid one (issue 10), and every
    // count is a JSON integer in range (4294967936 must not wrap to 640).
    io::CheckKnownKeys(
        j,
        {"format", "version", "generator", "scene", "seed", "views", "image_width", "image_height",
         "bit_depth", "scheme", "calibration_images", "calibration_target", "truth", "cameras",
         "scheme_horizontal", "camera_folders"},
        context);
    constexpr long long kMaxCount = 100000;  // views or board images: far beyond any scan
    constexpr long long kMaxSide = 65536;    // pixels
    ScanManifest m;
    m.generator = io::OptionalString(j, "generator", "", context);
    m.scene = io::OptionalString(j, "scene", "", context);
    m.seed = static_cast<uint64_t>(
        io::OptionalInteger(j, "seed", 0, 0, std::numeric_limits<long long>::max(), context));
    m.views = static_cast<int>(io::GetInteger(j, "views", 0, kMaxCount, context));
    m.image_width = static_cast<int>(io::GetInteger(j, "image_width", 1, kMaxSide, context));
    m.image_height = static_cast<int>(io::GetInteger(j, "image_height", 1, kMaxSide, context));
    m.bit_depth = static_cast<int>(io::OptionalInteger(j, "bit_depth", 8, 1, 16, context));
    m.cameras = static_cast<int>(io::OptionalInteger(j, "cameras", 2, 1, 2, context));
    m.scheme = OptionalPath(j, "scheme");
    m.scheme_horizontal =
        j.contains("scheme_horizontal") ? OptionalPath(j, "scheme_horizontal") : std::string();
    if (!m.scheme_horizontal.empty() && m.cameras != 1) {
      throw Error(
          "'scheme_horizontal' needs 'cameras': 1 (stereo matching uses vertical fringes only)");
    }
    if (!m.scheme_horizontal.empty() && m.scheme.empty()) {
      throw Error("'scheme_horizontal' is set but 'scheme' is null");
    }
    m.calibration_images =
        static_cast<int>(io::GetInteger(j, "calibration_images", 0, kMaxCount, context));
    m.calibration_target = OptionalPath(j, "calibration_target");
    m.truth = j.contains("truth") ? OptionalPath(j, "truth") : std::string();
    // 10 and 14: GenICam Mono10 / Mono14 cameras written by `fringe capture`.
    if (m.bit_depth != 8 && m.bit_depth != 10 && m.bit_depth != 12 && m.bit_depth != 14 &&
        m.bit_depth != 16) {
      throw Error(StrCat("'bit_depth' = ", m.bit_depth, " must be 8, 10, 12, 14 or 16"));
    }
    if (m.views > 0 && m.scheme.empty()) throw Error("'scheme' is null but there are views");
    if (j.contains("camera_folders")) {
      const json& f = j["camera_folders"];
      if (!f.is_array() || static_cast<int>(f.size()) != m.cameras) {
        throw Error(StrCat("'camera_folders' must list ", m.cameras, " folder name",
                           m.cameras == 2 ? "s (left, right)" : " (the camera)"));
      }
      for (const json& n : f) {
        if (!n.is_string()) throw Error("'camera_folders' holds a value that is not a name");
        m.camera_folders.push_back(n.get<std::string>());
      }
      bool known = false;
      for (const auto& [l, r] : CameraFolderNames()) {
        known = known || (m.camera_folders[0] == l && (m.cameras == 1 || m.camera_folders[1] == r));
      }
      if (!known) {
        throw Error(
            "'camera_folders' must be [\"left\", \"right\"], [\"L\", \"R\"] or "
            "[\"cam0\", \"cam1\"] (the first alone for one camera)");
      }
    }
    if (m.calibration_images > 0 && m.calibration_target.empty()) {
      throw Error("'calibration_target' is null but there are calibration images");
    }
    return m;
  });
}

void WriteManifest(const fs::path& path, const ScanManifest& manifest) {
  io::WriteJson(path, ManifestToJson(manifest));
}

const std::vector<std::pair<std::string, std::string>>& CameraFolderNames() {
  static const std::vector<std::pair<std::string, std::string>> names = {
      {"left", "right"}, {"L", "R"}, {"cam0", "cam1"}};
  return names;
}

InferredManifest InferManifest(const fs::path& root) {
  util::RequireDirectory(root, "scan folder");
  const ScanLayout l{root};
  InferredManifest out;
  ScanManifest& m = out.manifest;
  m.generator = "inferred by fringe from the folder (no scan.json)";
  const auto fail = [&](const std::string& why) {
    throw Error(StrCat(root.string(), ": no scan.json, and one cannot be inferred: ", why));
  };
  std::error_code ec;
  if (!fs::is_directory(l.ViewsDir(), ec)) fail("no views/ folder");
  std::vector<std::string> views;
  for (const auto& e : fs::directory_iterator(l.ViewsDir())) {
    if (!e.is_directory()) continue;
    const std::string name = e.path().filename().string();
    if (!IsIndexName(name)) {
      throw Error(StrCat(e.path().string(), ": not a view folder (expected a three-digit index)"));
    }
    views.push_back(name);
  }
  std::sort(views.begin(), views.end());
  if (views.empty()) fail("views/ holds no view folder (000, 001, ...)");
  m.views = static_cast<int>(views.size());
  // Camera folders: the first naming whose left folder view 000 has.
  const fs::path first_view = l.ViewDir(views[0]);
  std::string left, right;
  for (const auto& [ln, rn] : CameraFolderNames()) {
    if (fs::is_directory(first_view / ln, ec)) {
      left = ln;
      right = fs::is_directory(first_view / rn, ec) ? rn : "";
      break;
    }
  }
  if (left.empty()) {
    throw Error(StrCat(first_view.string(),
                       ": no camera folder (left/ right/, L/ R/ or cam0/ cam1/) to infer the "
                       "scan from"));
  }
  m.cameras = right.empty() ? 1 : 2;
  if (left != "left") {
    m.camera_folders = {left};
    if (!right.empty()) m.camera_folders.push_back(right);
  }
  out.notes.push_back(StrCat(m.views, " views (views/", views.front(), " .. views/", views.back(),
                             "), ", m.cameras == 2 ? "two cameras " : "one camera + projector ",
                             left, "/", right.empty() ? "" : " " + right + "/"));
  // Scheme(s).
  if (!fs::is_regular_file(l.Scheme(), ec)) {
    fail("no scheme.json (the pattern scheme the views were captured with)");
  }
  m.scheme = "scheme.json";
  if (m.cameras == 1 && fs::is_regular_file(l.HorizontalScheme(), ec)) {
    m.scheme_horizontal = "scheme_horizontal.json";
  }
  out.notes.push_back(StrCat("scheme ", m.scheme,
                             m.scheme_horizontal.empty() ? "" : " and " + m.scheme_horizontal));
  // Image size and depth: the first image of view 000's left stack (or of its first exposure
  // or direction folder).
  fs::path stack = first_view / left;
  for (const char* sub : {"", "vertical", "e0", "vertical/e0"}) {
    const fs::path dir = first_view / left / sub;
    if (fs::is_directory(dir, ec) && !io::ListImageFiles(dir).empty()) {
      stack = dir;
      break;
    }
  }
  const std::vector<std::string> images = io::ListImageFiles(stack);
  if (images.empty()) throw Error(StrCat(stack.string(), ": no images to infer the size from"));
  const cv::Mat image = io::ReadGrayImage(stack / images.front());
  m.image_width = image.cols;
  m.image_height = image.rows;
  m.bit_depth = image.depth() == CV_16U ? 16 : 8;
  out.notes.push_back(StrCat("images ", m.image_width, "x", m.image_height, ", ", m.bit_depth,
                             "-bit (", (stack / images.front()).lexically_relative(root).string(),
                             m.bit_depth == 16 ? "; a 12-bit sensor: set bit_depth 12" : "", ")"));
  // Calibration images, when their target is described.
  if (fs::is_regular_file(l.Target(), ec)) {
    m.calibration_target = "calibration/target.json";
    if (m.cameras == 2) {
      const fs::path dir = l.CalibrationDir() / left;
      m.calibration_images =
          fs::is_directory(dir, ec) ? static_cast<int>(io::ListImageFiles(dir).size()) : 0;
    } else {
      for (const auto& e : fs::directory_iterator(l.CalibrationDir())) {
        m.calibration_images += e.is_directory() ? 1 : 0;
      }
    }
    if (m.calibration_images == 0) m.calibration_target.clear();
    out.notes.push_back(StrCat(
        m.calibration_images,
        m.cameras == 2 ? " calibration images per camera" : " calibration board pose folders",
        ", target calibration/target.json"));
  } else {
    out.notes.push_back("no calibration (no calibration/target.json)");
  }
  return out;
}

InferredManifest WriteInferredManifest(const fs::path& root) {
  const ScanLayout layout{root};
  if (fs::exists(layout.Manifest())) {
    throw Error(util::StrCat(root.string(), ": already has ", layout.Manifest().filename().string(),
                             " (not overwritten)"));
  }
  InferredManifest inferred = InferManifest(root);
  (void)ScanFolder::Open(root);  // the folder agrees with what was inferred
  WriteManifest(layout.Manifest(), inferred.manifest);
  return inferred;
}

bool ScanFolder::IsScanFolder(const fs::path& dir) {
  std::error_code ec;
  return fs::is_regular_file(ScanLayout{dir}.Manifest(), ec);
}

std::optional<fs::path> ScanFolder::RootOfView(const fs::path& view_dir) {
  // Normalise "views/000/" and "views/000" alike.
  const fs::path view = view_dir.lexically_normal().filename().empty()
                            ? view_dir.lexically_normal().parent_path()
                            : view_dir.lexically_normal();
  const fs::path views = view.parent_path();
  if (views.filename() != "views") return std::nullopt;
  const fs::path root = views.parent_path();
  if (!IsScanFolder(root.empty() ? fs::path(".") : root)) return std::nullopt;
  return root.empty() ? fs::path(".") : root;
}

ScanFolder ScanFolder::Open(const fs::path& root) {
  util::RequireDirectory(root, "scan folder");
  ScanFolder s;
  s.layout_.root = root;
  const ScanLayout& l = s.layout_;
  if (IsScanFolder(root)) {
    s.manifest_ = ManifestFromJson(io::ReadJson(l.Manifest()), l.Manifest().string());
  } else {
    InferredManifest inferred = InferManifest(root);
    s.manifest_ = std::move(inferred.manifest);
    s.inferred_notes_ = std::move(inferred.notes);
    // Said where every command sees it; the folder is not written to.
    util::LogInfo(StrCat(root.string(), ": no scan.json; inferred from the folder:"));
    for (const std::string& n : s.inferred_notes_) util::LogInfo("  " + n);
  }
  const ScanManifest& m = s.manifest_;
  if (!m.camera_folders.empty()) {
    s.layout_.left_folder = m.camera_folders[0];
    if (m.camera_folders.size() > 1) s.layout_.right_folder = m.camera_folders[1];
  }

  // Views: exactly 000 .. views-1, each with both cameras.
  std::error_code ec;
  if (fs::is_directory(l.ViewsDir(), ec)) {
    for (const auto& e : fs::directory_iterator(l.ViewsDir())) {
      const std::string name = e.path().filename().string();
      if (!e.is_directory()) continue;
      if (!IsIndexName(name)) {
        throw Error(
            StrCat(e.path().string(), ": not a view folder (expected a three-digit index)"));
      }
      s.views_.push_back(name);
    }
  }
  std::sort(s.views_.begin(), s.views_.end());
  if (static_cast<int>(s.views_.size()) != m.views) {
    throw Error(StrCat(l.ViewsDir().string(), ": ", s.views_.size(), " view folders, but ",
                       l.Manifest().string(), " says ", m.views));
  }
  for (int v = 0; v < m.views; ++v) {
    if (s.views_[v] != IndexName(v)) {
      throw Error(StrCat(l.ViewDir(IndexName(v)).string(), ": missing view folder (views are ",
                         IndexName(0), " .. ", IndexName(m.views - 1), ")"));
    }
    util::RequireDirectory(l.CameraDir(s.views_[v], Camera::kLeft), "camera image folder");
    if (!m.scheme_horizontal.empty()) {
      for (const phase::FringeDirection d :
           {phase::FringeDirection::kVertical, phase::FringeDirection::kHorizontal}) {
        util::RequireDirectory(l.DirectionDir(s.views_[v], Camera::kLeft, d),
                               StrCat(phase::DirectionName(d),
                                      "-fringe image folder (scan.json names "
                                      "scheme_horizontal: both directions)"));
      }
    }
    if (m.cameras == 2) {
      util::RequireDirectory(l.CameraDir(s.views_[v], Camera::kRight), "camera image folder");
    } else if (fs::exists(l.CameraDir(s.views_[v], Camera::kRight), ec)) {
      // A stereo view in a camera + projector scan: one of the two is a mistake.
      throw Error(StrCat(l.CameraDir(s.views_[v], Camera::kRight).string(),
                         ": a right camera, but ", l.Manifest().string(),
                         " says 'cameras': 1 (camera + projector views hold left/ only)"));
    }
  }
  if (!m.scheme.empty()) util::RequireFile(root / m.scheme, "scheme manifest named by scan.json");
  if (!m.scheme_horizontal.empty()) {
    util::RequireFile(root / m.scheme_horizontal, "horizontal scheme manifest named by scan.json");
  }

  // Calibration images: the same names for both cameras.
  if (!m.calibration_target.empty())
    util::RequireFile(root / m.calibration_target, "calibration target named by scan.json");
  if (m.calibration_images > 0 && m.cameras == 1) {
    // Camera + projector: one folder per board pose (its board image and fringe stacks, checked
    // by the projector calibration that reads them).
    util::RequireDirectory(l.CalibrationDir(), "calibration folder");
    for (const auto& e : fs::directory_iterator(l.CalibrationDir())) {
      if (e.is_directory()) s.calibration_images_.push_back(e.path().filename().string());
    }
    std::sort(s.calibration_images_.begin(), s.calibration_images_.end());
    if (static_cast<int>(s.calibration_images_.size()) != m.calibration_images) {
      throw Error(StrCat(l.CalibrationDir().string(), ": ", s.calibration_images_.size(),
                         " board pose folders, but ", l.Manifest().string(), " says ",
                         m.calibration_images));
    }
  } else if (m.calibration_images > 0) {
    const std::vector<std::string> left = io::ListImageFiles(l.CalibrationDir(Camera::kLeft));
    const std::vector<std::string> right = io::ListImageFiles(l.CalibrationDir(Camera::kRight));
    for (const auto& [names, camera] :
         {std::make_pair(&left, Camera::kLeft), std::make_pair(&right, Camera::kRight)}) {
      if (static_cast<int>(names->size()) != m.calibration_images) {
        throw Error(StrCat(l.CalibrationDir(camera).string(), ": ", names->size(), " images, but ",
                           l.Manifest().string(), " says ", m.calibration_images));
      }
    }
    if (left != right) {
      throw Error(StrCat(l.CalibrationDir().string(),
                         ": left/ and right/ hold differently named images (a board pose needs "
                         "one image per camera under the same name)"));
    }
    s.calibration_images_ = left;
  }
  if (!m.truth.empty()) util::RequireDirectory(root / m.truth, "truth folder named by scan.json");
  return s;
}

phase::PatternScheme ScanFolder::ReadScheme() const {
  if (manifest_.scheme.empty()) {
    throw Error(StrCat(layout_.Manifest().string(), ": the scan has no pattern scheme (no views)"));
  }
  return phase::ReadScheme(root() / manifest_.scheme);
}

std::vector<phase::PatternScheme> ScanFolder::ReadSchemes() const {
  std::vector<phase::PatternScheme> schemes = {ReadScheme()};
  if (!both_directions()) return schemes;
  schemes.push_back(phase::ReadScheme(root() / manifest_.scheme_horizontal));
  const phase::FringeDirection expected[] = {phase::FringeDirection::kVertical,
                                             phase::FringeDirection::kHorizontal};
  const std::string files[] = {manifest_.scheme, manifest_.scheme_horizontal};
  for (size_t k = 0; k < 2; ++k) {
    if (schemes[k].direction != expected[k]) {
      throw Error(StrCat((root() / files[k]).string(), ": ",
                         phase::DirectionName(schemes[k].direction),
                         " fringes, but scan.json names it as the ",
                         phase::DirectionName(expected[k]), "-fringe scheme"));
    }
  }
  return schemes;
}

fs::path ScanFolder::StackDir(const std::string& view, Camera camera, size_t k) const {
  if (!both_directions()) return layout_.CameraDir(view, camera);
  return layout_.DirectionDir(
      view, camera,
      k == 0 ? phase::FringeDirection::kVertical : phase::FringeDirection::kHorizontal);
}

std::vector<std::vector<std::vector<cv::Mat>>> ScanFolder::ReadViewStacks(
    const std::string& view, Camera camera,
    const std::vector<phase::PatternScheme>& schemes) const {
  if (!std::binary_search(views_.begin(), views_.end(), view)) {
    throw Error(StrCat(layout_.ViewDir(view).string(), ": no such view in the scan"));
  }
  if (schemes.size() != (both_directions() ? 2u : 1u)) {
    throw Error(StrCat(layout_.ViewDir(view).string(), ": ", schemes.size(),
                       " schemes for a scan with ", both_directions() ? 2 : 1));
  }
  const cv::Size size(manifest_.image_width, manifest_.image_height);
  std::vector<std::vector<std::vector<cv::Mat>>> out;
  for (size_t k = 0; k < schemes.size(); ++k) {
    const fs::path dir = StackDir(view, camera, k);
    out.push_back(phase::ReadExposureStacks(dir, schemes[k]));
    for (const auto& images : out.back()) {
      if (!images.empty() && images[0].size() != size) {
        throw Error(StrCat(dir.string(), ": images are ", images[0].cols, "x", images[0].rows, ", ",
                           layout_.Manifest().string(), " says ", size.width, "x", size.height));
      }
    }
    if (out.back().size() != out.front().size()) {
      throw Error(StrCat(dir.string(), ": ", out.back().size(), " exposures, but ",
                         StackDir(view, camera, 0).string(), " holds ", out.front().size(),
                         " (both directions need the same exposures)"));
    }
  }
  return out;
}

std::vector<std::vector<cv::Mat>> ScanFolder::ReadExposureStacks(
    const std::string& view, Camera camera, const phase::PatternScheme& scheme) const {
  if (!std::binary_search(views_.begin(), views_.end(), view)) {
    throw Error(StrCat(layout_.ViewDir(view).string(), ": no such view in the scan"));
  }
  std::vector<std::vector<cv::Mat>> stacks =
      phase::ReadExposureStacks(layout_.CameraDir(view, camera), scheme);
  const cv::Size size(manifest_.image_width, manifest_.image_height);
  for (const auto& images : stacks) {
    if (!images.empty() && images[0].size() != size) {
      throw Error(StrCat(layout_.CameraDir(view, camera).string(), ": images are ", images[0].cols,
                         "x", images[0].rows, ", ", layout_.Manifest().string(), " says ",
                         size.width, "x", size.height));
    }
  }
  return stacks;
}

std::vector<cv::Mat> ScanFolder::ReadStack(const std::string& view, Camera camera,
                                           const phase::PatternScheme& scheme) const {
  std::vector<std::vector<cv::Mat>> stacks = ReadExposureStacks(view, camera, scheme);
  if (stacks.size() != 1) {
    throw Error(StrCat(layout_.CameraDir(view, camera).string(), ": holds ", stacks.size(),
                       " exposures; this reader takes one stack"));
  }
  return std::move(stacks[0]);
}

CalibrationTarget ScanFolder::ReadTarget() const {
  if (manifest_.calibration_target.empty()) {
    throw Error(StrCat(layout_.Manifest().string(), ": the scan has no calibration target"));
  }
  return io::ReadTarget(root() / manifest_.calibration_target);
}

void ScanFolder::RequireTruth(const fs::path& file) const {
  if (!has_truth()) {
    throw Error(StrCat(layout_.Manifest().string(), ": the scan has no truth (not simulated?); ",
                       file.filename().string(), " is needed"));
  }
}

StereoRig ScanFolder::ReadTruthRig() const {
  RequireTruth(layout_.TruthRig());
  return io::ReadRig(layout_.TruthRig());
}

TruthPoses ScanFolder::ReadTruthPoses() const {
  RequireTruth(layout_.TruthPoses());
  TruthPoses poses = scan::ReadTruthPoses(layout_.TruthPoses());
  for (const std::string& v : views_) {
    if (!poses.Find(v)) {
      throw Error(StrCat(layout_.TruthPoses().string(), ": no pose for view ", v));
    }
  }
  return poses;
}

TruthMarkers ScanFolder::ReadTruthMarkers() const {
  RequireTruth(layout_.TruthMarkers());
  return scan::ReadTruthMarkers(layout_.TruthMarkers());
}

TruthScene ScanFolder::ReadTruthScene() const {
  RequireTruth(layout_.TruthScene());
  return scan::ReadTruthScene(layout_.TruthScene());
}

TriangleMesh ScanFolder::ReadTruthMesh() const {
  RequireTruth(layout_.TruthMesh());
  return io::ReadMesh(layout_.TruthMesh());
}

}  // namespace fringe::scan
