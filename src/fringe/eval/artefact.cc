#include "fringe/eval/artefact.h"

#include <cmath>

#include "fringe/io/json.h"
#include "fringe/util/error.h"

namespace fringe::eval {
namespace {

using util::StrCat;

// Largest length an artefact file may state, mm (10 m: far beyond any area-scanning system's
// volume; a larger value is a unit mistake, not an artefact).
constexpr double kMaxLengthMm = 1e4;

// A length in (0, kMaxLengthMm] (positive) or [0, kMaxLengthMm] (may be zero).
double Length(const nlohmann::json& j, const char* key, bool required, bool may_be_zero,
              const std::string& context) {
  const double v =
      required ? io::GetNumber(j, key, context) : io::OptionalNumber(j, key, 0, context);
  const bool ok = std::isfinite(v) && v <= kMaxLengthMm && (may_be_zero ? v >= 0 : v > 0);
  if (!ok) {
    throw Error(StrCat(context, ".", key, ": ", v, " mm is out of range (expected ",
                       may_be_zero ? "0" : "a positive length", " up to ", kMaxLengthMm, " mm)"));
  }
  return v;
}

// An uncertainty that is not larger than the value it belongs to (a certificate giving more
// would make the figure meaningless; most likely a unit mistake).
double Uncertainty(const nlohmann::json& j, const char* key, double value,
                   const std::string& context) {
  const double u = Length(j, key, false, true, context);
  if (value > 0 && u >= value) {
    throw Error(StrCat(context, ".", key, ": ", u, " mm is not smaller than the certified value ",
                       value, " mm"));
  }
  return u;
}

}  // namespace

Artefact ArtefactFromJson(const nlohmann::json& j, const std::string& context) {
  return io::WithJsonContext(context, [&] {
    io::RequireObject(j, context);
    io::CheckKnownKeys(j, {"format", "version", "name", "sphere", "ballbar", "plane", "mpe"},
                       context);
    if (j.contains("format") && io::GetString(j, "format", context) != "fringe-artefact") {
      throw Error(
          StrCat(context, ".format: expected \"fringe-artefact\", got ", io::Brief(j["format"])));
    }
    io::OptionalInteger(j, "version", 1, 1, 1, context);
    Artefact a;
    a.name = io::OptionalString(j, "name", "", context);
    if (j.contains("sphere")) {
      const std::string c = context + ".sphere";
      const nlohmann::json& s = j["sphere"];
      io::RequireObject(s, c);
      io::CheckKnownKeys(s, {"diameter_mm", "uncertainty_mm"}, c);
      SphereArtefact sphere;
      sphere.diameter_mm = Length(s, "diameter_mm", true, false, c);
      sphere.uncertainty_mm = Uncertainty(s, "uncertainty_mm", sphere.diameter_mm, c);
      a.sphere = sphere;
    }
    if (j.contains("ballbar")) {
      const std::string c = context + ".ballbar";
      const nlohmann::json& b = j["ballbar"];
      io::RequireObject(b, c);
      io::CheckKnownKeys(b,
                         {"distance_mm", "distance_uncertainty_mm", "sphere_diameter_mm",
                          "sphere_diameter_uncertainty_mm"},
                         c);
      BallBarArtefact bar;
      bar.distance_mm = Length(b, "distance_mm", true, false, c);
      bar.distance_uncertainty_mm = Uncertainty(b, "distance_uncertainty_mm", bar.distance_mm, c);
      bar.sphere_diameter_mm = Length(b, "sphere_diameter_mm", false, true, c);
      bar.sphere_diameter_uncertainty_mm =
          Uncertainty(b, "sphere_diameter_uncertainty_mm", bar.sphere_diameter_mm, c);
      if (bar.sphere_diameter_mm == 0 && bar.sphere_diameter_uncertainty_mm > 0) {
        throw Error(c + ".sphere_diameter_uncertainty_mm: given without sphere_diameter_mm");
      }
      if (bar.sphere_diameter_mm >= bar.distance_mm) {
        throw Error(StrCat(c, ": the spheres (", bar.sphere_diameter_mm,
                           " mm) would overlap at a centre distance of ", bar.distance_mm, " mm"));
      }
      a.ballbar = bar;
    }
    if (j.contains("plane")) {
      const std::string c = context + ".plane";
      const nlohmann::json& p = j["plane"];
      io::RequireObject(p, c);
      io::CheckKnownKeys(p, {"flatness_mm", "uncertainty_mm"}, c);
      PlaneArtefact plane;
      plane.flatness_mm = Length(p, "flatness_mm", false, true, c);
      plane.uncertainty_mm = Length(p, "uncertainty_mm", false, true, c);
      a.plane = plane;
    }
    if (!a.sphere && !a.ballbar && !a.plane) {
      throw Error(context +
                  ": describes no artefact (give at least one of sphere, ballbar, plane)");
    }
    if (j.contains("mpe")) {
      const std::string c = context + ".mpe";
      const nlohmann::json& m = j["mpe"];
      io::RequireObject(m, c);
      io::CheckKnownKeys(m, {"PF_mm", "PS_mm", "SD_mm", "F_mm"}, c);
      a.mpe.PF_mm = Length(m, "PF_mm", false, true, c);
      a.mpe.PS_mm = Length(m, "PS_mm", false, true, c);
      a.mpe.SD_mm = Length(m, "SD_mm", false, true, c);
      a.mpe.F_mm = Length(m, "F_mm", false, true, c);
    }
    return a;
  });
}

Artefact ReadArtefact(const std::filesystem::path& path) {
  return ArtefactFromJson(io::ReadJson(path), path.string());
}

nlohmann::json ToJson(const Artefact& a) {
  nlohmann::json j = {{"format", "fringe-artefact"}, {"version", 1}};
  if (!a.name.empty()) j["name"] = a.name;
  if (a.sphere) {
    j["sphere"] = {{"diameter_mm", a.sphere->diameter_mm},
                   {"uncertainty_mm", a.sphere->uncertainty_mm}};
  }
  if (a.ballbar) {
    j["ballbar"] = {{"distance_mm", a.ballbar->distance_mm},
                    {"distance_uncertainty_mm", a.ballbar->distance_uncertainty_mm}};
    if (a.ballbar->sphere_diameter_mm > 0) {
      j["ballbar"]["sphere_diameter_mm"] = a.ballbar->sphere_diameter_mm;
      j["ballbar"]["sphere_diameter_uncertainty_mm"] = a.ballbar->sphere_diameter_uncertainty_mm;
    }
  }
  if (a.plane) {
    j["plane"] = {{"flatness_mm", a.plane->flatness_mm},
                  {"uncertainty_mm", a.plane->uncertainty_mm}};
  }
  nlohmann::json mpe = nlohmann::json::object();
  for (const auto& [key, v] : {std::pair{"PF_mm", a.mpe.PF_mm}, std::pair{"PS_mm", a.mpe.PS_mm},
                               std::pair{"SD_mm", a.mpe.SD_mm}, std::pair{"F_mm", a.mpe.F_mm}}) {
    if (v > 0) mpe[key] = v;
  }
  if (!mpe.empty()) j["mpe"] = mpe;
  return j;
}

}  // namespace fringe::eval
