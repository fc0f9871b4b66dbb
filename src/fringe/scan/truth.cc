#include "fringe/scan/truth.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "fringe/io/calibration_io.h"
#include "fringe/io/json.h"
#include "fringe/util/error.h"

namespace fringe::scan {
namespace {

using nlohmann::json;
using util::StrCat;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

json Vec(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }
// A pixel position; null when undefined (NaN).
json Px(const Eigen::Vector2d& v) {
  if (!v.allFinite()) return nullptr;
  return json::array({v.x(), v.y()});
}

template <int N>
Eigen::Matrix<double, N, 1> ReadVec(const json& j, const std::string& field) {
  if (!j.is_array() || j.size() != N) {
    throw Error(StrCat("'", field, "' must be an array of ", N, " numbers"));
  }
  Eigen::Matrix<double, N, 1> v;
  for (int k = 0; k < N; ++k) {
    if (!j[k].is_number()) throw Error(StrCat("'", field, "' must be an array of ", N, " numbers"));
    v[k] = j[k].get<double>();
  }
  if (!v.allFinite()) throw Error(StrCat("'", field, "' is not finite"));
  return v;
}

Eigen::Vector2d ReadPx(const json& j, const std::string& field) {
  if (j.is_null()) return Eigen::Vector2d::Constant(kNaN);
  return ReadVec<2>(j, field);
}

const json& Array(const json& j, const char* field) {
  const json& a = j.at(field);
  if (!a.is_array()) throw Error(StrCat("'", field, "' must be an array"));
  return a;
}

std::string ViewName(const json& j, std::set<std::string>* seen, const char* list) {
  const std::string view = j.at("view").get<std::string>();
  // A view name is a file stem (`fringe fuse REGDIR` opens registered/NAME.ply): never a path.
  const bool plain = !view.empty() && view != "." && view != ".." &&
                     std::none_of(view.begin(), view.end(), [](char c) {
                       return c == '/' || c == '\\' || static_cast<unsigned char>(c) < 0x20;
                     });
  if (!plain) {
    throw Error(
        StrCat(list, ": view name ", json(view).dump(-1, ' ', true, json::error_handler_t::replace),
               " is not a plain name (no path separators, '.', '..' or control characters)"));
  }
  if (!seen->insert(view).second) throw Error(StrCat(list, ": view '", view, "' listed twice"));
  return view;
}

}  // namespace

std::map<std::string, Rigid3d> TruthPoses::ByView() const {
  std::map<std::string, Rigid3d> poses;
  for (const ViewPose& v : views) poses.emplace(v.view, v.world_from_sensor);
  return poses;
}

const ViewPose* TruthPoses::Find(const std::string& view) const {
  for (const ViewPose& p : views) {
    if (p.view == view) return &p;
  }
  return nullptr;
}

const ViewMarkers* TruthMarkers::Find(const std::string& view) const {
  for (const ViewMarkers& v : views) {
    if (v.view == view) return &v;
  }
  return nullptr;
}

const TruthObject* TruthScene::Find(const std::string& name) const {
  for (const TruthObject& o : objects) {
    if (o.name == name) return &o;
  }
  return nullptr;
}

json PosesToJson(const TruthPoses& poses) {
  json views = json::array();
  for (const ViewPose& p : poses.views) {
    views.push_back(
        {{"view", p.view}, {"world_from_sensor", io::RigidToJson(p.world_from_sensor)}});
  }
  return {{"frame", "world_from_sensor (sensor = left camera), mm"},
          {"turntable", poses.turntable},
          {"views", views}};
}

TruthPoses PosesFromJson(const json& j, const std::string& context) {
  return io::WithJsonContext(context, [&] {
    TruthPoses out;
    io::RequireObject(j, context);
    if (io::OptionalString(j, "format", "fringe-poses", context) != "fringe-poses") {
      throw Error("'format' must be \"fringe-poses\"");
    }
    io::OptionalInteger(j, "version", 1, 1, 1, context);
    io::CheckKnownKeys(j, {"format", "version", "frame", "turntable", "views"}, context);
    io::OptionalString(j, "frame", "", context);  // descriptive, but a string
    out.turntable = io::OptionalBool(j, "turntable", false, context);
    std::set<std::string> seen;
    for (const json& v : Array(j, "views")) {
      ViewPose p;
      p.view = ViewName(v, &seen, "views");
      p.world_from_sensor =
          io::RigidFromJson(v.at("world_from_sensor"), StrCat(context, ": view ", p.view));
      out.views.push_back(p);
    }
    return out;
  });
}

json MarkersToJson(const TruthMarkers& truth) {
  json markers = json::array();
  for (const Marker& m : truth.markers) {
    markers.push_back({{"id", m.id},
                       {"centre_in_world", Vec(m.centre_in_world)},
                       {"normal_in_world", Vec(m.normal_in_world)},
                       {"inner_radius_mm", m.inner_radius_mm},
                       {"outer_radius_mm", m.outer_radius_mm}});
  }
  json views = json::array();
  for (const ViewMarkers& v : truth.views) {
    json obs = json::array();
    for (const MarkerObservation& o : v.observations) {
      obs.push_back({{"id", o.id},
                     {"centre_in_sensor", Vec(o.centre_in_sensor)},
                     {"left_px", Px(o.left_px)},
                     {"right_px", Px(o.right_px)},
                     {"visible_left", o.visible_left},
                     {"visible_right", o.visible_right}});
    }
    views.push_back({{"view", v.view}, {"observations", obs}});
  }
  return {{"frame", "world, mm"}, {"markers", markers}, {"views", views}};
}

TruthMarkers MarkersFromJson(const json& j, const std::string& context) {
  return io::WithJsonContext(context, [&] {
    TruthMarkers out;
    std::set<int> ids;
    for (const json& m : Array(j, "markers")) {
      Marker k;
      k.id = static_cast<int>(
          io::AsInteger(m.at("id"), 0, std::numeric_limits<int>::max(), context + ": marker id"));
      const std::string where = StrCat("marker ", k.id, ": ");
      if (!ids.insert(k.id).second) throw Error(StrCat(where, "id listed twice"));
      k.centre_in_world = ReadVec<3>(m.at("centre_in_world"), where + "centre_in_world");
      k.normal_in_world = ReadVec<3>(m.at("normal_in_world"), where + "normal_in_world");
      k.inner_radius_mm = io::AsNumber(m.at("inner_radius_mm"), where + "inner_radius_mm");
      k.outer_radius_mm = io::AsNumber(m.at("outer_radius_mm"), where + "outer_radius_mm");
      if (!(k.inner_radius_mm > 0 && k.inner_radius_mm < k.outer_radius_mm)) {
        throw Error(StrCat(where, "radii must satisfy 0 < inner_radius_mm < outer_radius_mm"));
      }
      out.markers.push_back(k);
    }
    std::set<std::string> seen;
    for (const json& v : Array(j, "views")) {
      ViewMarkers vm;
      vm.view = ViewName(v, &seen, "views");
      for (const json& o : Array(v, "observations")) {
        MarkerObservation ob;
        ob.id = static_cast<int>(io::AsInteger(o.at("id"), 0, std::numeric_limits<int>::max(),
                                               context + ": observation id"));
        const std::string where = StrCat("view ", vm.view, ", marker ", ob.id, ": ");
        if (!ids.count(ob.id)) throw Error(StrCat(where, "not in 'markers'"));
        ob.centre_in_sensor = ReadVec<3>(o.at("centre_in_sensor"), where + "centre_in_sensor");
        ob.left_px = ReadPx(o.at("left_px"), where + "left_px");
        ob.right_px = ReadPx(o.at("right_px"), where + "right_px");
        ob.visible_left = o.at("visible_left").get<bool>();
        ob.visible_right = o.at("visible_right").get<bool>();
        vm.observations.push_back(ob);
      }
      out.views.push_back(std::move(vm));
    }
    return out;
  });
}

json SceneToJson(const TruthScene& scene) {
  json objects = json::array();
  for (const TruthObject& o : scene.objects) {
    json j = {{"name", o.name},
              {"albedo", o.albedo ? json(*o.albedo) : json(nullptr)},
              {"triangles", o.triangles}};
    if (o.sphere) {
      j["sphere"] = {{"centre_in_world", Vec(o.sphere->centre_in_world)},
                     {"radius_mm", o.sphere->radius_mm}};
    }
    objects.push_back(j);
  }
  return {{"scene", scene.scene},
          {"frame", "world, mm, z up"},
          {"mesh", scene.mesh},
          {"objects", objects}};
}

TruthScene SceneFromJson(const json& j, const std::string& context) {
  return io::WithJsonContext(context, [&] {
    TruthScene out;
    out.scene = j.at("scene").get<std::string>();
    out.mesh = j.at("mesh").get<std::string>();
    for (const json& o : Array(j, "objects")) {
      TruthObject t;
      t.name = o.at("name").get<std::string>();
      const std::string where = StrCat("object '", t.name, "': ");
      if (!o.at("albedo").is_null()) t.albedo = o.at("albedo").get<double>();
      t.triangles = static_cast<size_t>(io::AsInteger(
          o.at("triangles"), 0, std::numeric_limits<int>::max(), where + "triangles"));
      if (o.contains("sphere")) {
        const json& s = o["sphere"];
        TruthSphere sphere;
        sphere.centre_in_world = ReadVec<3>(s.at("centre_in_world"), where + "centre_in_world");
        sphere.radius_mm = s.at("radius_mm").get<double>();
        if (!(sphere.radius_mm > 0)) throw Error(where + "sphere radius_mm must be > 0");
        t.sphere = sphere;
      }
      out.objects.push_back(t);
    }
    return out;
  });
}

void WriteTruthPoses(const std::filesystem::path& path, const TruthPoses& poses) {
  io::WriteJson(path, PosesToJson(poses));
}
TruthPoses ReadTruthPoses(const std::filesystem::path& path) {
  return PosesFromJson(io::ReadJson(path), path.string());
}
void WriteTruthMarkers(const std::filesystem::path& path, const TruthMarkers& markers) {
  io::WriteJson(path, MarkersToJson(markers));
}
TruthMarkers ReadTruthMarkers(const std::filesystem::path& path) {
  return MarkersFromJson(io::ReadJson(path), path.string());
}
void WriteTruthScene(const std::filesystem::path& path, const TruthScene& scene) {
  io::WriteJson(path, SceneToJson(scene));
}
TruthScene ReadTruthScene(const std::filesystem::path& path) {
  return SceneFromJson(io::ReadJson(path), path.string());
}

}  // namespace fringe::scan
